"""ROS wiring of the shared controller: operator command in, equilibrium pose and state out, at 50 Hz.

The MPC itself (``loop.SharedControl``) has no ROS in it; this module maps the task plane to ``base_link``, turns
device/joystick messages into the operator command h^r, validates every message, and publishes each cycle.
"""

import dataclasses
import math
import threading
import time
from typing import Optional, Sequence, Tuple

import numpy as np
from scipy.spatial.transform import Rotation

from teleteach.control.stiffness import translational_stiffness
from teleteach.core.frames import Transform
from teleteach.core.observed import SCENE_TOPIC, WORLD_FRAME, observed_from_markers
from teleteach.core.rotations import quaternion_to_rpy
from teleteach.core.wiping import load_wiping_config
from teleteach.shared_control import cache
from teleteach.shared_control.approach import Approach, start_in_plane
from teleteach.shared_control.config import SharedControlNodeConfig
from teleteach.shared_control.constraints import Box, StraightEdge
from teleteach.shared_control.cycles import CycleSchedule, CycleStatistics
from teleteach.shared_control.loop import (
    MODE_NAMES,
    UNBOUNDED,
    SharedControl,
    SharedControlConfig,
    SharedControlRecord,
)
from teleteach.shared_control.plane import TaskPlane
from teleteach.shared_control.surface import SurfaceError, SurfaceWipe
from teleteach.shared_control.timeline import CommandTimeline

# Lag behind the 50 Hz grid after which the cycles in between are skipped (counted late) rather than caught up [s].
MAX_LAG = 1.0
# Cycles in a row that catch up by following the plan before one solves again, however late [-].
MAX_COASTS = 4
# Seconds between the node's cycle reports in its log (rate, late cycles, modes, solve times) [s].
REPORT_PERIOD = 10.0
# How long enabling waits for the first arm pose when /cartesian_pose has a publisher [s] (without one the MPC
# starts at initial_state at once).
ARM_POSE_TIMEOUT = 5.0
BASE_FRAME = "base_link"  # the arm's frame: a wiped surface is located in it through TF
# How long enabling a wipe waits for perception to report the surface and for a stiffness [s].
SURFACE_TIMEOUT = 5.0
# Seconds between "still compiling" messages, and the compile time of the default configuration to announce.
PROGRESS_PERIOD = 15.0
COMPILE_ESTIMATE = "3 minutes"


class InvalidMessageError(ValueError):
    """A message that cannot be used (non-finite values, wrong frame)."""


def _finite(values, what):
    values = [float(v) for v in values]
    if not all(math.isfinite(v) for v in values):
        raise InvalidMessageError(f"{what} has non-finite values {values}")
    return values


def command_from_vector(message) -> np.ndarray:
    """h^r from geometry_msgs/Vector3Stamped (x, y in the task plane [m/s]; z unused)."""
    return np.array(_finite((message.vector.x, message.vector.y), "operator command"))


def command_from_twist(message, projection: np.ndarray, scale: float, deadband: float = 0.0) -> np.ndarray:
    """h^r = scale * P v from a device geometry_msgs/TwistStamped (P: 2 x 3 projection on the task plane).

    A projected device speed below ``deadband`` [m/s] is the hand at rest (tremor, drift) and gives zero.
    """
    linear = _finite((message.twist.linear.x, message.twist.linear.y, message.twist.linear.z), "twist")
    projected = projection @ np.array(linear)
    if float(np.linalg.norm(projected)) < deadband:
        return np.zeros(2)
    return scale * projected


def command_from_joy(message, axes: Sequence[int], scale: Sequence[float]) -> np.ndarray:
    """h^r from sensor_msgs/Joy: two axes (index), each scaled [m/s at full deflection]."""
    if max(axes) >= len(message.axes):
        raise InvalidMessageError(f"joy message has {len(message.axes)} axes, need index {max(axes)}")
    values = _finite((message.axes[axes[0]], message.axes[axes[1]]), "joy axes")
    return np.array([scale[0] * values[0], scale[1] * values[1]])


def _arm_pose(message) -> Optional[Tuple[np.ndarray, np.ndarray]]:
    """(position, quaternion x y z w) of a geometry_msgs/PoseStamped, None when not finite or not a rotation."""
    p, q = message.pose.position, message.pose.orientation
    position, orientation = np.array([p.x, p.y, p.z]), np.array([q.x, q.y, q.z, q.w])
    if np.all(np.isfinite(position)) and np.all(np.isfinite(orientation)) and np.linalg.norm(orientation) > 0.5:
        return position, orientation
    return None


def _set_pose(pose, position: Sequence[float], quaternion: Sequence[float]) -> None:
    """Fill a geometry_msgs/Pose from a position [m] and a quaternion (x, y, z, w)."""
    pose.position.x, pose.position.y, pose.position.z = (float(value) for value in position)
    pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w = (float(v) for v in quaternion)


def task_of(message) -> Tuple[TaskPlane, Optional[Tuple[str, Transform]]]:
    """The task plane of a /shared_control/task message, and the wiped surface (name, pose in base_link) or None.

    Raises:
        ValueError: a pose that is not finite or not a rotation.
    """

    def transform(pose) -> Transform:
        p, q = pose.position, pose.orientation
        position, quaternion = np.array([p.x, p.y, p.z]), np.array([q.x, q.y, q.z, q.w])
        if not (np.all(np.isfinite(position)) and np.all(np.isfinite(quaternion)) and np.linalg.norm(quaternion) > 0.5):
            raise ValueError(f"not a pose: {position.tolist()} {quaternion.tolist()}")
        return Transform(position, Rotation.from_quat(quaternion))

    plane = transform(message.plane)
    axes = plane.rotation.as_matrix()
    task_plane = TaskPlane(plane.position, axes[:, 0], axes[:, 1], plane.rotation.as_quat())
    surface = (message.surface, transform(message.surface_pose)) if message.surface else None
    return task_plane, surface


def obstacle_from_pose(message) -> StraightEdge:
    """Straight edge from geometry_msgs/PoseStamped in task-plane coordinates: (x, y) and yaw of the free side."""
    p, q = message.pose.position, message.pose.orientation
    x, y = _finite((p.x, p.y), "obstacle position")
    qx, qy, qz, qw = _finite((q.x, q.y, q.z, q.w), "obstacle orientation")
    if qx * qx + qy * qy + qz * qz + qw * qw < 1e-12:
        raise InvalidMessageError("obstacle orientation is a zero quaternion")
    return StraightEdge(x, y, float(quaternion_to_rpy((qx, qy, qz, qw))[2]))


class PerceivedSurface:
    """The surface of a wipe as the node sees it.

    Its pose from perception (teleteach/scene, in world), world in base_link from TF, and the stiffness the arm is
    given (/eigenvalues, /eigenvectors: the pressing depth follows it). The surface is located once per wipe (when
    the node is enabled): the plane does not follow perception's noise while the tool is on it.
    """

    def __init__(self, rospy, wipe: SurfaceWipe):
        import tf2_ros
        from geometry_msgs.msg import QuaternionStamped, Vector3Stamped
        from visualization_msgs.msg import MarkerArray

        self._rospy = rospy
        self.wipe = wipe
        self._lock = threading.Lock()
        self._seen = None  # the surface's ObservedBox in world, newest
        self._eigenvalues: Optional[np.ndarray] = None
        self._eigenvectors = np.array([0.0, 0.0, 0.0, 1.0])  # the arm's axes until /eigenvectors says otherwise
        self.in_base: Optional[Transform] = None
        self._buffer = tf2_ros.Buffer()
        self._listener = tf2_ros.TransformListener(self._buffer)
        self._subscribers = [
            rospy.Subscriber(SCENE_TOPIC, MarkerArray, self._on_scene, queue_size=1),
            rospy.Subscriber("eigenvalues", Vector3Stamped, self._on_eigenvalues, queue_size=1),
            rospy.Subscriber("eigenvectors", QuaternionStamped, self._on_eigenvectors, queue_size=1),
        ]

    def _on_scene(self, message) -> None:
        seen = observed_from_markers(message.markers)[0].surfaces.get(self.wipe.surface.name)
        if seen is not None:
            with self._lock:
                self._seen = seen

    def _on_eigenvalues(self, message) -> None:
        values = np.array([message.vector.x, message.vector.y, message.vector.z])
        if not (np.all(np.isfinite(values)) and np.all(values >= 0.0)):
            self._rospy.logwarn_throttle(5.0, f"shared_control: rejected /eigenvalues {values.tolist()}: not >= 0")
            return
        with self._lock:
            self._eigenvalues = values

    def _on_eigenvectors(self, message) -> None:
        q = message.quaternion
        quaternion = np.array([q.x, q.y, q.z, q.w])
        if not (np.all(np.isfinite(quaternion)) and abs(np.linalg.norm(quaternion) - 1.0) < 0.01):
            self._rospy.logwarn_throttle(5.0, f"shared_control: rejected /eigenvectors {quaternion.tolist()}: not unit")
            return
        with self._lock:
            self._eigenvectors = quaternion / np.linalg.norm(quaternion)

    def stiffness(self) -> np.ndarray:
        """The translational stiffness the arm was last given, in base_link [N/m]."""
        with self._lock:
            return translational_stiffness(self._eigenvalues, self._eigenvectors)

    def start(self, timeout: float) -> Tuple[TaskPlane, Box]:
        """Locate the surface (waiting up to timeout [s] for perception and a stiffness): the plane and boundary.

        Raises:
            SurfaceError: why the wipe cannot start (not perceived, no TF, no stiffness, out of reach).
        """
        rospy, name = self._rospy, self.wipe.surface.name
        deadline = time.monotonic() + timeout
        while (self._seen is None or self._eigenvalues is None) and time.monotonic() < deadline:
            if rospy.is_shutdown():
                raise SurfaceError("shutting down")
            time.sleep(0.05)
        if self._seen is None:
            raise SurfaceError(f"perception ({rospy.resolve_name(SCENE_TOPIC)}) reports no surface '{name}'")
        if self._eigenvalues is None:
            raise SurfaceError("no stiffness on /eigenvalues yet: the pressing depth is the contact force over it")
        try:
            transform = self._buffer.lookup_transform(
                BASE_FRAME, WORLD_FRAME, rospy.Time(0), rospy.Duration(max(deadline - time.monotonic(), 0.1))
            ).transform
        except Exception as error:  # tf2's lookup errors share no base class with a useful message
            raise SurfaceError(f"no transform {WORLD_FRAME} -> {BASE_FRAME}: {error}") from None
        world_in_base = Transform(
            np.array([transform.translation.x, transform.translation.y, transform.translation.z]),
            Rotation.from_quat(
                [transform.rotation.x, transform.rotation.y, transform.rotation.z, transform.rotation.w]
            ),
        )
        with self._lock:
            seen = self._seen
        self.in_base = world_in_base * Transform(seen.position, Rotation.from_quat(seen.quaternion))
        return self.wipe.start(self.in_base, self.stiffness())

    def plane(self) -> TaskPlane:
        """The plane of the located surface, pressing with the stiffness given now."""
        return self.wipe.plane(self.in_base, self.stiffness())

    def off_surface(self, point) -> np.ndarray:
        """Where the TCP holds the tool off the located surface over ``point`` (u, v) [m], in base_link."""
        return self.wipe.off_surface(self.in_base, point)

    def close(self) -> None:
        """Unregister the topics."""
        for subscriber in self._subscribers:
            subscriber.unregister()


class SharedControlNode:
    """50 Hz shared control over ROS, built from :class:`SharedControlNodeConfig` (config/shared_control.yaml).

    A thread keeps the cycles on a fixed grid (``cycles.CycleSchedule``): every cycle publishes a state and an
    equilibrium, a cycle ready after its period is counted in ``late_cycles``, and a loop that has fallen behind
    catches up by following the previous plan (``SharedControl.coast``) instead of skipping cycles. While disabled
    the thread waits on an event and the node subscribes to nothing at high rate. Every ``REPORT_PERIOD`` the log
    gets one line with the rate, late cycles, modes and solve times.

    Args:
        config: the node's parameters.
        surface: the surface to wipe, from ``config.surface`` (None: none).

    ROS Subscribers:
        /shared_control/operator_command (geometry_msgs/Vector3Stamped), or /sigma7/twist
        (geometry_msgs/TwistStamped), or /joy (sensor_msgs/Joy), while enabled; /shared_control/obstacle
        (geometry_msgs/PoseStamped); /shared_control/enable (std_msgs/Bool: while false nothing is published; each
        enable takes the reference smoothly from the arm's pose to its projection on the plane, inside the boundary,
        and starts the MPC there afresh, in direct control for a window; ``initial_state`` when nobody publishes
        /cartesian_pose), /cartesian_pose (geometry_msgs/PoseStamped, base_link: where the arm is; while enabled),
        /shared_control/clutch (std_msgs/Bool: each true holds the clutch for ``command_timeout``: the controller
        keeps the recognised pattern alone, ``SharedControl.keep``, while the operator's hand shapes the stiffness;
        false releases it)

    ROS Publishers:
        /equilibrium_pose (geometry_msgs/PoseStamped), /equilibrium_twist (geometry_msgs/TwistStamped: the plan's
        velocity at that pose, x_dot_r of the impedance law, same stamp and frame),
        /shared_control/state (teleteach/SharedControlState),
        /shared_control/plan (nav_msgs/Path: the planned horizon, in ``frame_id``, each cycle while someone
        listens; empty in direct control), /shared_control/boundary (geometry_msgs/PolygonStamped, latched: the box
        in ``frame_id``), /shared_control/task (teleteach/SharedControlTask, latched, again on each wipe's enable: the
        task plane's frame and the wiped surface as located)
    """

    WARN_PERIOD = 5.0

    @classmethod
    def from_params(cls) -> "SharedControlNode":
        """From the private parameters (config/shared_control.yaml, see launch/shared_control.launch)."""
        from teleteach.runtime.node import node_parameters

        config = SharedControlNodeConfig.from_parameters(node_parameters("shared_control.yaml"))
        surface = None
        if config.surface:
            from teleteach.core.paths import config_values
            from teleteach.core.scene import load_scene

            scene = load_scene()
            surface = SurfaceWipe(
                scene.surface(config.surface),
                scene.wiping_tool,
                load_wiping_config(),
                scene.robot.mount_height,
                float(config_values("shared/stiffness.yaml")["max_stiffness"]),
            )
        return cls(config, surface)

    def __init__(self, config: SharedControlNodeConfig, surface: Optional[SurfaceWipe] = None):
        import rospy

        self._rospy = rospy
        self._keep_settings(config)
        self._lock = threading.Lock()
        self._commands = CommandTimeline(config.command_timeout)
        self._obstacle: Optional[StraightEdge] = None
        self._obstacle_stamp = -math.inf
        self._start_cycle_state()
        self.controller = self._build(config.mpc, self.box, self.initial_state)
        self._advertise()
        self._publish_boundary()
        self._surface = PerceivedSurface(rospy, surface) if surface is not None else None
        self.task_publisher = rospy.Publisher("shared_control/task", self._task_type, queue_size=1, latch=True)
        self._publish_task()
        self._subscribe(config)
        self._stopping = False
        self._thread = threading.Thread(target=self._run, name="shared_control_cycles", daemon=True)
        self._thread.start()

    def _keep_settings(self, config: SharedControlNodeConfig) -> None:
        """Keep the parameters the cycles read, so they need not carry the whole config."""
        self.plane = config.plane
        self.frame_id = config.frame_id
        self.command_timeout = config.command_timeout
        self.command_delay = config.command_delay
        self.obstacle_timeout = config.obstacle_timeout
        self.initial_state = tuple(config.initial_state)
        self.box = config.box
        self.margin = config.mpc.margin
        self.dt = config.mpc.dt
        self.enabled = config.enabled
        self.approach_limits = (config.approach_speed, config.approach_turn_rate)
        self.state_from_arm = config.state_from_arm

    def _start_cycle_state(self) -> None:
        """The state the cycles carry from one to the next, as before any message or approach."""
        self._arm: Optional[Tuple[np.ndarray, np.ndarray]] = None  # the arm's position and orientation, base_link
        self._arm_time = -math.inf  # when the last /cartesian_pose came [s]
        self._rejected = ""  # why the newest bad message since the last cycle was rejected
        self._coasts = 0  # cycles coasted in a row
        self._approach: Optional[Tuple[Approach, float]] = None  # (the move, its time so far [s]) while it runs
        self._last_input = -math.inf  # when the newest operator command arrived [s, ROS time]
        self._retracting = False  # the wipe ended: the tool goes off the surface, then the node disables itself
        self._disable = False  # the retract has arrived: the loop disables the node after this cycle
        self._clutch_until = -math.inf  # [s, ROS time] the clutch holds until then (renewed by each true message)

    def _advertise(self) -> None:
        """Open the equilibrium, state, plan and boundary topics, keeping the message types the cycles fill."""
        from geometry_msgs.msg import Point32, PolygonStamped, PoseStamped, TwistStamped
        from nav_msgs.msg import Path

        from teleteach.msg import SharedControlState, SharedControlTask

        rospy = self._rospy
        self._task_type = SharedControlTask
        self._state_type = SharedControlState
        self._pose_type = PoseStamped
        self._path_type = Path
        self._twist_type = TwistStamped
        self._polygon_types = (PolygonStamped, Point32)
        self.pose_publisher = rospy.Publisher("equilibrium_pose", PoseStamped, queue_size=1)
        self.twist_publisher = rospy.Publisher("equilibrium_twist", TwistStamped, queue_size=1)
        self.state_publisher = rospy.Publisher("shared_control/state", SharedControlState, queue_size=10)
        self.plan_publisher = rospy.Publisher("shared_control/plan", Path, queue_size=1)
        self.boundary_publisher = rospy.Publisher("shared_control/boundary", PolygonStamped, queue_size=1, latch=True)

    def _subscribe(self, config: SharedControlNodeConfig) -> None:
        """Listen to the obstacle, enable and clutch topics; to the operator and the arm only while enabled."""
        from geometry_msgs.msg import PoseStamped
        from std_msgs.msg import Bool

        rospy = self._rospy
        self._input = self._operator_input(config)
        self._enabled_subscribers = []
        self._enabled = threading.Event()
        self._schedule: Optional[CycleSchedule] = None  # the cycle grid, from the first cycle after an enable
        self._statistics = CycleStatistics(REPORT_PERIOD, MODE_NAMES)
        if config.enabled:
            self._subscribe_while_enabled()
            self._enabled.set()
        self._subscribers = [
            rospy.Subscriber(
                "shared_control/obstacle", PoseStamped, self._guarded(self._set_obstacle, obstacle_from_pose)
            ),
            rospy.Subscriber("shared_control/enable", Bool, lambda message: self.set_enabled(message.data)),
            rospy.Subscriber("shared_control/clutch", Bool, self._on_clutch, queue_size=1),
        ]

    def _operator_input(self, config: SharedControlNodeConfig):
        """(topic, message type, callback) of the operator's command, as ``config.input`` says."""
        from geometry_msgs.msg import TwistStamped, Vector3Stamped
        from sensor_msgs.msg import Joy

        if config.input == "operator_command":
            topic, message_type, convert = "shared_control/operator_command", Vector3Stamped, command_from_vector
        elif config.input == "twist":
            topic, message_type = "sigma7/twist", TwistStamped
            projection = np.asarray(config.twist_projection, dtype=float)

            def convert(message):
                return command_from_twist(message, projection, config.twist_scale, config.twist_deadband)

        else:
            topic, message_type = "joy", Joy

            def convert(message):
                return command_from_joy(message, config.joy_axes, config.joy_scale)

        return topic, message_type, self._guarded(self._set_command, convert, stamped=True)

    def _publish_boundary(self) -> None:
        """The boundary on the plane, in ``frame_id`` (latched; empty without one)."""
        polygon_type, point_type = self._polygon_types
        boundary = polygon_type()
        boundary.header.stamp = self._rospy.Time.now()
        boundary.header.frame_id = self.frame_id
        box = self.box
        if box is not None:
            corners = ((box.x_min, box.y_min), (box.x_max, box.y_min), (box.x_max, box.y_max), (box.x_min, box.y_max))
            boundary.polygon.points = [point_type(*(float(v) for v in self.plane.to_base(c))) for c in corners]
        self.boundary_publisher.publish(boundary)

    def _locate_surface(self) -> bool:
        """On a wipe: the plane and boundary from the surface as perceived now; False (and one line why) if none."""
        try:
            plane, box = self._surface.start(SURFACE_TIMEOUT)
        except SurfaceError as error:
            self._rospy.logerr(f"shared_control: not enabled, cannot wipe {self._surface.wipe.surface.name}: {error}")
            return False
        with self._lock:
            self.plane, self.box = plane, box
            self.controller.set_boundary(box)
        self._publish_boundary()
        self._publish_task()
        return True

    def _publish_task(self) -> None:
        """Where the controller plans (latched): the task plane's frame and, on a wipe, the surface as located."""
        task = self._task_type()
        task.header.stamp = self._rospy.Time.now()
        task.header.frame_id = self.frame_id
        plane = self.plane
        x_axis, y_axis = np.asarray(plane.x_axis, dtype=float), np.asarray(plane.y_axis, dtype=float)
        axes = Rotation.from_matrix(np.column_stack([x_axis, y_axis, np.cross(x_axis, y_axis)]))
        _set_pose(task.plane, plane.to_base((0.0, 0.0)), axes.as_quat())
        _set_pose(task.surface_pose, np.zeros(3), np.array([0.0, 0.0, 0.0, 1.0]))
        if self._surface is not None and self._surface.in_base is not None:
            task.surface = self._surface.wipe.surface.name
            _set_pose(task.surface_pose, self._surface.in_base.position, self._surface.in_base.rotation.as_quat())
        self.task_publisher.publish(task)

    def _on_clutch(self, message) -> None:
        """The GUI's clutch on a wipe: true renews it for ``command_timeout`` (a GUI gone releases it), false ends it.

        A held clutch counts as the operator's input: the hand is on the device, shaping the stiffness.
        """
        now = self._rospy.get_time()
        with self._lock:
            if message.data:
                self._clutch_until, self._last_input = now + self.command_timeout, now
            else:
                self._clutch_until = -math.inf

    def _build(self, config: SharedControlConfig, box, initial_state) -> SharedControl:
        """The controller; with ``compiled`` solvers not cached yet (scripts/setup builds them), compile them first.

        The node then starts only when they are built, saying so every ``PROGRESS_PERIOD`` (a few minutes on two
        busy cores): a first session never runs on the slower virtual machine.
        """
        if config.solver != "compiled":
            return SharedControl(config, initial_state, box)
        try:
            # Quick when the compiled code is cached (only hashing and loading).
            with cache.only_cached():
                return SharedControl(config, initial_state, box)
        except cache.NotCachedError as missing:
            self._rospy.logwarn(
                f"shared_control: compiled solvers not cached ({missing}; scripts/setup builds them): compiling them "
                f"into {cache.cache_dir()} now, about {COMPILE_ESTIMATE} on two cores; the node starts when done"
            )
        started = time.monotonic()
        done = threading.Event()

        def progress():
            while not done.wait(PROGRESS_PERIOD):
                self._rospy.loginfo(f"shared_control: still compiling ({time.monotonic() - started:.0f} s)")

        threading.Thread(target=progress, daemon=True).start()
        try:
            controller = SharedControl(config, initial_state, box)
        except (OSError, RuntimeError) as error:
            if not self._rospy.is_shutdown():  # a compiler stopped by Ctrl-C is no failure to report
                self._rospy.logerr(f"shared_control: compiling failed ({error}); using the slower 'fast' solver")
            return SharedControl(dataclasses.replace(config, solver="fast"), initial_state, box)
        finally:
            done.set()
        self._rospy.loginfo(f"shared_control: compiled solvers built in {time.monotonic() - started:.0f} s")
        return controller

    def set_enabled(self, enabled: bool) -> None:
        """Drive the arm (from where it is, with a fresh window) or stop publishing and wait, costing nothing.

        While disabled the node subscribes to neither the operator's input (the device publishes at 1 kHz) nor the
        arm's pose (200 Hz: 7.8 % of a core for a disabled node). Enabling subscribes and, when /cartesian_pose has
        a publisher, waits for its first pose: the MPC must start where the arm is, or the equilibrium jumps (a
        half-second wait ran out on a loaded machine and the equilibrium jumped 3 cm).
        """
        enabled = bool(enabled)
        if enabled and not self.enabled and self._surface is not None and not self._locate_surface():
            return
        if enabled and not self.enabled:
            self._subscribe_while_enabled()
            self._wait_for_arm()
        with self._lock:
            if enabled and not self.enabled:
                start = self.initial_state
                if self._arm is not None:
                    position, orientation = self._arm
                    box = self.box if self.box is not None else UNBOUNDED
                    start = start_in_plane(self.plane.to_plane(position), box, self.margin)
                    goal = self.plane.to_base(start)
                    approach = Approach.at_most(
                        position, orientation, goal, self.plane.orientation, *self.approach_limits
                    )
                    self._approach = (approach, 0.0)
                self.controller.reset(start)
                self._commands = CommandTimeline(self.command_timeout)
                self._last_input = -math.inf  # input counts as lost only once it has come
                self._retracting = self._disable = False
            if enabled != self.enabled:
                self._schedule = None  # a fresh cycle grid from the next cycle on
                self._statistics = CycleStatistics(REPORT_PERIOD, MODE_NAMES)
            self.enabled = enabled
        if enabled:
            self._enabled.set()
        else:
            self._enabled.clear()
            for subscriber in self._enabled_subscribers:
                subscriber.unregister()
            self._enabled_subscribers = []
        self._rospy.loginfo(f"shared_control: {'enabled' if enabled else 'disabled'}")

    def _subscribe_while_enabled(self) -> None:
        if self._enabled_subscribers:
            return
        self._arm = None
        self._enabled_subscribers = [
            # Every command is kept (by its stamp), so the queue holds a second of them rather than only the last.
            self._rospy.Subscriber(*self._input, queue_size=1000),
            self._rospy.Subscriber("cartesian_pose", self._pose_type, self._on_arm, queue_size=1),
        ]

    def _wait_for_arm(self) -> None:
        """Wait up to ARM_POSE_TIMEOUT for the first arm pose, if anybody publishes one."""
        rospy = self._rospy
        topic = rospy.resolve_name("cartesian_pose")
        try:
            published = any(name == topic for name, _ in rospy.get_published_topics())
        except (OSError, rospy.ROSException):
            published = False
        deadline = time.monotonic() + ARM_POSE_TIMEOUT
        while published and self._arm is None and time.monotonic() < deadline and not rospy.is_shutdown():
            time.sleep(0.01)
        if published and self._arm is None:
            rospy.logwarn(f"shared_control: no pose on {topic} within {ARM_POSE_TIMEOUT} s: starting at initial_state")

    def _on_arm(self, message) -> None:
        pose = _arm_pose(message)
        if pose is not None:
            self._arm, self._arm_time = pose, self._rospy.get_time()

    def _guarded(self, setter, convert, stamped=False):
        def callback(message):
            try:
                if stamped:
                    setter(convert(message), self._stamp(message))
                else:
                    setter(convert(message))
            except (InvalidMessageError, ValueError) as error:
                self._rospy.logwarn_throttle(self.WARN_PERIOD, f"shared_control: rejected a message: {error}")
                with self._lock:
                    self._rejected = f"rejected a message: {error}"

        return callback

    def _stamp(self, message) -> float:
        """The header stamp [s] (zero: now); one further ahead than command_timeout is rejected."""
        now = self._rospy.get_time()
        stamp = message.header.stamp.to_sec() or now
        if stamp > now + self.command_timeout:
            raise InvalidMessageError(f"command stamped {stamp - now:.3f} s in the future")
        return stamp

    def _set_command(self, command: np.ndarray, stamp: float) -> None:
        with self._lock:
            self._commands.add(stamp, command)
            self._last_input = self._rospy.get_time()

    def _set_obstacle(self, obstacle: StraightEdge) -> None:
        with self._lock:
            self._obstacle = obstacle
            self._obstacle_stamp = self._rospy.get_time()

    def _run(self) -> None:
        """The 50 Hz loop: blocks on ``_enabled`` while disabled (no polling), then keeps the ``CycleSchedule``."""
        rospy = self._rospy
        while not self._stopping and not rospy.is_shutdown():
            self._enabled.wait()
            with self._lock:
                schedule = self._schedule
                if schedule is None and self.enabled:
                    schedule = self._schedule = CycleSchedule(rospy.get_time(), self.dt, MAX_LAG)
            if schedule is None:
                continue
            try:
                rospy.sleep(schedule.wait(rospy.get_time()))
            except rospy.ROSInterruptException:
                return
            with self._lock:
                if self._schedule is not schedule:  # disabled or enabled again meanwhile
                    continue
                skipped = schedule.restart_if_lost(rospy.get_time())
                if skipped:
                    rospy.logwarn(f"shared_control: {skipped} cycles behind the 50 Hz grid: skipped, counted late")
                record = self._cycle(schedule)
                disable, self._disable = self._disable, False
            if record is not None:
                self.publish(record)
            if disable:
                self.set_enabled(False)

    def _cycle(self, schedule: CycleSchedule) -> Optional[SharedControlRecord]:
        """One cycle at the schedule's next time (under the lock); a cycle that is overdue catches up by coasting."""
        now = self._rospy.get_time()
        cycle_time = schedule.next_time()
        if self._approach is not None:
            self._approach_step()
            schedule.finish(self._rospy.get_time())
            return None
        if self._surface is not None and not self._follow_surface(now):
            schedule.finish(self._rospy.get_time())
            return None
        command = self._commands.sample(cycle_time - self.command_delay)
        self._update_surroundings(now)
        record = self._control(schedule, now, command)
        late = schedule.finish(self._rospy.get_time())
        record.cycle, record.late_cycles = schedule.cycles, schedule.late
        if self._rejected:
            # The newest rejection since the last cycle, in the one line the state carries.
            record.message, self._rejected = f"{self._rejected}; {record.message}", ""
        line = self._statistics.add(
            now, record.mode, record.estimation_time + record.optimisation_time if record.fitting_errors else 0.0, late
        )
        if line:
            self._rospy.loginfo(f"shared_control: {line}")
        return record

    def _approach_step(self) -> None:
        """Publish the approach's next reference; after a retract's last one, ask the loop to disable the node.

        One period of the move per cycle, not the clock's time: a stalled loop slows the move down instead of making
        the equilibrium jump (a 0.3 s stall at approach_speed was a 3 cm step).
        """
        approach, elapsed = self._approach
        elapsed += self.dt
        self._publish_reference(self._rospy.Time.now(), *approach.at(elapsed))
        self._approach = None if approach.done(elapsed) else (approach, elapsed)
        self._disable = self._approach is None and self._retracting

    def _follow_surface(self, now: float) -> bool:
        """Move the plane to the taught stiffness' pressing depth; False (the wipe ends) if input or surface is lost."""
        silence = now - self._last_input
        try:
            if math.isfinite(self._last_input) and silence > self._surface.wipe.settings.input_loss_time:
                raise SurfaceError(f"no operator input for {silence:.1f} s")
            self.plane = self._surface.plane()  # the pressing depth follows the stiffness being taught
        except SurfaceError as error:
            self._end_wipe(str(error))
            return False
        return True

    def _update_surroundings(self, now: float) -> None:
        """Give the controller the obstacle (none once stale) and, if asked for, the arm's fresh position."""
        obstacle = self._obstacle
        if self.obstacle_timeout > 0 and now - self._obstacle_stamp > self.obstacle_timeout:
            obstacle = None
        self.controller.set_obstacle(obstacle)
        if self.state_from_arm and self._arm is not None and now - self._arm_time <= self.command_timeout:
            self.controller.measure(self.plane.to_plane(self._arm[0]))

    def _control(self, schedule: CycleSchedule, now: float, command: np.ndarray) -> SharedControlRecord:
        """Keep the pattern under the clutch, coast on the plan to catch up, or solve: the cycle's record.

        Catch up by coasting on the plan, but solve at least every MAX_COASTS + 1 cycles and whenever there is no
        plan to follow: a machine that never lets the loop catch up must not freeze the identification.
        """
        if now <= self._clutch_until:
            # The operator's hand shapes the stiffness (the GUI's wipe teaching): the controller keeps the pattern.
            record = self.controller.keep()
            self._coasts = 0
        elif schedule.behind(now) and self.controller.skill is not None and self._coasts < MAX_COASTS:
            record = self.controller.coast(command)
            self._coasts += 1
        else:
            record = self.controller.step(command)
            self._coasts = 0
        return record

    def _end_wipe(self, reason: str) -> None:
        """The wipe cannot go on: take the tool off the surface along its normal, then the node disables itself.

        ``reason`` (the input lost, a stiffness the arm does not take) is the one line the log says why in.
        """
        state = self.controller.state
        position, off = self.plane.to_base(state), self._surface.off_surface(state)
        orientation = self.plane.orientation
        self._approach = (Approach.at_most(position, orientation, off, orientation, *self.approach_limits), 0.0)
        self._retracting = True
        self._rospy.logwarn(
            f"shared_control: {reason}: the wipe ends, the tool retracts off {self._surface.wipe.surface.name} and "
            "shared control disables itself"
        )

    def _pose(self, stamp, point):
        pose = self._pose_type()
        pose.header.stamp = stamp
        pose.header.frame_id = self.frame_id
        position = self.plane.to_base(point)
        pose.pose.position.x, pose.pose.position.y, pose.pose.position.z = (float(v) for v in position)
        q = self.plane.orientation
        pose.pose.orientation.x, pose.pose.orientation.y = float(q[0]), float(q[1])
        pose.pose.orientation.z, pose.pose.orientation.w = float(q[2]), float(q[3])
        return pose

    def _publish_reference(self, stamp, position, orientation, velocity) -> None:
        """The arm's reference: /equilibrium_pose and its velocity on /equilibrium_twist (same stamp, base_link)."""
        twist = self._twist_type()
        twist.header.stamp = stamp
        twist.header.frame_id = self.frame_id
        twist.twist.linear.x, twist.twist.linear.y, twist.twist.linear.z = (float(v) for v in velocity)
        self.twist_publisher.publish(twist)
        pose = self._pose_type()
        pose.header.stamp = stamp
        pose.header.frame_id = self.frame_id
        pose.pose.position.x, pose.pose.position.y, pose.pose.position.z = (float(v) for v in position)
        q = orientation
        pose.pose.orientation.x, pose.pose.orientation.y = float(q[0]), float(q[1])
        pose.pose.orientation.z, pose.pose.orientation.w = float(q[2]), float(q[3])
        self.pose_publisher.publish(pose)

    def publish(self, record: SharedControlRecord) -> None:
        """Send the executed state and its velocity as the equilibrium, the plan as a path, the record as the state."""
        stamp = self._rospy.Time.now()
        self._publish_reference(
            stamp,
            self.plane.to_base(record.state),
            self.plane.orientation,
            self.plane.vector_to_base(record.velocity),
        )
        if self.plan_publisher.get_num_connections() > 0:
            # Only for a listener: 51 poses cost about as much CPU as a solve (1.2 ms on a loaded machine).
            path = self._path_type()
            path.header.stamp = stamp
            path.header.frame_id = self.frame_id
            path.poses = [self._pose(stamp, point) for point in np.asarray(record.plan).T]
            self.plan_publisher.publish(path)
        state = self._state_type()
        state.header.stamp = stamp
        state.header.frame_id = "task_plane"
        state.mode = record.mode
        state.skill = record.skill
        state.skills = record.skills
        state.fitting_errors = record.fitting_errors
        state.parameters = record.parameters
        state.estimation_time = record.estimation_time
        state.optimisation_time = record.optimisation_time
        state.command.x, state.command.y = record.command
        state.state.x, state.state.y = record.state
        state.message = record.message
        state.confidence = record.confidence
        state.authority = record.authority
        state.cycle = record.cycle
        state.late_cycles = record.late_cycles
        self.state_publisher.publish(state)

    def shutdown(self) -> None:
        """Stop the cycle loop and unregister the topics."""
        self.set_enabled(False)
        self._stopping = True
        self._enabled.set()  # wakes the loop, which sees _stopping
        self._thread.join(timeout=1.0)
        for subscriber in self._subscribers:
            subscriber.unregister()
        self.pose_publisher.unregister()
        self.twist_publisher.unregister()
        self.state_publisher.unregister()
        self.plan_publisher.unregister()
        self.boundary_publisher.unregister()
        if self._surface is not None:
            self._surface.close()
