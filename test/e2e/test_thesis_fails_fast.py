"""The main job fails fast: when the scripted operator's device node dies mid-scenario, run_thesis stops waiting within
seconds (not at its wall-time bound) and the summary's first problem names that node and how it ended."""

import json
import os
import queue
import re
import signal
import subprocess
import threading
import time
import xmlrpc.client

from conftest import ROOT

RUN_TIMEOUT = 300.0  # [s] wall: start, the kill, the stop and the report of a run cut short
NOTICE_BOUND = 10.0  # [s] from the kill to run_thesis saying it stopped waiting


def node_pid(master_uri: str, node: str) -> int:
    """The process id of a ROS node, asked through the master and the node's own XML-RPC API."""
    code, message, api = xmlrpc.client.ServerProxy(master_uri).lookupNode("/fails_fast_test", node)
    assert code == 1, message
    code, message, pid = xmlrpc.client.ServerProxy(api).getPid("/fails_fast_test")
    assert code == 1, message
    return pid


def test_a_device_node_killed_mid_scenario_ends_the_run_at_once_with_that_cause_first(tmp_path):
    env = dict(os.environ)
    env.pop("DISPLAY", None)
    runner = subprocess.Popen(
        [str(ROOT / "nodes" / "run_thesis"), "--data-dir", str(tmp_path), "--no-rviz"],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env=env,
    )
    lines: queue.Queue[tuple] = queue.Queue()

    def read_lines():
        for line in runner.stdout:
            lines.put((time.monotonic(), line))  # when run_thesis said it

    threading.Thread(target=read_lines, daemon=True).start()
    said = []

    def wait_for(pattern: str, timeout: float) -> tuple:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            try:
                stamp, line = lines.get(timeout=1.0)
            except queue.Empty:
                continue
            said.append(line)
            match = re.search(pattern, line)
            if match:
                return stamp, match
        raise AssertionError(f"run_thesis did not say {pattern!r} within {timeout:.0f} s:\n{''.join(said)}")

    try:
        _, master = wait_for(r"master (http://\S+)\)", 120.0)
        wait_for(r"PickItem: done", 180.0)  # mid-scenario: the tree runs, the operator has more to do
        pid = node_pid(master.group(1), "/sigma7_node")
        os.kill(pid, signal.SIGKILL)
        killed = time.monotonic()
        stopped, reason = wait_for(r"stopped waiting: (.*)", 60.0)
        # Expect the run to notice within seconds, naming the node that died and how
        assert stopped - killed <= NOTICE_BOUND, f"noticed after {stopped - killed:.1f} s"
        assert reason.group(1).startswith("sigma7_node died (exit code -9)"), reason.group(1)
        runner.wait(timeout=RUN_TIMEOUT)
    finally:
        if runner.poll() is None:
            runner.send_signal(signal.SIGINT)
            runner.wait(timeout=60)
    assert runner.returncode == 1
    folders = sorted((tmp_path / "runs").iterdir())
    summary = json.loads((folders[0] / "summary.json").read_text())
    # Expect the cause first, before the checks the unfinished run could not pass
    assert not summary["finished"]
    assert summary["problems"][0].startswith("sigma7_node died (exit code -9)"), summary["problems"]
