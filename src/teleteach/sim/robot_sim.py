"""The simulated robot without ROS: world + controller manager + validated command entry points.

The ROS node (teleteach.sim.ros) calls these methods from its callbacks and `tick()` from its loop; tests and
benchmarks call them directly.
"""

import pathlib

import numpy as np

from teleteach.control import panda
from teleteach.control.impedance import CartesianImpedanceController, ImpedanceParams
from teleteach.control.joint_trajectory import JointTrajectoryController
from teleteach.control.manager import ControllerManager
from teleteach.core import parameters, validation
from teleteach.core.frames import Transform
from teleteach.core.observed import ObservedScene, observed_from_scene
from teleteach.core.paths import config_file, config_values
from teleteach.core.robot_controllers import controller_names
from teleteach.core.scene import BasePose, Scene, Surface, load_scene
from teleteach.sim.gripper import SimGripper
from teleteach.sim.uncertainty import BaseError, PerceptionNoise, UncertaintySettings, base_stream
from teleteach.sim.world import SupermarketWorld

DEFAULT_CONTROLLER_FILE = config_file("controllers.yaml")
# the simulated robot serves config/robot_controllers.yaml's `simulation` controllers (their gains: controllers.yaml)
IMPEDANCE, TRAJECTORY = controller_names("simulation").impedance, controller_names("simulation").position
BASE_FRAME = "base_link"


class ControllerConfigError(ValueError):
    """The controller settings lack a value or hold a wrong one; the message names the file's section and field."""


def load_controller_config(path=None):
    """The controller settings (config/controllers.yaml by default) as a dict."""
    return config_values(pathlib.Path(path or DEFAULT_CONTROLLER_FILE))


def impedance_params(config) -> ImpedanceParams:
    """The impedance controller's gains from the controller settings (every one must be there: no code defaults)."""
    where = f"controller settings, {IMPEDANCE}"
    return parameters.from_mapping(ImpedanceParams, config.get(IMPEDANCE) or {}, where, ControllerConfigError)


class RobotSim:
    """The Panda on its mobile base in the supermarket, with its controllers.

    The world is the truth; MoveBase goals and the perceived scene carry the errors of ``uncertainty``.

    Args:
        scene: the scene (default: config/supermarket.yaml).
        config: controller settings (default: config/controllers.yaml), as load_controller_config() returns.
        gui: pybullet's own window.
        uncertainty: base error and perception noise (teleteach.sim.uncertainty.load_uncertainty()); default: none,
            MoveBase exact and perception perfect.
    """

    def __init__(self, scene: Scene = None, config=None, gui=False, uncertainty: UncertaintySettings = None):
        self.scene = scene or load_scene()
        self.uncertainty = uncertainty or UncertaintySettings.none()
        self.base_error = BaseError(self.uncertainty.base_error, base_stream(self.uncertainty.seed))
        self.perception = PerceptionNoise(self.uncertainty.perception, self.uncertainty.seed)
        self.base_goal = None
        self._new_viewpoint = False
        self.config = config or load_controller_config()
        simulation, gripper, base = self.config["simulation"], self.config["gripper"], self.config["base"]
        trajectory = self.config[TRAJECTORY]
        self.world = SupermarketWorld(
            self.scene,
            gui=gui,
            time_step=float(simulation["time_step"]),
            position_gain=float(trajectory["position_gain"]),
            velocity_gain=float(trajectory["velocity_gain"]),
            finger_force=float(gripper["force"]),
            finger_speed=float(gripper["max_speed"]),
            base_speed=float(base["max_speed"]),
            base_turn_rate=float(base["max_turn_rate"]),
            pad_friction=float(gripper["pad_friction"]),
            pad_spinning_friction=float(gripper["pad_spinning_friction"]),
            solver_residual_threshold=float(simulation["solver_residual_threshold"]),
        )
        self.gripper = SimGripper(
            self.world,
            max_width=panda.MAX_FINGER_WIDTH,
            max_speed=float(gripper["max_speed"]),
            max_force=float(gripper["max_force"]),
            move_force=float(gripper["force"]),
            settle_time=float(gripper["settle_time"]),
            position_tolerance=float(gripper["position_tolerance"]),
        )
        self.max_age = float(self.config["command_validation"]["max_age"])
        self.impedance = CartesianImpedanceController(impedance_params(self.config))
        self.trajectory = JointTrajectoryController()
        self.manager = ControllerManager({TRAJECTORY: self.trajectory, IMPEDANCE: self.impedance}, panda.ARM_JOINTS)
        self._eigenvalues = self.impedance.eigenvalues.copy()
        self._eigenvectors = np.array([0.0, 0.0, 0.0, 1.0])
        self.state = self.world.read_state()
        initial = simulation["initial_controller"]
        if initial != "none":
            ok, message = self.manager.switch([initial], [], 2, self.state)
            if not ok:
                raise ValueError(f"initial_controller: {message}")

    @property
    def time(self):
        """Simulated time [s]."""
        return self.world.time

    def close(self):
        """Release pybullet."""
        self.world.close()

    def tick(self):
        """One 1 kHz step: read the state, run the active controller, step physics (only while it holds the arm)."""
        self.state = self.world.read_state()
        command = self.manager.update(self.state)
        self.world.step(command)
        self.gripper.update(self.time)
        if self._new_viewpoint and not self.world.base_moving:
            self.perception.new_viewpoint()
            self._new_viewpoint = False

    def run(self, seconds):
        """Tick for a simulated duration [s]."""
        for _ in range(int(round(seconds / self.world.time_step))):
            self.tick()

    # ------------------------------------------------------------ commands: each validated, or InvalidCommandError
    def command_eigenvalues(self, values, stamp=0.0):
        """Principal stiffnesses [N/m] (/eigenvalues); clamped to the maximum."""
        validation.check_stamp(stamp, self.time, self.max_age)
        self._eigenvalues = validation.validate_eigenvalues(values, self.impedance.params.max_stiffness)
        self.impedance.set_stiffness(self._eigenvalues, self._eigenvectors)

    def command_eigenvectors(self, quaternion, stamp=0.0):
        """Orientation of the principal axes (/eigenvectors), quaternion (x, y, z, w) in base_link."""
        validation.check_stamp(stamp, self.time, self.max_age)
        self._eigenvectors = validation.validate_quaternion(quaternion, "eigenvectors")
        self.impedance.set_stiffness(self._eigenvalues, self._eigenvectors)

    def command_equilibrium(self, frame_id, position, quaternion, stamp=0.0):
        """Reference pose x_r (/equilibrium_pose) in base_link."""
        validation.check_stamp(stamp, self.time, self.max_age)
        position, quaternion = validation.validate_pose(frame_id, BASE_FRAME, position, quaternion)
        self.impedance.set_equilibrium(position, quaternion)

    def command_equilibrium_twist(self, frame_id, linear, angular, stamp=0.0):
        """Velocity x_dot_r of the reference pose (/equilibrium_twist) in base_link [m/s, rad/s]."""
        validation.check_stamp(stamp, self.time, self.max_age)
        validation.check_frame(frame_id, BASE_FRAME)
        linear = validation.finite_vector(linear, 3, "equilibrium twist linear")
        angular = validation.finite_vector(angular, 3, "equilibrium twist angular")
        self.impedance.set_reference_velocity(linear, angular, stamp if stamp != 0.0 else self.time)

    def command_trajectory(self, joint_names, points, stamp=0.0):
        """Joint trajectory: points are (positions [rad], velocities [rad/s] or [], time_from_start [s])."""
        validation.check_stamp(stamp, self.time, self.max_age)
        times, positions, velocities = validation.validate_joint_trajectory(
            joint_names, points, panda.ARM_JOINTS, panda.LOWER_LIMITS, panda.UPPER_LIMITS
        )
        start = stamp if stamp != 0.0 else self.time
        self.trajectory.set_trajectory(start, times, positions, velocities, self.time)

    def command_base_goal(self, frame_id, position, quaternion, stamp=0.0):
        """Base goal in world (x, y and yaw of the pose); the base stops at the goal plus the base error."""
        validation.check_stamp(stamp, self.time, self.max_age)
        self.base_goal = np.array(validation.validate_base_goal(frame_id, position, quaternion))
        self.world.set_base_goal(*self.base_error.stop_pose(self.base_goal))
        self._new_viewpoint = True

    def base_stop_in_goal(self) -> np.ndarray:
        """Where the base stops (stops: its last goal's stop pose) in the frame of its last goal: x [m], y [m], yaw."""
        goal = Transform.from_planar(*self.base_goal)
        return (goal.inverse() * Transform.from_planar(*self.world.base_goal)).planar()

    def place_base(self, pose: BasePose):
        """Put the base at a pose at once, where MoveBase would have stopped for it (set-up of benches and tests)."""
        self.base_goal = np.array([pose.x, pose.y, pose.yaw])
        x, y, yaw = self.base_error.stop_pose(self.base_goal)
        self.world.teleport_base(BasePose(x, y, yaw))
        self.perception.new_viewpoint()

    def true_scene(self) -> ObservedScene:
        """The world's products as they are, the scene's gaps and table: what judges an outcome."""
        return observed_from_scene(self.scene, self.world.product_poses(), self.time)

    def perceived_surface(self, name: str) -> Surface:
        """The surface called name as the robot's perception reports it now."""
        return self.perception.perceive_surface(self.scene.surface(name))

    def perceived_scene(self) -> ObservedScene:
        """The scene as the robot's perception reports it now (teleteach/scene)."""
        return self.perception.perceive(self.true_scene())

    def stop_base(self):
        """Stop the base where it is."""
        self.world.stop_base()

    def switch_controllers(self, start, stop, strictness):
        """ros_control switch; returns (ok, message). The started controller holds the current state."""
        return self.manager.switch(list(start), list(stop), strictness, self.world.read_state())
