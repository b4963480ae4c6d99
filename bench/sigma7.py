"""Benchmark: the sigma7 device loop, without ROS and over ROS.

1. Cost of one cycle of the library loop (scenario read + click emulation + twist), no publishing: mean and p99 [us].
2. The wall-clock rate keeper at 1 kHz for 5 s with that loop: achieved rate [Hz], interval p50/p99/max [ms].
3. Over ROS: the sigma7 node (example scenario, its own roscore on a free port) for 8 s, a subscriber counting
   /sigma7/pose by header stamp: publication rate [Hz], stamp interval p99/max [ms], node CPU [% of one core]; and
   the loop's rate, from /sigma7/force (published every force_rate-th share of the cycles, counted by arrival).
   Twice: publishing every cycle (``publish_rate`` 1000 Hz, ``over_ros``) and at config/device.yaml's publish_rate
   (``over_ros_default``: what the system runs).
Target: the loop at 1000 Hz +- 10 %, a cycle well under 1 ms. Prints and writes bench/results/sigma7.json.

    source build/env.sh && python bench/sigma7.py
"""

import json
import os
import pathlib
import subprocess
import sys
import tempfile
import time

import numpy as np
import roslib.packages
import yaml

from teleteach.haptics.click import ClickDetector, ClickParameters
from teleteach.haptics.loop import DeviceLoop, WallRate
from teleteach.haptics.scenario import ScenarioBackend, load_scenario
from teleteach.haptics.twist import TwistEstimator
from teleteach.runtime.experiment import Experiment

ROOT = pathlib.Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "config" / "scenarios" / "example.yaml"


def make_loop(sink):
    backend = ScenarioBackend(load_scenario(SCENARIO), start_time=time.monotonic())
    return DeviceLoop(
        backend, sink, time.monotonic, ClickDetector(ClickParameters.from_yaml()), TwistEstimator(20.0), print
    )


def cycle_cost(cycles=5000):
    loop = make_loop(lambda state: None)
    costs = []
    for _ in range(cycles):
        start = time.perf_counter()
        loop.step()
        costs.append(time.perf_counter() - start)
    costs = np.array(costs) * 1e6
    return {"mean_us": float(costs.mean()), "p99_us": float(np.percentile(costs, 99))}


def rate_keeping(seconds=5.0):
    stamps = []
    loop = make_loop(lambda state: stamps.append(time.monotonic()))
    rate = WallRate(1000.0)
    end = time.monotonic() + seconds
    loop.run(rate, lambda: time.monotonic() > end)
    intervals = np.diff(stamps) * 1e3
    return {
        "achieved_hz": float((len(stamps) - 1) / (stamps[-1] - stamps[0])),
        "interval_p50_ms": float(np.percentile(intervals, 50)),
        "interval_p99_ms": float(np.percentile(intervals, 99)),
        "interval_max_ms": float(intervals.max()),
    }


SUBSCRIBER = """
import sys, time, rospy
from geometry_msgs.msg import PoseStamped, WrenchStamped
stamps, forces = [], []
rospy.init_node("bench_sigma7_sub")
rospy.Subscriber("/sigma7/pose", PoseStamped, lambda msg: stamps.append(msg.header.stamp.to_sec()))
rospy.Subscriber("/sigma7/force", WrenchStamped, lambda msg: forces.append(time.monotonic()))
time.sleep(float(sys.argv[1]))
print(" ".join(repr(stamp) for stamp in stamps))
print(" ".join(repr(stamp) for stamp in forces))
"""
DEVICE = yaml.safe_load((ROOT / "config" / "device.yaml").read_text())


def over_ros(seconds=8.0, publish_rate=1000.0):
    folder = pathlib.Path(tempfile.mkdtemp(prefix="teleteach_bench_sigma7_"))
    with Experiment(folder) as experiment:
        experiment.own_roscore()
        executable = roslib.packages.find_node("teleteach", "sigma7_node")[0]
        node = experiment.start(
            "sigma7_node",
            [executable, "_backend:=scenario", f"_scenario:={SCENARIO}", f"_publish_rate:={publish_rate}"],
            folder / "sigma7_node.log",
            watched=True,
        )
        time.sleep(3.0)
        experiment.check()
        cpu_before = _cpu_seconds(node.pid)
        result = subprocess.run(
            [sys.executable, "-c", SUBSCRIBER, str(seconds)],
            env=experiment.environment(),
            capture_output=True,
            text=True,
            check=True,
        )
        cpu = (_cpu_seconds(node.pid) - cpu_before) / (seconds + 1.0)  # the subscriber's start-up included
    poses, forces = result.stdout.splitlines()[-2:]
    stamps = np.array([float(value) for value in poses.split()])
    stamps = stamps[stamps > stamps[0] + 1.0]  # skip the connection's first second
    arrivals = np.array([float(value) for value in forces.split()])
    arrivals = arrivals[arrivals > arrivals[0] + 1.0]
    cycles_per_force = round(DEVICE["rate"] / DEVICE["force_rate"])
    intervals = np.diff(stamps) * 1e3
    return {
        "publish_rate_hz": publish_rate,
        "loop_hz": float(cycles_per_force * (len(arrivals) - 1) / (arrivals[-1] - arrivals[0])),
        "publication_hz": float((len(stamps) - 1) / (stamps[-1] - stamps[0])),
        "stamp_interval_p99_ms": float(np.percentile(intervals, 99)),
        "stamp_interval_max_ms": float(intervals.max()),
        "node_cpu_percent_of_one_core": float(100.0 * cpu),
    }


def _cpu_seconds(pid):
    fields = pathlib.Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def main():
    results = {
        "cycle": cycle_cost(),
        "rate_keeping": rate_keeping(),
        "over_ros": over_ros(),
        "over_ros_default": over_ros(publish_rate=DEVICE["publish_rate"]),
    }
    results["load_average_1min"] = os.getloadavg()[0]
    print(json.dumps(results, indent=2))
    out = ROOT / "bench" / "results"
    out.mkdir(parents=True, exist_ok=True)
    (out / "sigma7.json").write_text(json.dumps(results, indent=2) + "\n")


if __name__ == "__main__":
    main()
