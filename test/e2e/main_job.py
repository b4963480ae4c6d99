"""Running the main job as a fresh headless machine would, and reading what a run left (the end-to-end tests' shared
helpers)."""

import os
import pathlib
import subprocess

import yaml

from teleteach.recording.session import open_bag

ROOT = pathlib.Path(__file__).resolve().parents[2]
RUN_TIMEOUT = 480.0  # [s] wall: the runner bounds itself (scenario 300 s, RViz picture 2 x 45 s, stop, report)
# The III-D variant at twice real time: every node runs on the simulation's clock, so the same run takes less wall time
# where a core is free (94 -> 55 s at load 3-7 on 2 cores), and about the same on a saturated machine
# (docs/benchmarks.md). teach_placement went back to 1.0 (at 2, in a full suite, its wait for START once ran out). The
# main job itself (test_thesis_e2e's module run, as scripts/demo runs it) stays at config/controllers.yaml's 1.0.
FASTER = ("--real-time-factor", "2")


def run_thesis(data: pathlib.Path, *arguments, timeout: float = RUN_TIMEOUT) -> subprocess.CompletedProcess:
    """``run_thesis --data-dir data ARGUMENTS``, without a display: the runner starts its own Xvfb."""
    env = dict(os.environ)
    env.pop("DISPLAY", None)
    command = [str(ROOT / "nodes" / "run_thesis"), "--data-dir", str(data), *map(str, arguments)]
    return subprocess.run(command, capture_output=True, text=True, timeout=timeout, env=env, check=False)


def saved_tree(data: pathlib.Path):
    """The behaviour tree node's saved tree, or None while it is being replaced or not written yet."""
    try:
        return yaml.safe_load((data / "trees" / "current_tree.yaml").read_text())
    except (OSError, yaml.YAMLError):
        return None


def bag_messages(bag: pathlib.Path, topic: str) -> list:
    """(time [s], message) of every message on ``topic``, in the bag's order."""
    with open_bag(bag) as reader:
        connections = [connection for connection in reader.connections if connection.topic == topic]
        return [
            (stamp * 1e-9, reader.deserialize(raw, connection.msgtype))
            for connection, stamp, raw in reader.messages(connections)
        ]
