"""Child processes of a run: an X server when there is no display, roslaunch of a whole system, RViz, screenshots.

A screenshot is of the screen once, or of each stage of an experiment while it runs (:class:`StageScreenshots`).

Processes are started in their own session and stopped by PID, in reverse order of starting (RViz before Xvfb),
first politely (SIGINT: roslaunch stops its nodes and rosbag closes the bag), then SIGTERM, then SIGKILL; then what
they started and left running (roslaunch's nodes live in sessions of their own) is waited for and stopped too. A process
may be told to stop when ours dies, however it dies (Linux's parent-death signal): a killed study runner leaves no
roslaunch behind. Every process starts with SIGINT's default action, even when ours ignores SIGINT (a shell without job
control starts its background commands so, and a child inherits that): else SIGINT would not stop a child that does not
catch it itself, and each polite stop would wait out its grace and end in SIGTERM.
"""

import ctypes
import os
import pathlib
import re
import select
import shutil
import signal
import socket
import subprocess
import threading
import time
import xmlrpc.client
from typing import IO, Any, Callable, Dict, List, Mapping, Optional, Sequence, Tuple

import yaml

PR_SET_PDEATHSIG = 1  # prctl option (linux/prctl.h)


class ProcessError(RuntimeError):
    """A child process could not be started or did not come up."""


def free_port() -> int:
    """A TCP port nobody listens on now; another process may take it before ours binds it: see :func:`own_master`."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def master_pid(uri: str) -> Optional[int]:
    """The process id of the ROS master answering at ``uri``, or None while none answers."""
    try:
        code, _, pid = xmlrpc.client.ServerProxy(uri).getPid("/teleteach_port_check")
    except (OSError, xmlrpc.client.Error):
        return None
    return pid if code == 1 else None


def parent_pid(pid: int) -> Optional[int]:
    """The parent process id of ``pid`` (Linux /proc), or None when it is gone."""
    try:
        stat = pathlib.Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    return int(stat.rsplit(")", 1)[1].split()[1])


def descendants(pid: int) -> List[int]:
    """The processes below ``pid``: its children, theirs, and so on.

    roslaunch starts each node in a session of its own, so signalling the launch's process group does not reach them.
    """
    children: Dict[int, List[int]] = {}
    for entry in pathlib.Path("/proc").iterdir():
        if entry.name.isdigit():
            parent = parent_pid(int(entry.name))
            if parent is not None:
                children.setdefault(parent, []).append(int(entry.name))
    found, pending = [], [pid]
    while pending:
        below = children.get(pending.pop(), [])
        found.extend(below)
        pending.extend(below)
    return found


def stop_tree(process: subprocess.Popen, grace: float = 20.0) -> Tuple[Optional[int], List[int]]:
    """Stop ``process`` and all it started: the exit code, and the pids it left running (stopped here).

    SIGINT, then SIGTERM, then SIGKILL to ``process``, each after a wait. What it started may still be finishing (the
    recorder under ``rosbag record`` closes its bag after the wrapper has exited) and gets ``grace`` to end by itself;
    what still runs then (the nodes of a launch killed before it stopped them) gets SIGINT, ``grace``, then SIGKILL.
    """
    below = descendants(process.pid)
    for sig, wait in ((signal.SIGINT, grace), (signal.SIGTERM, 5.0), (signal.SIGKILL, 5.0)):
        if process.poll() is not None:
            break
        try:
            os.kill(process.pid, sig)
        except ProcessLookupError:
            break
        try:
            process.wait(wait)
        except subprocess.TimeoutExpired:
            continue
    leftovers = still_running(below, grace)
    for sig, wait in ((signal.SIGINT, grace), (signal.SIGKILL, 5.0)):
        alive = still_running(leftovers, 0.0)
        for pid in alive:
            try:
                os.kill(pid, sig)
            except ProcessLookupError:
                pass  # it ended since
        if not still_running(alive, wait):
            break
    return process.poll(), leftovers


def still_running(pids: Sequence[int], timeout: float) -> List[int]:
    """Those of ``pids`` still running after waiting up to ``timeout`` seconds for them to end."""
    deadline = time.monotonic() + timeout
    while True:
        alive = [pid for pid in pids if running(pid)]
        if not alive or time.monotonic() >= deadline:
            return alive
        time.sleep(0.05)


def running(pid: int) -> bool:
    """Whether ``pid`` is a process that still runs (not gone, not a zombie waiting to be reaped)."""
    try:
        stat = pathlib.Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


def wait_for_own_master(uri: str, starter: subprocess.Popen, timeout: float) -> bool:
    """Whether the master answering at ``uri`` is the child of ``starter`` (roscore or roslaunch -p).

    False when ``starter`` ended, when another process's master answers (it took the port between the probe and the
    bind), or after ``timeout`` seconds without a master.
    """
    deadline = time.monotonic() + timeout
    while starter.poll() is None and time.monotonic() < deadline:
        pid = master_pid(uri)
        if pid is not None:
            return parent_pid(pid) == starter.pid
        time.sleep(0.2)
    return False


def own_master(
    start: Callable[[int], subprocess.Popen],
    stop: Callable[[subprocess.Popen], object],
    host: str = "localhost",
    attempts: int = 5,
    timeout: float = 60.0,
) -> Tuple[int, subprocess.Popen]:
    """Start something that brings up its own ROS master (``start(port)``) on a free port; returns (port, process).

    A port is only probed free, so a master that another process started there in between, or a starter that
    exits (the port was taken), means: ``stop`` it and try another port.
    """
    last = "it found another process's master on its port"
    for _ in range(attempts):
        port = free_port()
        process = start(port)
        if wait_for_own_master(f"http://{host}:{port}", process, timeout):
            return port, process
        if process.poll() is not None:
            last = f"it exited with {process.returncode}"
        elif master_pid(f"http://{host}:{port}") is None:
            last = f"no master answered on port {port} within {timeout:.0f} s"
        stop(process)
    raise ProcessError(f"no ROS master of our own after {attempts} ports; the last time {last}")


def own_roscore(
    start: Callable[[Sequence[str], str], subprocess.Popen],
    stop: Callable[[subprocess.Popen], object],
    host: str = "localhost",
) -> Tuple[str, subprocess.Popen]:
    """A roscore on a free port of its own (:func:`own_master`), started by ``start(command, uri)``; (URI, process).

    ``uri`` is the master's to be: the environment of the roscore and of everything started after it.
    """

    def start_at(port: int) -> subprocess.Popen:
        return start(["roscore", "-p", str(port)], f"http://{host}:{port}")

    port, process = own_master(start_at, stop, host)
    return f"http://{host}:{port}", process


class Processes:
    """The run's child processes; :meth:`stop_all` ends them newest first."""

    def __init__(self):
        self._started: List[Tuple[str, subprocess.Popen, Optional[IO]]] = []

    def start(
        self,
        name: str,
        command: Sequence[str],
        log: Optional[pathlib.Path] = None,
        env=None,
        pass_fds=(),
        parent_death_signal: Optional[int] = None,
    ):
        """Start a command in its own session, output to ``log`` (or discarded), with ``pass_fds`` left open.

        ``parent_death_signal``: the signal the command gets when this process (the thread that starts it) dies,
        e.g. SIGINT, so that roslaunch stops its nodes and rosbag closes its bag even after a SIGKILL of ours.
        """
        if shutil.which(command[0]) is None and not pathlib.Path(command[0]).is_file():
            raise ProcessError(f"{command[0]} is not installed (needed for {name})")
        stream = open(log, "ab") if log is not None else None
        process = subprocess.Popen(
            list(command),
            stdout=stream or subprocess.DEVNULL,
            stderr=subprocess.STDOUT,
            stdin=subprocess.DEVNULL,
            env=env,
            start_new_session=True,
            pass_fds=pass_fds,
            preexec_fn=_child_setup(parent_death_signal),
        )
        self._started.append((name, process, stream))
        return process

    def stop(self, process: subprocess.Popen, grace: float = 20.0) -> Optional[int]:
        """:func:`stop_tree` (nothing it started is left running); returns the exit code."""
        code, _ = stop_tree(process, grace)
        for index, (_, started, stream) in enumerate(self._started):
            if started is process:
                if stream is not None:
                    stream.close()
                del self._started[index]
                break
        return code

    def stop_all(self) -> None:
        """Stop everything still known, newest first."""
        while self._started:
            self.stop(self._started[-1][1])


def _child_setup(parent_death_signal: Optional[int]) -> Optional[Callable[[], None]]:
    """A preexec function for a child, or None when it needs none (no Python runs in the child then).

    SIGINT back to its default action when ours ignores it (an ignored signal stays ignored across exec);
    ``parent_death_signal``: the signal the child gets when its parent dies (prctl PR_SET_PDEATHSIG).
    """
    sigint_ignored = signal.getsignal(signal.SIGINT) == signal.SIG_IGN
    if parent_death_signal is None and not sigint_ignored:
        return None

    def set_up() -> None:
        if sigint_ignored:
            signal.signal(signal.SIGINT, signal.SIG_DFL)
        if parent_death_signal is not None:
            ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, parent_death_signal, 0, 0, 0)

    return set_up


def ros_environment(master_uri: str, display: str, data_root: pathlib.Path) -> Dict[str, str]:
    """The environment of a run's ROS processes: its master, its display, its data directory, loopback only.

    ROS_IP is 127.0.0.1 unless the user set ROS_IP or ROS_HOSTNAME (docs/real_robot.md: several machines).
    """
    env = dict(os.environ)
    if not env.get("ROS_IP") and not env.get("ROS_HOSTNAME"):
        env["ROS_IP"] = "127.0.0.1"
    env.update(ROS_MASTER_URI=master_uri, DISPLAY=display, TELETEACH_DATA=str(data_root), PYTHONUNBUFFERED="1")
    return env


def launch_value(value: Any) -> str:
    """A yaml value as a roslaunch argument (``true``, ``0.5``, ``[product_pick_1]``)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (list, dict)):
        return yaml.safe_dump(value, default_flow_style=True).strip()
    return str(value)


def full_launch(arguments: Mapping[str, Any], port: Optional[int] = None) -> List[str]:
    """``roslaunch [-p port] teleteach full.launch name:=value ...``: the whole system.

    As the main job and a study's trials start it; with ``port``, roslaunch starts a master of its own there.
    """
    command = ["roslaunch", *(["-p", str(port)] if port is not None else []), "teleteach", "full.launch"]
    return command + [f"{name}:={launch_value(value)}" for name, value in arguments.items()]


def scripted_device(scenario: pathlib.Path, rate: float) -> Dict[str, Any]:
    """full.launch's arguments for a scripted operator playing ``scenario`` with its device loop at ``rate`` [Hz].

    The device is required: an operator that fails its script (a keyframe waited for the system in vain) ends the
    whole system at once, and the run says why (:func:`required_death`).
    """
    return {"device": "scenario", "scenario": scenario, "device_rate": f"{rate:g}", "device_required": True}


def closed_bag(
    folder: pathlib.Path, prefix: str, into: pathlib.Path, timeout: float, name: Optional[str] = None
) -> Optional[pathlib.Path]:
    """The newest ``<prefix>_*.bag`` of ``folder``, moved into ``into`` once rosbag closed it (None: none closed).

    It keeps its name unless ``name`` is given. A recorder told to stop closes its bag (renames ``.bag.active`` to
    ``.bag``) a moment after its wrapper exits, so the bag is waited for, up to ``timeout`` seconds.
    """
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if sorted(folder.glob(f"{prefix}_*.bag")) and not list(folder.glob(f"{prefix}_*.bag.active")):
            break
        time.sleep(0.2)
    found = sorted(folder.glob(f"{prefix}_*.bag"))
    if not found:
        return None
    target = into / (name or found[-1].name)
    shutil.move(str(found[-1]), target)
    return target


def start_xvfb(
    processes: Processes, size: str = "1400x1000x24", timeout: float = 15.0, parent_death_signal: Optional[int] = None
) -> str:
    """Start Xvfb on a display it picks itself; returns the DISPLAY value.

    ``-displayfd``: no probe of free displays that another X server could race (abstract sockets are shared even
    across chroots).
    """
    read_end, write_end = os.pipe()
    try:
        process = processes.start(
            "Xvfb",
            ["Xvfb", "-displayfd", str(write_end), "-screen", "0", size, "-nolisten", "tcp"],
            pass_fds=(write_end,),
            parent_death_signal=parent_death_signal,
        )
    finally:
        os.close(write_end)
    with os.fdopen(read_end) as stream:
        ready, _, _ = select.select([stream], [], [], timeout)
        number = stream.readline().strip() if ready else ""
    if not number:
        processes.stop(process)
        raise ProcessError(f"Xvfb did not start within {timeout:.0f} s")
    return f":{number}"


def screenshot(display: str, path: pathlib.Path, timeout: float = 20.0) -> Optional[str]:
    """Save the whole X screen as an image (ImageMagick's import); returns an error text or None."""
    if shutil.which("import") is None:
        return "ImageMagick's import is not installed"
    result = subprocess.run(
        ["import", "-display", display, "-window", "root", str(path)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        timeout=timeout,
        check=False,
    )
    if result.returncode != 0 or not path.is_file():
        return result.stderr.decode(errors="replace").strip() or f"import exited with {result.returncode}"
    return None


class StageScreenshots:
    """What the operator saw, while it happens: each stage of an experiment (a GUI tab, a study's phase) pictured.

    A stage is pictured ``delay`` s after it began, then its latest state every ``period`` s while it lasts.
    ``stage()`` names the current stage; None: nothing worth a picture (a trial preparing). Each new stage is the
    next visit: ``<prefix>_<NN>_<stage>.png``, then ``<prefix>_<NN>_<stage>_latest.png``. Without a display nothing
    is taken. A picture that fails is listed in ``errors``; the run goes on.
    """

    POLL = 0.1  # [s] how often the stage is read

    def __init__(
        self,
        display: str,
        folder: pathlib.Path,
        prefix: str,
        stage: Callable[[], Optional[str]],
        delay: float,
        period: float,
    ):
        self.display, self.folder, self.prefix, self.stage = display, folder, prefix, stage
        self.delay, self.period = delay, period
        self.errors: List[str] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, name="screenshots", daemon=True) if display else None
        if self._thread is not None:
            self._thread.start()

    def _loop(self) -> None:
        visit, current, since, last = 0, None, 0.0, 0.0
        while not self._stop.wait(self.POLL):
            name, now = self.stage(), time.monotonic()
            if name != current:
                current, since, last = name, now, 0.0
                visit += name is not None
            if current is None or now - since < self.delay or (last and now - last < self.period):
                continue
            self.take(self.folder / f"{self.prefix}_{visit:02d}_{current}{'_latest' if last else ''}.png")
            last = now

    def take(self, path: pathlib.Path) -> None:
        """One picture of the whole screen (none without a display)."""
        if not self.display:
            return
        try:
            error = screenshot(self.display, path)
        except (OSError, subprocess.SubprocessError) as exception:
            error = str(exception)
        if error:
            self.errors.append(f"{path.name}: {error}")

    def stop(self) -> None:
        """End the pictures while the stage lasts (``take`` still works)."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(5.0)


_COLOUR = re.compile(r"\x1b\[[0-9;]*m|\x1b\][^\x07]*\x07")  # roslaunch's colours and terminal titles
_REQUIRED_DIED = re.compile(r"REQUIRED process \[(?P<name>[^\]]+?)-\d+\] has died!")
_EXIT_CODE = re.compile(r"process has died \[pid \d+, exit code (?P<code>-?\d+)")
_LOG_LINE = re.compile(r"^\[(?P<level>FATAL|ERROR)\] \[[^\]]*\]: (?P<message>.*)$", re.MULTILINE)


def required_death(launch_log: str) -> str:
    """Why a roslaunch ended early, in one line: the required process that died, its exit code and its last words.

    Its last words are the last FATAL (else ERROR) line that names it before it died, else the last FATAL line: a
    scripted operator's failed wait says where in its scenario file it waited. "" when no required process died.
    """
    text = _COLOUR.sub("", launch_log)
    died = _REQUIRED_DIED.search(text)
    if died is None:
        return ""
    name, before = died.group("name"), text[: died.start()]
    code = _EXIT_CODE.search(text, died.end())
    cause = f"{name} died" + (f" (exit code {code.group('code')})" if code else "")
    lines = [(match.group("level"), match.group("message").strip()) for match in _LOG_LINE.finditer(before)]
    for wanted in (
        lambda level, message: level == "FATAL" and name in message,
        lambda level, message: name in message,
        lambda level, message: level == "FATAL",
    ):
        said = [message for level, message in lines if wanted(level, message)]
        if said:
            return f"{cause}: {said[-1]}"
    return cause


def with_required_death(reason: str, launch_log: pathlib.Path) -> str:
    """``reason`` a launch ended for, led by the required node that died in its log (if one did)."""
    cause = required_death(launch_log.read_text(errors="replace")) if launch_log.exists() else ""
    return f"{cause}; {reason}" if cause else reason
