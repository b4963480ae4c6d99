"""The SHARED CONTROL tab's ROS side (what the MPC says and plans, in the task plane) and its place in the window.

The task plane is the one the shared_control node says it plans on (/shared_control/task, latched: the ``plane`` of
config/shared_control.yaml, or on a wipe the surface as located on that wipe's enable); everything the tab draws comes
as task-plane points through this adapter's signals. On a wipe the tab teaches the stiffness too
(teleteach.gui.shared_control.teaching): the gripper clutch moves the handle to the ellipsoid, in the surface's axes,
while the node keeps the pattern, and a recording is saved relative to the surface, for the tree to wipe with.

ROS Subscribers: /shared_control/task, /shared_control/state, /shared_control/plan, /shared_control/boundary,
/shared_control/obstacle, /sigma7/gripper_angle (on a wipe), /equilibrium_pose (recorded with the stiffness while
SHARED CONTROL records).
ROS Publishers: /shared_control/clutch (std_msgs/Bool, while the tab is active on a wipe: each tick, true while the
gripper clutch is held); while the tab is active the worker sends the stiffness on /eigenvalues and /eigenvectors
(``shared_control_stiffness``, or on a wipe the one being taught).
"""

import math
import threading
import time
from typing import Dict, Optional, Tuple

import numpy as np
import rospy
from geometry_msgs.msg import PolygonStamped, PoseStamped
from nav_msgs.msg import Path
from PyQt5.QtCore import Qt, pyqtSignal
from std_msgs.msg import Bool, Float64

from teleteach.control.stiffness import translational_stiffness
from teleteach.core import skill_file
from teleteach.core.active_tab import Tab
from teleteach.core.frames import Transform
from teleteach.core.gui_config import GuiConfig
from teleteach.gui.adapter import TabAdapter, TabParts
from teleteach.gui.arm import pose_to_array
from teleteach.gui.recording import StiffnessRecorder
from teleteach.gui.session import Action
from teleteach.gui.shared_control.teaching import WipeTeaching
from teleteach.gui.shared_control.view import SharedControlTab, SharedStatus
from teleteach.msg import SharedControlState, SharedControlTask
from teleteach.runtime.node import publish
from teleteach.shared_control.plane import TaskPlane
from teleteach.shared_control.ros import obstacle_from_pose, task_of

IDENTITY = (0.0, 0.0, 0.0, 1.0)


class SharedControlRos(TabAdapter):
    """Subscribes to the MPC's topics and turns them into task-plane values for the SHARED CONTROL tab."""

    hears_arm = True
    state = pyqtSignal(object)  # SharedStatus
    plan = pyqtSignal(object)  # n x 2 task-plane points [m]
    boundary = pyqtSignal(object)  # n x 2 task-plane points [m]
    obstacle = pyqtSignal(object)  # (x, y, yaw) in the task plane
    arm = pyqtSignal(object)  # the arm (/cartesian_pose) on the task plane (x, y) [m], while SHARED CONTROL
    teaching = pyqtSignal(str)  # on a wipe: the clutch and the stiffness being taught, in a line ("" on the plane)
    ARM_TRAIL_PERIOD = 0.02  # [s] the arm's trail keeps a point per 20 ms of /cartesian_pose (it comes at 200 Hz)

    def __init__(self, config: GuiConfig, recorder: StiffnessRecorder):
        super().__init__(Tab.SHARED_CONTROL)
        self.config = config
        self.recorder = recorder
        self.plane: Optional[TaskPlane] = None
        self.surface: Optional[Tuple[str, Transform]] = None  # the wiped surface and its pose in base_link
        self.wipe: Optional[WipeTeaching] = None  # the stiffness taught on this wipe
        self._lock = threading.Lock()
        self._gripper: Optional[float] = None
        self._said = None
        self._boundary = []  # the boundary's corners in base_link, as the node last sent them
        self._stamps: Dict[str, float] = {}  # the stamp of the newest latched message taken, per topic
        self._arm_stamp = -math.inf
        self._subscribers: Dict[str, rospy.Subscriber] = {}
        self._clutch = None

    def start(self, worker) -> None:
        """The subscribers and the clutch's publisher."""
        super().start(worker)
        self._clutch = rospy.Publisher("shared_control/clutch", Bool, queue_size=1)
        for topic, message_class, callback in (
            ("shared_control/task", SharedControlTask, self._on_task),
            ("sigma7/gripper_angle", Float64, self._on_gripper),
            ("shared_control/state", SharedControlState, self._on_state),
            ("shared_control/plan", Path, self._on_plan),
            ("shared_control/boundary", PolygonStamped, self._on_boundary),
            ("shared_control/obstacle", PoseStamped, self._on_obstacle),
            ("equilibrium_pose", PoseStamped, self._on_equilibrium),
        ):
            self._subscribers[topic] = rospy.Subscriber(topic, message_class, callback, queue_size=5, tcp_nodelay=True)

    def stop(self) -> None:
        """No more subscribers, nor the clutch."""
        for subscriber in self._subscribers.values():
            subscriber.unregister()
        self._subscribers.clear()
        if self._clutch is not None:
            self._clutch.unregister()

    def tick(self) -> None:
        """The stiffness: config/gui.yaml's ``shared_control_stiffness``, or on a wipe the one taught, and the clutch.

        The clutch is sent every tick on a wipe: the node takes a clutch it stops hearing as released.
        """
        with self._lock:
            wipe, gripper = self.wipe, self._gripper
        if wipe is None:
            self.worker.send_stiffness(self.config.shared_control_stiffness, IDENTITY)
            self._say("")
            return
        clutched = wipe.update(rospy.get_time(), gripper, self.worker.latest_sample())
        publish(self._clutch, Bool(clutched))
        values, quaternion = wipe.stiffness()
        self.worker.send_stiffness(values, quaternion)
        along = ", ".join(f"{value:.0f}" for value in values)
        if clutched:
            self._say(f"CLUTCH: the handle shapes the stiffness (u, v, normal: {along} N/m); the pattern goes on")
        else:
            self._say(f"wiping {self.surface[0]}: stiffness (u, v, normal) {along} N/m; close the gripper to teach it")

    def _say(self, line: str) -> None:
        if line != self._said:
            self._said = line
            self.teaching.emit(line)

    def taught_stiffness(self) -> np.ndarray:
        """The translational stiffness commanded now (base_link) [N/m]: the one recorded with the equilibrium."""
        with self._lock:
            wipe = self.wipe
        if wipe is None:
            return np.diag(np.asarray(self.config.shared_control_stiffness, dtype=float))
        values, quaternion = wipe.stiffness()
        return translational_stiffness(values, quaternion)

    def on_arm(self, stamp: float, pose: np.ndarray) -> None:
        """The arm's trail on the plane: a point per ARM_TRAIL_PERIOD."""
        if abs(stamp - self._arm_stamp) >= self.ARM_TRAIL_PERIOD:
            planar = self._to_plane([pose[:3]])
            if planar is not None:
                self._arm_stamp = stamp
                self.arm.emit(planar[0])

    def _to_plane(self, points) -> Optional[np.ndarray]:
        plane = self.plane
        if plane is None:
            return None
        planar = np.array([plane.to_plane(point) for point in points]).reshape(-1, 2)
        return planar if np.all(np.isfinite(planar)) else None

    def _on_task(self, message: SharedControlTask) -> None:
        """The node's plane, and on a wipe the surface: a new wipe starts teaching from SHARED CONTROL's stiffness."""
        try:
            plane, surface = task_of(message)
        except ValueError as error:
            rospy.logwarn(f"teaching_gui: ignored /shared_control/task: {error}")
            return
        with self._lock:
            if not self._newer("task", message.header.stamp.to_sec()):
                return
            self.plane, self.surface = plane, surface
            self.wipe = None if surface is None else WipeTeaching(self.config, surface[1].rotation)
        self._draw_boundary()

    def _on_gripper(self, message: Float64) -> None:
        with self._lock:
            self._gripper = float(message.data)

    def _on_state(self, message: SharedControlState) -> None:
        status = SharedStatus(
            mode=message.mode,
            skill=message.skill,
            skills=tuple(message.skills),
            fitting_errors=tuple(message.fitting_errors),
            estimation_time=message.estimation_time,
            optimisation_time=message.optimisation_time,
            state=(message.state.x, message.state.y),
            message=message.message,
        )
        if all(math.isfinite(value) for value in status.state):
            self.state.emit(status)

    def _on_plan(self, message: Path) -> None:
        planar = self._to_plane([(p.pose.position.x, p.pose.position.y, p.pose.position.z) for p in message.poses])
        if planar is not None:
            self.plan.emit(planar)

    def _on_boundary(self, message: PolygonStamped) -> None:
        """Kept in base_link and drawn on the plane, again when the plane comes (the two topics race)."""
        with self._lock:
            if not self._newer("boundary", message.header.stamp.to_sec()):
                return
            self._boundary = [(p.x, p.y, p.z) for p in message.polygon.points]
        self._draw_boundary()

    def _newer(self, topic: str, stamp: float) -> bool:
        """Whether a latched message is newer than the last one taken (lock held).

        The latched copy a new connection gets can arrive after a newer message published meanwhile: it must not undo
        it (the plane's own boundary drawn on the board, or the board's plane undone, 1 run in 3 here).
        """
        if stamp < self._stamps.get(topic, -math.inf):
            return False
        self._stamps[topic] = stamp
        return True

    def _draw_boundary(self) -> None:
        with self._lock:
            points = self._boundary
        planar = self._to_plane(points) if points else None
        if planar is not None:
            self.boundary.emit(planar)

    def _on_obstacle(self, message: PoseStamped) -> None:
        try:
            edge = obstacle_from_pose(message)
        except ValueError:  # InvalidMessageError or a non-finite edge
            return
        self.obstacle.emit((edge.x, edge.y, edge.yaw))

    def _on_equilibrium(self, message: PoseStamped) -> None:
        """While SHARED CONTROL records, the MPC's equilibrium pose is recorded with the stiffness commanded."""
        if self.active and self.recorder.active:
            self.recorder.add(
                message.header.stamp.to_sec(),
                self.taught_stiffness(),
                pose_to_array(message.pose),
                self.measured_pose(),
            )


def build(window) -> TabParts:
    """SHARED CONTROL in ``window``: the MPC's topics drawn; a double click records its output as a skill."""
    config, recorder = window.config, window.shared_recorder
    view = SharedControlTab(config, recorded_samples=lambda: len(recorder))
    adapter = SharedControlRos(config, recorder)
    for signal, slot in (
        (adapter.state, view.on_state),
        (adapter.plan, view.on_plan),
        (adapter.boundary, view.on_boundary),
        (adapter.obstacle, view.on_obstacle),
        (adapter.arm, view.on_arm),
        (adapter.teaching, view.on_teaching),
    ):
        signal.connect(slot, Qt.QueuedConnection)
    view.recording_toggled.connect(lambda: window.carry_out(window.session.toggle_shared_recording()))
    view.click_hint.connect(lambda text: window.statusBar().showMessage(text, 8000))
    actions = {
        Action.SHARED_CONTROL_ON: lambda: publish(window.topics.shared_control, Bool(True)),
        Action.SHARED_CONTROL_OFF: lambda: publish(window.topics.shared_control, Bool(False)),
        Action.START_SHARED_RECORDING: lambda: _start_recording(window, view, recorder),
        Action.STOP_SHARED_RECORDING: lambda: _stop_recording(window, view, recorder),
        Action.SAVE_SHARED_SKILL: lambda: _save_skill(window, recorder, adapter),
    }
    return TabParts(Tab.SHARED_CONTROL.title, view, adapter, actions)


def _start_recording(window, view: SharedControlTab, recorder: StiffnessRecorder) -> None:
    """Record the MPC's /equilibrium_pose and /cartesian_pose."""
    recorder.start()
    window.topics.send_recording(True)
    view.recording_since = time.monotonic()
    window.statusBar().showMessage("recording the shared-control trajectory", 5000)


def _stop_recording(window, view: SharedControlTab, recorder: StiffnessRecorder) -> None:
    recorder.stop()
    window.topics.send_recording(False)
    view.recording_since = None
    view.show_status(view.status)


def _save_skill(window, recorder: StiffnessRecorder, adapter: SharedControlRos) -> None:
    """The shared-control recording becomes a ``shared_control`` skill; a wipe's, relative to the wiped surface."""
    prefix = window.config.shared_skill_prefix
    surface = adapter.surface
    if surface is None:
        stiffness = [float(value) for value in window.config.shared_control_stiffness]
        window.skills.save(recorder, "shared_control", prefix, {"stiffness": stiffness})
        return
    name, pose = surface
    target = (name, pose, skill_file.SURFACE)
    window.skills.save(recorder, "shared_control", prefix, {"wiped": name}, target=target)
