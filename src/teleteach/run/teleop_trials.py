"""Teleoperated placements in-process, with the placement's shared control on or off, judged from the true world.

A scripted operator puts the held product into a gap through TELEOP, as the skills' trials (teleteach.run.trials)
replay a skill. The trial starts as those do (the base where MoveBase stopped, the product in the fingers, off its
centre as a pick leaves it), switches the arm to the impedance controller and drives its equilibrium through
:class:`teleteach.core.teleoperation.Teleoperation` at the GUI's 200 Hz, exactly as TELEOP does, from a device the
operator moves. The operator is a model, not a person: they see the gap (the true one, off by their own aim error,
drawn once per trial), hold the clutch, move the hand in minimum-jerk strokes to in front of the gap, in, down, open
the fingers and pull back, with a small hand tremor, and do not react to what the robot does. With assistance, the
teleoperation's target goes through teleteach.shared_control.placement, from the opening the robot perceives.
"""

import dataclasses
import math
import time
from typing import Callable, Optional, Sequence, Tuple

import numpy as np
from scipy.spatial.transform import Rotation

from teleteach.core import skill_file
from teleteach.core.frames import Transform
from teleteach.core.gui_config import GuiConfig
from teleteach.core.scene import Scene
from teleteach.core.teleoperation import AssistanceParameters, Teleoperation, TeleopParameters
from teleteach.core.trajectories import minimum_jerk
from teleteach.run.sim_robot import SimRobot
from teleteach.run.trials import (
    ContactRecordingSim,
    TrialSetup,
    bootstrap_median_interval,
    grasp_offset,
    hold_product,
    judged_in_world,
    scene_around,
    success_figures,
)
from teleteach.shared_control.placement import Opening, assist
from teleteach.sim.robot_sim import IMPEDANCE, TRAJECTORY
from teleteach.sim.uncertainty import UncertaintySettings
from teleteach.skills.config import MotionConfig

CYCLE = 0.005  # [s] the GUI's teleoperation tick (publish_rate 200 Hz)
RECORD_PERIOD = 0.01  # [s] a taught placement keeps a sample this often
CLOSED, OPEN = 0.0, 0.25  # [rad] the operator's gripper: holding the clutch, resting
PLACED = Rotation.from_quat([0.70711, 0.70711, 0.0, 0.0])  # the hand in the gap's frame (config/trajectories)


@dataclasses.dataclass(frozen=True)
class OperatorModel:
    """How the scripted operator moves.

    Attributes:
        aim_std: [m] of their error of where the gap is (depth, across, height), one draw per trial.
        tremor: [m] amplitude of their hand's tremor on each axis (8-12 Hz).
        strokes: (gap-frame TCP position [m], duration [s]) of each stroke after the first, which goes to
            ``approach`` from where the hand is in ``approach_time``; the hand turns to the placing orientation
            during it.
        release_after: [s] the fingers open this long after the last stroke into the gap.
        retreat: the strokes out (as ``strokes``), 0.5 s after the fingers opened.
    """

    aim_std: Tuple[float, float, float] = (0.003, 0.005, 0.003)
    tremor: float = 0.0005
    approach: Tuple[float, float, float] = (-0.17, 0.0, 0.075)
    approach_time: float = 4.0
    strokes: Tuple[Tuple[Tuple[float, float, float], float], ...] = (
        ((-0.12, 0.0, 0.075), 1.0),  # lined up in front of the gap
        ((0.0, 0.0, 0.075), 4.0),  # in, over the shelf's front fence
        ((0.0, 0.0, 0.035), 1.5),  # down onto the board
    )
    release_after: float = 0.5
    retreat: Tuple[Tuple[Tuple[float, float, float], float], ...] = (
        ((0.0, 0.0, 0.1), 1.0),  # straight up: the back finger clears the product's top
        ((-0.15, 0.0, 0.1), 2.0),  # and back out
    )


class ScriptedOperator:
    """Where the operator wants the hand at each instant (base frame), and the device pose that asks for it."""

    def __init__(
        self,
        model: OperatorModel,
        gap: Transform,
        hand: np.ndarray,
        parameters: TeleopParameters,
        rng: np.random.Generator,
    ):
        """``gap``: the gap as the operator sees it, in the base frame; ``hand``: the hand's pose when they start."""
        self.model = model
        self.aim = rng.normal(0.0, 1.0, 3) * np.asarray(model.aim_std)
        seen = gap * Transform(self.aim, Rotation.identity())
        self._start = hand[:3].copy()
        self._turn_start = Rotation.from_quat(hand[3:])
        self._turn_end = seen.rotation * PLACED
        self._turn = parameters.rotation
        self._scale, self._rotation_scale = parameters.scale, parameters.rotation_scale
        points = [seen.apply_point(model.approach)] + [seen.apply_point(point) for point, _ in model.strokes]
        times = np.cumsum([model.approach_time] + [duration for _, duration in model.strokes])
        self.placed_at = float(times[-1])
        self.release_at = self.placed_at + model.release_after
        self._legs = [(0.0, times[0], self._start, points[0])]
        self._legs += [(times[i], times[i + 1], points[i], points[i + 1]) for i in range(len(points) - 1)]
        begin, last = self.release_at + 0.5, points[-1]
        for point, duration in model.retreat:
            goal = seen.apply_point(point)
            self._legs.append((begin, begin + duration, last, goal))
            begin, last = begin + duration, goal
        self.end = begin
        self._phases = rng.uniform(0.0, 2.0 * math.pi, (3, 2))
        self._frequencies = rng.uniform(8.0, 12.0, (3, 2))

    def hand(self, t: float) -> Tuple[np.ndarray, Rotation]:
        """The hand's position (base frame) and orientation the operator wants at ``t`` [s] after they started."""
        position = self._start
        for begin, end, start, goal in self._legs:
            if t >= begin:
                position = start + (goal - start) * minimum_jerk((t - begin) / (end - begin))
        fraction = minimum_jerk(t / self.model.approach_time)
        turn = Rotation.from_rotvec(fraction * (self._turn_end * self._turn_start.inv()).as_rotvec())
        return position, turn * self._turn_start

    def device(self, t: float) -> Tuple[np.ndarray, np.ndarray]:
        """The device pose (operator frame, from where the clutch engaged) that asks for :meth:`hand` at ``t``."""
        position, orientation = self.hand(t)
        tremor = self.model.tremor * np.sin(2.0 * math.pi * self._frequencies * t + self._phases).sum(axis=1) / 2.0
        moved = self._turn.inv().apply(position - self._start) / self._scale + tremor
        turned = (orientation * self._turn_start.inv()).as_rotvec()
        if self._rotation_scale > 0.0:
            device_turn = Rotation.from_rotvec(self._turn.inv().apply(turned) / self._rotation_scale)
        else:
            device_turn = Rotation.identity()
        return moved, device_turn.as_quat()


def run_teleop_trial(
    scene: Scene,
    config: MotionConfig,
    uncertainty: UncertaintySettings,
    setup: TrialSetup,
    gui: GuiConfig,
    assistance: bool,
    model: OperatorModel,
    teach: str = "",
) -> dict:
    """One teleoperated placement in a fresh world, with or without assistance; what happened, judged from the world.

    TELEOP's parameters and stiffness are the GUI's (``gui``: its teleop section, the initial ellipsoid). With
    ``teach`` (a skill name), the placement is also kept as a skill, as TELEOP and LOW-LEVEL would teach it: the
    equilibrium and the measured pose from the clutch to the release, every RECORD_PERIOD, at that stiffness, relative
    to the gap as the robot perceived it (``result["skill"]``, a skill_file.Skill).
    """
    parameters = gui.teleop
    trial_scene = scene_around(scene, setup.gap, setup.product)
    trial_uncertainty = uncertainty.with_overrides(seed=setup.seed)
    sim = ContactRecordingSim(trial_scene, trial_uncertainty)
    try:
        offset = grasp_offset(trial_uncertainty, np.random.default_rng([setup.seed, 2]))
        robot, hand = _held_under_impedance(sim, config, setup, offset, gui.initial_stiffness)
        base = Transform.from_planar(*robot.base_pose())
        operator = _scripted_operator(model, parameters, base, trial_scene.gap(setup.gap), hand, setup.seed)
        constrain, why = (
            _assistance(robot, setup.gap, base, hand, config, parameters.assistance) if assistance else (None, "")
        )
        before = {name: pose for name, (pose, _) in sim.world.product_poses().items()}
        sim.watch(setup.product)
        start, wall_start = sim.time, time.perf_counter()
        limited, recorded = _teleoperate(sim, robot, parameters, hand, operator, constrain, config, teach)
        wall = time.perf_counter() - wall_start
        judged = judged_in_world(sim, setup, trial_scene.gap(setup.gap), before)
        taught = _skill(teach, recorded, gui, robot, setup.gap, base) if teach else None
        return {
            "skill": taught,
            "seed": setup.seed,
            "assistance": assistance,
            "assistance_problem": why,
            **judged,
            "aim_error_m": operator.aim.tolist(),
            "grasp_offset": offset.tolist(),
            "limits_met": sorted(limited),
            "sim_s": sim.time - start,
            "wall_s": wall,
        }
    finally:
        sim.close()


def _held_under_impedance(
    sim: ContactRecordingSim, config: MotionConfig, setup: TrialSetup, offset, stiffness: float
) -> Tuple[SimRobot, np.ndarray]:
    """The robot holding the product under TELEOP's impedance at the trial's start, and its hand pose."""
    hold_product(sim, config, setup.product, setup.base_pose, offset)
    robot = SimRobot(sim)
    robot.switch_controllers([IMPEDANCE], [TRAJECTORY])
    robot.command_stiffness([stiffness] * 3, [0.0, 0.0, 0.0, 1.0], sim.time)
    position, quaternion = robot.cartesian_pose()
    return robot, np.concatenate([position, quaternion])


def _scripted_operator(
    model: OperatorModel, parameters: TeleopParameters, base: Transform, gap, hand: np.ndarray, seed: int
) -> ScriptedOperator:
    """The modelled operator aiming at the true gap as the robot's base sees it, with the trial's own noise."""
    return ScriptedOperator(model, base.inverse() * gap.frame, hand, parameters, np.random.default_rng([seed, 3]))


def _teleoperate(
    sim: ContactRecordingSim,
    robot: SimRobot,
    parameters: TeleopParameters,
    hand: np.ndarray,
    operator: ScriptedOperator,
    constrain,
    config: MotionConfig,
    teach: str,
) -> Tuple[set, list]:
    """The operator's part: hold the clutch, move the device, release; the limits met and the samples to teach.

    Returns the names of the limits TELEOP applied and, with ``teach``, (time, equilibrium, measured pose) every
    RECORD_PERIOD until the release.
    """
    teleop = Teleoperation(parameters)
    teleop.start(hand, sim.time)
    _tick(sim, robot, teleop, sim.time, OPEN, (np.zeros(3), [0.0, 0.0, 0.0, 1.0]), None)  # the gripper rests first
    clutch_at = sim.time + parameters.clutch_hold + 2 * CYCLE
    while sim.time < clutch_at:
        _tick(sim, robot, teleop, sim.time, CLOSED, (np.zeros(3), [0.0, 0.0, 0.0, 1.0]), constrain)
    began, released, limited, recorded = sim.time, False, set(), []
    while sim.time - began < operator.end:
        t = sim.time - began
        if not released and t >= operator.release_at:
            robot.move_gripper(config.gripper.release_width, config.gripper.speed)
            released = True
        command = _tick(sim, robot, teleop, sim.time, CLOSED, operator.device(t), constrain)
        limited.update(part.split(":")[0] for part in command.reason.split("; ") if part)
        if teach and not released and (not recorded or sim.time - recorded[-1][0] >= RECORD_PERIOD - 1e-9):
            recorded.append((sim.time, command.pose, np.concatenate(robot.cartesian_pose())))
    return limited, recorded


def _skill(name: str, recorded, gui: GuiConfig, robot: SimRobot, gap: str, base: Transform) -> skill_file.Skill:
    """The recorded placement as a stiffness skill relative to the gap the robot perceives."""
    times = np.array([t for t, _, _ in recorded])
    skill = skill_file.Skill(
        name=name,
        kind="stiffness",
        time=times - times[0],
        stiffness=np.repeat(np.diag([gui.initial_stiffness] * 3)[None], times.size, axis=0),
        equilibrium_pose=np.array([pose for _, pose, _ in recorded]),
        cartesian_pose=np.array([measured for _, _, measured in recorded]),
        rotational_stiffness=gui.rotational_stiffness,
        provenance={"source": "teleteach.run.teleop_trials", "teleoperated": True},
    )
    perceived = robot.observed_scene().gaps[gap].frame
    return skill.relative_to(gap, base.inverse() * perceived)


def _assistance(
    robot: SimRobot,
    gap: str,
    base: Transform,
    hand: np.ndarray,
    config: MotionConfig,
    parameters: AssistanceParameters,
) -> Tuple[Optional[Callable], str]:
    """The constraint of the opening the robot perceives (None and why when it cannot tell)."""
    opening, why = Opening.perceived(robot.observed_scene(), gap, base, hand, config.grasp.height_above_center)
    if opening is None:
        return None, why
    return (lambda now, asked: assist(opening, now, asked, parameters)), ""


def _tick(sim, robot: SimRobot, teleop: Teleoperation, now: float, gripper: float, device, constrain):
    """One teleoperation cycle: the command from the device, sent, then CYCLE of physics."""
    command = teleop.update(now, gripper, device, 0.0, 1.0, constrain)
    robot.command_equilibrium(command.pose[:3], command.pose[3:], sim.time)
    sim.run(CYCLE)
    return command


def summarise_forces(trials: Sequence[dict]) -> dict:
    """One condition's figures: success, the neighbours' peak force (median and bootstrap interval, mean, largest)."""
    forces = [trial["peak_neighbour_force_n"] for trial in trials]
    return {
        **success_figures(list(trials)),
        "touched_neighbours": sum(force > 0.0 for force in forces),
        "median_peak_neighbour_force_n": float(np.median(forces)),
        "median_peak_neighbour_force_interval": list(bootstrap_median_interval(forces)),
        "mean_peak_neighbour_force_n": float(np.mean(forces)),
        "largest_peak_neighbour_force_n": max(forces),
        "median_peak_shelf_force_n": float(np.median([trial["peak_shelf_force_n"] for trial in trials])),
        "sim_s": sum(trial["sim_s"] for trial in trials),
        "wall_s": sum(trial["wall_s"] for trial in trials),
    }


@dataclasses.dataclass(frozen=True)
class TeleopJob:
    """One teleoperated trial for teleteach.run.trials.run_trials: its group, setup and condition."""

    group: str
    setup: TrialSetup
    gui: GuiConfig
    assistance: bool
    model: OperatorModel

    def run(self, process: dict) -> dict:
        """The trial, in a worker process (``process``: what it loaded once)."""
        return run_teleop_trial(
            process["scene"],
            process["config"],
            process["uncertainty"],
            self.setup,
            self.gui,
            self.assistance,
            self.model,
        )
