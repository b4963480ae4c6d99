"""Arm, gripper and base motions on the position controller, each waited for until the robot reports it done.

Point-to-point moves are minimum-jerk in joint space; straight TCP lines are dense IK waypoints timed by a
minimum-jerk path parameter. Every wait polls the robot, reports progress and honours preemption.
"""

import math
from typing import Tuple

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from teleteach.control import panda
from teleteach.core.frames import Transform
from teleteach.core.rotations import wrap_angle, yaw_rotation
from teleteach.skills import trajectory
from teleteach.skills.config import MotionConfig
from teleteach.skills.robot import Execution, PreemptedError, Robot, SkillError

POLL_PERIOD = 0.02  # [s] how often waits look at the robot's state
TOP_DOWN = Rotation.from_euler("x", math.pi)  # TCP z axis pointing down, fingers closing across base y


def base_to_world(base_pose, position):
    """A point [m] given in base_link, in world (base_pose: x [m], y [m], yaw [rad] of base_link)."""
    return Transform.from_planar(*base_pose).apply_point(position)


def world_to_base(base_pose, position):
    """A point [m] given in world, in base_link (base_pose: x [m], y [m], yaw [rad] of base_link)."""
    return Transform.from_planar(*base_pose).inverse().apply_point(position)


class InverseKinematics:
    """Damped least-squares IK of the TCP in base_link, biased toward a seed posture in the Jacobian's nullspace.

    Args:
        kinematics: forward(q) -> (position, quaternion) and jacobian(q) -> 6x7 in base_link
            (teleteach.control.kinematics.PandaKinematics).
        tolerance: accepted position [m] and orientation [rad] error.
    """

    def __init__(self, kinematics, tolerance=5e-4, damping=1e-2, nullspace_gain=0.2, max_iterations=300):
        self.kinematics = kinematics
        self.tolerance = tolerance
        self.damping = damping
        self.nullspace_gain = nullspace_gain
        self.max_iterations = max_iterations

    def forward(self, joints) -> Tuple[np.ndarray, Rotation]:
        """TCP position [m] and orientation in base_link."""
        position, quaternion = self.kinematics.forward(joints)
        return np.asarray(position, dtype=float), Rotation.from_quat(quaternion)

    def solve(self, position, orientation: Rotation, seed):
        """Joint positions [rad] reaching the pose, or SkillError saying how far the best attempt stayed."""
        seed = np.asarray(seed, dtype=float)
        joints = seed.copy()
        target = np.asarray(position, dtype=float)
        for _ in range(self.max_iterations):
            reached, rotation = self.forward(joints)
            error = np.concatenate([target - reached, (orientation * rotation.inv()).as_rotvec()])
            if np.linalg.norm(error[:3]) < self.tolerance and np.linalg.norm(error[3:]) < self.tolerance:
                return joints
            jacobian = self.kinematics.jacobian(joints)
            gram = jacobian @ jacobian.T + self.damping**2 * np.eye(6)
            step = jacobian.T @ np.linalg.solve(gram, error)
            nullspace = np.eye(7) - np.linalg.pinv(jacobian) @ jacobian
            step += nullspace @ (self.nullspace_gain * (seed - joints))
            joints = np.clip(joints + step, panda.LOWER_LIMITS, panda.UPPER_LIMITS)
        raise SkillError(
            f"no arm posture reaches {np.round(target, 3).tolist()} m (left {np.linalg.norm(error[:3]):.4f} m, "
            f"{np.linalg.norm(error[3:]):.4f} rad off)"
        )


class Motion:
    """Moves of the arm, gripper and base for one skill execution.

    Args:
        robot: the robot interface.
        config: motion limits and tolerances.
        ik: the inverse kinematics.
        execution: feedback and preemption of the running skill.
    """

    def __init__(self, robot: Robot, config: MotionConfig, ik: InverseKinematics, execution: Execution):
        self.robot = robot
        self.config = config
        self.ik = ik
        self.execution = execution

    # --------------------------------------------------------------------------------------------- state
    def tcp_pose(self, joints=None) -> Tuple[np.ndarray, Rotation]:
        """TCP in base_link, from forward kinematics of the measured (or given) joint positions."""
        return self.ik.forward(self.robot.joint_positions() if joints is None else joints)

    def tcp_world(self) -> Tuple[np.ndarray, Rotation]:
        """TCP in world: the measured base pose composed with forward kinematics."""
        base_pose = self.robot.base_pose()
        position, rotation = self.tcp_pose()
        return base_to_world(base_pose, position), yaw_rotation(base_pose[2]) * rotation

    def ensure_position_control(self) -> None:
        """Make the position controller the running one (STRICT switch when it is not).

        The teaching GUI switches back to position control when a demonstration ends, just as the tree resumes:
        a switch refused because the GUI's switch came first is no error when the position controller now runs.
        """
        wanted = self.config.position_controller
        running = list(self.robot.active_controllers())
        if running == [wanted]:
            return
        try:
            self.robot.switch_controllers([wanted], [name for name in running if name != wanted])
        except SkillError:
            if list(self.robot.active_controllers()) != [wanted]:
                raise

    def hold(self) -> None:
        """Stop the arm where it is."""
        self.robot.hold(self.robot.joint_positions())

    # ---------------------------------------------------------------------------------------------- arm
    def move_joints(self, goal) -> None:
        """Minimum-jerk joint-space move to goal [rad]."""
        arm = self.config.arm
        start = self.robot.joint_positions()
        goal = np.clip(np.asarray(goal, dtype=float), panda.LOWER_LIMITS, panda.UPPER_LIMITS)
        duration = trajectory.move_duration(np.abs(goal - start).max(), arm.joint_speed, arm.min_duration)
        self._execute(trajectory.point_to_point(start, goal, duration, arm.sample_period))

    def move_to_pose(self, position, orientation: Rotation) -> None:
        """Joint-space move to the IK solution of a TCP pose in base_link (seeded by the current posture)."""
        self.move_joints(self.ik.solve(position, orientation, self.robot.joint_positions()))

    def move_linear(self, position, orientation: Rotation) -> None:
        """Straight TCP line to a pose in base_link, with IK waypoints every cartesian_step."""
        arm = self.config.arm
        start_joints = self.robot.joint_positions()
        start_position, start_rotation = self.tcp_pose(start_joints)
        position = np.asarray(position, dtype=float)
        distance = float(np.linalg.norm(position - start_position))
        angle = float(np.linalg.norm((orientation * start_rotation.inv()).as_rotvec()))
        count = max(2, math.ceil(max(distance / arm.cartesian_step, angle / 0.05)) + 1)
        fractions = np.linspace(0.0, 1.0, count)
        rotations = Slerp([0.0, 1.0], Rotation.concatenate([start_rotation, orientation]))(fractions)
        waypoints = [start_joints]
        for fraction, rotation in zip(fractions[1:], rotations[1:]):
            point = start_position + fraction * (position - start_position)
            joints = self.ik.solve(point, rotation, waypoints[-1])
            if np.abs(joints - waypoints[-1]).max() > arm.max_ik_step:
                raise SkillError(f"straight move to {np.round(position, 3).tolist()} m needs a joint flip")
            waypoints.append(joints)
        duration = max(
            trajectory.move_duration(distance, arm.linear_speed, arm.min_duration),
            trajectory.move_duration(angle, arm.angular_speed, arm.min_duration),
        )
        self._execute(trajectory.along_path(waypoints, duration, arm.sample_period))

    def _execute(self, path: trajectory.JointTrajectory) -> None:
        arm = self.config.arm
        self.robot.send_joint_trajectory(path.times, path.positions, path.velocities)
        start = self.robot.now()
        while True:
            self.execution.check()
            elapsed = self.robot.now() - start
            self.execution.report(elapsed / path.duration if path.duration > 0 else 1.0)
            if elapsed >= path.duration:
                error = float(np.abs(self.robot.joint_positions() - path.goal).max())
                if error < arm.goal_tolerance:
                    return
                if elapsed > path.duration + arm.settle_timeout:
                    raise SkillError(
                        f"the arm did not reach its goal: {error:.3f} rad off {arm.settle_timeout:.1f} s after "
                        "the trajectory's end (blocked?)"
                    )
            self.robot.sleep(POLL_PERIOD)

    # ------------------------------------------------------------------------------------------ gripper
    def gripper(self, width) -> float:
        """Move the fingers to width [m] (franka_gripper/move); returns the measured width, SkillError if it fails."""
        settings = self.config.gripper
        initial_error = max(abs(self.robot.gripper_width() - width), 1e-6)
        goal = self.robot.move_gripper(width, settings.speed)
        succeeded, said = self._wait(
            goal,
            settings.timeout,
            f"the gripper's move to {width:.3f} m",
            lambda: 1.0 - abs(self.robot.gripper_width() - width) / initial_error,
        )
        if not succeeded:
            raise SkillError(f"the gripper did not reach {width:.3f} m: {said or 'the move failed'}")
        return self.robot.gripper_width()

    def grasp(self, width) -> Tuple[bool, float, str]:
        """Grasp an object of width [m] (franka_gripper/grasp): (held, measured width [m], what the gripper said)."""
        settings = self.config.gripper
        initial_error = max(abs(self.robot.gripper_width() - width), 1e-6)
        goal = self.robot.grasp(
            width, settings.grasp_epsilon_inner, settings.grasp_epsilon_outer, settings.speed, settings.grasp_force
        )
        held, said = self._wait(
            goal,
            settings.timeout,
            f"the grasp of {width:.3f} m",
            lambda: 1.0 - abs(self.robot.gripper_width() - width) / initial_error,
        )
        return held, self.robot.gripper_width(), said

    def _wait(self, goal, timeout, what, progress) -> Tuple[bool, str]:
        """Wait (robot time, at most timeout [s]) for a robot goal to finish; cancel it when preempted or late."""
        start = self.robot.now()
        while not goal.done():
            try:
                self.execution.check()
            except PreemptedError:
                goal.cancel()
                raise
            self.execution.report(progress())
            if self.robot.now() - start > timeout:
                goal.cancel()
                raise SkillError(f"{what} did not finish within {timeout:.1f} s")
            self.robot.sleep(POLL_PERIOD)
        return goal.outcome()

    # --------------------------------------------------------------------------------------------- base
    def move_base(self, x, y, yaw) -> None:
        """Drive the base to (x [m], y [m], yaw [rad]) in world (move_base); done when TF says it stands there."""
        settings = self.config.base
        start_pose = self.robot.base_pose()
        initial = math.hypot(x - start_pose[0], y - start_pose[1]) + abs(wrap_angle(yaw - start_pose[2]))
        limit = initial / settings.expected_speed + settings.timeout
        goal = self.robot.move_base(x, y, yaw)
        start = self.robot.now()
        while True:
            try:
                self.execution.check()
            except PreemptedError:
                goal.cancel()
                raise
            pose = self.robot.base_pose()
            distance = math.hypot(x - pose[0], y - pose[1])
            turn = abs(wrap_angle(yaw - pose[2]))
            self.execution.report(1.0 - (distance + turn) / initial if initial > 0 else 1.0)
            if goal.done():
                succeeded, said = goal.outcome()
                if not succeeded:
                    raise SkillError(f"move_base did not reach ({x:.2f}, {y:.2f}, {yaw:.2f}): {said or 'it failed'}")
                pose = self.robot.base_at_rest()
                distance = math.hypot(x - pose[0], y - pose[1])
                turn = abs(wrap_angle(yaw - pose[2]))
                if distance < settings.position_tolerance and turn < settings.yaw_tolerance:
                    return
            if self.robot.now() - start > limit:
                goal.cancel()
                said = " (move_base said it arrived: see base tolerances)" if goal.done() else ""
                raise SkillError(
                    f"the base did not reach ({x:.2f}, {y:.2f}, {yaw:.2f}) within {limit:.0f} s: "
                    f"{distance:.3f} m, {turn:.3f} rad away{said}"
                )
            self.robot.sleep(POLL_PERIOD)
