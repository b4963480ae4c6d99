"""One way to run an experiment on a live ROS system: display, master, processes, watching, pictures, stopping.

The thesis run (:mod:`teleteach.run.thesis`), a study session (:mod:`teleteach.study.runner`) and the benches that
need a ROS graph (bench/haptic_guidance.py, bench/shared_control_sweep.py, bench/gui_latency.py, bench/sigma7.py,
bench/change_tree.py) run on an :class:`Experiment`; each keeps only its question: what to launch, what to watch,
what to judge. An experiment

- has a display: the user's, or an X server of its own when there is none (:meth:`Experiment.own_display`);
- has a ROS master: a roscore of its own, a roslaunch that brings its own, or the running one, and joins it as a
  rospy node when it watches topics itself (:meth:`Experiment.join`);
- starts its processes with that master, display and a data directory in their environment, stopped when the
  experiment's process dies however it dies, and stopped newest first when it ends (:meth:`Experiment.close`);
- watches the processes it depends on: a wait (:meth:`Experiment.wait_until`) ends at once with the reason when one
  of them ended (the required node that died and its last words, from roslaunch's log);
- pictures each stage of what the operator saw (:meth:`Experiment.screenshots`).
"""

import os
import pathlib
import signal
import subprocess
import time
from typing import Callable, Dict, List, Optional, Sequence, Tuple

from teleteach.runtime.processes import (
    Processes,
    StageScreenshots,
    own_master,
    own_roscore,
    ros_environment,
    start_xvfb,
    with_required_death,
)

POLL = 0.2  # [s] how often a wait looks at its condition and at the watched processes
SIM_TIME_WAIT = 60.0  # [s] for a launch to set /use_sim_time (roslaunch sets parameters before it starts nodes)


class SystemEndedError(RuntimeError):
    """A process the experiment depends on ended before it was told to stop; the message says why."""


class Experiment:
    """What one experiment runs on; use it as a context manager (or call :meth:`close`): everything stops.

    ``folder`` takes the logs the experiment does not name itself (roscore.log). ``data_root`` is the data directory
    its processes get unless a start names another.
    """

    def __init__(self, folder: pathlib.Path, data_root: Optional[pathlib.Path] = None):
        self.folder = pathlib.Path(folder)
        self.data_root = pathlib.Path(data_root) if data_root is not None else self.folder
        self.processes = Processes()
        self.display = os.environ.get("DISPLAY", "")
        self.master_uri = os.environ.get("ROS_MASTER_URI", "")
        self._watched: Dict[int, Tuple[subprocess.Popen, Optional[pathlib.Path]]] = {}

    def __enter__(self) -> "Experiment":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # where it runs ----------------------------------------------------------------------------------------------
    def own_display(self) -> bool:
        """An X server of our own when there is no display; whether one was started (then GUIs run headless)."""
        if self.display:
            return False
        self.display = start_xvfb(self.processes, parent_death_signal=signal.SIGTERM)
        return True

    def own_roscore(self, log: Optional[pathlib.Path] = None, host: str = "localhost") -> str:
        """A roscore of our own on a free port, its output in ``log`` (default ``<folder>/roscore.log``); its URI."""
        log = log or self.folder / "roscore.log"

        def start(command: Sequence[str], uri: str) -> subprocess.Popen:
            return self.start("roscore", command, log, master_uri=uri)

        self.master_uri, _ = own_roscore(start, self.processes.stop, host)
        return self.master_uri

    def own_launch(
        self,
        command: Callable[[int], List[str]],
        log: pathlib.Path,
        data_root: Optional[pathlib.Path] = None,
        host: str = "localhost",
    ) -> subprocess.Popen:
        """A roslaunch that brings its own master (``command(port)``: ``roslaunch -p port ...``), watched."""

        def start(port: int) -> subprocess.Popen:
            return self.start("roslaunch", command(port), log, data_root, master_uri=f"http://{host}:{port}")

        port, launch = own_master(start, self.processes.stop, host)
        self.master_uri = f"http://{host}:{port}"
        self.watch(launch, log)
        return launch

    def environment(self, data_root: Optional[pathlib.Path] = None, master_uri: str = "") -> Dict[str, str]:
        """The environment of the experiment's processes: its master, its display, a data directory."""
        return ros_environment(master_uri or self.master_uri, self.display, data_root or self.data_root)

    def join(self, name: str, anonymous: bool = False, sim_time: bool = False) -> None:
        """This process as a rospy node on the experiment's master (to watch topics, call services, publish).

        ``sim_time``: the launch sets /use_sim_time, and the node must be on its clock: it joins once the parameter
        is there (rospy reads it once, at init), else its times would be the wall's, racing the launch.
        """
        os.environ["ROS_MASTER_URI"] = self.master_uri
        os.environ["TELETEACH_DATA"] = str(self.data_root)
        if not os.environ.get("ROS_IP") and not os.environ.get("ROS_HOSTNAME"):
            os.environ["ROS_IP"] = "127.0.0.1"
        if sim_time:
            import rosgraph

            master = rosgraph.Master(f"/{name}")
            if not self.wait_until(lambda: master.hasParam("/use_sim_time"), SIM_TIME_WAIT):
                raise TimeoutError(f"the launch set no /use_sim_time within {SIM_TIME_WAIT:g} s")
        from teleteach.runtime.node import init_node

        init_node(name, anonymous=anonymous, disable_signals=True)

    # what it runs ----------------------------------------------------------------------------------------------
    def start(
        self,
        name: str,
        command: Sequence[str],
        log: Optional[pathlib.Path] = None,
        data_root: Optional[pathlib.Path] = None,
        watched: bool = False,
        master_uri: str = "",
    ) -> subprocess.Popen:
        """Start ``command`` on the experiment's master and display; ``watched``: a wait ends when it ends.

        ``master_uri``: the master being brought up instead (a roscore or roslaunch of our own, on a probed port).

        It gets SIGINT when this process dies, however it dies: roslaunch stops its nodes, rosbag closes its bag.
        """
        process = self.processes.start(
            name, command, log, self.environment(data_root, master_uri), parent_death_signal=signal.SIGINT
        )
        if watched:
            self.watch(process, log)
        return process

    def watch(self, process: subprocess.Popen, log: Optional[pathlib.Path]) -> None:
        """A wait ends when ``process`` ends; its ``log`` (roslaunch's) says which required node died."""
        self._watched[process.pid] = (process, log)

    def stop(self, process: subprocess.Popen, grace: float = 20.0) -> Optional[int]:
        """Stop ``process`` (no longer watched: it ends because we asked); its exit code."""
        self._watched.pop(process.pid, None)
        return self.processes.stop(process, grace)

    def close(self) -> None:
        """Stop everything still running, newest first."""
        self._watched.clear()
        self.processes.stop_all()

    # watching --------------------------------------------------------------------------------------------------
    def ended(self) -> str:
        """Why a watched process ended (the required node that died first, when roslaunch says), or ""."""
        for process, log in self._watched.values():
            if process.poll() is not None:
                name = pathlib.Path(process.args[0]).name
                reason = f"{name} ended early (exit {process.returncode})" + (f"; see {log}" if log else "")
                return with_required_death(reason, log) if log else reason
        return ""

    def check(self) -> None:
        """Raise :class:`SystemEndedError` when a watched process ended."""
        reason = self.ended()
        if reason:
            raise SystemEndedError(reason)

    def wait_until(self, condition: Callable[[], bool], timeout: Optional[float], poll: float = POLL) -> bool:
        """Until ``condition()`` holds (True) or ``timeout`` seconds passed (False; None: as long as it takes).

        Raises :class:`SystemEndedError` at once when a watched process ended: a wait never outlives the system.
        """
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            self.check()
            if condition():
                return True
            if deadline is not None and time.monotonic() > deadline:
                return False
            time.sleep(poll)

    def screenshots(
        self,
        prefix: str,
        stage: Callable[[], Optional[str]],
        delay: float,
        period: float,
        folder: Optional[pathlib.Path] = None,
        enabled: bool = True,
    ) -> StageScreenshots:
        """Each stage of the experiment pictured into ``folder`` (default the experiment's).

        None when not ``enabled`` or without a display. Stop them (``.stop()``) before the stage's system stops.
        """
        display = self.display if enabled else ""
        return StageScreenshots(display, folder or self.folder, prefix, stage, delay, period)
