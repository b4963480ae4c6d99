"""Stress: the main job (run_thesis) several times while busy loops hold the cores, as a loaded machine would.

Each run's stdout is read line by line and stamped with wall time; run_thesis prints the simulated time of every
leaf that ends ("run_thesis: t = 12.3 s  PickItem: done"), so the real-time factor between two such lines at least
``--window`` wall seconds apart is (simulated time between them) / (wall time between them). Reports per run the
exit status and the lowest such factor, then the passes and the lowest factor of all runs; writes
bench/results/stress.json. Exit status 0 when every run passed.

    source build/env.sh && python bench/stress.py --runs 3 --hogs 4      (or: bash scripts/stress --hogs 4)
"""

import argparse
import json
import os
import pathlib
import re
import subprocess
import sys
import tempfile
import time

RESULTS = pathlib.Path(__file__).resolve().parent / "results"
SIM_TIME = re.compile(r"run_thesis: t = +([0-9.]+) s ")


def busy_loop(core: int) -> subprocess.Popen:
    """A process spinning on one core (taskset), the load other work would put on the machine."""
    return subprocess.Popen(["taskset", "-c", str(core), sys.executable, "-c", "while True: pass"])


def hog_cores(hogs: int, cores: int) -> list:
    """The core of each busy loop: spread evenly from the last core down, so one hog holds the last core and
    four on two cores put two on each."""
    return [(cores - 1 - index) % cores for index in range(hogs)]


def lowest_real_time_factor(events, window: float):
    """The smallest (sim time difference) / (wall time difference) over pairs of (wall, sim) events that are at
    least ``window`` wall seconds apart, each event paired with the first one far enough after it (None if none)."""
    lowest = None
    for index, (wall, sim) in enumerate(events):
        later = next(((w, s) for w, s in events[index + 1 :] if w - wall >= window), None)
        if later is not None:
            factor = (later[1] - sim) / (later[0] - wall)
            lowest = factor if lowest is None else min(lowest, factor)
    return lowest


def run_once(index: int, arguments, window: float) -> dict:
    data_dir = tempfile.mkdtemp(prefix=f"teleteach_stress_{index}_")
    command = ["rosrun", "teleteach", "run_thesis", "--no-rviz", "--data-dir", data_dir, *arguments]
    started = time.monotonic()
    events = []
    with subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True) as process:
        for line in process.stdout:
            print(f"  [{index}] {line}", end="", flush=True)
            match = SIM_TIME.search(line)
            if match:
                events.append((time.monotonic(), float(match.group(1))))
    return {
        "run": index,
        "passed": process.returncode == 0,
        "exit_status": process.returncode,
        "wall_s": round(time.monotonic() - started, 1),
        "lowest_real_time_factor": lowest_real_time_factor(events, window),
        "data_dir": data_dir,
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3, help="how many times to run the main job")
    parser.add_argument("--hogs", type=int, default=1, help="how many busy loops, spread over the cores")
    parser.add_argument("--window", type=float, default=10.0, help="[s] wall time over which a factor is measured")
    options, arguments = parser.parse_known_args()
    cores = hog_cores(options.hogs, os.cpu_count() or 1)
    hogs = [busy_loop(core) for core in cores]
    try:
        runs = [run_once(index, arguments, options.window) for index in range(1, options.runs + 1)]
    finally:
        for hog in hogs:
            hog.kill()
            hog.wait()
    factors = [run["lowest_real_time_factor"] for run in runs if run["lowest_real_time_factor"] is not None]
    summary = {
        "runs": runs,
        "passes": sum(run["passed"] for run in runs),
        "lowest_real_time_factor": min(factors) if factors else None,
        "busy_cores": cores,
    }
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "stress.json").write_text(json.dumps(summary, indent=2) + "\n")
    for run in runs:
        factor = run["lowest_real_time_factor"]
        shown = f"{factor:.2f}" if factor is not None else "-"
        print(f"run {run['run']}: {'PASSED' if run['passed'] else 'FAILED'} in {run['wall_s']} s, lowest RTF {shown}")
    lowest = summary["lowest_real_time_factor"]
    shown = f"{lowest:.2f}" if lowest is not None else "-"
    print(
        f"stress: {summary['passes']} of {len(runs)} passed, lowest real-time factor {shown} "
        f"({len(cores)} busy loops on cores {cores})"
    )
    return 0 if summary["passes"] == len(runs) else 1


if __name__ == "__main__":
    sys.exit(main())
