"""The sigma7 node's wiring: params -> backend -> device loop -> the four ``/sigma7/*`` topics.

ROS Publishers (relative names, ``/sigma7/...`` in the root namespace):
    sigma7/pose (geometry_msgs/PoseStamped): position [m] and orientation, frame ``~frame_id``.
    sigma7/twist (geometry_msgs/TwistStamped): filtered velocity [m/s, rad/s], same frame.
    sigma7/gripper_angle (std_msgs/Float64): [rad], 0 = closed.
    sigma7/button (std_msgs/Bool): emulated click state; one rising edge per click.
    These four at ``~publish_rate``, a share of the loop's ``~rate`` cycles (every cycle when the loop is slower), and
    in the cycle the button changes.
    sigma7/force (geometry_msgs/WrenchStamped): the guidance force [N] and torque [Nm] rendered (~force_rate).

ROS Subscribers:
    sigma7/guidance (teleteach/HapticGuidance): what to render; a bad message is refused with its reason (logged)
        and renders nothing.
    sigma7/input/pose (geometry_msgs/PoseStamped), sigma7/input/gripper_angle (std_msgs/Float64): the ``topic``
        backend's input (another program's device pose and gripper angle [rad]); bad input is refused, logged.
"""

import dataclasses
import os
import threading
import time as wall_time
import warnings
from typing import Any, Callable, Dict, Mapping, Optional, Sequence, Union

import rospy
from geometry_msgs.msg import PoseStamped, TwistStamped, WrenchStamped
from std_msgs.msg import Bool, Float64, Int8

from teleteach.core.parameters import from_mapping
from teleteach.core.study_phase import phase_name
from teleteach.haptics.axes import AxisMapping
from teleteach.haptics.click import ClickDetector, ClickParameters
from teleteach.haptics.device import DeviceBackend, DeviceUnavailableError
from teleteach.haptics.dhd import DhdBackend
from teleteach.haptics.guidance import (
    AXES,
    AxisGuidance,
    Guidance,
    GuidanceError,
    GuidanceLimits,
    GuidanceRenderer,
    Wrench,
)
from teleteach.haptics.hand import HandModelBackend, HandParameters
from teleteach.haptics.loop import Decimated, DeviceLoop, DeviceState, ThrottledLog, WallRate
from teleteach.haptics.monitor import DeviceMonitor
from teleteach.haptics.scenario import (
    AT_END_CHOICES,
    ScenarioBackend,
    ScenarioError,
    SystemState,
    check_clicks,
    load_scenario,
)
from teleteach.haptics.topic import TopicInput
from teleteach.haptics.twist import TwistEstimator
from teleteach.msg import Behaviour, BehaviourTree, HapticGuidance, HelpRequest, StudyState
from teleteach.runtime.node import end_parent_launch, node_parameters, server_has, server_value, shutting_down

BACKENDS = ("dhd", "scenario", "virtual", "topic")


@dataclasses.dataclass(frozen=True)
class TwistSettings:
    """config/device.yaml's ``twist``."""

    cutoff_frequency: float


@dataclasses.dataclass(frozen=True)
class VirtualSettings:
    """config/device.yaml's ``virtual``: the virtual window's scripted clicks."""

    click_duration: float
    double_click_gap: float


@dataclasses.dataclass(frozen=True)
class TopicSettings:
    """config/device.yaml's ``topic``: the topic backend's input."""

    timeout: float
    gripper: float


@dataclasses.dataclass(frozen=True)
class DhdSettings:
    """config/device.yaml's ``dhd``: the Force Dimension SDK."""

    library: str
    native_button: bool


@dataclasses.dataclass(frozen=True)
class HandSettings:
    """config/device.yaml's ``hand``: whether a modelled hand holds the device, and the model."""

    enabled: bool
    model: HandParameters


@dataclasses.dataclass(frozen=True)
class Sigma7Config:
    """The node's parameters: the keys of ``config/device.yaml`` (their values and units)."""

    backend: str
    scenario: str
    at_end: str
    rate: float
    publish_rate: float
    max_catch_up: float
    frame_id: str
    axes: Dict[str, Union[str, Sequence[Sequence[float]]]]
    click: ClickParameters
    twist: TwistSettings
    virtual: VirtualSettings
    topic: TopicSettings
    dhd: DhdSettings
    guidance: GuidanceLimits
    force_rate: float
    hand: HandSettings

    @property
    def axis_mapping(self) -> AxisMapping:
        """The backend's frame -> the operator frame (teleteach.haptics.axes)."""
        return AxisMapping.from_config(self.axes[self.backend], f"~axes/{self.backend}")

    @property
    def hand_model(self) -> Optional[HandParameters]:
        """The hand that holds the device, or None (the backend's pose is the device's)."""
        return self.hand.model if self.hand.enabled else None

    def __post_init__(self):
        if self.backend not in BACKENDS:
            raise ValueError(f"~backend must be one of {', '.join(BACKENDS)}, got {self.backend!r}")
        if self.backend == "scenario" and not self.scenario:
            raise ValueError("the scenario backend needs ~scenario, the path of a scenario file")
        if self.at_end not in AT_END_CHOICES:
            raise ValueError(f"~at_end must be one of {', '.join(AT_END_CHOICES)}, got {self.at_end!r}")
        if not self.rate > 0.0:
            raise ValueError(f"~rate must be a positive number of Hz, got {self.rate}")
        if not self.max_catch_up >= 0.0:
            raise ValueError(f"~max_catch_up must be a number of seconds >= 0, got {self.max_catch_up}")
        if self.hand.enabled and self.backend == "dhd":
            raise ValueError(
                "~hand/enabled models a hand for the scenario, virtual and topic backends; a real device has one"
            )
        if not self.publish_rate > 0.0:
            raise ValueError(f"~publish_rate must be a positive number of Hz, got {self.publish_rate}")
        if not 0.0 < self.force_rate <= self.rate:
            raise ValueError(f"~force_rate must be in (0, ~rate], got {self.force_rate}")
        if self.backend not in self.axes:
            raise ValueError(f"~axes has no entry for the {self.backend} backend (see config/device.yaml)")
        self.axis_mapping  # noqa: B018 - a bad ~axes entry is refused here, with its reason

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any]) -> "Sigma7Config":
        """From config/device.yaml's keys; a missing or unknown key is named."""
        values = dict(values)
        if isinstance(values.get("hand"), Mapping):  # the yaml's hand/enabled beside the model's own keys
            model = dict(values["hand"])
            values["hand"] = {"model": model, **({"enabled": model.pop("enabled")} if "enabled" in model else {})}
        return from_mapping(cls, values, "sigma7_node's parameters (config/device.yaml)")

    @classmethod
    def from_params(cls, get_param: Optional[Callable[[str, Any], Any]] = None) -> "Sigma7Config":
        """The yaml's keys, each overridden by its private parameter.

        ``get_param(name, default)`` is rospy's, unless a test gives another parameter server.
        """
        return cls.from_mapping(node_parameters("device.yaml", get_param))


class Sigma7Publisher:
    """Publishes a :class:`DeviceState` on the four device topics."""

    def __init__(self, frame_id: str) -> None:
        self._frame_id = frame_id
        # Synchronous publishing (no queue_size): measured here ~60 us of CPU per cycle for the four topics, against
        # ~320 us with rospy's queue threads, which a 1 kHz loop on a busy machine cannot afford. rospy warns
        # about the missing queue_size; the choice is deliberate, so the warning is silenced.
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", SyntaxWarning)
            self._pose = rospy.Publisher("sigma7/pose", PoseStamped)
            self._twist = rospy.Publisher("sigma7/twist", TwistStamped)
            self._gripper = rospy.Publisher("sigma7/gripper_angle", Float64)
            self._button = rospy.Publisher("sigma7/button", Bool)

    def __call__(self, state: DeviceState) -> None:
        """Publishes one cycle (nothing once ROS shuts down: Ctrl-C may close the topics in the middle of a cycle)."""
        try:
            self._publish(state)
        except (rospy.ROSException, ValueError, OSError):
            if not shutting_down():
                raise

    def _publish(self, state: DeviceState) -> None:
        stamp = rospy.Time.from_sec(state.stamp)
        pose = PoseStamped()
        pose.header.stamp = stamp
        pose.header.frame_id = self._frame_id
        position, orientation = pose.pose.position, pose.pose.orientation
        position.x, position.y, position.z = state.position
        orientation.x, orientation.y, orientation.z, orientation.w = state.orientation
        twist = TwistStamped()
        twist.header = pose.header
        linear, angular = twist.twist.linear, twist.twist.angular
        linear.x, linear.y, linear.z = state.linear_velocity
        angular.x, angular.y, angular.z = state.angular_velocity
        self._pose.publish(pose)
        self._twist.publish(twist)
        self._gripper.publish(Float64(state.gripper))
        self._button.publish(Bool(state.button))


def guidance_from_message(message: HapticGuidance) -> Guidance:
    """The library's guidance of a message; raises GuidanceError naming what is wrong."""
    detents = (
        message.detents_x,
        message.detents_y,
        message.detents_z,
        message.detents_roll,
        message.detents_pitch,
        message.detents_yaw,
    )
    axes = tuple(
        AxisGuidance(
            mode=message.modes[index],
            centre=message.centres[index],
            detents=tuple(detents[index]),
            stiffness=message.stiffness[index],
            width=message.detent_widths[index],
            damping=message.damping[index],
            click_stiffness=message.click_stiffness[index],
        )
        for index in range(len(AXES))
    )
    return Guidance(
        axes=axes,
        gripper_detent=message.gripper_detent if message.gripper_click else None,
        gripper_stiffness=message.gripper_stiffness,
        gripper_width=message.gripper_width,
        max_force=message.max_force,
        max_torque=message.max_torque,
    )


class WrenchPublisher:
    """Publishes every ``decimation``-th rendered wrench on sigma7/force (what the operator's hand was given)."""

    def __init__(self, frame_id: str, decimation: int) -> None:
        self._frame_id = frame_id
        self._decimation = max(1, decimation)
        self._count = 0
        self._publisher = rospy.Publisher("sigma7/force", WrenchStamped, queue_size=10)

    def __call__(self, wrench: Wrench) -> None:
        """Publishes one wrench of ``decimation``."""
        self._count += 1
        if self._count % self._decimation:
            return
        message = WrenchStamped()
        message.header.stamp = rospy.Time.now()
        message.header.frame_id = self._frame_id
        force, torque = message.wrench.force, message.wrench.torque
        force.x, force.y, force.z = wrench.force
        torque.x, torque.y, torque.z = wrench.torque
        self._publisher.publish(message)


class Sigma7Node:
    """Builds the backend named by the config and runs the device loop until shutdown.

    Raises:
        ScenarioError: the scenario file is invalid (the node must refuse to start).
        DeviceUnavailableError: the device, its library or (virtual) a display is missing.
    """

    def __init__(self, config: Sigma7Config) -> None:
        self.config = config
        self._application = None
        self._window = None
        self.backend = self._make_backend()
        self.guidance = GuidanceRenderer(config.guidance, click_below=config.click.release_threshold)
        self.loop = DeviceLoop(
            self.backend,
            Decimated(Sigma7Publisher(config.frame_id), round(config.rate / config.publish_rate)),
            clock=lambda: rospy.get_rostime().to_sec(),
            click_detector=ClickDetector(config.click),
            twist_estimator=TwistEstimator(config.twist.cutoff_frequency),
            log_error=rospy.logerr,
            log_info=rospy.loginfo,
            guidance=self.guidance,
            publish_wrench=WrenchPublisher(config.frame_id, round(config.rate / config.force_rate)),
            axes=config.axis_mapping,
        )
        self._guidance_subscriber = rospy.Subscriber(
            "sigma7/guidance", HapticGuidance, self._on_guidance, queue_size=10
        )

    @classmethod
    def from_params(cls) -> "Sigma7Node":
        """Build from the private parameters (config/device.yaml, :class:`Sigma7Config`)."""
        return cls(Sigma7Config.from_params())

    def _on_guidance(self, message: HapticGuidance) -> None:
        """Render the new guidance, or refuse it (and render nothing) saying why."""
        try:
            guidance = guidance_from_message(message)
        except (GuidanceError, IndexError) as error:
            self.guidance.drop()
            rospy.logwarn(f"sigma7_node: guidance refused, rendering none: {error}")
            return
        self.guidance.set(guidance, wall_time.monotonic())

    def _make_backend(self) -> DeviceBackend:
        backend = self._make_input()
        if self.config.hand_model is None:
            return backend
        rospy.loginfo(f"sigma7_node: a modelled hand holds the device ({self.config.hand_model})")
        return HandModelBackend(backend, self.config.hand_model)

    def _make_input(self) -> DeviceBackend:
        config = self.config
        if config.backend == "dhd":
            return DhdBackend(config.dhd.library, config.dhd.native_button)
        if config.backend == "virtual":
            return self._open_virtual_window()
        if config.backend == "topic":
            return self._subscribe_input()
        scenario = load_scenario(config.scenario)
        check_clicks(scenario, config.click)
        start_time = self._wait_for_ros_time()
        rospy.set_param("~scenario_start", start_time)
        rospy.loginfo(
            f"playing {scenario.source} ({len(scenario.keyframes)} keyframes, {scenario.duration:g} s, "
            f"{len(scenario.click_times())} clicks) from ROS time {start_time:.3f}"
        )
        if scenario.waits:
            backend = ScenarioBackend(scenario, start_time, config.at_end, system=RosSystemView())
        else:
            backend = ScenarioBackend(scenario, start_time, config.at_end)
        threading.Thread(target=self._note_played, args=(backend,), name="scenario_played", daemon=True).start()
        return backend

    def _subscribe_input(self) -> TopicInput:
        """The ``topic`` backend: the latest sigma7/input/pose and sigma7/input/gripper_angle."""
        device = TopicInput(self.config.topic.timeout, self.config.topic.gripper)
        refused = ThrottledLog(rospy.logwarn)

        def on_pose(message: PoseStamped) -> None:
            position, orientation = message.pose.position, message.pose.orientation
            try:
                device.pose(
                    (position.x, position.y, position.z), (orientation.x, orientation.y, orientation.z, orientation.w)
                )
            except ValueError as error:
                refused(f"sigma7_node: input refused: {error}")

        def on_gripper(message: Float64) -> None:
            try:
                device.gripper(message.data)
            except ValueError as error:
                refused(f"sigma7_node: input refused: {error}")

        self._input_subscribers = (
            rospy.Subscriber("sigma7/input/pose", PoseStamped, on_pose, queue_size=10),
            rospy.Subscriber("sigma7/input/gripper_angle", Float64, on_gripper, queue_size=10),
        )
        rospy.loginfo("sigma7_node: reading the device from sigma7/input/pose and sigma7/input/gripper_angle")
        return device

    @staticmethod
    def _note_played(backend: ScenarioBackend) -> None:
        """Set ~scenario_played once the last keyframe has been played (looked at 10 times a second of wall time).

        With waits, nobody can tell the end from the start time and the duration; the main job waits for this. A
        plain thread, not a rospy.Timer: under /use_sim_time that would wake at every /clock message.
        """
        while not backend.played and not rospy.is_shutdown():
            wall_time.sleep(0.1)
        if backend.played:
            rospy.set_param("~scenario_played", True)

    @staticmethod
    def _wait_for_ros_time() -> float:
        """Scenario time starts at the first non-zero ROS time (under use_sim_time, the first /clock)."""
        while rospy.get_rostime().is_zero() and not rospy.is_shutdown():
            wall_time.sleep(0.01)
        return rospy.get_rostime().to_sec()

    def _open_virtual_window(self) -> DeviceBackend:
        if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
            raise DeviceUnavailableError("the virtual backend needs a display, but DISPLAY is not set")
        from PyQt5 import QtWidgets

        from teleteach.haptics.virtual import VirtualDevice, VirtualDeviceWindow

        self._application = QtWidgets.QApplication.instance() or QtWidgets.QApplication([])
        device = VirtualDevice(self.config.virtual.click_duration, self.config.virtual.double_click_gap)
        self._window = VirtualDeviceWindow(device)
        self._window.show()
        return device

    def spin(self) -> None:
        """Runs the loop at ``~rate`` until ROS shuts down or the backend finishes (then closes the device)."""
        rate = WallRate(self.config.rate, max_lag=self.config.max_catch_up)
        try:
            if self._application is None:
                self.loop.run(rate, rospy.is_shutdown)
            else:
                self._spin_with_window(rate)
        finally:
            self.backend.close()
        rospy.loginfo(
            f"published {self.loop.published} cycles at {self.loop.achieved_rate:.1f} Hz on average, "
            f"{self.loop.failed_reads} failed reads, {rate.overruns} stalls longer than {rate.max_lag} s"
        )
        if self.failure:
            rospy.logfatal(f"sigma7_node: scenario failed: {self.failure}")

    @property
    def failure(self) -> str:
        """Why the scenario failed (a wait timed out), or ""."""
        return getattr(self.backend, "failure", "")

    def _spin_with_window(self, rate: WallRate) -> None:
        from PyQt5 import QtCore

        stop = threading.Event()
        worker = threading.Thread(target=self.loop.run, args=(rate, lambda: stop.is_set() or rospy.is_shutdown()))
        worker.start()
        watchdog = QtCore.QTimer()
        watchdog.timeout.connect(lambda: self._application.quit() if rospy.is_shutdown() else None)
        watchdog.start(100)
        self._application.exec_()
        stop.set()
        worker.join()


class RosSystemView:
    """What a scripted operator waits for (scenario ``wait:``), read from the topics a real operator sees on the GUI.

    The latest :class:`SystemState`; call it to read it (any thread).

    ROS Subscribers (all latched by their publishers):
        /teleteach/active_tab (std_msgs/Int8): the GUI's tab
        /teleteach/recording (std_msgs/Bool): whether the GUI records a demonstration
        /behaviour_tree/log/tree (teleteach/BehaviourTree): the nodes RUNNING
        /behaviour_tree/help_request (teleteach/HelpRequest): open while its node_name is not empty
        study/state (teleteach/StudyState): a user study's phase
    """

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._state = SystemState()
        self._subscribers = [
            rospy.Subscriber("teleteach/active_tab", Int8, self._update("tab", lambda m: int(m.data))),
            rospy.Subscriber("teleteach/recording", Bool, self._update("recording", lambda m: bool(m.data))),
            rospy.Subscriber(
                "behaviour_tree/log/tree",
                BehaviourTree,
                self._update(
                    "running", lambda m: frozenset(b.name for b in m.behaviours if b.status == Behaviour.RUNNING)
                ),
                queue_size=1,
            ),
            rospy.Subscriber(
                "behaviour_tree/help_request", HelpRequest, self._update("help_request", lambda m: bool(m.node_name))
            ),
            rospy.Subscriber("study/state", StudyState, self._update("study", _study_phase)),
        ]

    def _update(self, field, convert):
        def callback(message) -> None:
            with self._lock:
                self._state = dataclasses.replace(self._state, **{field: convert(message)})

        return callback

    def __call__(self) -> SystemState:
        """The state as last heard."""
        with self._lock:
            return self._state


def _study_phase(message: StudyState) -> str:
    return phase_name(message.phase, str(message.phase))


def _running_nodes(message: BehaviourTree) -> frozenset:
    return frozenset(b.name for b in message.behaviours if b.status == Behaviour.RUNNING)


@dataclasses.dataclass(frozen=True)
class DeviceMonitorConfig:
    """device_monitor's parameters: config/device_monitor.yaml's keys (the one place of values and meanings)."""

    scenario: str
    start_param: str
    margin: float
    end_launch: bool

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any]) -> "DeviceMonitorConfig":
        """From the yaml's keys, each perhaps overridden; a missing or unknown key, or no scenario, is named."""
        config = from_mapping(cls, values, "device_monitor's parameters (config/device_monitor.yaml)")
        if not config.scenario:
            raise ValueError("missing parameter ~scenario (the scenario file to listen for)")
        return config


class DeviceMonitorNode:
    """Listens to /sigma7/* for the length of a scenario (from the sigma7 node's start time), then summarises it."""

    def __init__(self, duration: float, start_param: str, margin: float, end_launch: bool):
        self.duration, self.start_param, self.margin, self.end_launch = duration, start_param, margin, end_launch
        self.monitor = DeviceMonitor()

    @classmethod
    def from_params(cls) -> "DeviceMonitorNode":
        """From the private parameters; a missing or unreadable ~scenario raises ValueError naming it."""
        config = DeviceMonitorConfig.from_mapping(node_parameters("device_monitor.yaml"))
        try:
            duration = load_scenario(config.scenario).duration
        except ScenarioError as error:
            raise ValueError(str(error)) from None
        return cls(duration, config.start_param, config.margin, config.end_launch)

    def run(self) -> None:
        """Subscribe, wait for the scenario's start and end, print the summary (and end the launch if asked)."""
        monitor = self.monitor
        rospy.Subscriber(
            "sigma7/pose",
            PoseStamped,
            lambda msg: monitor.on_pose(
                msg.header.stamp.to_sec(),
                (msg.pose.position.x, msg.pose.position.y, msg.pose.position.z),
                (msg.pose.orientation.x, msg.pose.orientation.y, msg.pose.orientation.z, msg.pose.orientation.w),
            ),
        )
        rospy.Subscriber(
            "sigma7/twist",
            TwistStamped,
            lambda msg: monitor.on_twist(
                msg.header.stamp.to_sec(), (msg.twist.linear.x, msg.twist.linear.y, msg.twist.linear.z)
            ),
        )
        rospy.Subscriber("sigma7/gripper_angle", Float64, lambda msg: monitor.on_gripper(rospy.get_time(), msg.data))
        rospy.Subscriber("sigma7/button", Bool, lambda msg: monitor.on_button(rospy.get_time(), msg.data))
        while not server_has(self.start_param) and not rospy.is_shutdown():
            rospy.sleep(0.05)
        monitor.start_time = server_value(self.start_param)
        end = monitor.start_time + self.duration + self.margin
        while rospy.get_time() < end and not rospy.is_shutdown():
            rospy.sleep(0.05)
        print(monitor.summary(), flush=True)
        if self.end_launch:
            end_parent_launch("device_monitor")
