"""A scripted wipe through the real nodes: what test/ros/shared_control_wipe_check.py and bench/wiping_rate.py do.

The system is robot_sim with the eraser mounted (``sim.launch wiping_tool:=true``, impedance control) and the shared
controller on the counter's whiteboard (``shared_control.launch surface:=counter_board enabled:=false``). A caller that
has joined the master as a rospy node drives the base to ``wipe_counter`` (move_base), locates the board as perceived
(``teleteach/scene``) and as it truly is (``teleteach/true_scene``) in base_link, sends the taught stiffness with its
axes along the perceived board, enables shared control and commands a wave on ``/shared_control/operator_command``
(``models.synthetic_commands``: the identifier's own wave, a hand's noise). Contact is judged from the world: the force
the board puts on the tool along its true normal (``/force_torque_ext``).
"""

import math
import threading
from typing import Callable, Optional, Sequence, Tuple

import numpy as np
from scipy.spatial.transform import Rotation

from teleteach.core.frames import Transform
from teleteach.core.observed import observed_from_markers
from teleteach.core.scene import load_scene
from teleteach.shared_control.models import synthetic_commands

BOARD = "counter_board"
BASE_POSE = "wipe_counter"  # config/supermarket.yaml: where the base stands to wipe the board
TAUGHT = (3000.0, 3000.0, 300.0)  # [N/m] along u, along v, along the normal
RATE = 50.0  # [Hz] of the operator's commands
WAVE = (0.03, 20.0, 0.0)  # amplitude [m], spatial frequency [1/m], phase [m]
PATTERNS = {"wave": WAVE, "cycloid": (0.025, 20.0, 0.0)}  # rho of each skill the scripted operator draws
SPEED = 0.05  # [m/s]
NOISE = 0.005  # [m/s] per axis: the hand's noise on the commands
CONTACT = 1.0  # [N] a normal force below this is no contact


def transform_of(box) -> Transform:
    """The pose of an observed or true box (``position``, ``quaternion``) as a Transform."""
    return Transform(np.asarray(box.position), Rotation.from_quat(box.quaternion))


def drive_to(pose_name: str = BASE_POSE, timeout: float = 90.0) -> bool:
    """Drive the base to a base pose of the scene with move_base; whether it arrived within ``timeout`` [s]."""
    import actionlib
    from move_base_msgs.msg import MoveBaseAction

    pose = load_scene().base_poses[pose_name]
    base = actionlib.SimpleActionClient("/move_base", MoveBaseAction)
    try:
        return _drive(base, pose, timeout)
    finally:
        base.action_client.stop()  # the caller's process keeps no move_base topics


def _drive(base, pose, timeout: float) -> bool:
    """Send the goal on ``base`` (an actionlib client of move_base) and wait for it."""
    import rospy
    from move_base_msgs.msg import MoveBaseGoal

    if not base.wait_for_server(rospy.Duration(60.0)):
        raise RuntimeError("no move_base server")
    goal = MoveBaseGoal()
    goal.target_pose.header.frame_id = "world"
    goal.target_pose.header.stamp = rospy.Time.now()
    goal.target_pose.pose.position.x, goal.target_pose.pose.position.y = pose.x, pose.y
    goal.target_pose.pose.orientation.z = math.sin(pose.yaw / 2)
    goal.target_pose.pose.orientation.w = math.cos(pose.yaw / 2)
    base.send_goal(goal)
    return base.wait_for_result(rospy.Duration(timeout))


def board_in_base(settle: float = 1.0) -> Tuple[Transform, Transform]:
    """(the board as perceived, the board as it truly is) in base_link, after ``settle`` [s] for perception."""
    import rospy
    import tf2_ros
    from visualization_msgs.msg import MarkerArray

    buffer = tf2_ros.Buffer()
    tf2_ros.TransformListener(buffer)
    rospy.sleep(settle)  # perception reports the board from the new viewpoint
    stamped = buffer.lookup_transform("base_link", "world", rospy.Time(0), rospy.Duration(10.0)).transform
    world_in_base = Transform(
        np.array([stamped.translation.x, stamped.translation.y, stamped.translation.z]),
        Rotation.from_quat([stamped.rotation.x, stamped.rotation.y, stamped.rotation.z, stamped.rotation.w]),
    )

    def seen(topic):
        message = rospy.wait_for_message(topic, MarkerArray, timeout=30.0)
        return transform_of(observed_from_markers(message.markers)[0].surfaces[BOARD])

    return world_in_base * seen("/teleteach/scene"), world_in_base * seen("/teleteach/true_scene")


def joy_axes_for(command, axes: Sequence[int], scale: Sequence[float]) -> np.ndarray:
    """The joystick's deflections that ask for ``command`` (u, v) [m/s] (shared_control's ``joy`` input).

    Each within [-1, 1]: a command beyond full deflection saturates, as a real stick does.
    """
    deflections = np.zeros(max(axes) + 1)
    for axis, value, per_deflection in zip(axes, command, scale):
        deflections[axis] = np.clip(value / per_deflection, -1.0, 1.0)
    return deflections


def device_velocity_for(command, projection, scale: float) -> np.ndarray:
    """The device's linear velocity [m/s] whose projection on the task plane, scaled, is ``command`` (``twist``)."""
    return np.linalg.pinv(np.asarray(projection, dtype=float)) @ (np.asarray(command, dtype=float) / scale)


class ScriptedWipe:
    """The operator's side of a wipe: the stiffness, the enable and the commands (publishers made once).

    ``hand``: what the commands come through, one of shared_control's inputs: ``operator_command`` (the task-plane
    velocity itself), ``joy`` (a joystick's axes, /joy) or ``twist`` (the Sigma.7's velocity, /sigma7/twist), mapped
    with the node's own parameters (config/shared_control.yaml). ``patterns``: each skill's rho (default PATTERNS).
    """

    def __init__(self, hand: str = "operator_command", patterns=PATTERNS):
        import rospy
        from geometry_msgs.msg import QuaternionStamped, TwistStamped, Vector3Stamped
        from sensor_msgs.msg import Joy
        from std_msgs.msg import Bool

        from teleteach.core.paths import config_values
        from teleteach.shared_control.config import INPUTS, SharedControlNodeConfig

        if hand not in INPUTS:
            raise ValueError(f"unknown input {hand!r}: one of {', '.join(INPUTS)}")
        self._rospy, self.hand, self.patterns = rospy, hand, dict(patterns)
        self._node = SharedControlNodeConfig.from_parameters(config_values("shared_control.yaml"))
        self._types = (Vector3Stamped, QuaternionStamped, Bool)
        self.eigenvalues = rospy.Publisher("/eigenvalues", Vector3Stamped, queue_size=1, latch=True)
        self.eigenvectors = rospy.Publisher("/eigenvectors", QuaternionStamped, queue_size=1, latch=True)
        self.enabler = rospy.Publisher("/shared_control/enable", Bool, queue_size=1, latch=True)
        topic, message_type = {
            "operator_command": ("/shared_control/operator_command", Vector3Stamped),
            "joy": ("/joy", Joy),
            "twist": ("/sigma7/twist", TwistStamped),
        }[hand]
        self._command_type = message_type
        self.command = rospy.Publisher(topic, message_type, queue_size=10)
        self.clutch = rospy.Publisher("/shared_control/clutch", Bool, queue_size=1)
        self.sent = []  # (ROS time [s], command (u, v) [m/s]) of each pattern command
        self.stiffness = (np.array(TAUGHT, dtype=float), np.array([0.0, 0.0, 0.0, 1.0]))  # the last sent, its axes

    def press_with(self, seen_in_base: Transform, stiffness=TAUGHT) -> None:
        """Send the stiffness (along u, v and the normal of the board as perceived) on /eigenvalues, /eigenvectors."""
        vector_type, quaternion_type, _ = self._types
        values = vector_type()
        values.header.stamp = self._rospy.Time.now()
        values.vector.x, values.vector.y, values.vector.z = (float(value) for value in stiffness)
        axes = quaternion_type()
        axes.header.stamp = values.header.stamp
        axes.quaternion.x, axes.quaternion.y, axes.quaternion.z, axes.quaternion.w = seen_in_base.rotation.as_quat()
        self.eigenvectors.publish(axes)
        self.eigenvalues.publish(values)
        self.stiffness = (np.array(stiffness, dtype=float), seen_in_base.rotation.as_quat())

    def enable(self, enabled: bool = True) -> None:
        """Publish on /shared_control/enable (latched)."""
        self.enabler.publish(self._types[2](data=enabled))

    def pattern(
        self,
        skill: str,
        duration: float,
        heading: float = math.pi,
        rng: Optional[np.random.Generator] = None,
        each: Optional[Callable[[int, float], None]] = None,
    ) -> Tuple[float, float]:
        """Command ``skill`` (its rho from ``patterns``) along ``heading`` [rad] (pi: right to left) at RATE.

        For ``duration`` [s] of ROS time; ``each(k, stamp)`` runs after the k-th command is sent, and each command is
        kept in ``sent`` (ROS time [s], (u, v) [m/s]). Returns the ROS times [s] of the first and last.
        """
        rospy = self._rospy
        times = np.arange(0.0, duration, 1.0 / RATE)
        rng = rng or np.random.default_rng(49)
        commands = synthetic_commands(skill, self.patterns[skill], heading, SPEED, times, NOISE, rng)
        start = rospy.Time.now().to_sec()
        rate = rospy.Rate(RATE)
        for k, command in enumerate(commands):
            message, asked = self._command_message(command, rospy.Time.now())
            self.command.publish(message)
            self.sent.append((message.header.stamp.to_sec(), asked))
            if each is not None:
                each(k, message.header.stamp.to_sec())
            rate.sleep()
        return start, rospy.Time.now().to_sec()

    def _command_message(self, command, stamp):
        """The message of ``command`` (u, v) [m/s] through the hand, and the command the node reads from it."""
        message = self._command_type()
        message.header.stamp = stamp
        node = self._node
        if self.hand == "joy":
            message.axes = [float(value) for value in joy_axes_for(command, node.joy_axes, node.joy_scale)]
            asked = np.array([node.joy_scale[i] * message.axes[axis] for i, axis in enumerate(node.joy_axes)])
        elif self.hand == "twist":
            velocity = device_velocity_for(command, node.twist_projection, node.twist_scale)
            message.twist.linear.x, message.twist.linear.y, message.twist.linear.z = (float(v) for v in velocity)
            asked = node.twist_scale * np.asarray(node.twist_projection, dtype=float) @ velocity
        else:
            message.vector.x, message.vector.y = float(command[0]), float(command[1])
            asked = np.asarray(command, dtype=float)
        return message, asked

    def teach(self, duration: float, seen_in_base: Transform, before=TAUGHT, after=TAUGHT) -> Tuple[float, float]:
        """Hold the clutch for ``duration`` [s] of ROS time, shaping the stiffness from ``before`` into ``after``.

        As the GUI does on a wipe: /shared_control/clutch true at RATE (no pattern commands meanwhile: the hand is on
        the ellipsoid) and the stiffness, each principal value along a minimum-jerk ramp; then the clutch released.
        Returns the ROS times [s] of the first and last clutch message.
        """
        from teleteach.core.trajectories import minimum_jerk

        rospy, clutch = self._rospy, self._types[2]
        start = rospy.Time.now().to_sec()
        rate = rospy.Rate(RATE)
        while rospy.Time.now().to_sec() - start < duration and not rospy.is_shutdown():
            phase = float(minimum_jerk((rospy.Time.now().to_sec() - start) / duration))
            self.press_with(seen_in_base, np.asarray(before) + phase * (np.asarray(after) - np.asarray(before)))
            self.clutch.publish(clutch(data=True))
            rate.sleep()
        end = rospy.Time.now().to_sec()
        self.press_with(seen_in_base, after)
        self.clutch.publish(clutch(data=False))
        return start, end


class WorldRecord:
    """The force on the tool, the TCP, the equilibrium and the controller's states as they come, with their ROS stamps.

    Poses also carry the TCP's orientation, states the wall time [s, time.monotonic] at which they were received.
    ``poses``: False leaves /cartesian_pose (200 Hz) and /equilibrium_pose alone, for a caller that needs neither.
    """

    def __init__(self, poses: bool = True):
        import time

        import rospy
        from geometry_msgs.msg import PoseStamped, WrenchStamped

        from teleteach.msg import SharedControlState

        self._clock = time.monotonic
        self.lock = threading.Lock()
        self.forces, self.poses, self.states, self.equilibria = [], [], [], []
        self._subscribers = [
            rospy.Subscriber("/force_torque_ext", WrenchStamped, self._on_force, queue_size=1000),
            rospy.Subscriber("/shared_control/state", SharedControlState, self._on_state, queue_size=1000),
        ]
        if poses:
            self._subscribers += [
                rospy.Subscriber("/cartesian_pose", PoseStamped, self._on_pose, queue_size=1000),
                rospy.Subscriber("/equilibrium_pose", PoseStamped, self._on_equilibrium, queue_size=1000),
            ]

    def _on_force(self, message):
        f = message.wrench.force
        with self.lock:
            self.forces.append((message.header.stamp.to_sec(), np.array([f.x, f.y, f.z])))

    def _on_pose(self, message):
        p, q = message.pose.position, message.pose.orientation
        with self.lock:
            position, quaternion = np.array([p.x, p.y, p.z]), np.array([q.x, q.y, q.z, q.w])
            self.poses.append((message.header.stamp.to_sec(), position, quaternion))

    def _on_equilibrium(self, message):
        p = message.pose.position
        with self.lock:
            self.equilibria.append((message.header.stamp.to_sec(), np.array([p.x, p.y, p.z])))

    def _on_state(self, message):
        with self.lock:
            self.states.append((message.header.stamp.to_sec(), message, self._clock()))

    def between(self, store: str, start: float, end: float) -> np.ndarray:
        """The values of ``forces``, ``poses`` (positions) or ``equilibria`` stamped in [start, end] [s of ROS time]."""
        with self.lock:
            return np.array([value for stamp, value, *_ in getattr(self, store) if start <= stamp <= end])

    def stamped_between(self, store: str, start: float, end: float) -> list:
        """The (stamp, value, ...) entries of ``store`` stamped in [start, end]."""
        with self.lock:
            return [entry for entry in getattr(self, store) if start <= entry[0] <= end]

    def close(self) -> None:
        """Unregister the topics."""
        for subscriber in self._subscribers:
            subscriber.unregister()
