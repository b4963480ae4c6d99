"""Child processes of a run: an X server when there is no display, roslaunch, RViz, screenshots.

Processes are started in their own session and stopped by PID, in reverse order of starting (RViz before Xvfb),
first politely (SIGINT: roslaunch stops its nodes and rosbag closes the bag), then SIGTERM, then SIGKILL.
"""

import os
import pathlib
import shutil
import signal
import socket
import subprocess
import time
from typing import IO, List, Optional, Sequence, Tuple


class ProcessError(RuntimeError):
    """A child process could not be started or did not come up."""


def free_port() -> int:
    """A TCP port nobody listens on now (for the run's own roscore)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def free_display(first: int = 90, last: int = 200) -> int:
    """An X display number without a lock file or socket."""
    for number in range(first, last):
        lock, unix_socket = pathlib.Path(f"/tmp/.X{number}-lock"), pathlib.Path(f"/tmp/.X11-unix/X{number}")
        if not lock.exists() and not unix_socket.exists():
            return number
    raise ProcessError(f"no free X display between :{first} and :{last}")


class Processes:
    """The run's child processes; :meth:`stop_all` ends them newest first."""

    def __init__(self):
        self._started: List[Tuple[str, subprocess.Popen, Optional[IO]]] = []

    def start(self, name: str, command: Sequence[str], log: Optional[pathlib.Path] = None, env=None):
        """Start a command in its own session, output to ``log`` (or discarded)."""
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
        )
        self._started.append((name, process, stream))
        return process

    def stop(self, process: subprocess.Popen, grace: float = 20.0) -> Optional[int]:
        """SIGINT, then SIGTERM, then SIGKILL, each after a wait; returns the exit code."""
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
        for index, (_, started, stream) in enumerate(self._started):
            if started is process:
                if stream is not None:
                    stream.close()
                del self._started[index]
                break
        return process.poll()

    def stop_all(self) -> None:
        """Stop everything still known, newest first."""
        while self._started:
            self.stop(self._started[-1][1])


def start_xvfb(processes: Processes, size: str = "1400x1000x24") -> str:
    """Start Xvfb on a free display and wait for its socket; returns the DISPLAY value."""
    number = free_display()
    process = processes.start("Xvfb", ["Xvfb", f":{number}", "-screen", "0", size, "-nolisten", "tcp"])
    deadline = time.monotonic() + 15.0
    while not pathlib.Path(f"/tmp/.X11-unix/X{number}").exists():
        if process.poll() is not None or time.monotonic() > deadline:
            processes.stop(process)
            raise ProcessError(f"Xvfb did not start on :{number}")
        time.sleep(0.1)
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
