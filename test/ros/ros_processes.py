"""Start real ROS processes for a test (own roscore on a free port, own Xvfb) and stop them by PID in reverse order."""

import os
import pathlib
import signal
import socket
import subprocess
import time


def free_port():
    with socket.socket() as probe:
        probe.bind(("localhost", 0))
        return probe.getsockname()[1]


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


def start_roscore(processes, name="roscore", attempts=5):
    """A roscore on a free port; sets ROS_MASTER_URI for every process started afterwards.

    The port is probed free, then bound by roscore: another run may take it in between, so a roscore that exits, or
    a master on that port that is not this roscore's child, means: try another port.
    """
    processes.env["ROS_LOG_DIR"] = str(processes.log_dir / "ros_log")
    for attempt in range(attempts):
        port = free_port()
        uri = f"http://localhost:{port}"
        processes.env["ROS_MASTER_URI"] = uri
        core = processes.start(f"{name}_{attempt}" if attempt else name, ["roscore", "-p", str(port)])
        deadline = time.monotonic() + 60
        while core.poll() is None and time.monotonic() < deadline:
            owner = master_pid(uri)
            if owner is not None:
                if parent_pid(owner) == core.pid:
                    return uri
                break  # somebody else's master took the port
            time.sleep(0.2)
        processes.stop(f"{name}_{attempt}" if attempt else name)
    raise AssertionError(f"no roscore after {attempts} ports: {processes.log(name)}")


def master_pid(uri):
    """The process id of the master at ``uri``, or None while none answers."""
    import xmlrpc.client

    try:
        code, _, pid = xmlrpc.client.ServerProxy(uri).getPid("/start_roscore")
    except (OSError, xmlrpc.client.Error):
        return None
    return pid if code == 1 else None


def parent_pid(pid):
    """The parent process id of ``pid`` (Linux /proc), or None if it is gone."""
    try:
        stat = pathlib.Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    return int(stat.rsplit(")", 1)[1].split()[1])


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
