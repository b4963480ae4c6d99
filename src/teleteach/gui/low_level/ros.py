"""The LOW-LEVEL tab's place in the window (the ellipsoid the device shapes; a double click records) and its player.

ROS Publishers: /equilibrium_pose (the window's publisher), from the trajectory player while a recording plays.
Its other topics (the stiffness stream, the scene and TF for a recording's gap) are still the worker's.
"""

import threading
from typing import Optional

import numpy as np
import rospy
from geometry_msgs.msg import PoseStamped

from teleteach.core.active_tab import Tab
from teleteach.core.trajectories import Trajectory
from teleteach.gui.adapter import TabParts
from teleteach.gui.low_level import demonstration
from teleteach.gui.low_level.view import LowLevelTab
from teleteach.gui.session import Action
from teleteach.runtime.node import publish


def build(window) -> TabParts:
    """LOW-LEVEL in ``window``: the tab over the window's ellipsoid command, its recording the window's."""
    view = LowLevelTab(
        window.config,
        window.command,
        recorded_samples=lambda: len(window.recorder),
        last_click=lambda: window.worker.last_click,
        device_time=lambda: window.worker.device_time,
    )
    view.recording_toggled.connect(lambda: window.carry_out(window.session.toggle_stiffness_recording()))
    view.click_hint.connect(lambda text: window.statusBar().showMessage(text, 8000))
    actions = {
        Action.ENTER_LOW_LEVEL: lambda: view.on_enter(window.worker.latest_sample()),
        Action.LEAVE_LOW_LEVEL: view.on_leave,
        Action.START_STIFFNESS_RECORDING: lambda: demonstration.start_recording(window, view),
        Action.STOP_STIFFNESS_RECORDING: lambda: demonstration.stop_recording(window, view),
        Action.SAVE_STIFFNESS_SKILL: lambda: demonstration.save_skill(window),
    }
    return TabParts(Tab.LOW_LEVEL.title, view, actions=actions)


class TrajectoryPlayer:
    """Plays the predefined kinematic trajectory on /equilibrium_pose from its own thread on ROS time (A.2.2)."""

    def __init__(self, trajectory: Trajectory, rate: float, publisher: rospy.Publisher):
        self.trajectory = trajectory
        self._period = 1.0 / rate
        self._publisher = publisher
        self._stop = threading.Event()
        self._thread: Optional[threading.Thread] = None
        self._lock = threading.Lock()
        self._current: Optional[np.ndarray] = None

    def current(self) -> Optional[np.ndarray]:
        """The pose last sent, or None before the first one."""
        with self._lock:
            return self._current

    @property
    def running(self) -> bool:
        """True while the thread plays (or holds the end pose)."""
        return self._thread is not None and self._thread.is_alive()

    def start(self, trajectory: Optional[Trajectory] = None) -> None:
        """Start from the first waypoint (of ``trajectory``, a base_link one, if given); then hold the end pose."""
        self.stop()
        if trajectory is not None:
            self.trajectory = trajectory
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="trajectory_player", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        """Stop the thread and wait for it."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
        self._thread = None

    def _run(self) -> None:
        # The trajectory's times are the robot's (ROS time: simulated time on a simulation): on wall time it would
        # play too fast whenever the simulation runs slower than real time, and run the product into the shelf.
        start = rospy.get_time()
        while not self._stop.is_set() and not rospy.is_shutdown():
            now = rospy.get_time()
            pose = self.trajectory.sample(now - start)
            message = PoseStamped()
            message.header.stamp = rospy.Time.from_sec(now)
            message.header.frame_id = self.trajectory.frame
            p, q = message.pose.position, message.pose.orientation
            p.x, p.y, p.z, q.x, q.y, q.z, q.w = (float(value) for value in pose)
            with self._lock:
                self._current = pose
            publish(self._publisher, message)
            self._stop.wait(self._period)
