"""Start real ROS processes for a test (own roscore on a free port, own Xvfb) and stop them by PID in reverse order."""

import os
import pathlib
import signal
import subprocess
import sys
import time

from teleteach.runtime.processes import own_roscore


class Processes:
    """Processes started in order and stopped in reverse order (SIGINT, then SIGTERM, then SIGKILL), each by PID."""

    def __init__(self, log_dir: pathlib.Path, env=None):
        self.log_dir = pathlib.Path(log_dir)
        self.log_dir.mkdir(parents=True, exist_ok=True)
        self.env = dict(os.environ if env is None else env)
        self.started = []

    def start(self, name, command, extra_env=None, **kwargs):
        env = dict(self.env, **(extra_env or {}))
        log = open(self.log_dir / f"{name}.log", "w")  # closed in _stop
        process = subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT, env=env, **kwargs)
        self.started.append((name, process, log))
        return process

    def log(self, name):
        return (self.log_dir / f"{name}.log").read_text(errors="replace")

    def stop(self, name):
        for entry in list(self.started):
            if entry[0] == name:
                self._stop(*entry)
                self.started.remove(entry)

    def stop_all(self):
        while self.started:
            self._stop(*self.started.pop())

    @staticmethod
    def _stop(name, process, log):
        for sig, wait in ((signal.SIGINT, 15), (signal.SIGTERM, 5), (signal.SIGKILL, 5)):
            if process.poll() is not None:
                break
            process.send_signal(sig)
            try:
                process.wait(wait)
            except subprocess.TimeoutExpired:
                continue
        log.close()

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

    uri, _ = own_roscore(start, lambda core: processes.stop(names[core.pid]))
    return uri


def run_probe(log_dir, code, timeout=120):
    """Run a Python program (one ROS node) against a roscore of its own; returns the finished process."""
    with Processes(log_dir) as processes:
        start_roscore(processes)
        command = [sys.executable, "-c", code]
        return subprocess.run(command, env=processes.env, capture_output=True, text=True, timeout=timeout, check=False)


def start_xvfb(processes, size="1280x900x24"):
    """An Xvfb of the given size on a free display (Xvfb -displayfd picks it); sets DISPLAY for what follows."""
    read_end, write_end = os.pipe()
    processes.start(
        "xvfb", ["Xvfb", "-displayfd", str(write_end), "-screen", "0", size, "-nolisten", "tcp"], pass_fds=(write_end,)
    )
    os.close(write_end)
    with os.fdopen(read_end) as stream:
        display = ":" + stream.readline().strip()
    assert display != ":", processes.log("xvfb")
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
