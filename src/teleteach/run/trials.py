"""Placement trials in-process, faster than real time, judged from the true world.

A product is in the hand in front of a gap, a taught skill is replayed by the skill runner. Each trial builds a
fresh simulation (pybullet physics, the real controllers and skills, no ROS, no GUI) that steps as fast as it can.
Its set-up stands for what PickItem and MoveBase leave behind, at a fraction of their cost: the base is put where
MoveBase would have stopped for the pose (config/uncertainty.yaml's base error), the arm in the carry posture, and
the product in the fingers where a pick would have grasped it (off its centre by perception's bias at the pick
table, as PickItem aims at the perceived product), squeezed with the grasp force. Products farther than
``scene_radius`` from the gap are left out: nothing in the trial can touch them, and each costs physics time. The
trial records the largest normal contact force the held product takes from the shelf and from other products, and
judges the placement from the world (teleteach.core.placement on the true poses), next to the skill's own verdict (from
its perceived scene).
"""

import collections
import dataclasses
import math
import pathlib
import time
from typing import Callable, Dict, List, Optional, Sequence

import numpy as np
import pybullet
from scipy.spatial.transform import Rotation

from teleteach.control import panda
from teleteach.core import placement
from teleteach.core.paths import config_file
from teleteach.core.rotations import yaw_rotation
from teleteach.core.scene import Scene
from teleteach.run.engine import run_jobs
from teleteach.run.provenance import provenance
from teleteach.run.sim_robot import SimRobot
from teleteach.sim.robot_sim import TRAJECTORY, RobotSim
from teleteach.sim.uncertainty import UncertaintySettings
from teleteach.skills.config import MotionConfig
from teleteach.skills.motion import TOP_DOWN
from teleteach.skills.runner import REPLAY_SKILL, SkillRunner

SETTLE_TIME = 0.5  # [s] the squeezed product settles in the fingers before the skill starts
SCENE_RADIUS = 0.3  # [m] products farther than this from the gap's target are left out of a trial's scene
FORCE_WINDOW = 20  # [steps] contact forces are averaged over this many 1 ms steps (a 50 Hz force sensor)
PLACEMENT_CONFIG = ("supermarket.yaml", "skills_motion.yaml", "controllers.yaml")  # what every placement trial reads


class ContactRecordingSim(RobotSim):
    """RobotSim that keeps the largest normal contact force [N] on a watched product, from the shelf and from others.

    The force is pybullet's contact points' normal forces, summed per kind of body and averaged over
    FORCE_WINDOW steps: the force a wrist force/torque sensor filtered at about 50 Hz reports. Unfiltered, a 1 kHz
    rigid-contact step turns a product set down at 4 cm/s into a one-step spike of tens of newtons.
    """

    def __init__(self, scene: Scene, uncertainty: UncertaintySettings):
        super().__init__(scene, uncertainty=uncertainty)
        self._watched = None
        self._kinds: Dict[int, str] = {}
        self._recent = {kind: collections.deque(maxlen=FORCE_WINDOW) for kind in ("shelf", "neighbours")}
        self.peak_force = {"shelf": 0.0, "neighbours": 0.0}

    def watch(self, product: str) -> None:
        """Record the contact forces on product from now on."""
        world = self.world
        self._watched = world.products[product]
        self._kinds = {world.static_bodies[part.name]: "shelf" for part in self.scene.shelf}
        self._kinds.update({body: "neighbours" for name, body in world.products.items() if name != product})

    def tick(self):
        """One step, then the contact forces on the watched product."""
        super().tick()
        if self._watched is None:
            return
        total = {"shelf": 0.0, "neighbours": 0.0}
        for contact in pybullet.getContactPoints(bodyA=self._watched, physicsClientId=self.world.client):
            kind = self._kinds.get(contact[2])
            if kind is not None:
                total[kind] += contact[9]  # normal force [N]
        for kind, force in total.items():
            recent = self._recent[kind]
            recent.append(force)
            self.peak_force[kind] = max(self.peak_force[kind], sum(recent) / FORCE_WINDOW)


def scene_around(scene: Scene, gap: str, product: str, radius: float = SCENE_RADIUS) -> Scene:
    """The scene with only the product to place and the products within radius [m] of the gap's target."""
    target = np.array(scene.gap(gap).position)
    kept = [
        item
        for item in scene.products
        if item.name == product or np.linalg.norm(np.array(item.position) - target) <= radius
    ]
    return dataclasses.replace(scene, products=kept)


def grasp_offset(uncertainty: UncertaintySettings, rng: np.random.Generator) -> np.ndarray:
    """Where the pick grasped the product off its centre, in the product's frame (x, y, z [m], yaw [rad]).

    PickItem aims at the perceived product: its grasp is off by perception's bias of the product at the pick table.
    The fingers close along the product's x (skills_motion grasp.yaw), which centres it in x.
    """
    noise = uncertainty.perception.products
    if not uncertainty.perception.enabled:
        return np.zeros(4)
    offset = rng.normal(0.0, 1.0, 3) * noise.position_bias_std
    offset[0] = 0.0
    return np.array([*offset, rng.normal(0.0, noise.yaw_bias_std)])


def hold_product(sim: RobotSim, config: MotionConfig, product: str, base_pose: str, offset: np.ndarray) -> None:
    """Set the trial up: base, arm and product as a pick and a MoveBase to base_pose would leave them.

    The base stands where MoveBase stops for base_pose, the arm in the carry posture on the position controller, the
    product in the fingers (``offset`` from :func:`grasp_offset`), squeezed with the grasp force.
    """
    world = sim.world
    sim.place_base(sim.scene.base_poses[base_pose])
    carry = np.asarray(config.postures["carry"], dtype=float)
    for index, value in zip(panda.ARM_INDICES, carry):
        pybullet.resetJointState(world.robot, index, value, physicsClientId=world.client)
    if sim.manager.running != TRAJECTORY:
        sim.switch_controllers([TRAJECTORY], [sim.manager.running] if sim.manager.running else [], 2)
    sim.command_trajectory(panda.ARM_JOINTS, [(carry.tolist(), [0.0] * 7, 0.05)], stamp=sim.time)
    tcp = pybullet.getLinkState(
        world.robot, panda.TCP_LINK, computeForwardKinematics=True, physicsClientId=world.client
    )
    hand = Rotation.from_quat(tcp[5])
    # the product's frame in the hand: below the TCP by the grasp height, turned back by the grasp yaw
    in_hand = TOP_DOWN.inv() * yaw_rotation(-config.grasp.yaw)
    orientation = hand * in_hand * yaw_rotation(offset[3])
    centre = np.array(tcp[4]) + hand.apply([0.0, 0.0, config.grasp.height_above_center])
    centre -= orientation.apply(offset[:3])
    pybullet.resetBasePositionAndOrientation(
        world.products[product], centre.tolist(), orientation.as_quat().tolist(), physicsClientId=world.client
    )
    depth = next(item.size for item in sim.scene.products if item.name == product)[0]
    for index in panda.FINGER_INDICES:
        pybullet.resetJointState(world.robot, index, depth / 2.0 + 0.001, physicsClientId=world.client)
    sim.gripper.grasp(depth, 0.005, 0.005, config.gripper.speed, config.gripper.grasp_force, sim.time)
    sim.run(SETTLE_TIME)


@dataclasses.dataclass
class TrialSetup:
    """What one trial places where: the product, the gap, the base pose it stands at, the seed of its errors."""

    product: str
    gap: str
    base_pose: str
    seed: int


def run_trial(
    scene: Scene,
    config: MotionConfig,
    kinematics,
    uncertainty: UncertaintySettings,
    setup: TrialSetup,
    skill_path: pathlib.Path,
    target: Optional[str] = None,
) -> dict:
    """One placement in a fresh world; returns what happened, judged from the world.

    Args:
        scene: the whole scene (the trial keeps the products near the gap).
        config: the skills' motion configuration.
        kinematics: Panda kinematics for the skills' IK (teleteach.control.kinematics.PandaKinematics).
        uncertainty: the world's uncertainty; its seed is replaced by the trial's.
        setup: product, gap, base pose and seed.
        skill_path: the skill file ReplaySkill plays.
        target: the gap ReplaySkill is told to place at (None: it finds the gap itself).
    """
    trial_scene = scene_around(scene, setup.gap, setup.product)
    trial_uncertainty = uncertainty.with_overrides(seed=setup.seed)
    sim = ContactRecordingSim(trial_scene, trial_uncertainty)
    try:
        offset = grasp_offset(trial_uncertainty, np.random.default_rng([setup.seed, 2]))
        hold_product(sim, config, setup.product, setup.base_pose, offset)
        runner = SkillRunner(SimRobot(sim), config, trial_scene, kinematics)
        before = {name: position for name, (position, _) in sim.world.product_poses().items()}
        held_before = sim.world.grasped
        gap_truth = trial_scene.gap(setup.gap)
        gap_seen = sim.perceived_scene().gap(setup.gap)
        sim.watch(setup.product)
        sim_start = sim.time
        outcome, wall = _timed_replay(runner, skill_path, target)
        judged = judged_in_world(sim, setup, gap_truth, before)
        return {
            "seed": setup.seed,
            "success": judged.pop("success"),
            "skill_success": outcome.success,
            "message": outcome.message,
            "held_at_start": held_before == setup.product,
            **judged,
            "base_error": sim.base_error.last.tolist(),
            "gap_perception_error": _perception_error(gap_truth, gap_seen),
            "grasp_offset": offset.tolist(),
            "sim_s": sim.time - sim_start,
            "wall_s": wall,
        }
    finally:
        sim.close()


def _timed_replay(runner: SkillRunner, skill_path: pathlib.Path, target: Optional[str]):
    """ReplaySkill's outcome on the skill file, and the wall time it took [s] (what the trials' speed-up measures)."""
    wall_start = time.perf_counter()
    parameters = f"{{data_file: '{skill_path}'" + (f", target: {target}" if target else "") + "}"
    outcome = runner.execute(REPLAY_SKILL, parameters)
    return outcome, time.perf_counter() - wall_start


def _perception_error(gap_truth, gap_seen) -> list:
    """Where the robot saw the gap, in the true gap's frame [m], and its yaw error [rad]: what it placed against."""
    seen_in_gap = gap_truth.frame.inverse().apply_point(gap_seen.position)
    return [*seen_in_gap.tolist(), gap_seen.yaw - gap_truth.yaw]


def judged_in_world(sim: ContactRecordingSim, setup: TrialSetup, gap_truth, before: dict) -> dict:
    """The placement as the world judges it: success, the forces, the neighbours moved, the product in the gap.

    ``before``: each product's pose when the trial began, to see which ones the placement moved.
    """
    poses = sim.world.product_poses()
    final = {name: pose for name, (pose, _) in poses.items()}
    judged = placement.judge(sim.true_scene(), setup.product, poses[setup.product], before, final, setup.gap)
    in_gap = gap_truth.frame.inverse().apply_point(poses[setup.product][0])
    return {
        "success": not judged.problems(setup.gap) and sim.world.grasped is None,
        "peak_force_n": max(sim.peak_force.values()),
        "peak_shelf_force_n": sim.peak_force["shelf"],
        "peak_neighbour_force_n": sim.peak_force["neighbours"],
        "neighbour_max_move_m": judged.neighbours_max_move_m,
        "distance_m": judged.distance_m,
        "depth_m": float(in_gap[0]),
        "lateral_m": float(in_gap[1]),
        "tilt_deg": judged.tilt_deg,
    }


def wilson_interval(successes: int, trials: int, z: float = 1.959964) -> tuple:
    """Wilson score interval of a success rate (95 % by default): (low, high), always holding the rate itself.

    At 0 or all successes the formula's bound equals the rate only up to rounding (1 - 1e-16): clamped to it.
    """
    if trials == 0:
        return (0.0, 1.0)
    rate = successes / trials
    denominator = 1.0 + z * z / trials
    centre = (rate + z * z / (2.0 * trials)) / denominator
    half = z * math.sqrt(rate * (1.0 - rate) / trials + z * z / (4.0 * trials * trials)) / denominator
    return (max(0.0, min(rate, centre - half)), min(1.0, max(rate, centre + half)))


def bootstrap_median_interval(values, seed: int = 0, resamples: int = 2000, level: float = 0.95) -> tuple:
    """Percentile bootstrap interval of the median of values: (low, high)."""
    values = np.asarray(values, dtype=float)
    if values.size == 0:
        return (math.nan, math.nan)
    rng = np.random.default_rng(seed)
    medians = np.median(rng.choice(values, size=(resamples, values.size), replace=True), axis=1)
    tail = (1.0 - level) / 2.0
    return (float(np.quantile(medians, tail)), float(np.quantile(medians, 1.0 - tail)))


def success_figures(trials: List[dict]) -> dict:
    """How many trials, and their success (the world's verdict) with its Wilson interval: every kind of trial's."""
    count = len(trials)
    successes = sum(trial["success"] for trial in trials)
    return {
        "trials": count,
        "success_rate": successes / count,
        "success_interval": list(wilson_interval(successes, count)),
    }


def summarise(trials: List[dict], seed: int = 0) -> dict:
    """One group of trials' figures.

    Success (the world's verdict) with its Wilson interval, the skill's own verdict, the peak contact force's median
    with its bootstrap interval, neighbour displacement, time.
    """
    count = len(trials)
    peaks = [trial["peak_force_n"] for trial in trials]
    moves = [trial["neighbour_max_move_m"] for trial in trials]
    return {
        **success_figures(trials),
        "skill_success_rate": sum(trial["skill_success"] for trial in trials) / count,
        "verdicts_disagree": sum(trial["success"] != trial["skill_success"] for trial in trials),
        "peak_force_n": max(peaks),
        "median_peak_force_n": float(np.median(peaks)),
        "median_peak_force_interval": list(bootstrap_median_interval(peaks, seed)),
        "peak_neighbour_force_n": max(trial["peak_neighbour_force_n"] for trial in trials),
        "neighbour_max_move_m": max(moves),
        "median_neighbour_move_m": float(np.median(moves)),
        "median_time_s": float(np.median([trial["sim_s"] for trial in trials])),
        "sim_s": sum(trial["sim_s"] for trial in trials),
        "wall_s": sum(trial["wall_s"] for trial in trials),
    }


@dataclasses.dataclass(frozen=True)
class TrialJob:
    """One trial to run: the group it counts for, what it places where, the skill file, the target it names."""

    group: str
    setup: TrialSetup
    skill_path: str
    target: Optional[str] = None

    def run(self, process: dict) -> dict:
        """The trial, in a worker process (``process``: what it loaded once, see run_trials)."""
        return run_trial(
            process["scene"],
            process["config"],
            process["kinematics"],
            process["uncertainty"],
            self.setup,
            pathlib.Path(self.skill_path),
            self.target,
        )


def run_trials(
    jobs: Sequence,
    processes: int,
    progress: Callable[[str], None] = print,
    uncertainty_file: Optional[str] = None,
    cluster: Optional[str] = None,
    store: Optional[pathlib.Path] = None,
) -> Dict[str, list]:
    """Run every job; returns each group's results, ordered by seed.

    A job has a ``group``, a ``setup`` and a ``run(process)`` (a TrialJob, or another kind of trial's job). Each worker
    loads the default scene, motion configuration and Panda kinematics once, and the uncertainty of
    ``uncertainty_file`` (default: config/uncertainty.yaml). The workers are ``processes`` local processes, or with
    ``cluster`` (``ray://HOST:PORT`` or ``auto``) one per CPU of a Ray cluster; with ``store`` (a JSON-lines file) a
    run continues with the trials an interrupted run stored there (teleteach.run.engine).
    """
    results: Dict[str, List[dict]] = {job.group: [] for job in jobs}
    for job, result in run_jobs(jobs, processes, progress, uncertainty_file, cluster, store):
        results[job.group].append(result)
    for group in results.values():
        group.sort(key=lambda trial: trial["seed"])
    return results


def add_trial_arguments(parser, trials: int, least: int = 1) -> None:
    """A bench's --trials (default ``trials``, at least ``least``), --development and the engine's options."""
    parser.add_argument("--trials", type=int, default=trials, help=f"trials per cell (at least {least})")
    parser.add_argument("--development", action="store_true", help="seeds 0.. instead of the held-out ones")
    parser.set_defaults(least_trials=least)
    add_engine_arguments(parser)


def add_engine_arguments(parser, processes: int = 2) -> None:
    """Where a bench's trials run: --processes (the local pool's size), --cluster (Ray), --fresh (no resuming)."""
    parser.add_argument("--processes", type=int, default=processes, help="parallel simulations of the local pool")
    parser.add_argument(
        "--cluster",
        metavar="ADDRESS",
        help="run the trials on a Ray cluster: ray://HOST:PORT, or auto (the cluster this machine is a node of); "
        "needs `scripts/setup --cluster` (docs/cluster.md)",
    )
    parser.add_argument(
        "--fresh", action="store_true", help="run every trial, not continuing with those an interrupted run stored"
    )


def placement_provenance(*files) -> dict:
    """A placement bench's provenance: the configuration every trial reads (scene, motion, controllers) and ``files``.

    ``files``: what else the trials read, such as the uncertainty file or a skill file (teleteach.run.provenance).
    """
    return provenance([*(config_file(name) for name in PLACEMENT_CONFIG), *files])


def trial_store(results: pathlib.Path, arguments) -> pathlib.Path:
    """The JSON-lines file where a bench writing ``results`` keeps its finished trials (emptied by --fresh)."""
    path = results.with_name(f".{results.stem}.trials.jsonl")
    if arguments.fresh:
        path.unlink(missing_ok=True)
    return path


def trial_seeds(parser, arguments, held_out_first: int) -> List[int]:
    """The seeds the parsed options ask for: the held-out ones from ``held_out_first``, or 0.. with --development."""
    if arguments.trials < arguments.least_trials or arguments.processes < 1:
        parser.error(f"--trials must be >= {arguments.least_trials} and --processes >= 1")
    first = 0 if arguments.development else held_out_first
    return list(range(first, first + arguments.trials))
