"""Benchmark: offline report of a long teaching session, and the ellipsoid marker's cost per message.

Writes a scripted session bag (the test suite's generator) of --duration seconds with the device at --rate Hz
(the Sigma.7 publishes at 1 kHz), then times reading it with rosbags and making the three figures and the summary.
Also times the marker builder (validate three messages + build the Marker). Prints the figures and writes
bench/results/report.json. Goal: a 60 s session at 1 kHz reported in well under a minute.

    source build/env.sh && python bench/report.py [--duration 60] [--rate 1000]
"""

import argparse
import json
import pathlib
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "test" / "unit"))

from session_bags import eigenvalues_message, eigenvectors_message, pose_message, write_session  # noqa: E402

from teleteach.recording.report import make_report  # noqa: E402
from teleteach.recording.session import read_session  # noqa: E402
from teleteach.viz.ellipsoid import EllipsoidMarkerConfig  # noqa: E402


def marker_cost(repetitions):
    builder = EllipsoidMarkerConfig.from_yaml().builder()
    values, vectors, pose = eigenvalues_message(800.0, 1200.0, 2000.0), eigenvectors_message(0.4), pose_message()
    start = time.perf_counter()
    for _ in range(repetitions):
        builder.set_eigenvalues(values)
        builder.set_eigenvectors(vectors)
        builder.set_pose(pose)
        builder.marker()
    return (time.perf_counter() - start) / repetitions


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--duration", type=float, default=60.0, help="session length [s]")
    parser.add_argument("--rate", type=float, default=1000.0, help="device rate [Hz]")
    arguments = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        bag = pathlib.Path(folder) / "session.bag"
        start = time.perf_counter()
        write_session(bag, duration=arguments.duration, device_rate=arguments.rate)
        write_time = time.perf_counter() - start
        start = time.perf_counter()
        session = read_session(bag)
        read_time = time.perf_counter() - start
        messages = sum(info.count for info in session.topics.values())
        start = time.perf_counter()
        report = make_report(bag, pathlib.Path(folder) / "report")
        report_time = time.perf_counter() - start
        size = bag.stat().st_size
    marker = marker_cost(20000)
    results = {
        "session_duration_s": arguments.duration,
        "device_rate_hz": arguments.rate,
        "messages": messages,
        "bag_megabytes": round(size / 1e6, 2),
        "write_bag_s": round(write_time, 2),
        "read_session_s": round(read_time, 2),
        "read_messages_per_s": round(messages / read_time),
        "make_report_s": round(report_time, 2),
        "figures": sorted(report.figures),
        "marker_update_us": round(marker * 1e6, 1),
    }
    for key, value in results.items():
        print(f"{key}: {value}")
    out = ROOT / "bench" / "results"
    out.mkdir(parents=True, exist_ok=True)
    (out / "report.json").write_text(json.dumps(results, indent=2) + "\n")


if __name__ == "__main__":
    main()
