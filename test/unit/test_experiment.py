"""teleteach.runtime.experiment: what the thesis run, the study and the ROS benches run on, driven for real (a
roscore, an Xvfb, child processes that end on their own)."""

import os
import sys
import time

import pytest

from teleteach.runtime.experiment import Experiment, SystemEndedError
from teleteach.runtime.processes import master_pid, parent_pid

SLEEPER = [sys.executable, "-c", "import time; time.sleep(60)"]


def test_its_own_roscore_answers_until_the_experiment_closes(tmp_path, monkeypatch):
    monkeypatch.setenv("ROS_LOG_DIR", str(tmp_path / "ros"))
    with Experiment(tmp_path) as experiment:
        uri = experiment.own_roscore()
        pid = master_pid(uri)
        # Expect a master of ours (a child of the roscore we started), and our processes pointed at it
        assert pid is not None and parent_pid(parent_pid(pid)) == os.getpid()
        assert experiment.environment()["ROS_MASTER_URI"] == uri
        assert experiment.environment(tmp_path / "other")["TELETEACH_DATA"] == str(tmp_path / "other")
    assert master_pid(uri) is None
    assert (tmp_path / "roscore.log").is_file()


def test_a_wait_ends_at_once_with_the_reason_when_a_watched_process_ends(tmp_path):
    log = tmp_path / "launch.log"
    log.write_text(
        "[FATAL] [1.0]: sigma7_node: scenario line 12: waited 30 s for the tab LOW_LEVEL in vain\n"
        "REQUIRED process [sigma7_node-3] has died!\nprocess has died [pid 42, exit code 1, cmd ...]\n"
    )
    with Experiment(tmp_path) as experiment:
        experiment.start("launch", [sys.executable, "-c", "import time; time.sleep(0.5); exit(1)"], log, watched=True)
        started = time.monotonic()
        with pytest.raises(SystemEndedError) as ended:
            experiment.wait_until(lambda: False, 30.0)
    # Expect the end noticed within a poll, the required node and its last words first
    assert time.monotonic() - started < 5.0
    assert str(ended.value).startswith("sigma7_node died (exit code 1): sigma7_node: scenario line 12"), ended.value
    assert "ended early (exit 1)" in str(ended.value)


def test_a_process_we_stopped_or_do_not_watch_does_not_end_a_wait(tmp_path):
    with Experiment(tmp_path) as experiment:
        watched = experiment.start("sleeper", SLEEPER, watched=True)
        experiment.start("short", [sys.executable, "-c", "exit(2)"])
        experiment.stop(watched, grace=5.0)
        # Expect: False after the timeout (nothing watched ended), True as soon as the condition holds
        assert experiment.wait_until(lambda: False, 0.5) is False
        assert experiment.wait_until(lambda: True, 0.0) is True
        assert experiment.ended() == ""


def test_every_process_stops_when_it_closes(tmp_path):
    experiment = Experiment(tmp_path)
    first = experiment.start("first", SLEEPER, tmp_path / "first.log")
    second = experiment.start("second", SLEEPER)
    experiment.close()
    assert first.poll() is not None and second.poll() is not None


def test_without_a_display_it_brings_its_own_x_server(tmp_path, monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    with Experiment(tmp_path) as experiment:
        assert experiment.own_display() is True
        display = experiment.display
        assert display.startswith(":") and experiment.environment()["DISPLAY"] == display
        shots = experiment.screenshots("stage", lambda: "start", delay=0.0, period=10.0)
        deadline = time.monotonic() + 20.0
        while not (tmp_path / "stage_01_start.png").exists() and time.monotonic() < deadline:
            time.sleep(0.1)
        shots.stop()
        assert (tmp_path / "stage_01_start.png").stat().st_size > 0, shots.errors
    # Expect the X server gone with the experiment
    assert not os.path.exists(f"/tmp/.X11-unix/X{display[1:]}")


def test_with_a_display_it_uses_it_and_pictures_nothing_when_told_not_to(tmp_path, monkeypatch):
    monkeypatch.setenv("DISPLAY", ":4242")
    with Experiment(tmp_path) as experiment:
        assert experiment.own_display() is False and experiment.display == ":4242"
        shots = experiment.screenshots("stage", lambda: "start", delay=0.0, enabled=False)
        time.sleep(0.3)
        shots.stop()
        assert list(tmp_path.glob("*.png")) == [] and shots.errors == []
