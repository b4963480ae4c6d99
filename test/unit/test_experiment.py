"""teleteach.runtime.experiment: what the thesis run, the study and the ROS benches run on, driven for real (a
roscore, an Xvfb, child processes that end on their own)."""

import contextlib
import os
import pathlib
import signal
import subprocess
import sys
import time

import pytest

from teleteach.runtime.experiment import Experiment, SystemEndedError
from teleteach.runtime.processes import descendants, master_pid, parent_pid, running, still_running, stop_tree

SLEEPER = [sys.executable, "-c", "import time; time.sleep(60)"]
READY_SLEEPER = [sys.executable, "-c", "import time; print('ready', flush=True); time.sleep(60)"]
PYTHON = pathlib.Path(sys.executable).name


def gone(pid, timeout=10.0):
    """Whether process ``pid`` has ended (or is a zombie nobody waits for) within ``timeout`` seconds."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            state = pathlib.Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            return True
        if state == "Z":
            return True
        time.sleep(0.1)
    return False


def wait_until_ready(log, timeout=30.0):
    """Wait until the process that writes ``log`` says it is ready: a Python interrupted while it starts up (imports
    its site module) exits with 1, not by the signal."""
    deadline = time.monotonic() + timeout
    while "ready" not in log.read_text() and time.monotonic() < deadline:
        time.sleep(0.05)


def with_our_path(env):
    """``env`` with this process's module path: the probe imports the teleteach under test (mutmut's copy too)."""
    return dict(env, PYTHONPATH=os.pathsep.join(path for path in sys.path if path))


def probe(tmp_path, code, env):
    """Run ``code`` (an experiment in a process of its own) and return what it printed, one line per value."""
    env = with_our_path(env)
    result = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120, check=False
    )
    assert result.returncode == 0, result.stderr
    return result.stdout.split()


@pytest.mark.system
def test_its_own_roscore_answers_until_the_experiment_closes(tmp_path, monkeypatch):
    monkeypatch.setenv("ROS_LOG_DIR", str(tmp_path / "ros"))
    with Experiment(tmp_path) as experiment:
        uri = experiment.own_roscore()
        pid = master_pid(uri)
        # Expect a master of ours (a child of the roscore we started), and our processes pointed at it
        assert pid is not None and parent_pid(parent_pid(pid)) == os.getpid()
        assert experiment.environment()["ROS_MASTER_URI"] == uri
        assert experiment.environment()["TELETEACH_DATA"] == str(tmp_path)  # its folder, unless given one
        assert experiment.environment(tmp_path / "other")["TELETEACH_DATA"] == str(tmp_path / "other")
    assert master_pid(uri) is None
    assert (tmp_path / "roscore.log").is_file()


def test_its_processes_run_on_its_master_display_and_data_directory(tmp_path, monkeypatch):
    monkeypatch.setenv("ROS_MASTER_URI", "http://localhost:11999")
    monkeypatch.setenv("DISPLAY", ":77")
    printer = [
        sys.executable,
        "-c",
        "import os; print(os.environ['ROS_MASTER_URI'], os.environ['DISPLAY'], os.environ['TELETEACH_DATA'])",
    ]
    with Experiment(tmp_path, tmp_path / "data") as experiment:
        assert experiment.master_uri == "http://localhost:11999"  # the running master, unless it brings its own
        experiment.start("printer", printer, tmp_path / "a.log").wait(30)
        experiment.start("printer", printer, tmp_path / "b.log", data_root=tmp_path / "trial").wait(30)
    assert (tmp_path / "a.log").read_text().split() == ["http://localhost:11999", ":77", str(tmp_path / "data")]
    assert (tmp_path / "b.log").read_text().split() == ["http://localhost:11999", ":77", str(tmp_path / "trial")]


@pytest.mark.system
def test_a_roscore_on_another_host_name_is_reached_by_it(tmp_path, monkeypatch):
    monkeypatch.setenv("ROS_LOG_DIR", str(tmp_path / "ros"))
    with Experiment(tmp_path) as experiment:
        uri = experiment.own_roscore(tmp_path / "core.log", host="127.0.0.1")
        assert uri.startswith("http://127.0.0.1:") and master_pid(uri) is not None
    assert (tmp_path / "core.log").is_file()


@pytest.mark.system
def test_a_roslaunch_brings_its_master_and_gets_the_experiment_s_environment(tmp_path, monkeypatch):
    monkeypatch.setenv("ROS_LOG_DIR", str(tmp_path / "ros"))
    launch_file = tmp_path / "probe.launch"
    launch_file.write_text('<launch><param name="data" command="printenv TELETEACH_DATA"/></launch>')
    log = tmp_path / "launch.log"
    with Experiment(tmp_path, tmp_path / "data") as experiment:
        command = lambda port: ["roslaunch", "-p", str(port), str(launch_file)]  # noqa: E731
        launch = experiment.own_launch(command, log, data_root=tmp_path / "launch_data")
        uri = experiment.master_uri
        assert parent_pid(master_pid(uri)) == launch.pid
        # Expect roslaunch to run in the experiment's environment (its param command saw the data directory)
        import xmlrpc.client

        deadline = time.monotonic() + 60.0
        code, value = -1, None
        while code != 1 and time.monotonic() < deadline:
            code, _, value = xmlrpc.client.ServerProxy(uri).getParam("/probe", "/data")
            time.sleep(0.2)
        assert value.strip() == str(tmp_path / "launch_data")
        assert "started roslaunch server" in log.read_text()  # roslaunch's own output, in its log
        orphans = descendants(launch.pid)  # its master and rosout, which its SIGKILL leaves running
        os.kill(launch.pid, signal.SIGKILL)
        try:
            with pytest.raises(SystemEndedError, match=rf"roslaunch ended early \(exit -9\); see {log}"):
                experiment.wait_until(lambda: False, 30.0)
        finally:
            for pid in still_running(orphans, 0.0):
                with contextlib.suppress(ProcessLookupError):  # it ended since
                    os.kill(pid, signal.SIGKILL)


@pytest.mark.system
def test_joining_makes_this_process_a_node_of_its_master(tmp_path):
    code = f"""
import os, pathlib, rospy, signal
from teleteach.runtime.experiment import Experiment
with Experiment(pathlib.Path({str(tmp_path)!r})) as experiment:
    uri = experiment.own_roscore()
    ours = signal.getsignal(signal.SIGINT)
    experiment.join("joined", anonymous=True)
    print(rospy.get_name(), os.environ["ROS_MASTER_URI"] == uri, os.environ["TELETEACH_DATA"], os.environ["ROS_IP"])
    print(rospy.core.is_shutdown_requested(), rospy.get_param("/rosout_disable_topics_generation"))
    print(signal.getsignal(signal.SIGINT) is ours)
    rospy.signal_shutdown("probe done")
"""
    env = {key: value for key, value in os.environ.items() if key not in ("ROS_IP", "ROS_HOSTNAME")}
    env["ROS_LOG_DIR"] = str(tmp_path / "ros")
    name, same_master, data, ip, shut_down, rosout, own_sigint = probe(tmp_path, code, env)
    # Expect an anonymous node (name and a suffix) on the experiment's master, with its data directory and loopback
    assert name.startswith("/joined_") and same_master == "True" and data == str(tmp_path) and ip == "127.0.0.1"
    assert shut_down == "False" and rosout == "False" and own_sigint == "True"  # rospy left Ctrl-C to us
    env["ROS_HOSTNAME"] = "localhost"
    code = code.replace('os.environ["ROS_IP"]', 'os.environ.get("ROS_IP", "unset")').replace("anonymous=True", "")
    name, _, _, ip, _, _, _ = probe(tmp_path, code, env)
    assert name == "/joined" and ip == "unset"  # the user's ROS_HOSTNAME is left alone


@pytest.mark.system
def test_a_node_on_the_launch_s_clock_joins_once_the_launch_set_use_sim_time(tmp_path):
    code = f"""
import pathlib, subprocess, threading, time, rospy
from teleteach.runtime.experiment import Experiment
with Experiment(pathlib.Path({str(tmp_path)!r})) as experiment:
    uri = experiment.own_roscore()
    late = threading.Timer(2.0, subprocess.run, (["rosparam", "set", "/use_sim_time", "true"],))
    late.start()  # a launch that sets its parameters late
    started = time.monotonic()
    experiment.join("joined", anonymous=True, sim_time=True)
    print(time.monotonic() - started > 1.5, rospy.get_time() < 1e6)  # no /clock yet: simulated time 0, not the wall's
    rospy.signal_shutdown("probe done")
"""
    env = dict(os.environ, ROS_LOG_DIR=str(tmp_path / "ros"))
    waited, on_sim_time = probe(tmp_path, code, env)
    assert waited == "True" and on_sim_time == "True"


@pytest.mark.system
def test_what_it_started_stops_when_its_process_dies_however_it_dies(tmp_path):
    code = f"""
import os, pathlib, sys, time
from teleteach.runtime.experiment import Experiment
experiment = Experiment(pathlib.Path({str(tmp_path)!r}))
experiment.own_display()
sleeper = "import signal as s, time; s.signal(s.SIGINT, s.SIG_DFL); print('ready', flush=True); time.sleep(60)"
log = pathlib.Path({str(tmp_path)!r}) / "sleeper.log"
child = experiment.start("sleeper", [sys.executable, "-c", sleeper], log)  # SIGINT kills it, even if ours ignores it
while "ready" not in log.read_text():
    time.sleep(0.05)
children = [p.name for p in pathlib.Path("/proc").iterdir() if p.name.isdigit() and p.name != str(child.pid)]
xvfb = [pid for pid in children if (pathlib.Path("/proc") / pid / "comm").read_text().strip() == "Xvfb"
        and (pathlib.Path("/proc") / pid / "stat").read_text().rsplit(")", 1)[1].split()[1] == str(os.getpid())]
print(child.pid, *xvfb, flush=True)
os.kill(os.getpid(), 9)
"""
    env = {key: value for key, value in os.environ.items() if key != "DISPLAY"}
    result = subprocess.run(
        [sys.executable, "-c", code], env=with_our_path(env), capture_output=True, text=True, timeout=60
    )
    assert result.returncode == -9, result.stderr
    sleeper, xvfb = (int(pid) for pid in result.stdout.split())
    # Expect both gone: the child got SIGINT, the X server SIGTERM, when the experiment's process was killed
    assert gone(sleeper) and gone(xvfb)


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
        experiment.start("short", [sys.executable, "-c", "exit(2)"]).wait(30)  # ended on its own, never watched
        experiment.stop(watched, grace=5.0)
        # Expect: False after the timeout (nothing watched ended), True as soon as the condition holds
        assert experiment.wait_until(lambda: False, 0.5) is False
        assert experiment.wait_until(lambda: True, 0.0) is True
        assert experiment.wait_until(lambda: True, None) is True
        assert experiment.ended() == ""


def test_a_process_deaf_to_sigint_is_stopped_after_the_grace_asked_for(tmp_path, monkeypatch):
    monkeypatch.delenv("ROS_MASTER_URI", raising=False)
    deaf = [
        sys.executable,
        "-c",
        "import signal, time; signal.signal(signal.SIGINT, signal.SIG_IGN); print('ready', flush=True); time.sleep(60)",
    ]
    with Experiment(tmp_path) as experiment:
        assert experiment.master_uri == ""  # no master yet: its processes get none until it brings one
        process = experiment.start("deaf", deaf, tmp_path / "deaf.log")
        wait_until_ready(tmp_path / "deaf.log")
        started = time.monotonic()
        assert experiment.stop(process, grace=0.5) == -signal.SIGTERM
        assert time.monotonic() - started < 5.0


def test_what_a_stopped_process_left_running_in_a_session_of_its_own_is_killed(tmp_path):
    """Like roslaunch's nodes: each in a session of its own, so the launch's process group does not reach them."""
    pid_file = tmp_path / "pid"
    launcher = ["bash", "-c", f"setsid sleep 600 & echo $! > {pid_file}; exec sleep 600"]
    with Experiment(tmp_path) as experiment:
        process = experiment.start("launcher", launcher)
        deadline = time.monotonic() + 30.0
        while not (pid_file.is_file() and pid_file.read_text().strip()) and time.monotonic() < deadline:
            time.sleep(0.05)
        apart = int(pid_file.read_text())
        assert descendants(process.pid) == [apart] and running(apart)
        # Expect the launcher stopped by SIGINT, and what it left running in its own session stopped and reported
        assert stop_tree(process, grace=1.0) == (-signal.SIGINT, [apart])
        assert not running(apart)
        # Expect a process that leaves nothing behind to report nothing
        alone = experiment.start("alone", READY_SLEEPER, tmp_path / "alone.log")
        wait_until_ready(tmp_path / "alone.log")
        assert stop_tree(alone, grace=1.0) == (-signal.SIGINT, [])


def test_a_child_is_stopped_by_sigint_even_when_ours_ignores_sigint(tmp_path):
    """A shell without job control starts its background commands with SIGINT ignored, and children inherit that."""
    code = """
import pathlib, signal, sys
from teleteach.runtime.experiment import Experiment
from teleteach.runtime.processes import stop_tree
assert signal.getsignal(signal.SIGINT) == signal.SIG_IGN
with Experiment(pathlib.Path(sys.argv[1])) as experiment:
    print(*stop_tree(experiment.start("sleeper", ["sleep", "60"]), grace=10.0))
"""
    ignoring = ["bash", "-c", 'trap "" INT; exec "$0" "$@"', sys.executable, "-c", code, str(tmp_path)]
    result = subprocess.run(ignoring, env=with_our_path(os.environ), capture_output=True, text=True, timeout=60)
    # Expect the sleeper (which does not catch SIGINT) ended by the first, polite signal, leaving nothing behind
    assert result.returncode == 0, result.stderr
    assert result.stdout.split() == [str(-signal.SIGINT), "[]"]


def test_a_process_that_ended_without_a_log_is_named_with_its_exit_code(tmp_path):
    with Experiment(tmp_path) as experiment:
        experiment.start("short", [sys.executable, "-c", "exit(2)"], watched=True).wait(30)
        assert experiment.ended() == f"{PYTHON} ended early (exit 2)"


def test_every_process_stops_when_it_closes(tmp_path):
    experiment = Experiment(tmp_path)
    first = experiment.start("first", SLEEPER, tmp_path / "first.log")
    second = experiment.start("second", SLEEPER)
    experiment.close()
    assert first.poll() is not None and second.poll() is not None


@pytest.mark.system
def test_without_a_display_it_brings_its_own_x_server(tmp_path, monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    with Experiment(tmp_path) as experiment:
        assert experiment.own_display() is True
        display = experiment.display
        assert display.startswith(":") and experiment.environment()["DISPLAY"] == display
        (tmp_path / "shots").mkdir()
        shots = experiment.screenshots("stage", lambda: "start", delay=0.0, period=0.5, folder=tmp_path / "shots")
        deadline = time.monotonic() + 20.0
        while not (tmp_path / "shots" / "stage_01_start_latest.png").exists() and time.monotonic() < deadline:
            time.sleep(0.1)
        shots.stop()
        # Expect the stage pictured, then its latest state, into the folder asked for
        assert (tmp_path / "shots" / "stage_01_start.png").stat().st_size > 0, shots.errors
        assert (tmp_path / "shots" / "stage_01_start_latest.png").stat().st_size > 0, shots.errors
    # Expect the X server gone with the experiment
    assert not os.path.exists(f"/tmp/.X11-unix/X{display[1:]}")


def test_with_a_display_it_uses_it_and_pictures_nothing_when_told_not_to(tmp_path, monkeypatch):
    monkeypatch.setenv("DISPLAY", ":4242")
    with Experiment(tmp_path) as experiment:
        assert experiment.own_display() is False and experiment.display == ":4242"
        shots = experiment.screenshots("stage", lambda: "start", delay=0.0, period=0.1, enabled=False)
        time.sleep(0.3)
        shots.stop()
        assert list(tmp_path.glob("*.png")) == [] and shots.errors == []
