"""The robot interface over the in-process simulation (teleteach.sim.robot_sim.RobotSim), without ROS.

The skills then run against the same physics, controllers and command validation as behind the ROS node; time
passes only when a skill waits (sleep() steps the simulation), so runs are deterministic and faster than real time.
"""

from typing import Callable, List, Optional, Sequence, Tuple

import numpy as np

from teleteach.control import panda
from teleteach.control.manager import STRICT
from teleteach.core.observed import ObservedScene
from teleteach.core.rotations import yaw_rotation
from teleteach.sim.robot_sim import RobotSim
from teleteach.skills.authority import AuthorityReport
from teleteach.skills.robot import Robot, RobotGoal, SkillError


class _GripperGoal(RobotGoal):
    """A command of the simulated hand (teleteach.sim.gripper.GripperCommand) as a robot goal."""

    def __init__(self, sim: RobotSim, command):
        self.sim, self.command = sim, command

    def done(self) -> bool:
        return self.command.done

    def outcome(self) -> Tuple[bool, str]:
        return self.command.success, self.command.error

    def cancel(self) -> None:
        if not self.command.done:
            self.sim.gripper.stop(self.sim.time)


class _BaseGoal(RobotGoal):
    """The simulated base driving to its goal, as a robot goal."""

    def __init__(self, sim: RobotSim):
        self.sim = sim

    def done(self) -> bool:
        return not self.sim.world.base_moving

    def outcome(self) -> Tuple[bool, str]:
        return True, ""

    def cancel(self) -> None:
        self.sim.stop_base()


class SimRobot(Robot):
    """Robot interface of a RobotSim stepped by the skills' own waits.

    Args:
        sim: the simulated robot (its world, controllers and validated commands).
        operator: a scripted operator correcting replayed skills: time [s] -> correction [m] (3,) base_link or None.
    """

    def __init__(self, sim: RobotSim, operator: Optional[Callable[[float], Optional[Sequence[float]]]] = None):
        self.sim = sim
        self.operator = operator
        self.authority_reports: List[AuthorityReport] = []
        self.library: List[Tuple[str, str, str]] = []  # the skill library's (name, kind, data file) entries

    def taught_skills(self) -> Sequence[Tuple[str, str, str]]:
        """``library``."""
        return tuple(self.library)

    def operator_correction(self) -> Optional[Tuple[np.ndarray, float]]:
        """The scripted operator's correction now."""
        correction = None if self.operator is None else self.operator(self.now())
        return None if correction is None else (np.asarray(correction, dtype=float), self.now())

    def report_authority(self, report: AuthorityReport) -> None:
        """Kept in ``authority_reports``."""
        self.authority_reports.append(report)

    def now(self) -> float:
        """Simulated time [s]."""
        return self.sim.time

    def sleep(self, seconds: float) -> None:
        """Step the simulation for seconds [s]."""
        self.sim.run(max(seconds, self.sim.world.time_step))

    def joint_positions(self) -> np.ndarray:
        """panda_joint1..7 [rad]."""
        return np.array(self.sim.world.joint_states()[0][:7])

    def gripper_width(self) -> float:
        """Both fingers' opening [m]."""
        positions = self.sim.world.joint_states()[0]
        return float(positions[7] + positions[8])

    def base_pose(self) -> Tuple[float, float, float]:
        """base_link in world (x [m], y [m], yaw [rad])."""
        x, y, yaw = self.sim.world.base_pose
        return float(x), float(y), float(yaw)

    def observed_scene(self) -> ObservedScene:
        """What robot_sim would publish on teleteach/scene now: the world as its perception reports it."""
        return self.sim.perceived_scene()

    def cartesian_pose(self) -> Tuple[np.ndarray, np.ndarray]:
        """TCP in base_link as the controllers see it."""
        state = self.sim.world.read_state()
        return state.position.copy(), state.quaternion.copy()

    def contact_force(self) -> np.ndarray:
        """The contact force on the hand and what it holds or carries, base_link [N] (what /force_torque_ext says)."""
        return self.sim.world.external_wrench()[0]

    def active_controllers(self) -> Sequence[str]:
        """The running controller, if any."""
        running = self.sim.manager.running
        return [running] if running else []

    def switch_controllers(self, start: Sequence[str], stop: Sequence[str]) -> None:
        """STRICT switch; SkillError with the manager's reason when refused."""
        ok, message = self.sim.switch_controllers(start, stop, STRICT)
        if not ok:
            raise SkillError(f"controller switch (start {list(start)}, stop {list(stop)}) refused: {message}")

    def send_joint_trajectory(self, times, positions, velocities) -> None:
        """Replace the joint trajectory (times from now)."""
        points = [(list(p), list(v), float(t)) for t, p, v in zip(times, positions, velocities)]
        self.sim.command_trajectory(panda.ARM_JOINTS, points, stamp=self.sim.time)

    def move_gripper(self, width: float, speed: float) -> RobotGoal:
        """The simulated hand's move (franka_gripper/move)."""
        return _GripperGoal(self.sim, self.sim.gripper.move(width, speed, self.sim.time))

    def grasp(self, width: float, epsilon_inner: float, epsilon_outer: float, speed: float, force: float) -> RobotGoal:
        """The simulated hand's grasp (franka_gripper/grasp)."""
        return _GripperGoal(
            self.sim, self.sim.gripper.grasp(width, epsilon_inner, epsilon_outer, speed, force, self.sim.time)
        )

    def move_base(self, x: float, y: float, yaw: float) -> RobotGoal:
        """Drive the simulated base to a goal in world (move_base)."""
        self.sim.command_base_goal("world", [x, y, 0.0], yaw_rotation(yaw).as_quat(), stamp=self.sim.time)
        return _BaseGoal(self.sim)

    def command_stiffness(self, eigenvalues, eigenvectors, stamp: float) -> None:
        """Principal stiffnesses [N/m] and their axes' quaternion."""
        self.sim.command_eigenvectors(eigenvectors, stamp)
        self.sim.command_eigenvalues(eigenvalues, stamp)

    def command_equilibrium(self, position, quaternion, stamp: float) -> None:
        """Impedance reference in base_link."""
        self.sim.command_equilibrium("base_link", position, quaternion, stamp)
