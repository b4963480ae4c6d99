"""Start real ROS processes for a test (own roscore on a free port, own Xvfb) and stop them by PID in reverse order."""

import os
import pathlib
import subprocess
import sys
import time

from teleteach.runtime import processes as runtime


class Processes:
    """A test's processes by name, each writing ``<log_dir>/<name>.log`` (read it when the test fails).

    On :class:`teleteach.runtime.processes.Processes`: each in its own session, stopped by PID newest first, SIGINT,
    then SIGTERM, then SIGKILL.
    """

    GRACE = 15.0  # [s] after SIGINT

    def __init__(self, log_dir: pathlib.Path, env=None):
        self.log_dir = pathlib.Path(log_dir)
        self.log_dir.mkdir(parents=True, exist_ok=True)
        self.env = dict(os.environ if env is None else env)
        self.runtime = runtime.Processes()
        self._named = []

    def start(self, name, command, extra_env=None, pass_fds=()):
        """Start ``command`` as ``name``; a name started again gets a fresh log."""
        log = self.log_dir / f"{name}.log"
        log.unlink(missing_ok=True)
        env = dict(self.env, **(extra_env or {}))
        process = self.runtime.start(name, command, log, env, pass_fds=pass_fds)
        self._named.append((name, process))
        return process

    def process(self, name):
        """The process last started as ``name``."""
        return [process for started, process in self._named if started == name][-1]

    def log(self, name):
        return (self.log_dir / f"{name}.log").read_text(errors="replace")

    def stop(self, name):
        for entry in [entry for entry in self._named if entry[0] == name]:
            self.runtime.stop(entry[1], self.GRACE)
            self._named.remove(entry)

    def stop_all(self):
        while self._named:
            self.runtime.stop(self._named.pop()[1], self.GRACE)
        self.runtime.stop_all()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.stop_all()


def echo_once(processes, topic, timeout=30):
    """One message of topic as `rostopic echo` prints it (arrays left out), or "" when none came in time."""
    result = subprocess.run(
        ["rostopic", "echo", "-n", "1", "--noarr", topic],
        env=processes.env,
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )
    return result.stdout if result.returncode == 0 else ""


def wait_until(condition, timeout, what):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return
        time.sleep(0.2)
    raise AssertionError(f"timed out after {timeout} s waiting for {what}")


def start_roscore(processes, name="roscore"):
    """A roscore on a free port of its own (teleteach.runtime.processes.own_roscore); sets ROS_MASTER_URI for every
    process started afterwards."""
    processes.env["ROS_LOG_DIR"] = str(processes.log_dir / "ros_log")
    names = {}

    def start(command, uri):
        processes.env["ROS_MASTER_URI"] = uri
        core_name = f"{name}_{len(names)}" if names else name
        core = processes.start(core_name, command)
        names[core.pid] = core_name
        return core

    uri, _ = runtime.own_roscore(start, lambda core: processes.stop(names[core.pid]))
    return uri


def run_probe(log_dir, code, timeout=120):
    """Run a Python program (one ROS node) against a roscore of its own; returns the finished process."""
    with Processes(log_dir) as processes:
        start_roscore(processes)
        command = [sys.executable, "-c", code]
        return subprocess.run(command, env=processes.env, capture_output=True, text=True, timeout=timeout, check=False)


def start_xvfb(processes, size="1280x900x24"):
    """An Xvfb of the given size on a free display (teleteach.runtime.processes.start_xvfb); sets DISPLAY for what
    follows."""
    display = runtime.start_xvfb(processes.runtime, size)
    processes.env["DISPLAY"] = display
    return display


_MISSING = object()


def node_pid(name, missing=_MISSING):
    """The process id of a ROS node, asked from the node itself (its getPid API); ``missing`` if it does not answer."""
    import xmlrpc.client

    import rosgraph
    import rosnode

    try:
        api = rosnode.get_api_uri(rosgraph.Master("/node_pid"), name, skip_cache=True)
        code, _, pid = xmlrpc.client.ServerProxy(api).getPid("/node_pid")
        if code == 1:
            return pid
        error = f"{name} answered getPid with code {code}"
    except (OSError, TypeError, rosnode.ROSNodeIOException, xmlrpc.client.Error) as exception:
        error = f"{name} does not answer: {exception}"
    if missing is _MISSING:
        raise AssertionError(error)
    return missing
