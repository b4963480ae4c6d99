"""The small robot interface the skills run on, and how a running skill reports and gets stopped.

The ROS layer (:mod:`teleteach.skills.ros`) implements :class:`Robot` over topics, TF, services and actions (the
gripper through franka_gripper's actions, the base through move_base); anything else that can report joint states,
product poses and the base pose and take joint trajectories, gripper and base goals (a simulation stepped in-process,
for example) can run the same skills.
"""

import abc
from typing import Callable, Dict, Optional, Sequence, Tuple

import numpy as np

from teleteach.core.observed import ObservedScene
from teleteach.skills.authority import AuthorityReport

HOLD_TIME = 0.05  # [s] a hold point lies this far ahead (a point at time 0 would already be in the past)


class SkillError(RuntimeError):
    """A skill cannot do its job; the message says why (it becomes the action result's message)."""


class PreemptedError(Exception):
    """The client cancelled the goal or sent a new one."""


class RobotGoal(abc.ABC):
    """A goal the robot works on by itself (a gripper or base action): polled until done, cancelled when preempted."""

    @abc.abstractmethod
    def done(self) -> bool:
        """Whether the robot has finished with the goal (succeeded, failed or cancelled)."""

    @abc.abstractmethod
    def outcome(self) -> Tuple[bool, str]:
        """Once done: whether it succeeded, and what the robot said (empty when it said nothing)."""

    @abc.abstractmethod
    def cancel(self) -> None:
        """Ask the robot to stop working on the goal."""


class Robot(abc.ABC):
    """What the skills read from and command to the robot. Times are the robot's clock (sim time) [s]."""

    @abc.abstractmethod
    def now(self) -> float:
        """Current time [s]."""

    @abc.abstractmethod
    def sleep(self, seconds: float) -> None:
        """Let seconds of robot time pass."""

    @abc.abstractmethod
    def joint_positions(self) -> np.ndarray:
        """panda_joint1..7 [rad]; raises SkillError when none has been received."""

    @abc.abstractmethod
    def gripper_width(self) -> float:
        """Measured finger opening (both fingers together) [m]."""

    @abc.abstractmethod
    def base_pose(self) -> Tuple[float, float, float]:
        """base_link in world: x [m], y [m], yaw [rad]; raises SkillError when unknown."""

    def base_at_rest(self) -> Tuple[float, float, float]:
        """The base pose once the base stands still, and from then on a scene that shows it standing there.

        A robot read synchronously (an in-process simulation) is at rest as soon as its base goal ends.
        """
        return self.base_pose()

    @abc.abstractmethod
    def observed_scene(self) -> ObservedScene:
        """The products, gaps and tables as the robot's perception reports them now (teleteach.perception)."""

    def product_poses(self) -> Dict[str, Tuple[np.ndarray, np.ndarray]]:
        """Product name -> centre position [m] and (x, y, z, w) quaternion in world, as the scene reports them now."""
        return self.observed_scene().product_poses()

    def product_positions(self) -> Dict[str, np.ndarray]:
        """Product name -> centre position [m] in world, as the scene reports them now."""
        return {name: position for name, (position, _) in self.product_poses().items()}

    @abc.abstractmethod
    def cartesian_pose(self) -> Tuple[np.ndarray, np.ndarray]:
        """Measured TCP pose in base_link: position [m], quaternion (x, y, z, w)."""

    @abc.abstractmethod
    def contact_force(self) -> np.ndarray:
        """The newest contact force on the hand and what it holds or carries (a mounted tool), base_link [N].

        Franka's estimated external force (/force_torque_ext), the force the environment applies.
        """

    @abc.abstractmethod
    def active_controllers(self) -> Sequence[str]:
        """Names of the running controllers."""

    @abc.abstractmethod
    def switch_controllers(self, start: Sequence[str], stop: Sequence[str]) -> None:
        """STRICT switch; raises SkillError with the controller manager's answer when it refuses."""

    @abc.abstractmethod
    def send_joint_trajectory(self, times: np.ndarray, positions: np.ndarray, velocities: np.ndarray) -> None:
        """Replace the position controller's trajectory (times from now [s], positions [rad], velocities [rad/s])."""

    @abc.abstractmethod
    def move_gripper(self, width: float, speed: float) -> RobotGoal:
        """franka_gripper/move: the fingers to width [m] at speed [m/s]."""

    @abc.abstractmethod
    def grasp(self, width: float, epsilon_inner: float, epsilon_outer: float, speed: float, force: float) -> RobotGoal:
        """franka_gripper/grasp: close at speed [m/s] on an object of width [m] and squeeze it with force [N].

        It succeeds when the fingers stop within [width - epsilon_inner, width + epsilon_outer] [m].
        """

    @abc.abstractmethod
    def move_base(self, x: float, y: float, yaw: float) -> RobotGoal:
        """move_base: drive base_link to (x [m], y [m], yaw [rad]) in world."""

    @abc.abstractmethod
    def command_stiffness(self, eigenvalues: np.ndarray, eigenvectors: np.ndarray, stamp: float) -> None:
        """Impedance controller: principal stiffnesses [N/m] and the quaternion (x, y, z, w) of their axes."""

    @abc.abstractmethod
    def command_equilibrium(self, position: np.ndarray, quaternion: np.ndarray, stamp: float) -> None:
        """Impedance controller: reference pose in base_link (position [m], quaternion (x, y, z, w))."""

    def taught_skills(self) -> Sequence[Tuple[str, str, str]]:
        """The skill library's (name, kind, data file) entries, in the order they joined; none without a library."""
        return ()

    def operator_correction(self) -> Optional[Tuple[np.ndarray, float]]:
        """The operator's newest correction of a replayed skill ([m] (3,) base_link) and when it came [s]; None: none.

        A robot without an operator's channel has none.
        """
        return None

    def report_authority(self, report: AuthorityReport) -> None:
        """Say who leads the replay now (the GUI shows it); a robot without an operator's channel says nothing."""
        return None

    def hold(self, positions: np.ndarray) -> None:
        """Stop the arm where it is: a one-point trajectory to positions [rad], reached within HOLD_TIME."""
        positions = np.asarray(positions, dtype=float)[None, :]
        self.send_joint_trajectory(np.array([HOLD_TIME]), positions, np.zeros_like(positions))


class Execution:
    """The link between a running skill and whoever asked for it: feedback out, preemption in.

    Args:
        preempt_requested: returns True when the skill must stop.
        feedback: called with (progress 0..1, phase name).
    """

    def __init__(
        self,
        preempt_requested: Optional[Callable[[], bool]] = None,
        feedback: Optional[Callable[[float, str], None]] = None,
    ):
        self._preempt_requested = preempt_requested or (lambda: False)
        self._feedback = feedback or (lambda progress, phase: None)
        self._phase = ""
        self._start = 0.0
        self._weight = 0.0
        self._fraction = 0.0
        self.progress = 0.0

    def check(self) -> None:
        """Raise PreemptedError when the skill must stop."""
        if self._preempt_requested():
            raise PreemptedError()

    def phase(self, name: str, weight: float) -> None:
        """Start the next phase, which covers the following weight (0..1) of the overall progress."""
        self._start = min(1.0, self._start + self._weight) if self._phase else 0.0
        self._phase, self._weight, self._fraction = name, weight, 0.0
        self.report(0.0)

    def report(self, fraction: float) -> None:
        """Progress within the current phase (0..1).

        It never goes back within a phase: fingers closing on a product give a little and spring back, and the grasp
        was still that far.
        """
        self._fraction = max(self._fraction, min(max(fraction, 0.0), 1.0))
        self.progress = min(1.0, self._start + self._weight * self._fraction)
        self._feedback(self.progress, self._phase)

    def complete(self, phase: str) -> None:
        """The whole skill is done."""
        self._phase, self._start, self._weight, self._fraction = phase, 1.0, 0.0, 0.0
        self.report(1.0)
