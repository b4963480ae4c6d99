"""The SHARED CONTROL tab's ROS side (what the MPC says and plans, in the task plane) and its place in the window.

The task plane is the ``plane`` section of config/shared_control.yaml, the shared_control node's own (the one place
it is written); everything the tab draws comes as task-plane points through this adapter's signals.

ROS Subscribers: /shared_control/state, /shared_control/plan, /shared_control/boundary, /shared_control/obstacle,
/equilibrium_pose (recorded with the constant stiffness while SHARED CONTROL records).
ROS Publishers: none of its own; while the tab is active the worker sends ``shared_control_stiffness`` on
/eigenvalues and /eigenvectors.
"""

import math
import time
from typing import Dict, Optional

import numpy as np
import rospy
import yaml
from geometry_msgs.msg import PolygonStamped, PoseStamped
from nav_msgs.msg import Path
from PyQt5.QtCore import Qt, pyqtSignal
from std_msgs.msg import Bool

from teleteach.core.active_tab import Tab
from teleteach.core.gui_config import GuiConfig
from teleteach.core.paths import config_file
from teleteach.gui.adapter import TabAdapter, TabParts
from teleteach.gui.recording import StiffnessRecorder
from teleteach.gui.session import Action
from teleteach.gui.shared_control.view import SharedControlTab, SharedStatus
from teleteach.gui.worker import pose_to_array
from teleteach.msg import SharedControlState
from teleteach.runtime.node import publish
from teleteach.shared_control.plane import TaskPlane
from teleteach.shared_control.ros import obstacle_from_pose

IDENTITY = (0.0, 0.0, 0.0, 1.0)


def shared_plane(path=None) -> Optional[TaskPlane]:
    """The shared_control node's task plane (config/shared_control.yaml's ``plane``), or None when it is bad."""
    try:
        section = yaml.safe_load((path or config_file("shared_control.yaml")).read_text()).get("plane")
        return TaskPlane.from_params(section) if isinstance(section, dict) else None
    except (ValueError, TypeError, OSError, AttributeError) as error:
        rospy.logwarn(f"teaching_gui: bad shared-control plane (config/shared_control.yaml): {error}")
        return None


class SharedControlRos(TabAdapter):
    """Subscribes to the MPC's topics and turns them into task-plane values for the SHARED CONTROL tab."""

    hears_arm = True
    state = pyqtSignal(object)  # SharedStatus
    plan = pyqtSignal(object)  # n x 2 task-plane points [m]
    boundary = pyqtSignal(object)  # n x 2 task-plane points [m]
    obstacle = pyqtSignal(object)  # (x, y, yaw) in the task plane
    arm = pyqtSignal(object)  # the arm (/cartesian_pose) on the task plane (x, y) [m], while SHARED CONTROL
    ARM_TRAIL_PERIOD = 0.02  # [s] the arm's trail keeps a point per 20 ms of /cartesian_pose (it comes at 200 Hz)

    def __init__(self, config: GuiConfig, recorder: StiffnessRecorder):
        super().__init__(Tab.SHARED_CONTROL)
        self.config = config
        self.recorder = recorder
        self.plane: Optional[TaskPlane] = None
        self._arm_stamp = -math.inf
        self._subscribers: Dict[str, rospy.Subscriber] = {}

    def start(self, worker) -> None:
        """The plane, then the subscribers."""
        super().start(worker)
        self.plane = shared_plane()
        for topic, message_class, callback in (
            ("shared_control/state", SharedControlState, self._on_state),
            ("shared_control/plan", Path, self._on_plan),
            ("shared_control/boundary", PolygonStamped, self._on_boundary),
            ("shared_control/obstacle", PoseStamped, self._on_obstacle),
            ("equilibrium_pose", PoseStamped, self._on_equilibrium),
        ):
            self._subscribers[topic] = rospy.Subscriber(topic, message_class, callback, queue_size=5, tcp_nodelay=True)

    def stop(self) -> None:
        """No more subscribers."""
        for subscriber in self._subscribers.values():
            subscriber.unregister()
        self._subscribers.clear()

    def tick(self) -> None:
        """The constant stiffness of config/gui.yaml's ``shared_control_stiffness``, axes unturned."""
        self.worker.send_stiffness(self.config.shared_control_stiffness, IDENTITY)

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
        planar = self._to_plane([(p.x, p.y, p.z) for p in message.polygon.points])
        if planar is not None:
            self.boundary.emit(planar)

    def _on_obstacle(self, message: PoseStamped) -> None:
        try:
            edge = obstacle_from_pose(message)
        except ValueError:  # InvalidMessageError or a non-finite edge
            return
        self.obstacle.emit((edge.x, edge.y, edge.yaw))

    def _on_equilibrium(self, message: PoseStamped) -> None:
        """While SHARED CONTROL records, the MPC's equilibrium pose is recorded with the constant stiffness."""
        if self.active and self.recorder.active:
            stiffness = np.diag(np.asarray(self.config.shared_control_stiffness, dtype=float))
            self.recorder.add(
                message.header.stamp.to_sec(), stiffness, pose_to_array(message.pose), self.measured_pose()
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
    ):
        signal.connect(slot, Qt.QueuedConnection)
    view.recording_toggled.connect(lambda: window.carry_out(window.session.toggle_shared_recording()))
    actions = {
        Action.SHARED_CONTROL_ON: lambda: publish(window.topics.shared_control, Bool(True)),
        Action.SHARED_CONTROL_OFF: lambda: publish(window.topics.shared_control, Bool(False)),
        Action.START_SHARED_RECORDING: lambda: _start_recording(window, view, recorder),
        Action.STOP_SHARED_RECORDING: lambda: _stop_recording(window, view, recorder),
        Action.SAVE_SHARED_SKILL: lambda: _save_skill(window, recorder),
    }
    return TabParts(Tab.SHARED_CONTROL.title, view, adapter, actions)


def _start_recording(window, view: SharedControlTab, recorder: StiffnessRecorder) -> None:
    """Record the MPC's /equilibrium_pose and /cartesian_pose."""
    recorder.start()
    window.set_recording(True)
    view.recording_since = time.monotonic()
    window.statusBar().showMessage("recording the shared-control trajectory", 5000)


def _stop_recording(window, view: SharedControlTab, recorder: StiffnessRecorder) -> None:
    recorder.stop()
    window.set_recording(False)
    view.recording_since = None
    view.show_status(view.status)


def _save_skill(window, recorder: StiffnessRecorder) -> None:
    """The shared-control recording becomes a ``shared_control`` skill."""
    stiffness = [float(value) for value in window.config.shared_control_stiffness]
    window.save_recording(recorder, "shared_control", window.config.shared_skill_prefix, {"stiffness": stiffness})
