"""The ROS side of the GUI (thesis Appendix A.1): a worker QObject in its own QThread and background helpers.

rospy callbacks never touch a widget: they update thread-safe state or emit class-level signals, which Qt delivers
queued in the GUI thread. The worker also publishes /eigenvalues and /eigenvectors from its own thread at
``publish_rate`` while LOW-LEVEL (or a tab whose adapter hears the arm) is active, its timer stopped in the other tabs,
independent of the repaint rate (the thesis tied stiffness to the GUI refresh and recorded it too sparsely, Appendix
C.2), and samples the recording at the same instants; a device sample that changes the ellipsoid is sent at once from
the subscriber's thread, so the latency does not include waiting for the next tick.
"""

import math
import threading
import time
from typing import Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np
import rospy
from geometry_msgs.msg import PoseStamped, QuaternionStamped, Vector3Stamped
from PyQt5.QtCore import QObject, Qt, QTimer, pyqtSignal, pyqtSlot
from std_msgs.msg import Bool, Float64

from teleteach.core.active_tab import Tab
from teleteach.core.gui_config import GuiConfig
from teleteach.gui.adapter import TabAdapter
from teleteach.gui.arm import ArmListener
from teleteach.gui.device import DeviceFilter, EdgeDetector, parse_pose
from teleteach.gui.ellipsoid import EllipsoidCommand
from teleteach.gui.perception import Perception
from teleteach.gui.proposal import HelpRequestView
from teleteach.gui.recording import StiffnessRecorder
from teleteach.gui.selection import LibrarySkill, TreeNode, TreeSnapshot
from teleteach.gui.study import study_view
from teleteach.msg import (
    BehaviourTree,
    HelpRequest,
    SkillLibrary,
    StudyState,
    TreeExecution,
)
from teleteach.runtime.node import publish, shutting_down

DEVICE_LOST = "device lost (/sigma7/pose silent)"


class RosWorker(QObject):
    """The device's and the tree's subscribers, the stiffness publishers, the tabs' adapters; in its own QThread.

    Thesis Fig. A.1, orange block. The tabs' own topics are their adapters' (teleteach.gui.adapter).

    ROS Subscribers: /sigma7/pose, /sigma7/button, /sigma7/gripper_angle, /behaviour_tree/log/tree,
    /behaviour_tree/skill_library, /behaviour_tree/help_request, /behaviour_tree/execution, study/state (a user study's
    state); through ``arm`` (teleteach.gui.arm) /cartesian_pose and /joint_states in LOW-LEVEL and a tab whose adapter
    ``hears_arm``, through ``perception`` (teleteach.gui.perception) teleteach/scene and TF in LOW-LEVEL and a tab
    whose adapter ``hears_scene``. The tree's execution and /joint_states tell whether the arm is free for the
    impedance controller.
    ROS Publishers: /eigenvalues, /eigenvectors (while LOW-LEVEL is active, or as a ``hears_arm`` adapter's ``tick``
    sends them).
    """

    device_changed = pyqtSignal(object)  # DeviceSample, at most device_ui_rate
    clicked = pyqtSignal(float)  # the device's clock at the click: the stamp of its latest pose
    gripper_opened = pyqtSignal()
    tree_received = pyqtSignal(object)  # TreeSnapshot
    library_received = pyqtSignal(object)  # list of LibrarySkill
    help_requested = pyqtSignal(object)  # HelpRequestView: the failure, the remembered repair, the robot's proposal
    health = pyqtSignal(str)  # "" when all inputs are alive, else what is missing
    study_state = pyqtSignal(object)  # StudyView of a user study (study/state)
    _tab_changed = pyqtSignal()  # to the worker's own thread, where its timers live
    execution_changed = pyqtSignal(int, str)  # the tree's TreeExecution state and its message

    def __init__(
        self,
        config: GuiConfig,
        command: EllipsoidCommand,
        recorder: StiffnessRecorder,
        equilibrium: Callable[[], Optional[np.ndarray]],
        adapters: Sequence[TabAdapter] = (),
    ):
        """The worker of the window.

        ``equilibrium``: the pose the player commands now (recorded with each stiffness sample), or None;
        ``adapters``: the tabs' ROS sides, run in this worker's thread.
        """
        super().__init__()
        self.config = config
        self.command = command
        self.recorder = recorder
        self.adapters = list(adapters)
        for adapter in self.adapters:
            adapter.setParent(self)  # moves to the worker's thread with it
        self._active_tab = 0
        self._publish_timer: Optional[QTimer] = None
        self._tab_changed.connect(self._follow_tab, Qt.QueuedConnection)
        self.equilibrium = equilibrium
        self._filter = DeviceFilter(config)
        self._button = EdgeDetector(0.5, 0.5)
        self._gripper = EdgeDetector(config.gripper_open_threshold, config.gripper_rearm_below)
        self._lock = threading.Lock()
        self._sample = None
        self._sample_seq = 0
        self._emitted_seq = 0
        self._emitted: Optional[object] = None  # the DeviceSample last sent to the widgets
        self._pose: Optional[tuple] = None  # the newest /sigma7/pose not yet parsed: (position, quaternion)
        self._publish_lock = threading.Lock()
        self._last_publish = -1.0
        self._last_seen = {}
        self._rejected = 0
        self._health: Optional[str] = None
        self.last_click = -math.inf  # the device's clock at the last click that arrived
        self.device_time = 0.0  # the device's clock: the header stamp of its latest pose [s]
        self._subscribers: Dict[str, rospy.Subscriber] = {}
        self._timers: List[QTimer] = []
        self.arm = ArmListener(config, self._on_arm)  # heard in the tabs that command a stiffness
        self.perception = Perception(config.base_frame)  # the scene and TF, heard in LOW-LEVEL and TELEOP
        self._execution: Optional[TreeExecution] = None
        self._device_pose: Optional[tuple] = None  # the newest /sigma7/pose: (position, quaternion, when it came)
        self._gripper_angle: Optional[float] = None

    @pyqtSlot()
    def start(self) -> None:
        """Create subscribers, publishers and timers (runs in the worker thread)."""
        self._eigenvalues = rospy.Publisher("eigenvalues", Vector3Stamped, queue_size=10)
        self._eigenvectors = rospy.Publisher("eigenvectors", QuaternionStamped, queue_size=10)
        subscriptions: List[Tuple[str, type, Callable]] = [
            ("sigma7/pose", PoseStamped, self._on_pose),
            ("sigma7/button", Bool, self._on_button),
            ("sigma7/gripper_angle", Float64, self._on_gripper),
            ("behaviour_tree/log/tree", BehaviourTree, self._on_tree),
            ("behaviour_tree/skill_library", SkillLibrary, self._on_library),
            ("behaviour_tree/help_request", HelpRequest, self._on_help),
            ("study/state", StudyState, lambda message: self.study_state.emit(study_view(message))),
            ("behaviour_tree/execution", TreeExecution, self._on_execution),
        ]
        for topic, message_class, callback in subscriptions:
            # every button and gripper message counts (a dropped one can be a whole click); of poses, the newest
            queue = 2000 if topic in ("sigma7/button", "sigma7/gripper_angle") else 5
            self._subscribers[topic] = rospy.Subscriber(
                topic, message_class, callback, queue_size=queue, tcp_nodelay=True
            )
        for rate, slot in (
            (self.config.publish_rate, self._publish_stiffness),
            (self.config.device_ui_rate, self._emit_device),
            (self.config.health_rate, self._check_health),
        ):
            timer = QTimer(self)
            timer.setTimerType(Qt.PreciseTimer)
            timer.timeout.connect(slot)
            timer.setInterval(max(1, int(round(1000.0 / rate))))
            self._timers.append(timer)
        self._publish_timer = self._timers[0]
        for timer in self._timers[1:]:
            timer.start()
        for adapter in self.adapters:
            adapter.start(self)
        self._follow_tab()

    def _adapter(self, hearing_arm: bool = False) -> Optional[TabAdapter]:
        """The active tab's adapter (only one that hears the arm, if ``hearing_arm``), or None."""
        for adapter in self.adapters:
            if adapter.tab == self._active_tab and (adapter.hears_arm or not hearing_arm):
                return adapter
        return None

    @property
    def active_tab(self) -> int:
        """The GUI's tab (teleteach.core.active_tab.Tab); set from the GUI thread."""
        return self._active_tab

    @active_tab.setter
    def active_tab(self, tab: int) -> None:
        self._active_tab = tab
        self._tab_changed.emit()

    @pyqtSlot()
    def _follow_tab(self) -> None:
        """Run the stiffness stream and hear the arm only in the tabs that command a stiffness (worker thread)."""
        if self._publish_timer is None:
            return  # not started yet: start() looks at the tab
        for adapter in self.adapters:
            adapter.tab_changed(self._active_tab)
        commanding = self._active_tab == Tab.LOW_LEVEL or self._adapter(hearing_arm=True) is not None
        if commanding and not self._publish_timer.isActive():
            self._publish_timer.start()
        elif not commanding:
            self._publish_timer.stop()
        self.arm.listen(commanding)
        adapter = self._adapter()
        self.perception.listen(self._active_tab == Tab.LOW_LEVEL or (adapter is not None and adapter.hears_scene))

    @pyqtSlot()
    def stop(self) -> None:
        """Cooperative stop: timers off, topics and the TF listener gone (runs in the worker thread)."""
        for timer in self._timers:
            timer.stop()
        self.perception.listen(False)
        self.arm.listen(False)
        for subscriber in self._subscribers.values():
            subscriber.unregister()
        self._subscribers.clear()
        for adapter in self.adapters:
            adapter.stop()
        for publisher in (self._eigenvalues, self._eigenvectors):
            publisher.unregister()

    def latest_sample(self):
        """The newest filtered device sample (None before the first), whether or not it was emitted yet."""
        with self._lock:
            return self._sample

    def reset_device_filter(self) -> None:
        """Take the next device sample as it is (a new tab starts from where the device is, told even when still)."""
        with self._lock:
            self._filter.reset()
            self._emitted = None

    # rospy threads ---------------------------------------------------------------------------
    def _on_pose(self, message: PoseStamped) -> None:
        """Keep the pose; LOW-LEVEL turns it into a stiffness at once, the other tabs take it at device_ui_rate."""
        p, q = message.pose.position, message.pose.orientation
        self._last_seen["sigma7/pose"] = time.monotonic()
        self.device_time = message.header.stamp.to_sec() or self.device_time
        with self._lock:
            self._pose = ((p.x, p.y, p.z), (q.x, q.y, q.z, q.w))
        self._device_pose = ((p.x, p.y, p.z), (q.x, q.y, q.z, q.w), time.monotonic())
        if self.active_tab == Tab.LOW_LEVEL:
            sample = self._take_sample()
            if sample is not None and self.command.device(sample):
                self._publish(urgent=True)

    def _take_sample(self) -> Optional[object]:
        """The newest pose as a filtered DeviceSample (parsed once), or None when it is NaN or out of range."""
        with self._lock:
            pose, self._pose = self._pose, None
            if pose is None:
                return self._sample
            raw = parse_pose(*pose, self.config)
            if raw is not None:
                self._sample = self._filter.apply(raw)
                self._sample_seq += 1
                return self._sample
        self._rejected += 1
        rospy.logwarn_throttle(5.0, f"teaching_gui: ignored {self._rejected} NaN or out-of-range device poses")
        return None

    def _on_button(self, message: Bool) -> None:
        if self._button.update(1.0 if message.data else 0.0):
            # the click is timed by the device that made it (ROS time of the device node: simulated time when a
            # scenario plays it), so neither a slow simulation nor a busy GUI splits or joins a double click
            self.last_click = self.device_time
            self.clicked.emit(self.last_click)

    def _on_gripper(self, message: Float64) -> None:
        self._gripper_angle = message.data
        if self._gripper.update(message.data):
            self.gripper_opened.emit()

    def _on_arm(self, stamp: float, pose: np.ndarray) -> None:
        adapter = self._adapter(hearing_arm=True)
        if adapter is not None:
            adapter.on_arm(stamp, pose)

    def _on_tree(self, message: BehaviourTree) -> None:
        nodes = [
            TreeNode(b.name, b.class_name, b.own_id, b.parent_id, tuple(b.child_ids), b.type, b.status, b.is_active)
            for b in message.behaviours
        ]
        self.tree_received.emit(TreeSnapshot(nodes))

    def _on_library(self, message: SkillLibrary) -> None:
        padding = [""] * len(message.names)
        kinds, files, problems = (
            list(field) + padding for field in (message.kinds, message.data_files, message.problems)
        )
        self.library_received.emit([LibrarySkill(*skill) for skill in zip(message.names, kinds, files, problems)])

    def _on_help(self, message: HelpRequest) -> None:
        veto_left = 0.0
        if message.veto_window > 0.0:  # the window opened at the stamp: what is left of it now
            age = (rospy.Time.now() - message.header.stamp).to_sec()
            veto_left = min(message.veto_window, max(0.0, message.veto_window - age))
        view = HelpRequestView(
            message.node_name,
            message.reason,
            tuple(message.suggestion),
            tuple(message.proposal),
            message.confidence,
            message.why,
            message.applied,
            veto_left,
        )
        self.help_requested.emit(view)

    def _on_execution(self, message: TreeExecution) -> None:
        self._execution = message
        self.execution_changed.emit(message.state, message.message)

    def arm_free(self) -> Tuple[bool, str]:
        """Whether the impedance controller may take the arm now (tree stopped, arm at rest), or why not."""
        return self.arm.free(self._subscribers.get("behaviour_tree/execution"), self._execution)

    def device_pose(self) -> Optional[tuple]:
        """The newest /sigma7/pose: (position, quaternion, when it came on time.monotonic()), or None."""
        return self._device_pose

    @property
    def gripper_angle(self) -> Optional[float]:
        """The newest /sigma7/gripper_angle [rad], or None."""
        return self._gripper_angle

    # worker thread timers -----------------------------------------------------------------------
    def _publish_stiffness(self) -> None:
        """The steady stream (and the recording's samples) at publish_rate while LOW-LEVEL is active.

        On simulated time a sample is timed by the measured pose it holds, which the simulation stamps to the
        millisecond, where ROS time advances in steps of 1/clock_rate: samples at publish_rate keep distinct times
        under a coarser clock (the same measured pose twice is one sample). On the wall clock, the time now.
        """
        if shutting_down():
            return  # Ctrl-C closed the publishers; the window closes within the watchdog's period
        adapter = self._adapter(hearing_arm=True)
        if adapter is not None:
            adapter.tick()
            return
        if self.active_tab != Tab.LOW_LEVEL:
            return
        self._publish(urgent=False)
        measured = self.arm.measured
        if self.recorder.active and measured is not None:
            stamp = rospy.get_time() if rospy.rostime.is_wallclock() else measured[0]
            self.recorder.add(stamp, self.command.stiffness_matrix(), self.equilibrium(), measured[1])

    def _publish(self, urgent: bool) -> None:
        """Send the ellipsoid; an urgent send (the device changed it) is skipped when one just went out."""
        now = time.monotonic()
        with self._publish_lock:
            if urgent and now - self._last_publish < 0.5 / self.config.publish_rate:
                return
            self._last_publish = now
        self.send_stiffness(*self.command.stiffness())

    def send_stiffness(self, values, quaternion) -> None:
        """/eigenvalues and /eigenvectors now: principal stiffnesses [N/m], the axes' rotation (x y z w)."""
        stamp = rospy.Time.now()
        eigenvalues = Vector3Stamped()
        eigenvalues.header.stamp = stamp
        eigenvalues.header.frame_id = self.config.base_frame
        eigenvalues.vector.x, eigenvalues.vector.y, eigenvalues.vector.z = (float(value) for value in values)
        eigenvectors = QuaternionStamped()
        eigenvectors.header = eigenvalues.header
        q = eigenvectors.quaternion
        q.x, q.y, q.z, q.w = quaternion
        publish(self._eigenvalues, eigenvalues)
        publish(self._eigenvectors, eigenvectors)

    def _emit_device(self) -> None:
        """The latest device sample to the widgets, unless the last one sent was the same (a device at rest is free)."""
        self._take_sample()
        with self._lock:
            if self._sample_seq == self._emitted_seq or self._sample == self._emitted:
                return
            self._emitted_seq = self._sample_seq
            sample = self._emitted = self._sample
        self.device_changed.emit(sample)

    def _check_health(self) -> None:
        """Emit what is missing when that changes.

        The device counts as lost as soon as its publisher disconnects (the node died) or its poses stop for
        ``device_timeout``; the stiffness keeps its last valid value meanwhile.
        """
        missing = []
        silent = time.monotonic() - self._last_seen.get("sigma7/pose", -1e9) > self.config.device_timeout
        if silent or self._subscribers["sigma7/pose"].get_num_connections() == 0:
            missing.append(DEVICE_LOST)
        if self._subscribers["behaviour_tree/log/tree"].get_num_connections() == 0:
            missing.append("no behaviour tree (/behaviour_tree/log/tree)")
        problems = "; ".join(missing)
        if problems != self._health:
            self._health = problems
            self.health.emit(problems)
