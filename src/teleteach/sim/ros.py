"""ROS layer of robot_sim: topics, TF, services and the real-time loop around teleteach.sim.robot_sim.RobotSim.

Callbacks unpack messages and hand plain values to RobotSim under one lock; RobotSim validates them. A rejected
message is logged (throttled) and announced on ~rejected; the last good command stays in force.
"""

import dataclasses
import threading
import time
import warnings
from typing import Any, Dict, Mapping, Optional, Tuple

import rospy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import (
    PoseStamped,
    QuaternionStamped,
    TransformStamped,
    TwistStamped,
    Vector3Stamped,
    WrenchStamped,
)
from move_base_msgs.msg import MoveBaseAction, MoveBaseFeedback, MoveBaseResult
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from tf2_msgs.msg import TFMessage
from trajectory_msgs.msg import JointTrajectory
from visualization_msgs.msg import MarkerArray

from teleteach.control import panda
from teleteach.core.observed import WORLD_FRAME, box_marker, scene_markers
from teleteach.core.parameters import from_mapping
from teleteach.core.rotations import yaw_quaternion
from teleteach.core.scene import load_scene
from teleteach.core.validation import InvalidCommandError
from teleteach.msg import (
    ControllerState,
    GraspAction,
    GraspResult,
    HardwareInterfaceResources,
    HomingAction,
    HomingResult,
    MoveAction,
    MoveResult,
    StopAction,
    StopResult,
)
from teleteach.runtime.node import node_parameters
from teleteach.runtime.ros_actions import OneGoalActionServer, WallStatusTimer
from teleteach.sim.robot_sim import BASE_FRAME, ControllerConfigError, RobotSim, load_controller_config
from teleteach.sim.uncertainty import load_uncertainty
from teleteach.sim.urdf import robot_description
from teleteach.sim.world import SHELF_COLOUR
from teleteach.srv import ListControllers, ListControllersResponse, SwitchController, SwitchControllerResponse

JOINT_NAMES = list(panda.ARM_JOINTS + panda.FINGER_JOINTS)
BASE_ERROR_FRAME = "move_base_goal"  # ~base_error's poses are where the base stops, in the frame of its goal
ACTION_POLL = 0.002  # [s] wall time between two looks at a running gripper or base command
FEEDBACK_PERIOD = 0.1  # [s] wall time between move_base feedback messages


def _synchronous_publisher(topic, message_type):
    """A publisher that writes in the caller's thread.

    rospy's queued publishers hand every message to a writer thread and yield the GIL (time.sleep(0)), which costs
    the 1 kHz loop far more than the write itself.
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return rospy.Publisher(topic, message_type, queue_size=None)


def _stamp(msg):
    return msg.header.stamp.to_sec()


def _xyz(vector):
    return [vector.x, vector.y, vector.z]


def _xyzw(quaternion):
    return [quaternion.x, quaternion.y, quaternion.z, quaternion.w]


SIMULATION_OVERRIDES = (
    "real_time_factor",
    "clock_rate",
    "clock",
    "initial_controller",
    "cartesian_pose_rate",
    "state_rate",
    "scene_rate",
)
"""robot_sim's parameters that replace a key of the controllers file's ``simulation`` section when not null."""


@dataclasses.dataclass(frozen=True)
class RobotSimConfig:
    """robot_sim's parameters: config/robot_sim.yaml's keys (the one place of values and meanings)."""

    gui: bool
    scene_file: str
    absent_products: Tuple[str, ...]
    wiping_tool: bool
    controllers_file: str
    uncertainty_file: str
    seed: Optional[int]
    base_error: Optional[bool]
    perception_noise: Optional[bool]
    real_time_factor: Optional[float]
    clock_rate: Optional[float]
    clock: Optional[str]
    initial_controller: Optional[str]
    cartesian_pose_rate: Optional[float]
    state_rate: Optional[float]
    scene_rate: Optional[float]

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any]) -> "RobotSimConfig":
        """From the yaml's keys, each perhaps overridden; a missing or unknown one is named."""
        return from_mapping(cls, values, "robot_sim's parameters (config/robot_sim.yaml)")

    def simulation(self, section: Mapping[str, Any]) -> Dict[str, Any]:
        """The controllers file's ``simulation`` section with the values these parameters set."""
        overrides = {name: getattr(self, name) for name in SIMULATION_OVERRIDES}
        return {**section, **{name: value for name, value in overrides.items() if value is not None}}


class RobotSimNode:
    """robot_sim: the simulated Panda on its mobile base, its controller manager, and the supermarket.

    Args:
        sim: the simulation.
        real_time_factor: simulated seconds per wall-clock second; 0 runs as fast as possible.
        rates: [Hz of simulated time] of /clock (``clock``), /cartesian_pose (``cartesian_pose``), /joint_states with
            /force_torque_ext and TF (``state``) and /teleteach/scene (``scene``): config/controllers.yaml says why.
        status_rate: [Hz of wall time] of the action servers' periodic status (``WallStatusTimer``).
        follow_clock: publish no /clock; step the world up to the /clock another robot_sim publishes (ROS has one
            clock per master: a second simulated robot on the same master follows the first one's).

    ROS Publishers (at ``rates``):
        /clock, /joint_states, /cartesian_pose (base_link), /force_torque_ext (base_link, contact wrench on the end
        effector about the TCP), /teleteach/scene (the products, gaps and pick table as the robot's perception reports
        them, with config/uncertainty.yaml's errors, teleteach.perception's format, and the shelf boards for RViz),
        /teleteach/true_scene (the same format: the world as it is, for whoever judges an outcome; a real robot has
        none), /diagnostics (1 Hz: real-time factor, step cost, running controller), ~rejected (String: each rejected
        command), ~base_error (latched PoseStamped in frame ``move_base_goal``, per MoveBase goal: where the base will
        stop, in its goal's frame: the truth a real robot does not have), TF world -> base_link.

    ROS Subscribers:
        /eigenvalues, /eigenvectors, /equilibrium_pose, /equilibrium_twist (x_dot_r of eq 5),
        /position_joint_trajectory_controller/command.

    ROS Services:
        /controller_manager/switch_controller, /controller_manager/list_controllers.

    ROS Action Servers:
        /franka_gripper/{move,grasp,homing,stop} (franka_gripper's actions and result semantics: a move or grasp
        that ends away from its width succeeds as a goal with ``success`` false; a bad goal is aborted with the
        reason in ``error``), /move_base (move_base_msgs/MoveBaseAction: target_pose in world, feedback base_position).
    """

    def __init__(
        self, sim: RobotSim, real_time_factor: float, rates: Dict[str, float], status_rate: float, follow_clock=False
    ):
        self.sim = sim
        self.real_time_factor = float(real_time_factor)
        dt = sim.world.time_step
        self._every = {name: max(1, int(round(1.0 / (float(rate) * dt)))) for name, rate in rates.items()}  # [ticks]
        self._lock = threading.Lock()
        self._step_seconds = 0.0
        self._steps = 0
        self._rejected = 0
        rospy.set_param("robot_description", robot_description(sim.scene.robot.mount_height, sim.scene.robot.base_size))
        self._advertise(follow_clock)
        self._subscribers = self._subscribe()
        self._services = [
            rospy.Service("controller_manager/switch_controller", SwitchController, self._on_switch),
            rospy.Service("controller_manager/list_controllers", ListControllers, self._on_list),
        ]
        self._action_servers = self._gripper_and_base_servers()
        for server in self._action_servers:
            server.start()
        self._status = WallStatusTimer(self._action_servers, status_rate)

    def _advertise(self, follow_clock: bool) -> None:
        """Open the topics the simulation publishes (no /clock when it follows another robot_sim's)."""
        self._clock = None if follow_clock else _synchronous_publisher("/clock", Clock)  # /clock: global by design
        self._joint_states = _synchronous_publisher("joint_states", JointState)
        self._cartesian_pose = _synchronous_publisher("cartesian_pose", PoseStamped)
        self._force_torque = _synchronous_publisher("force_torque_ext", WrenchStamped)
        self._tf = _synchronous_publisher("tf", TFMessage)
        self._scene = rospy.Publisher("teleteach/scene", MarkerArray, queue_size=1, latch=True)
        self._true_scene = rospy.Publisher("teleteach/true_scene", MarkerArray, queue_size=1, latch=True)
        self._diagnostics = rospy.Publisher("diagnostics", DiagnosticArray, queue_size=1)
        self._rejections = rospy.Publisher("~rejected", String, queue_size=10)
        self._base_error = rospy.Publisher("~base_error", PoseStamped, queue_size=5, latch=True)

    def _subscribe(self):
        """The subscribers to the controllers' commands, each guarded so a bad message is rejected, not applied."""
        return [
            rospy.Subscriber("eigenvalues", Vector3Stamped, self._guard("eigenvalues", self._on_eigenvalues)),
            rospy.Subscriber("eigenvectors", QuaternionStamped, self._guard("eigenvectors", self._on_eigenvectors)),
            rospy.Subscriber("equilibrium_pose", PoseStamped, self._guard("equilibrium_pose", self._on_equilibrium)),
            rospy.Subscriber(
                "equilibrium_twist", TwistStamped, self._guard("equilibrium_twist", self._on_equilibrium_twist)
            ),
            rospy.Subscriber(
                "position_joint_trajectory_controller/command",
                JointTrajectory,
                self._guard("position_joint_trajectory_controller/command", self._on_trajectory),
            ),
        ]

    def _gripper_and_base_servers(self):
        """The franka_gripper and move_base action servers, built but not started: the caller starts them all."""
        gripper = self.sim.gripper
        return [
            self._gripper_server(
                "franka_gripper/move",
                MoveAction,
                MoveResult,
                lambda goal: gripper.move(goal.width, goal.speed, self.sim.time),
            ),
            self._gripper_server(
                "franka_gripper/grasp",
                GraspAction,
                GraspResult,
                lambda goal: gripper.grasp(
                    goal.width, goal.epsilon.inner, goal.epsilon.outer, goal.speed, goal.force, self.sim.time
                ),
            ),
            self._gripper_server(
                "franka_gripper/homing", HomingAction, HomingResult, lambda goal: gripper.homing(self.sim.time)
            ),
            self._gripper_server(
                "franka_gripper/stop", StopAction, StopResult, lambda goal: gripper.stop(self.sim.time)
            ),
            OneGoalActionServer("move_base", MoveBaseAction, execute_cb=self._move_base),
        ]

    @classmethod
    def from_params(cls):
        """Build the node from its private parameters (config/robot_sim.yaml, :class:`RobotSimConfig`)."""
        params = RobotSimConfig.from_mapping(node_parameters("robot_sim.yaml"))
        scene = load_scene(params.scene_file or None).without_products(params.absent_products)
        uncertainty = load_uncertainty(params.uncertainty_file or None).with_overrides(
            seed=params.seed, base_error=params.base_error, perception_noise=params.perception_noise
        )
        config = load_controller_config(params.controllers_file or None)
        config["simulation"] = simulation = params.simulation(config["simulation"])
        rates = ("clock_rate", "cartesian_pose_rate", "state_rate", "scene_rate")
        sim = RobotSim(scene, config, gui=params.gui, uncertainty=uncertainty)
        if params.wiping_tool:
            if scene.wiping_tool is None:
                raise ValueError("wiping_tool: true, but the scene file has no wiping_tool section")
            sim.world.mount_tool(scene.wiping_tool)
        if simulation["clock"] not in ("publish", "follow"):
            raise ControllerConfigError(f"simulation clock must be publish or follow, got {simulation['clock']!r}")
        return cls(
            sim,
            float(simulation["real_time_factor"]),
            {name.replace("_rate", ""): simulation[name] for name in rates},
            float(simulation["action_status_rate"]),
            follow_clock=simulation["clock"] == "follow",
        )

    # ---------------------------------------------------------------------------------------------- callbacks
    def _guard(self, topic, apply):
        def callback(msg):
            try:
                with self._lock:
                    apply(msg)
            except (InvalidCommandError, ValueError, TypeError) as error:
                self._reject(topic, error)

        return callback

    def _on_eigenvalues(self, msg):
        self.sim.command_eigenvalues(_xyz(msg.vector), _stamp(msg))

    def _on_eigenvectors(self, msg):
        self.sim.command_eigenvectors(_xyzw(msg.quaternion), _stamp(msg))

    def _on_equilibrium(self, msg):
        self.sim.command_equilibrium(
            msg.header.frame_id, _xyz(msg.pose.position), _xyzw(msg.pose.orientation), _stamp(msg)
        )

    def _on_equilibrium_twist(self, msg):
        self.sim.command_equilibrium_twist(
            msg.header.frame_id, _xyz(msg.twist.linear), _xyz(msg.twist.angular), _stamp(msg)
        )

    def _on_trajectory(self, msg):
        points = [(point.positions, point.velocities, point.time_from_start.to_sec()) for point in msg.points]
        self.sim.command_trajectory(msg.joint_names, points, _stamp(msg))

    def _reject(self, name, error):
        """Count, announce on ~rejected and log (throttled) a message or goal that changed nothing."""
        name = rospy.resolve_name(name)  # as it is seen on the graph: /eigenvalues at the root
        self._rejected += 1
        self._rejections.publish(String(data=f"{name}: {error}"))
        rospy.logwarn_throttle(1.0, f"robot_sim rejected a message on {name}: {error}")

    def _gripper_server(self, name, action, result_type, start):
        """A franka_gripper action server: start(goal) begins a SimGripper command, which is followed until it ends."""

        def execute(goal):
            try:
                with self._lock:
                    command = start(goal)
            except (InvalidCommandError, ValueError, TypeError) as error:
                self._reject(name, error)
                server.set_aborted(result_type(success=False, error=str(error)), str(error))
                return
            while not command.done and not rospy.is_shutdown():
                if server.is_preempt_requested():
                    with self._lock:
                        self.sim.gripper.stop(self.sim.time)
                    server.set_preempted(result_type(success=False, error="preempted"), "preempted")
                    return
                time.sleep(ACTION_POLL)
            # franka_gripper: the goal succeeds, the result says whether the fingers got there (or hold the object)
            server.set_succeeded(result_type(success=command.success, error=command.error), command.error)

        server = OneGoalActionServer(name, action, execute_cb=execute)
        return server

    def _move_base(self, goal):
        """move_base: drive the base to target_pose (world); preempted, it stops where it is."""
        server = self._action_servers[-1]
        target = goal.target_pose
        try:
            with self._lock:
                # an action goal is not stale by its stamp: it may have waited for the goal before it to end
                self.sim.command_base_goal(
                    target.header.frame_id, _xyz(target.pose.position), _xyzw(target.pose.orientation)
                )
                error = self.sim.base_stop_in_goal()
        except (InvalidCommandError, ValueError, TypeError) as error:
            self._reject("move_base", error)
            server.set_aborted(MoveBaseResult(), str(error))
            return
        message = PoseStamped(header=self._header(BASE_ERROR_FRAME))
        message.pose.position.x, message.pose.position.y = error[0], error[1]
        orientation = message.pose.orientation
        orientation.x, orientation.y, orientation.z, orientation.w = yaw_quaternion(error[2])
        self._base_error.publish(message)
        last_feedback = 0.0
        while not rospy.is_shutdown():
            with self._lock:
                moving, base = self.sim.world.base_moving, self.sim.world.base_pose.copy()
            if not moving:
                break
            if server.is_preempt_requested():
                with self._lock:
                    self.sim.stop_base()
                server.set_preempted(MoveBaseResult(), "preempted: the base stopped where it was")
                return
            if time.monotonic() - last_feedback >= FEEDBACK_PERIOD:
                last_feedback = time.monotonic()
                server.publish_feedback(MoveBaseFeedback(base_position=self._base_pose_message(base)))
            time.sleep(ACTION_POLL)
        server.set_succeeded(MoveBaseResult(), "goal reached")

    def _base_pose_message(self, base):
        x, y, yaw = base
        pose = PoseStamped(header=self._header("world"))
        pose.pose.position.x, pose.pose.position.y = x, y
        orientation = pose.pose.orientation
        orientation.x, orientation.y, orientation.z, orientation.w = yaw_quaternion(yaw)
        return pose

    def _on_switch(self, request):
        with self._lock:
            ok, message = self.sim.switch_controllers(
                request.start_controllers, request.stop_controllers, request.strictness
            )
        log = rospy.loginfo if ok else rospy.logwarn
        log(
            f"robot_sim switch_controller start={list(request.start_controllers)} "
            f"stop={list(request.stop_controllers)}: {'ok' if ok else 'failed'} ({message})"
        )
        return SwitchControllerResponse(ok=ok)

    def _on_list(self, _request):
        with self._lock:
            infos = self.sim.manager.list_controllers()
        return ListControllersResponse(
            controller=[
                ControllerState(
                    name=info.name,
                    state=info.state,
                    type=info.type,
                    claimed_resources=[
                        HardwareInterfaceResources(
                            hardware_interface=info.hardware_interface, resources=list(info.resources)
                        )
                    ],
                )
                for info in infos
            ]
        )

    # ------------------------------------------------------------------------------------------------- loop
    def spin(self):
        """Tick the simulation until shutdown, paced to the real-time factor (or to another robot_sim's /clock)."""
        if self._clock is None:
            self._follow()
            return
        wall_start, sim_start = time.monotonic(), self.sim.time
        self._report_wall, self._report_sim = wall_start, sim_start
        while not rospy.is_shutdown():
            self._step()
            now = time.monotonic()
            if self.real_time_factor > 0.0:
                ahead = (self.sim.time - sim_start) / self.real_time_factor - (now - wall_start)
                if ahead > 0.002:
                    time.sleep(ahead)
                elif ahead < -0.2:
                    # Too slow to keep up: run on without trying to catch up with lost time.
                    wall_start, sim_start = now, self.sim.time

    def _step(self):
        """One tick, its publications, and every 1000 ticks the real-time factor report."""
        started = time.perf_counter()
        with self._lock:
            self.sim.tick()
        self._step_seconds += time.perf_counter() - started
        self._steps += 1
        self._publish(self.sim.world.ticks)
        if self._steps % 1000 == 0:
            now = time.monotonic()
            self._report((self.sim.time - self._report_sim) / max(now - self._report_wall, 1e-9))
            self._report_wall, self._report_sim = now, self.sim.time

    def _follow(self):
        """Step the world up to /clock (published by another robot_sim); the world's time starts at its first value."""
        while not rospy.is_shutdown() and rospy.get_time() <= 0.0:
            time.sleep(0.01)
        with self._lock:
            self.sim.world.time = rospy.get_time()
        self._report_wall, self._report_sim = time.monotonic(), self.sim.time
        rospy.loginfo(f"robot_sim follows /clock from t = {self.sim.time:.3f} s")
        step = self.sim.world.time_step
        while not rospy.is_shutdown():
            while self.sim.time + step <= rospy.get_time() and not rospy.is_shutdown():
                self._step()
            time.sleep(0.0005)

    def _report(self, factor):
        mean_us = 1e6 * self._step_seconds / max(self._steps, 1)
        running = self.sim.manager.running or "none"
        rospy.loginfo_throttle(
            10.0,
            f"robot_sim real-time factor {factor:.2f}, step {mean_us:.0f} us, "
            f"controller {running}, rejected commands {self._rejected}",
        )
        status = DiagnosticStatus(
            level=DiagnosticStatus.OK,
            name="robot_sim",
            hardware_id="pybullet",
            message=f"real-time factor {factor:.2f}",
            values=[
                KeyValue("real_time_factor", f"{factor:.3f}"),
                KeyValue("mean_step_us", f"{mean_us:.1f}"),
                KeyValue("running_controller", running),
                KeyValue("rejected_commands", str(self._rejected)),
            ],
        )
        self._diagnostics.publish(DiagnosticArray(header=self._header(""), status=[status]))
        self._step_seconds, self._steps = 0.0, 0

    def _header(self, frame_id):
        msg = PoseStamped().header
        msg.stamp = rospy.Time.from_sec(self.sim.time)
        msg.frame_id = frame_id
        return msg

    def _publish(self, tick):
        every = self._every
        if self._clock is not None and tick % every["clock"] == 0:
            self._clock.publish(Clock(clock=rospy.Time.from_sec(self.sim.time)))
        if tick % every["cartesian_pose"] == 0:
            state = self.sim.state
            pose = PoseStamped(header=self._header(BASE_FRAME))
            pose.pose.position.x, pose.pose.position.y, pose.pose.position.z = state.position
            orientation = pose.pose.orientation
            orientation.x, orientation.y, orientation.z, orientation.w = state.quaternion
            self._cartesian_pose.publish(pose)
        if tick % every["state"] == 0:
            with self._lock:
                positions, velocities, efforts = self.sim.world.joint_states()
                force, torque = self.sim.world.external_wrench()
                base = self.sim.world.base_pose.copy()
            self._joint_states.publish(
                JointState(
                    header=self._header(""), name=JOINT_NAMES, position=positions, velocity=velocities, effort=efforts
                )
            )
            wrench = WrenchStamped(header=self._header(BASE_FRAME))
            wrench.wrench.force.x, wrench.wrench.force.y, wrench.wrench.force.z = force
            wrench.wrench.torque.x, wrench.wrench.torque.y, wrench.wrench.torque.z = torque
            self._force_torque.publish(wrench)
            self._publish_base_tf(base)
        if tick % every["scene"] == 0:
            self._publish_scene()

    def _publish_base_tf(self, base):
        x, y, yaw = base
        transform = TransformStamped(header=self._header("world"), child_frame_id=BASE_FRAME)
        transform.transform.translation.x, transform.transform.translation.y = x, y
        rotation = transform.transform.rotation
        rotation.x, rotation.y, rotation.z, rotation.w = yaw_quaternion(yaw)
        self._tf.publish(TFMessage(transforms=[transform]))

    def _publish_scene(self):
        """Publish teleteach/scene as perception reports it (with the shelf for RViz) and teleteach/true_scene."""
        scene = self.sim.scene
        with self._lock:
            truth = self.sim.true_scene()
            perceived = self.sim.perceived_scene()
        header = self._header(WORLD_FRAME)
        shelf = [
            box_marker(
                header, "shelf", index, part.center, yaw_quaternion(part.yaw), part.size, SHELF_COLOUR, part.name
            )
            for index, part in enumerate(scene.shelf)
        ]
        self._scene.publish(scene_markers(perceived, self.sim.time, shelf))
        self._true_scene.publish(scene_markers(truth, self.sim.time))
