"""The ROS layer of the skills: the robot interface over topics, TF and services, and the skills as action servers.

:class:`RosRobot` implements :class:`teleteach.skills.robot.Robot`. In: /joint_states, TF world->base_link,
/teleteach/scene, /cartesian_pose. Out: joint trajectories, stiffness and equilibrium commands, controller switches,
gripper goals (franka_gripper's actions) and base goals (move_base). :class:`SkillServer` serves /skills/<Name>
(teleteach/ExecuteSkill), one action server per skill (thesis Appendix B.2), all running through one SkillRunner.
Names are the ROS graph of docs/reference.md.
"""

import math
import threading
import time
from typing import Optional, Sequence, Tuple

import actionlib
import numpy as np
import rospy
import tf2_ros
from actionlib_msgs.msg import GoalStatus
from geometry_msgs.msg import PoseStamped, QuaternionStamped, Vector3Stamped, WrenchStamped
from move_base_msgs.msg import MoveBaseAction, MoveBaseGoal
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint
from visualization_msgs.msg import MarkerArray

from teleteach.control import panda
from teleteach.core.observed import ObservedScene, observed_from_markers
from teleteach.core.rotations import wrap_angle, yaw_rotation
from teleteach.core.validation import InvalidCommandError, check_frame, finite_vector
from teleteach.msg import (
    ExecuteSkillAction,
    ExecuteSkillFeedback,
    ExecuteSkillResult,
    GraspAction,
    GraspEpsilon,
    GraspGoal,
    MoveAction,
    MoveGoal,
    SkillAuthority,
    SkillLibrary,
)
from teleteach.runtime.ros_actions import OneGoalActionServer, WallStatusTimer, server_ready
from teleteach.skills.authority import AuthorityReport
from teleteach.skills.robot import Execution, Robot, RobotGoal, SkillError
from teleteach.skills.runner import REPLAY_SKILL, SKILL_NAMES, SkillRunner
from teleteach.srv import ListControllers, SwitchController, SwitchControllerRequest

WORLD_FRAME = "world"
BASE_FRAME = "base_link"
MAX_CORRECTION_MESSAGE = 1.0  # [m] a longer /skills/correction is not a correction but a mistake: refused
SERVICE_TIMEOUT = 5.0  # [s] wall time to wait for the controller manager
SCENE_FRESHNESS = 0.15  # [s] sim time: a scene older than this when asked is waited for
SCENE_WAIT = 2.0  # [s] wall time to wait for a fresh scene before using the last one
TF_FRESHNESS = 0.05  # [s] sim time: a base transform older than this when asked is waited for
TF_WAIT = 2.0  # [s] wall time to wait for a fresh base transform before using the last one
REST_INTERVAL = 0.1  # [s] robot time between the two transforms that must agree for the base to be at rest
REST_DISTANCE = 0.001  # [m] the base moved less than this over REST_INTERVAL: at rest (1 cm/s)
REST_ANGLE = 0.002  # [rad] the base turned less than this over REST_INTERVAL: at rest
REST_WAIT = 10.0  # [s] wall time for the base to come to rest after move_base's goal ended
CONNECTION_WAIT = 3.0  # [s] wall time to wait for a command topic's subscriber or an action server to connect
STATE_WAIT = 10.0  # [s] wall time to wait for the first /joint_states or base transform (robot_sim may be starting)


class _ActionGoal(RobotGoal):
    """One goal's handle; ``judge(state, result, text)`` says whether it succeeded.

    A handle per goal, not a SimpleActionClient, which tracks one goal per client and logs an ERROR ("a goal handle
    that we're not tracking") whenever the server's last status for the previous goal arrives after the next goal left.
    """

    def __init__(self, handle: actionlib.ClientGoalHandle, judge):
        self.handle, self.judge = handle, judge

    def done(self) -> bool:
        return self.handle.get_comm_state() == actionlib.CommState.DONE

    def outcome(self) -> Tuple[bool, str]:
        handle = self.handle
        return self.judge(handle.get_goal_status(), handle.get_result(), handle.get_goal_status_text())

    def cancel(self) -> None:
        self.handle.cancel()


def _gripper_outcome(state, result, text):
    """franka_gripper: a goal that ended SUCCEEDED says in its result whether the fingers got there (or hold)."""
    if state == GoalStatus.SUCCEEDED and result is not None:
        return bool(result.success), result.error
    return False, (result.error if result is not None and result.error else text) or GoalStatus.to_string(state)


def _move_base_outcome(state, _result, text):
    """move_base: only SUCCEEDED is success; the status text says why not."""
    return state == GoalStatus.SUCCEEDED, text or GoalStatus.to_string(state)


class RosRobot(Robot):
    """Robot interface over topics, TF, the controller manager services and the gripper and base actions.

    ROS Publishers (names relative, at the root as shown): /<position controller>/command, /eigenvalues,
    /eigenvectors, /equilibrium_pose, /skills/authority (teleteach/SkillAuthority, while a skill replays).
    ROS Subscribers: /joint_states, /teleteach/scene, /cartesian_pose, /force_torque_ext (a wipe judges its contact
    by it), /skills/correction (geometry_msgs/Vector3Stamped in base_link [m]: the operator's correction of a
    replayed skill),
    /behaviour_tree/skill_library (what PlaceTaught may place with); TF world->base_link.
    ROS Services (called): /controller_manager/switch_controller, /controller_manager/list_controllers.
    ROS Action Clients: /franka_gripper/move, /franka_gripper/grasp (franka_gripper's actions), /move_base
    (move_base_msgs/MoveBaseAction, target_pose in world).
    """

    def __init__(self, position_controller: str, idle_after: float):
        """position_controller: the joint trajectory controller's name; its trajectories go to <name>/command.

        idle_after: [s] wall time without a skill after which the robot's state is no longer listened to (:meth:`rest`).
        """
        self._lock = threading.Condition()
        self._joints = None
        self._fingers = None
        self._scene = ObservedScene({}, {}, {})
        self._scene_stamp = -1.0
        self._rest_stamp = -1.0  # [s] robot time the base was last found at rest: older scenes are stale
        self._cartesian = None
        self._force = None
        self._tf_buffer = tf2_ros.Buffer(cache_time=rospy.Duration(10.0))
        self._listeners = []
        self._skills = 0
        self._idle_after = idle_after
        self._trajectory = rospy.Publisher(f"{position_controller}/command", JointTrajectory, queue_size=1)
        self._gripper_move = actionlib.ActionClient("franka_gripper/move", MoveAction)
        self._gripper_grasp = actionlib.ActionClient("franka_gripper/grasp", GraspAction)
        self._move_base = actionlib.ActionClient("move_base", MoveBaseAction)
        self._eigenvalues = rospy.Publisher("eigenvalues", Vector3Stamped, queue_size=10)
        self._eigenvectors = rospy.Publisher("eigenvectors", QuaternionStamped, queue_size=10)
        self._equilibrium = rospy.Publisher("equilibrium_pose", PoseStamped, queue_size=10)
        self._authority = rospy.Publisher("skills/authority", SkillAuthority, queue_size=10)
        self._correction: Optional[Tuple[np.ndarray, float]] = None
        rospy.Subscriber("skills/correction", Vector3Stamped, self._on_correction, queue_size=1)
        self._library: Tuple[Tuple[str, str, str], ...] = ()
        rospy.Subscriber("behaviour_tree/skill_library", SkillLibrary, self._on_library, queue_size=1)
        self._switch = rospy.ServiceProxy("controller_manager/switch_controller", SwitchController)
        self._list = rospy.ServiceProxy("controller_manager/list_controllers", ListControllers)
        self.listen()
        self.rest()  # the first skill may come at once (robot_sim starting), or not for a long time

    # ------------------------------------------------------------------------------------------- listening
    def listen(self) -> None:
        """Listen to the robot's state (joint states, scene, pose, TF) from now on: a skill is about to run."""
        with self._lock:
            self._skills += 1
            if self._listeners:
                return
            self._listeners = [
                rospy.Subscriber("joint_states", JointState, self._on_joint_states, queue_size=1),
                rospy.Subscriber("teleteach/scene", MarkerArray, self._on_scene, queue_size=1),
                rospy.Subscriber("cartesian_pose", PoseStamped, self._on_cartesian_pose, queue_size=1),
                rospy.Subscriber("force_torque_ext", WrenchStamped, self._on_force, queue_size=1),
                tf2_ros.TransformListener(self._tf_buffer),
            ]

    def rest(self) -> None:
        """Stop listening ``idle_after`` seconds (wall time) from now, unless a skill starts before.

        Between skills nothing reads the robot's state, some 600 messages a second (joint states, pose, TF, scene).
        What was heard is forgotten with it: the next skill waits for fresh state (its first messages arrive within a
        few milliseconds of subscribing) instead of using values from before the rest.
        """
        timer = threading.Timer(self._idle_after, self._stop_listening, args=(self._skills,))
        timer.daemon = True
        timer.start()

    def _stop_listening(self, skills: int) -> None:
        with self._lock:
            if skills != self._skills or not self._listeners:
                return  # a skill started after the rest was asked for
            for listener in self._listeners:
                listener.unregister()
            self._listeners = []
            self._joints = self._fingers = self._cartesian = self._force = None
            self._scene_stamp = self._rest_stamp = -1.0
            self._tf_buffer.clear()

    # ------------------------------------------------------------------------------------------- callbacks
    def _on_joint_states(self, msg):
        positions = dict(zip(msg.name, msg.position))
        try:
            joints = np.array([positions[name] for name in panda.ARM_JOINTS])
        except KeyError:
            return  # another publisher's partial joint state
        fingers = sum(positions.get(name, 0.0) for name in panda.FINGER_JOINTS)
        if np.all(np.isfinite(joints)):
            with self._lock:
                if self._listeners:  # not a message that was under way when the subscriber went
                    self._joints, self._fingers = joints, float(fingers)
                    self._lock.notify_all()

    def _on_scene(self, msg):
        scene, rejected = observed_from_markers(msg.markers)
        if rejected:
            rospy.logwarn_throttle(5.0, f"skill_server: left out of teleteach/scene: {'; '.join(rejected)}")
        with self._lock:
            if self._listeners:
                self._scene = scene
                self._scene_stamp = scene.stamp if scene.products or scene.gaps else rospy.get_time()
                self._lock.notify_all()

    def _on_cartesian_pose(self, msg):
        if msg.header.frame_id.lstrip("/") != BASE_FRAME:
            return
        position, orientation = msg.pose.position, msg.pose.orientation
        with self._lock:
            if self._listeners:
                self._cartesian = (
                    np.array([position.x, position.y, position.z]),
                    np.array([orientation.x, orientation.y, orientation.z, orientation.w]),
                )
                self._lock.notify_all()

    def _on_force(self, msg):
        if msg.header.frame_id.lstrip("/") != BASE_FRAME:
            return
        force = np.array([msg.wrench.force.x, msg.wrench.force.y, msg.wrench.force.z])
        if np.all(np.isfinite(force)):
            with self._lock:
                if self._listeners:
                    self._force = force
                    self._lock.notify_all()

    def _on_library(self, msg):
        with self._lock:
            self._library = tuple(zip(msg.names, msg.kinds, msg.data_files))

    def _on_correction(self, msg):
        try:
            check_frame(msg.header.frame_id, BASE_FRAME)
            vector = finite_vector([msg.vector.x, msg.vector.y, msg.vector.z], 3, "correction")
            if np.linalg.norm(vector) > MAX_CORRECTION_MESSAGE:
                raise InvalidCommandError(f"{np.linalg.norm(vector):.2f} m long (more than {MAX_CORRECTION_MESSAGE} m)")
        except InvalidCommandError as error:
            rospy.logwarn_throttle(2.0, f"skill_server: /skills/correction refused ({error}): the replay ignores it")
            return
        with self._lock:
            self._correction = (vector, self.now())

    # ----------------------------------------------------------------------------------------------- state
    def now(self) -> float:
        """ROS time (sim time under /use_sim_time) [s]."""
        return rospy.get_time()

    def sleep(self, seconds: float) -> None:
        """rospy.sleep: follows /clock."""
        rospy.sleep(seconds)

    def joint_positions(self) -> np.ndarray:
        """Latest panda_joint1..7 [rad]."""
        with self._lock:
            self._wait_for_joint_states()
            return self._joints.copy()

    def gripper_width(self) -> float:
        """Latest finger opening [m]."""
        with self._lock:
            self._wait_for_joint_states()
            return self._fingers

    def _wait_for_joint_states(self) -> None:
        """Wait (lock held) for the first /joint_states, so a skill asked while robot_sim starts does not fail."""
        self._lock.wait_for(lambda: self._joints is not None or rospy.is_shutdown(), timeout=STATE_WAIT)
        if self._joints is None:
            raise SkillError(f"no /joint_states received in {STATE_WAIT:.0f} s: is robot_sim running?")

    def _base_transform(self, newer_than: float = -1.0) -> Tuple[float, Tuple[float, float, float]]:
        """The newest TF world->base_link as (stamp [s], (x [m], y [m], yaw [rad])), waited for until past newer_than.

        The wait is bounded in wall time (TF_WAIT): a dead simulator's clock must not hang the skill. A skill asked
        while the TF listener still connects (the first goal after start-up) waits for the first transform likewise.
        Returns the newest one held when the wait runs out; SkillError when there is none.
        """
        started = time.monotonic()
        transform = None
        while not rospy.is_shutdown():
            try:
                transform = self._tf_buffer.lookup_transform(WORLD_FRAME, BASE_FRAME, rospy.Time(0))
            except (tf2_ros.LookupException, tf2_ros.ConnectivityException, tf2_ros.ExtrapolationException) as error:
                if time.monotonic() - started > STATE_WAIT:
                    message = f"no transform {WORLD_FRAME} -> {BASE_FRAME} in {STATE_WAIT:.0f} s: {error}"
                    raise SkillError(message) from None
            else:
                if transform.header.stamp.to_sec() > newer_than or time.monotonic() - started > TF_WAIT:
                    break
            time.sleep(0.005)
        if transform is None:
            raise SkillError(f"no transform {WORLD_FRAME} -> {BASE_FRAME}: shutting down")
        translation, rotation = transform.transform.translation, transform.transform.rotation
        yaw = 2.0 * np.arctan2(rotation.z, rotation.w)
        pose = (float(translation.x), float(translation.y), float(wrap_angle(yaw)))
        return transform.header.stamp.to_sec(), pose

    def base_pose(self) -> Tuple[float, float, float]:
        """TF world->base_link as (x [m], y [m], yaw [rad]), no older than TF_FRESHNESS when it can be had.

        A loaded process receives TF late: the newest transform it holds can be from before the base stopped, while
        the scene it compares with is fresh (a carried product then looks out of the hand). So it waits for a
        transform as new as the scene.
        """
        return self._base_transform(newer_than=self.now() - TF_FRESHNESS - 1e-9)[1]

    def base_at_rest(self) -> Tuple[float, float, float]:
        """The base pose once two transforms REST_INTERVAL apart (stamped by the robot's clock) agree.

        From then on :meth:`observed_scene` waits for a scene stamped after them. When move_base reports its goal
        done, a loaded process may still hold transforms (and a scene) from the last centimetres of the drive, and its
        own clock lags the robot's: "fresh" by that clock is not fresh. Comparing stamps of the robot's own clock is:
        a skill that places relative to the base then never mixes the drive's last poses with the base standing still.
        """
        started = time.monotonic()
        stamp, pose = self._base_transform()
        while time.monotonic() - started < REST_WAIT and not rospy.is_shutdown():
            later_stamp, later_pose = self._base_transform(newer_than=stamp + REST_INTERVAL)
            if later_stamp < stamp + REST_INTERVAL:
                break  # TF stopped coming: _base_transform already waited TF_WAIT for it
            moved = math.hypot(later_pose[0] - pose[0], later_pose[1] - pose[1])
            turned = abs(wrap_angle(later_pose[2] - pose[2]))
            stamp, pose = later_stamp, later_pose
            if moved < REST_DISTANCE and turned < REST_ANGLE:
                with self._lock:
                    self._rest_stamp = stamp
                return pose
        raise SkillError(
            f"the base did not come to rest within {REST_WAIT:.0f} s (TF {WORLD_FRAME} -> {BASE_FRAME} last stamped "
            f"{stamp:.2f} s, robot clock {self.now():.2f} s)"
        )

    def observed_scene(self) -> ObservedScene:
        """The latest /teleteach/scene, waited for (SCENE_WAIT) until a fresh one arrives.

        Fresh: no older than SCENE_FRESHNESS, and stamped after the base was last found at rest (:meth:`base_at_rest`).
        """
        with self._lock:
            wanted = max(self.now() - SCENE_FRESHNESS, self._rest_stamp)
            self._lock.wait_for(lambda: self._scene_stamp >= wanted or rospy.is_shutdown(), timeout=SCENE_WAIT)
            return self._scene

    def cartesian_pose(self) -> Tuple[np.ndarray, np.ndarray]:
        """Latest /cartesian_pose (TCP in base_link), the first one waited for (STATE_WAIT)."""
        with self._lock:
            self._lock.wait_for(lambda: self._cartesian is not None or rospy.is_shutdown(), timeout=STATE_WAIT)
            if self._cartesian is None:
                raise SkillError(f"no /cartesian_pose received in {STATE_WAIT:.0f} s: is robot_sim running?")
            return self._cartesian[0].copy(), self._cartesian[1].copy()

    def contact_force(self) -> np.ndarray:
        """Latest /force_torque_ext force (base_link) [N], the first one waited for (STATE_WAIT)."""
        with self._lock:
            self._lock.wait_for(lambda: self._force is not None or rospy.is_shutdown(), timeout=STATE_WAIT)
            if self._force is None:
                raise SkillError(f"no /force_torque_ext received in {STATE_WAIT:.0f} s: is robot_sim running?")
            return self._force.copy()

    # ------------------------------------------------------------------------------------------ controllers
    def active_controllers(self) -> Sequence[str]:
        """Running controllers according to list_controllers."""
        try:
            self._list.wait_for_service(SERVICE_TIMEOUT)
            response = self._list()
        except (rospy.ROSException, rospy.ServiceException) as error:
            raise SkillError(f"{self._list.resolved_name} failed: {error}") from None
        return [controller.name for controller in response.controller if controller.state == "running"]

    def switch_controllers(self, start: Sequence[str], stop: Sequence[str]) -> None:
        """STRICT switch_controller; SkillError when refused or unreachable."""
        request = SwitchControllerRequest(
            start_controllers=list(start), stop_controllers=list(stop), strictness=SwitchControllerRequest.STRICT
        )
        try:
            self._switch.wait_for_service(SERVICE_TIMEOUT)
            response = self._switch(request)
        except (rospy.ROSException, rospy.ServiceException) as error:
            raise SkillError(f"{self._switch.resolved_name} failed: {error}") from None
        if not response.ok:
            raise SkillError(f"the controller manager refused to start {list(start)} and stop {list(stop)} (STRICT)")

    # ---------------------------------------------------------------------------------------------- commands
    @staticmethod
    def _publish(publisher, msg):
        """Publish once the robot listens: a message sent before the connection exists would be lost."""
        deadline = time.monotonic() + CONNECTION_WAIT
        while publisher.get_num_connections() == 0:
            if time.monotonic() > deadline or rospy.is_shutdown():
                raise SkillError(f"nobody subscribes to {publisher.resolved_name}: is robot_sim running?")
            time.sleep(0.01)
        publisher.publish(msg)

    def send_joint_trajectory(self, times, positions, velocities) -> None:
        """JointTrajectory starting on reception (header stamp 0, ros_control convention)."""
        msg = JointTrajectory(joint_names=list(panda.ARM_JOINTS))
        msg.points = [
            JointTrajectoryPoint(
                positions=list(map(float, point)),
                velocities=list(map(float, velocity)),
                time_from_start=rospy.Duration.from_sec(float(time)),
            )
            for time, point, velocity in zip(times, positions, velocities)
        ]
        self._publish(self._trajectory, msg)

    @staticmethod
    def _send(client: actionlib.ActionClient, goal, judge) -> RobotGoal:
        """Send a goal once its server is connected (waited for in wall time: a stopped /clock must not hang here)."""
        deadline = time.monotonic() + CONNECTION_WAIT
        while not server_ready(client):
            if time.monotonic() > deadline or rospy.is_shutdown():
                name = rospy.resolve_name(client.ns)
                raise SkillError(f"nobody serves {name}: is robot_sim (or the robot's driver) running?")
            time.sleep(0.01)
        return _ActionGoal(client.send_goal(goal), judge)

    def move_gripper(self, width: float, speed: float) -> RobotGoal:
        """franka_gripper/move."""
        return self._send(self._gripper_move, MoveGoal(width=float(width), speed=float(speed)), _gripper_outcome)

    def grasp(self, width: float, epsilon_inner: float, epsilon_outer: float, speed: float, force: float) -> RobotGoal:
        """franka_gripper/grasp."""
        goal = GraspGoal(
            width=float(width),
            epsilon=GraspEpsilon(inner=float(epsilon_inner), outer=float(epsilon_outer)),
            speed=float(speed),
            force=float(force),
        )
        return self._send(self._gripper_grasp, goal, _gripper_outcome)

    def move_base(self, x: float, y: float, yaw: float) -> RobotGoal:
        """move_base to a pose in world."""
        goal = MoveBaseGoal()
        target = goal.target_pose
        target.header.frame_id, target.header.stamp = WORLD_FRAME, rospy.Time.now()
        target.pose.position.x, target.pose.position.y = float(x), float(y)
        orientation = target.pose.orientation
        orientation.x, orientation.y, orientation.z, orientation.w = (float(v) for v in yaw_rotation(yaw).as_quat())
        return self._send(self._move_base, goal, _move_base_outcome)

    def command_stiffness(self, eigenvalues, eigenvectors, stamp: float) -> None:
        """/eigenvalues [N/m] and /eigenvectors (quaternion of the principal axes), base_link."""
        values = Vector3Stamped()
        values.header.frame_id, values.header.stamp = BASE_FRAME, rospy.Time.from_sec(stamp)
        values.vector.x, values.vector.y, values.vector.z = (float(value) for value in eigenvalues)
        vectors = QuaternionStamped()
        vectors.header = values.header
        quaternion = vectors.quaternion
        quaternion.x, quaternion.y, quaternion.z, quaternion.w = (float(value) for value in eigenvectors)
        self._publish(self._eigenvectors, vectors)
        self._publish(self._eigenvalues, values)

    def taught_skills(self) -> Sequence[Tuple[str, str, str]]:
        """The newest /behaviour_tree/skill_library."""
        with self._lock:
            return self._library

    def operator_correction(self) -> Optional[Tuple[np.ndarray, float]]:
        """The newest valid /skills/correction and when it came (ROS time)."""
        with self._lock:
            return self._correction

    def report_authority(self, report: AuthorityReport) -> None:
        """/skills/authority."""
        msg = SkillAuthority()
        msg.header.frame_id, msg.header.stamp = BASE_FRAME, rospy.Time.from_sec(self.now())
        msg.skill, msg.confidence, msg.operator_weight = report.skill, report.confidence, report.operator_weight
        msg.spread, msg.target_distance = report.spread, report.target_distance
        msg.correction.x, msg.correction.y, msg.correction.z = (float(value) for value in report.correction)
        msg.max_correction = report.max_correction
        self._authority.publish(msg)  # nobody listening (no GUI) is fine: nothing waits for it

    def command_equilibrium(self, position, quaternion, stamp: float) -> None:
        """/equilibrium_pose in base_link."""
        msg = PoseStamped()
        msg.header.frame_id, msg.header.stamp = BASE_FRAME, rospy.Time.from_sec(stamp)
        msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = (float(value) for value in position)
        orientation = msg.pose.orientation
        orientation.x, orientation.y, orientation.z, orientation.w = (float(value) for value in quaternion)
        self._publish(self._equilibrium, msg)


FEEDBACK_PERIOD = 0.1  # [s] wall time between feedback messages within one phase


class SkillServer:
    """One action server per skill (SimpleActionServer's policy), all executing through one SkillRunner.

    Args:
        runner: executes the skills on a :class:`RosRobot`, which listens to the robot's state only around them.
        status_rate: [Hz of wall time] of the servers' periodic status (:class:`WallStatusTimer`).
        namespace: where the servers live (/skills/<Name>).

    ROS Action Servers: /skills/<Name> for each predefined skill and /skills/ReplaySkill (teleteach/ExecuteSkill).
    """

    def __init__(self, runner: SkillRunner, status_rate: float, namespace="skills"):
        self.runner = runner
        self.servers = {}
        for name in SKILL_NAMES:
            server = OneGoalActionServer(
                f"{namespace}/{name}", ExecuteSkillAction, execute_cb=lambda goal, name=name: self._execute(name, goal)
            )
            self.servers[name] = server
        for server in self.servers.values():
            server.start()
        self._status = WallStatusTimer(self.servers.values(), status_rate)
        rospy.loginfo(f"skill_server: serving {', '.join(f'{namespace}/{name}' for name in SKILL_NAMES)}")

    @classmethod
    def from_params(cls) -> "SkillServer":
        """From the private parameters: the site, the motion config and the robot (defaults: skill_server.yaml).

        A bad scene or motion file raises its ValueError (SceneError, MotionConfigError) naming the file.
        """
        from teleteach.control.kinematics import PandaKinematics
        from teleteach.core.scene import load_site
        from teleteach.runtime.node import node_parameters
        from teleteach.skills.config import SkillServerConfig, load_motion_config

        params = SkillServerConfig.from_mapping(node_parameters("skill_server.yaml"))
        site = load_site(params.scene_file or None)
        config = load_motion_config(params.motion_file or None, params.controllers or None)
        robot = RosRobot(config.position_controller, params.idle_after)
        runner = SkillRunner(robot, config, site, PandaKinematics(site.robot.mount_height))
        return cls(runner, params.action_status_rate)

    def _execute(self, name, goal):
        server = self.servers[name]
        last = {"phase": None, "time": 0.0}

        def feedback(progress, phase):
            now = time.monotonic()
            if phase != last["phase"] or now - last["time"] >= FEEDBACK_PERIOD or progress >= 1.0:
                last["phase"], last["time"] = phase, now
                server.publish_feedback(ExecuteSkillFeedback(progress=progress, phase=phase))

        label = f"{name} ({goal.skill})" if name == REPLAY_SKILL and goal.skill else name
        rospy.loginfo(f"skill_server: {label} started")
        self.runner.robot.listen()
        try:
            outcome = self.runner.execute(name, goal.parameters, Execution(server.is_preempt_requested, feedback))
        finally:
            self.runner.robot.rest()
        result = ExecuteSkillResult(success=outcome.success, message=outcome.message)
        if outcome.success:
            feedback(1.0, "done")  # a skill may finish its last phase between two throttled feedbacks
            rospy.loginfo(f"skill_server: {label} succeeded: {outcome.message}")
            server.set_succeeded(result, outcome.message)
        elif outcome.preempted:
            rospy.logwarn(f"skill_server: {label} preempted")
            server.set_preempted(result, outcome.message)
        else:
            rospy.logwarn(f"skill_server: {label} failed: {outcome.message}")
            server.set_aborted(result, outcome.message)
