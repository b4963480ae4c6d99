"""Replay of a demonstrated placing skill on the Cartesian impedance controller, judged by where the product ends.

A skill taught relative to a target (a shelf gap) is replayed relative to the gap the robot perceives now: its
reference poses and stiffness, stored in the target's frame, are composed with the perceived gap's pose in base_link
(T_base^ee = T_base^gap T_gap^ee, K_base = R K_gap R^T), so a profile compliant across the gap stays compliant across
the gap. A base_link skill (an older file) is replayed where it was recorded. The recorded stiffness K(t) and
kinematic reference x_r(t) are resampled at the playback rate (K linearly, which keeps it SPD; positions linearly,
orientations by slerp). Each K is sent as its eigendecomposition, the way the GUI commands it: principal stiffnesses
on /eigenvalues and the right-handed rotation of the principal axes on /eigenvectors. The axes are matched to the
previous sample's (order, sign, quaternion sign), so the controller sees a continuous ellipsoid even when two
principal stiffnesses cross. While it plays, an operator's correction moves the reference by as much as the skill is
unsure there (:mod:`teleteach.skills.authority`).
"""

import itertools
import pathlib
from dataclasses import dataclass
from typing import Optional, Sequence, Tuple

import numpy as np
import yaml
from scipy.spatial.transform import Rotation, Slerp

from teleteach.core import skill_file
from teleteach.core.frames import Transform, continuous_quaternions
from teleteach.core.scene import Gap
from teleteach.skills import authority
from teleteach.skills.motion import Motion
from teleteach.skills.predefined import WorldView, release
from teleteach.skills.robot import SkillError

AUTHORITY_REPORT_PERIOD = 0.05  # [s] robot time between reports of who leads the replay (/skills/authority)
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
    eigenvectors = continuous_quaternions(Rotation.from_matrix(rotations).as_quat())
    return ReplayPlan(skill.name, times, eigenvalues, eigenvectors, positions, orientations)


@dataclass(frozen=True)
class ReplayRequest:
    """A ReplaySkill goal: the skill file, the kind it must be (or None), the target to replay at.

    With no target, the skill takes the perceived gap where the taught one would be.
    """

    path: pathlib.Path
    kind: Optional[str]
    target: Optional[str]


def parse_replay_parameters(parameters: str) -> ReplayRequest:
    """The goal's yaml {data_file, kind, target}; SkillError when it is not that."""
    try:
        values = yaml.safe_load(parameters or "")
    except yaml.YAMLError as error:
        raise SkillError(f"ReplaySkill parameters are not valid yaml: {error}") from None
    if not isinstance(values, dict) or not isinstance(values.get("data_file"), str) or not values["data_file"]:
        raise SkillError(
            "ReplaySkill parameters must be yaml {data_file: <path of the skill file>, kind: stiffness, "
            "target: <gap, optional>}"
        )
    kind = values.get("kind")
    if kind is not None and kind not in skill_file.KINDS:
        raise SkillError(f"unknown skill kind '{kind}'; expected one of {', '.join(skill_file.KINDS)}")
    target = values.get("target")
    if target is not None and (not isinstance(target, str) or not target):
        raise SkillError(f"ReplaySkill target must be the name of a gap, got {target!r}")
    return ReplayRequest(pathlib.Path(values["data_file"]).expanduser(), kind, target)


def load_replay(parameters: str) -> Tuple[ReplayRequest, skill_file.Skill]:
    """A ReplaySkill goal's request and the skill file it names, loaded and of the kind asked; SkillError if not."""
    request = parse_replay_parameters(parameters)
    try:
        skill = skill_file.load(request.path)
    except skill_file.SkillFileError as error:
        raise SkillError(str(error)) from None
    if request.kind is not None and request.kind != skill.kind:
        raise SkillError(f"skill file {request.path} holds a '{skill.kind}' skill, the goal asked for '{request.kind}'")
    return request, skill


def replay_target(world: WorldView, skill: skill_file.Skill, requested: Optional[str]) -> Gap:
    """The perceived gap a target-frame skill is replayed at.

    The requested one, or the one where the taught gap would be from the base's pose now (within
    replay.target_search_radius).

    Raises:
        SkillError: naming the skill and the target, when perception reports no such gap.
    """
    scene = world.perceived()
    taught = skill.target.name
    if requested is not None:
        if requested not in scene.gaps:
            raise SkillError(
                f"{skill.name} (taught at {taught}) cannot be replayed at {requested}: perception reports no "
                f"{requested} (it reports {', '.join(sorted(scene.gaps)) or 'no gaps'})"
            )
        return scene.gaps[requested]
    base = Transform.from_planar(*world.motion.robot.base_pose())
    expected = (base * skill.target.transform).position
    if not scene.gaps:
        raise SkillError(f"{skill.name} places relative to a gap like {taught}, but perception reports no gaps")
    nearest = scene.nearest_gap(expected)
    distance = nearest.distance(expected)[0]
    if distance > world.config.replay.target_search_radius:
        raise SkillError(
            f"{skill.name} places relative to a gap like {taught}, but perception reports none within "
            f"{world.config.replay.target_search_radius:.2f} m of where it would be from here (nearest: "
            f"{nearest.name}, {distance:.2f} m away); name the target: {{target: <gap>}}"
        )
    return nearest


def gap_in_base(world: WorldView, gap: Gap) -> Transform:
    """base_link <- the gap's frame (origin at the placed product's centre, x into the shelf, z up)."""
    return Transform.from_planar(*world.motion.robot.base_pose()).inverse() * gap.frame


class StiffnessReplay:
    """Places the product in the hand with a demonstrated skill, and judges the placement from the world.

    Approach the skill's start, switch to impedance control, play the recorded stiffness and reference, switch back,
    release the product and retreat: the skill succeeds only when the product then stands upright in the gap the
    playback ended at, without pushing its neighbours. With no product in the hand it fails before moving; when the
    playback leaves the product outside the gap it fails without letting it go (it would fall).
    """

    def run(self, world: WorldView, request: ReplayRequest, skill: skill_file.Skill) -> str:
        """Replay ``skill`` (what ``request`` loaded); returns the success message saying where the product ended."""
        skill, where, distance = self._in_base(world, request, skill)
        product = self._product_in_hand(world, skill.name)
        motion = world.motion
        config = motion.config
        plan = plan_replay(skill, config.replay.rate)
        spread = authority.spread_along(skill, plan.times, config.authority)
        confidence = np.array([authority.confidence(value, distance, config.authority) for value in spread])
        before = motion.robot.product_positions()
        self._start_in_impedance(motion, plan)
        robot = motion.robot
        try:
            corrected = self._play(motion, plan, spread, confidence, distance)
        except BaseException:
            self._hold_and_switch_back(motion)
            raise
        motion.execution.phase("settle", 0.05)
        robot.sleep(config.replay.settle_time)
        error = float(np.linalg.norm(robot.cartesian_pose()[0] - plan.positions[-1] - corrected))
        motion.execution.phase("switch to position control", 0.05)
        robot.switch_controllers([config.position_controller], [config.impedance_controller])
        placed = release(world, product, before, progress=0.15, only_in_gap=True)
        return (
            f"replayed {skill.name} ({skill.kind}) {where}: {len(plan.times)} samples over {plan.duration:.2f} s, "
            f"final end-effector error {1000.0 * error:.1f} mm; confidence {confidence.min():.2f}-"
            f"{confidence.max():.2f}, the operator's correction {1000.0 * np.linalg.norm(corrected):.0f} mm at the "
            f"end; {product} released upright in {placed.gap}, "
            f"{1000.0 * placed.distance_m:.1f} mm from its centre"
        )

    @staticmethod
    def _in_base(world: WorldView, request: ReplayRequest, skill: skill_file.Skill):
        """The skill in base_link, where it replays (for the message) and its target's distance from the taught one.

        The distance lowers the replay's confidence: the further from where it was taught, the more the operator may
        correct.
        """
        if skill.target is not None and skill.target.kind != skill_file.GAP:
            raise SkillError(f"{skill.name} was taught on a {skill.target.kind}, not at a gap: it places nothing")
        if skill.frame == skill_file.TARGET_FRAME:
            gap = replay_target(world, skill, request.target)
            where = f"relative to {gap.name} (taught at {skill.target.name})"
            target = gap_in_base(world, gap)
            return skill.in_base(target), where, authority.target_distance(skill, target)
        if request.target is not None:
            raise SkillError(f"{skill.name} is a base_link skill (no target frame): it cannot be replayed at a target")
        return skill, "in base_link where it was recorded (a skill without a target frame)", 0.0

    @staticmethod
    def _product_in_hand(world: WorldView, skill_name: str) -> str:
        """The product the hand holds; without one the replay would place nothing, so it fails saying what is near."""
        product, _ = world.product_in_hand()
        if product is None:
            width = world.motion.robot.gripper_width()
            nearest, distance = world.nearest_to_hold()
            seen = "no product in the scene"
            if nearest is not None:
                seen = f"{nearest} {100 * distance:.1f} cm from the hand's hold"
            raise SkillError(
                f"{skill_name} places a product, but there is none in the hand: pick one first "
                f"({seen}, the gripper {1000 * width:.0f} mm open)"
            )
        return product

    @staticmethod
    def _start_in_impedance(motion: Motion, plan: ReplayPlan) -> None:
        """Move to the plan's start if away from it, then hand over to impedance control holding the arm where it is."""
        config = motion.config
        start_position = plan.positions[0]
        start_orientation = Rotation.from_quat(plan.orientations[0])
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

    @staticmethod
    def _play(motion: Motion, plan: ReplayPlan, spread, confidence, distance: float) -> np.ndarray:
        """Publish the sample due now every 1/rate; when the loop lags it skips ahead, keeping the recorded timing.

        The operator's correction moves the equilibrium weighted by 1 - confidence there (:mod:`.authority`);
        returns the correction applied at the end [m].
        """
        robot, execution = motion.robot, motion.execution
        execution.phase("replay", 0.6)
        period, last = 1.0 / motion.config.replay.rate, len(plan.times) - 1
        correction = authority.Correction(motion.config.authority)
        start = robot.now()
        next_tick = next_report = start
        while True:
            execution.check()
            elapsed = robot.now() - start
            index = min(max(int(np.searchsorted(plan.times, elapsed, side="right")) - 1, 0), last)
            stamp = start + plan.times[index]
            robot.command_stiffness(plan.eigenvalues[index], plan.eigenvectors[index], stamp)
            weight = 1.0 - confidence[index]
            corrected = weight * correction.step(robot.now(), robot.operator_correction())
            robot.command_equilibrium(plan.positions[index] + corrected, plan.orientations[index], stamp)
            execution.report(plan.times[index] / plan.duration)
            if robot.now() >= next_report or index == last:
                next_report = robot.now() + AUTHORITY_REPORT_PERIOD
                robot.report_authority(
                    authority.AuthorityReport(
                        plan.name,
                        float(confidence[index]),
                        weight,
                        float(spread[index]),
                        distance,
                        corrected,
                        motion.config.authority.max_correction,
                    )
                )
            if index == last:
                return corrected
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


TAUGHT_KINDS = ("dmp", "stiffness")  # the library's taught placements, the learned one preferred


class PlaceTaught:
    """Places the held product with what the operator taught for the gap in front of the robot; asks when nothing.

    The library's taught skills (kinds dmp, then stiffness; the newest first) that are relative to a target and find
    a perceived gap where their taught one would be from the base now (:func:`replay_target`) can place here; the
    first is replayed there. With none, the skill fails saying so, and the tree asks the operator for help: they
    teach one (TELEOP, then LOW-LEVEL). A product that already stands in the gap (the operator's demonstration set it
    down) is only let go: the skill's promise is the product released in the gap.
    """

    def __init__(self, replay: StiffnessReplay):
        self.replay = replay

    def run(self, world: WorldView, library: Sequence[Tuple[str, str, str]]) -> str:
        """Place with the best of ``library``'s (name, kind, data file) skills; the message says which and how."""
        product, _ = world.product_in_hand()
        if product is None:
            raise SkillError("PlaceTaught places the product in the hand, but the hand holds none")
        gap = world.gap_near_hand()
        before = world.motion.robot.product_positions()
        if not world.placement(product, before, gap.name).problems(gap.name):
            placed = release(world, product, before, progress=1.0, only_in_gap=True)
            return (
                f"{product} already stood in {gap.name} (set down while the operator taught): released there, "
                f"{1000.0 * placed.distance_m:.1f} mm from its centre"
            )
        usable = []
        for newest, (name, kind, data_file) in enumerate(reversed(library)):
            if kind not in TAUGHT_KINDS:
                continue
            try:
                skill = skill_file.load(data_file)
                at_gap = skill.frame == skill_file.TARGET_FRAME and skill.target.kind == skill_file.GAP
                target = replay_target(world, skill, None) if at_gap else None
            except (skill_file.SkillFileError, SkillError):
                continue
            if target is not None:
                usable.append((TAUGHT_KINDS.index(kind), newest, name, data_file, target.name))
        if not usable:
            raise SkillError(
                f"no taught skill places at {gap.name}: teach one (TELEOP: put the product in, double click to record "
                "the path; then LOW-LEVEL: its stiffness along that path)"
            )
        _, _, name, data_file, target = min(usable)
        request = ReplayRequest(pathlib.Path(data_file), None, target)
        return f"with {name}: " + self.replay.run(world, request, skill_file.load(data_file))
