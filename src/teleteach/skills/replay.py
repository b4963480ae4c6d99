"""Replay of a demonstrated placing skill on the Cartesian impedance controller, judged by where the product ends.

The recorded stiffness K(t) and kinematic reference x_r(t) (a :class:`teleteach.skill_file.Skill`) are resampled at
the playback rate (K linearly, which keeps it SPD; positions linearly, orientations by slerp). Each K is sent as its
eigendecomposition, the way the GUI commands it: principal stiffnesses on /eigenvalues and the right-handed rotation
of the principal axes on /eigenvectors. The axes are matched to the previous sample's (order, sign, quaternion
sign), so the controller sees a continuous ellipsoid even when two principal stiffnesses cross.
"""

import itertools
import pathlib
from dataclasses import dataclass

import numpy as np
import yaml
from scipy.spatial.transform import Rotation, Slerp

from teleteach import skill_file
from teleteach.skills.motion import Motion
from teleteach.skills.predefined import WorldView, release
from teleteach.skills.robot import SkillError

PERMUTATIONS = np.array(list(itertools.permutations(range(3))))


def principal_axes(stiffness, previous=None):
    """Eigenvalues [N/m] and a right-handed rotation (columns = principal axes) with K = V diag(values) V^T.

    Args:
        stiffness: symmetric 3x3 stiffness [N/m].
        previous: the previous sample's rotation; the axes are ordered and signed to stay closest to it.
    """
    values, axes = np.linalg.eigh(np.asarray(stiffness, dtype=float))
    return _match(values, axes, previous)


def _match(values, axes, previous):
    if previous is not None:
        alignment = np.abs(previous.T @ axes)
        order = PERMUTATIONS[int(np.argmax(alignment[[0, 1, 2], PERMUTATIONS].sum(axis=1)))]
        values, axes = values[order], axes[:, order]
        axes = axes * np.where(np.einsum("ij,ij->j", previous, axes) < 0.0, -1.0, 1.0)
    if np.linalg.det(axes) < 0.0:
        weakest = 2 if previous is None else int(np.argmin(np.abs(np.einsum("ij,ij->j", previous, axes))))
        axes[:, weakest] *= -1.0
    return values, axes


@dataclass
class ReplayPlan:
    """The skill resampled for playback, in base_link.

    Times from start [s] (N), eigenvalues (N, 3) [N/m], eigenvector quaternions (N, 4), equilibrium positions
    (N, 3) [m] and quaternions (N, 4).
    """

    name: str
    times: np.ndarray
    eigenvalues: np.ndarray
    eigenvectors: np.ndarray
    positions: np.ndarray
    orientations: np.ndarray

    @property
    def duration(self):
        """Length of the playback [s]."""
        return float(self.times[-1])


def plan_replay(skill: skill_file.Skill, rate: float) -> ReplayPlan:
    """Resample a validated skill at rate [Hz] and decompose every stiffness."""
    recorded = skill.time - skill.time[0]
    times = np.arange(0.0, recorded[-1], 1.0 / rate)
    times = np.append(times, recorded[-1]) if recorded[-1] - times[-1] > 1e-9 else times
    stiffness = np.stack(
        [np.interp(times, recorded, skill.stiffness[:, row, column]) for row in range(3) for column in range(3)],
        axis=1,
    ).reshape(-1, 3, 3)
    stiffness = 0.5 * (stiffness + stiffness.transpose(0, 2, 1))
    positions = np.stack([np.interp(times, recorded, skill.equilibrium_pose[:, axis]) for axis in range(3)], axis=1)
    orientations = Slerp(recorded, Rotation.from_quat(skill.equilibrium_pose[:, 3:]))(times).as_quat()
    all_values, all_axes = np.linalg.eigh(stiffness)
    eigenvalues, rotations = np.zeros((len(times), 3)), np.zeros((len(times), 3, 3))
    previous = None
    for index in range(len(times)):
        eigenvalues[index], previous = _match(all_values[index], all_axes[index], previous)
        rotations[index] = previous
    eigenvectors = Rotation.from_matrix(rotations).as_quat()
    # q and -q are the same rotation: keep each quaternion on the side of the previous one
    flips = np.cumprod(np.where(np.einsum("ij,ij->i", eigenvectors[1:], eigenvectors[:-1]) < 0.0, -1.0, 1.0))
    eigenvectors[1:] *= flips[:, None]
    return ReplayPlan(skill.name, times, eigenvalues, eigenvectors, positions, orientations)


def parse_replay_parameters(parameters: str):
    """The goal's yaml {data_file, kind}: (path, kind or None); SkillError when it is not that."""
    try:
        values = yaml.safe_load(parameters or "")
    except yaml.YAMLError as error:
        raise SkillError(f"ReplaySkill parameters are not valid yaml: {error}") from None
    if not isinstance(values, dict) or not isinstance(values.get("data_file"), str) or not values["data_file"]:
        raise SkillError("ReplaySkill parameters must be yaml {data_file: <path of the skill file>, kind: stiffness}")
    kind = values.get("kind")
    if kind is not None and kind not in skill_file.KINDS:
        raise SkillError(f"unknown skill kind '{kind}'; expected one of {', '.join(skill_file.KINDS)}")
    return pathlib.Path(values["data_file"]).expanduser(), kind


class StiffnessReplay:
    """Places the product in the hand with a demonstrated skill, and judges the placement from the world.

    Approach the skill's start, switch to impedance control, play the recorded stiffness and reference, switch back,
    release the product and retreat: the skill succeeds only when the product then stands upright in the gap the
    playback ended at, without pushing its neighbours. With no product in the hand it fails before moving; when the
    playback leaves the product outside the gap it fails without letting it go (it would fall).
    """

    def run(self, world: WorldView, parameters: str) -> str:
        """Replay the skill the goal names; returns the success message saying where the product ended."""
        path, kind = parse_replay_parameters(parameters)
        try:
            skill = skill_file.load(path)
        except skill_file.SkillFileError as error:
            raise SkillError(str(error)) from None
        if kind is not None and kind != skill.kind:
            raise SkillError(f"skill file {path} holds a '{skill.kind}' skill, the goal asked for '{kind}'")
        product, _ = world.product_in_hand()
        if product is None:
            width = world.motion.robot.gripper_width()
            nearest, distance = world.nearest_to_hold()
            seen = "no product in the scene"
            if nearest is not None:
                seen = f"{nearest} {100 * distance:.1f} cm from the hand's hold"
            raise SkillError(
                f"{skill.name} places a product, but there is none in the hand: pick one first "
                f"({seen}, the gripper {1000 * width:.0f} mm open)"
            )
        motion = world.motion
        config = motion.config
        plan = plan_replay(skill, config.replay.rate)
        start_position = plan.positions[0]
        start_orientation = Rotation.from_quat(plan.orientations[0])
        before = motion.robot.product_positions()
        motion.ensure_position_control()
        motion.execution.phase("approach the start", 0.1)
        if np.linalg.norm(motion.tcp_pose()[0] - start_position) > config.replay.approach_tolerance:
            motion.move_to_pose(start_position, start_orientation)
        motion.execution.phase("switch to impedance control", 0.05)
        robot = motion.robot
        now = robot.now()
        robot.command_stiffness(plan.eigenvalues[0], plan.eigenvectors[0], now)
        robot.command_equilibrium(*robot.cartesian_pose(), now)
        robot.switch_controllers([config.impedance_controller], [config.position_controller])
        try:
            self._play(motion, plan)
        except BaseException:
            self._hold_and_switch_back(motion)
            raise
        motion.execution.phase("settle", 0.05)
        robot.sleep(config.replay.settle_time)
        error = float(np.linalg.norm(robot.cartesian_pose()[0] - plan.positions[-1]))
        motion.execution.phase("switch to position control", 0.05)
        robot.switch_controllers([config.position_controller], [config.impedance_controller])
        placed = release(world, product, before, progress=0.15, only_in_gap=True)
        return (
            f"replayed {skill.name} ({skill.kind}): {len(plan.times)} samples over {plan.duration:.2f} s, "
            f"final end-effector error {1000.0 * error:.1f} mm; {product} released upright in {placed.gap}, "
            f"{1000.0 * placed.distance_m:.1f} mm from its centre"
        )

    @staticmethod
    def _play(motion: Motion, plan: ReplayPlan) -> None:
        """Publish the sample due now every 1/rate; when the loop lags it skips ahead, keeping the recorded timing."""
        robot, execution = motion.robot, motion.execution
        execution.phase("replay", 0.6)
        period, last = 1.0 / motion.config.replay.rate, len(plan.times) - 1
        start = robot.now()
        next_tick = start
        while True:
            execution.check()
            elapsed = robot.now() - start
            index = min(max(int(np.searchsorted(plan.times, elapsed, side="right")) - 1, 0), last)
            stamp = start + plan.times[index]
            robot.command_stiffness(plan.eigenvalues[index], plan.eigenvectors[index], stamp)
            robot.command_equilibrium(plan.positions[index], plan.orientations[index], stamp)
            execution.report(plan.times[index] / plan.duration)
            if index == last:
                return
            next_tick += period
            wait = next_tick - robot.now()
            if wait > 0.0:
                robot.sleep(wait)
            else:
                next_tick = robot.now()

    @staticmethod
    def _hold_and_switch_back(motion: Motion) -> None:
        """Stop safely: the reference jumps to where the hand is, then the position controller takes over there."""
        robot = motion.robot
        position, quaternion = robot.cartesian_pose()
        robot.command_equilibrium(position, quaternion, robot.now())
        robot.switch_controllers([motion.config.position_controller], [motion.config.impedance_controller])
        motion.hold()
