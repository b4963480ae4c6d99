"""The TELEOP tab's ROS side (the device drives the arm's equilibrium through the clutch) and its place in the window.

ROS Publishers: /equilibrium_pose (the window's publisher, shared with LOW-LEVEL's trajectory player), while the
session holds the arm: where the device puts it, inside the placement's assistance; the worker sends LOW-LEVEL's
ellipsoid on /eigenvalues and /eigenvectors meanwhile.
It hears the arm (/cartesian_pose) and the perceived scene with TF (the gap the assistance keeps out of, the gap a
recorded path is kept relative to) through the worker that hosts it.
"""

import functools
import math
import threading
import time
from typing import Callable, Optional, Tuple

import numpy as np
import rospy
from geometry_msgs.msg import PoseStamped
from PyQt5.QtCore import Qt, pyqtSignal

from teleteach.core.active_tab import Tab
from teleteach.core.gui_config import GuiConfig
from teleteach.core.teleoperation import Teleoperation
from teleteach.core.validation import InvalidCommandError
from teleteach.gui.adapter import TabAdapter, TabParts
from teleteach.gui.recording import PathRecorder
from teleteach.gui.session import Action
from teleteach.gui.teleop import paths
from teleteach.gui.teleop.view import TeleopTab, TeleopView
from teleteach.runtime.node import publish
from teleteach.shared_control.placement import Opening, assist
from teleteach.skills.config import load_motion_config


class TeleopRos(TabAdapter):
    """TELEOP_ON: each tick the equilibrium goes where the device puts it (from where the arm was); the tab is told."""

    hears_arm = True
    hears_scene = True
    changed = pyqtSignal(object)  # TeleopView: when the clutch or the reason changes, else at VIEW_RATE
    VIEW_RATE = 10.0  # [Hz] the TELEOP tab's poses are refreshed this often (the clutch at once)
    ASSISTANCE_PERIOD = 0.2  # [s] the opening TELEOP's assistance keeps out of is looked up again this often

    def __init__(self, config: GuiConfig, equilibrium: rospy.Publisher, path_recorder: PathRecorder):
        """``equilibrium``: /equilibrium_pose; ``path_recorder``: where the poses go while a path is recorded."""
        super().__init__(Tab.TELEOP)
        self.config = config
        self._equilibrium = equilibrium
        self.path_recorder = path_recorder
        self.teleop = Teleoperation(config.teleop)
        self._lock = threading.Lock()
        self._driving = False  # TELEOP_ON: the session holds the arm and the device drives it
        self._started = False  # the teleoperation holds a pose (the arm's, once /cartesian_pose came)
        self._shown: Tuple[object, str, float] = (None, "", -math.inf)  # clutch, reason, when (monotonic)
        self._opening: Tuple[Optional[Callable], str] = (None, "")  # the assistance's constraint, what it is
        self._opening_checked = -math.inf
        self._held_below = load_motion_config().grasp.height_above_center  # the skills' grasp: the product in the hand

    def drive_arm(self, driving: bool) -> None:
        """TELEOP_ON / TELEOP_OFF (from the GUI thread): the device drives the equilibrium from where the arm is."""
        with self._lock:
            self._driving, self._started = driving, False
            if not driving:
                self.teleop.stop()

    def tick(self) -> None:
        """LOW-LEVEL's ellipsoid on /eigenvalues and /eigenvectors, then the teleoperation's step."""
        values, quaternion = self.worker.command.stiffness()
        self.worker.send_stiffness(values, quaternion)
        self._teleoperate(tuple(float(value) for value in values))

    def _teleoperate(self, stiffness: Tuple[float, float, float]) -> None:
        """TELEOP's tick: the equilibrium where the device puts it, the tab told (worker thread, publish_rate)."""
        with self._lock:
            now = rospy.get_time()
            refused = self._refused(now, stiffness)
            if refused is not None:
                self._show(refused)
                return
            device = self.worker.device_pose()
            age = math.inf if device is None else time.monotonic() - device[2]
            constrain, assistance = self._assistance(self.teleop.pose)
            command = self.teleop.update(
                now, self.worker.gripper_angle, device and device[:2], age, self.config.device_timeout, constrain
            )
        if command.pose is not None:
            message = PoseStamped()
            message.header.stamp = rospy.Time.from_sec(now)
            message.header.frame_id = self.config.base_frame
            p, q = message.pose.position, message.pose.orientation
            p.x, p.y, p.z, q.x, q.y, q.z, q.w = (float(value) for value in command.pose)
            publish(self._equilibrium, message)
            self.path_recorder.add(now, command.pose)
        measured = self.measured_pose()
        self._show(TeleopView(True, command.clutch, command.reason, command.pose, measured, stiffness, assistance))

    def _refused(self, now: float, stiffness) -> Optional[TeleopView]:
        """What the tab shows while the device does not drive (not TELEOP_ON, no arm pose yet, a refused one)."""
        clutch = self.teleop.clutch
        if not self._driving:
            return TeleopView(False, clutch, "", None, self.measured_pose(), stiffness, "")
        if self._started:
            return None
        arm = self.measured_pose()
        if arm is None:
            return TeleopView(True, clutch, "waiting for /cartesian_pose", None, None, stiffness, "")
        try:
            self.teleop.start(arm, now)
        except InvalidCommandError as error:
            return TeleopView(True, self.teleop.clutch, f"arm pose refused: {error}", None, arm, stiffness, "")
        self._started = True
        return None

    def _show(self, view: TeleopView) -> None:
        """Tell the tab when the clutch or the reason changed, and otherwise at VIEW_RATE."""
        clutch, reason, shown = self._shown
        now = time.monotonic()
        if (view.clutch, view.reason) == (clutch, reason) and now - shown < 1.0 / self.VIEW_RATE:
            return
        self._shown = (view.clutch, view.reason, now)
        self.changed.emit(view)

    def _assistance(self, hand: np.ndarray):
        """TELEOP's shared control in the placement: the opening's constraint near the hand (or None), and its words.

        Looked up from perception and TF every ASSISTANCE_PERIOD.
        """
        parameters = self.config.teleop.assistance
        if not parameters.enabled:
            return None, "assistance off"
        now = time.monotonic()
        if now - self._opening_checked < self.ASSISTANCE_PERIOD:
            return self._opening
        self._opening_checked = now
        gap, target, why = self.worker.perception.nearest_gap(hand[:3])
        base, base_why = self.worker.perception.base_in_world()
        if gap is None or base is None:
            self._opening = (None, f"assistance: {why or base_why}")
        elif np.linalg.norm(target.position - hand[:3]) > parameters.reach:
            self._opening = (None, f"assistance: no gap within {100 * parameters.reach:.0f} cm")
        else:
            opening, why = Opening.perceived(self.worker.perception.scene(), gap, base, hand, self._held_below)
            if opening is None:
                self._opening = (None, f"assistance at {gap}: {why}")
            else:
                constrain = functools.partial(assist, opening, parameters=parameters)
                said = f"assistance at {gap}: its opening, {1000 * opening.width:.0f} mm wide"
                self._opening = (constrain, said)
        return self._opening


def build(window) -> TabParts:
    """TELEOP in ``window``."""
    view = TeleopTab(window.config)
    adapter = TeleopRos(window.config, window.topics.equilibrium, window.path_recorder)
    adapter.changed.connect(view.on_state, Qt.QueuedConnection)
    view.recording_toggled.connect(lambda: window.carry_out(window.session.toggle_path_recording()))
    view.click_hint.connect(lambda text: window.statusBar().showMessage(text, 8000))
    actions = {
        Action.TELEOP_ON: lambda: adapter.drive_arm(True),
        Action.TELEOP_OFF: lambda: adapter.drive_arm(False),
        Action.START_PATH_RECORDING: lambda: paths.start_recording(window, view),
        Action.STOP_PATH_RECORDING: lambda: paths.stop_recording(window),
        Action.SAVE_PATH: lambda: paths.save_path(window, view),
    }
    return TabParts(Tab.TELEOP.title, view, adapter, actions)
