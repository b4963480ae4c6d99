#!/usr/bin/env python3
"""Benchmark: the premise of low-level teaching, measured. Does the taught variable stiffness place a product into a
tight gap better than a constant stiffness (thesis II-C, III-C: variable stiffness "to ensure both safe interaction
and precise execution")?

One taught placing skill (bench/data/DemonstratedPlace_1.npz, recorded by `bash scripts/demo`) is replayed by
ReplaySkill on the in-process simulation (pybullet physics, the real impedance controller, no ROS, no GUI) into
gap_1 of bench/scenes/tight_gap.yaml, 5 mm clearance on each side of the product. Every trial starts from a fresh
world: PickItem picks the product and MoveBase drives to the taught base pose plus a sampled error (uniform, up to
+-1 cm in x and y and +-2 degrees in yaw, fixed seed). The same errors are replayed with three stiffness profiles
over the same equilibrium poses: constant low (the taught skill's first sample, the approach stiffness), constant
high (3000 N/m on every axis) and the taught one. Per profile: the success rate (ReplaySkill's own judgement of the
world after the release: product in the gap, upright, no neighbour moved more than 1 cm), the peak normal contact
force between the product and the shelf or its neighbours during the replay, the largest neighbour displacement
and the time. Prints the table, writes bench/results/stiffness_ablation.json and .png.

    source build/env.sh && python bench/stiffness_ablation.py [--trials N]
"""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import collections
import dataclasses
import json
import math
import pathlib
import tempfile
import time
from typing import Dict

import numpy as np
import pybullet
from matplotlib.figure import Figure

from teleteach import placement, skill_file
from teleteach.sim.kinematics import PandaKinematics
from teleteach.sim.robot_sim import RobotSim
from teleteach.sim.scene import BasePose, Scene, load_scene
from teleteach.skills.config import load_motion_config
from teleteach.skills.motion import base_to_world, world_to_base
from teleteach.skills.runner import REPLAY_SKILL, SkillRunner
from teleteach.skills.sim_robot import SimRobot

BENCH = pathlib.Path(__file__).resolve().parent
SCENE_FILE = BENCH / "scenes" / "tight_gap.yaml"
SKILL_FILE = BENCH / "data" / "DemonstratedPlace_1.npz"
RESULTS = BENCH / "results" / "stiffness_ablation.json"

PRODUCT = "product_pick_1"
GAP = "gap_1"
TAUGHT_BASE_POSE = "place_perpendicular"  # where the skill was recorded (its trajectory is in base_link)
TRIAL_BASE_POSE = "perturbed"  # the taught pose plus the trial's error, added to the scene for MoveBase
HIGH_STIFFNESS = 3000.0  # [N/m] the controller's max_stiffness (config/controllers.yaml)
MAX_OFFSET = 0.01  # [m] largest base position error, in x and in y
MAX_YAW = math.radians(2.0)  # [rad] largest base yaw error
SEED = 14
PROFILES = ("constant_low", "constant_high", "taught")


def results_file(scene_file: pathlib.Path) -> pathlib.Path:
    """Where the results of a scene go: RESULTS for the default scene, a name with the scene's otherwise."""
    if scene_file.resolve() == SCENE_FILE:
        return RESULTS
    return RESULTS.with_name(f"{RESULTS.stem}_{scene_file.stem}.json")


def base_pose_errors(trials: int, seed: int = SEED) -> np.ndarray:
    """(trials, 3) base pose errors: x [m], y [m], yaw [rad], uniform within +-MAX_OFFSET and +-MAX_YAW."""
    limits = np.array([MAX_OFFSET, MAX_OFFSET, MAX_YAW])
    return np.random.default_rng(seed).uniform(-limits, limits, size=(trials, 3))


def stiffness_profiles(taught: skill_file.Skill) -> Dict[str, skill_file.Skill]:
    """The three skills compared: the taught trajectory with its stiffness replaced by each profile, by name.

    Only the translational stiffness differs: times, equilibrium poses and the rotational stiffness are the taught
    ones. Constant low is the taught skill's first sample, the stiffness its operator preset for the approach.
    """
    count = len(taught.time)
    constant = {
        "constant_low": np.repeat(taught.stiffness[:1], count, axis=0),
        "constant_high": np.tile(HIGH_STIFFNESS * np.eye(3), (count, 1, 1)),
        "taught": taught.stiffness,
    }
    return {
        name: dataclasses.replace(taught, name=f"{taught.name}_{name}", stiffness=stiffness)
        for name, stiffness in constant.items()
    }


def aim_offset(base_pose: BasePose, scene: Scene, reference) -> np.ndarray:
    """Where the skill's last reference (base_link) lands from base_pose, relative to the gap's target [m].

    Depth (into the shelf) and lateral offset: where the product would end if nothing were in its way.
    """
    gap = scene.gap(GAP)
    point = base_to_world((base_pose.x, base_pose.y, base_pose.yaw), reference)
    return world_to_base((gap.position[0], gap.position[1], gap.yaw), point)[:2]


class ContactRecordingSim(RobotSim):
    """RobotSim that, once told which product to watch, keeps the largest normal contact force [N] the product takes
    from the shelf and from the other products at any physics step (pybullet's contact points, summed per body)."""

    def __init__(self, scene: Scene):
        super().__init__(scene)
        self._watched = None
        self._kinds = {}
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
        per_body = collections.defaultdict(float)
        for contact in pybullet.getContactPoints(bodyA=self._watched, physicsClientId=self.world.client):
            if contact[2] in self._kinds:
                per_body[contact[2]] += contact[9]  # normal force [N]
        for body, force in per_body.items():
            kind = self._kinds[body]
            self.peak_force[kind] = max(self.peak_force[kind], force)


def run_trial(kinematics, config, scene: Scene, skill_path: pathlib.Path, error) -> dict:
    """One placement in a fresh world: pick, drive to the taught base pose plus error, replay the skill file."""
    taught = scene.base_poses[TAUGHT_BASE_POSE]
    perturbed = BasePose(taught.x + error[0], taught.y + error[1], taught.yaw + error[2])
    trial_scene = dataclasses.replace(scene, base_poses={**scene.base_poses, TRIAL_BASE_POSE: perturbed})
    sim = ContactRecordingSim(trial_scene)
    try:
        runner = SkillRunner(SimRobot(sim), config, trial_scene, kinematics)
        for name, parameters in (
            ("LookToShelf", ""),
            ("PickItem", ""),
            ("MoveBase", f"{{base_pose: {TRIAL_BASE_POSE}}}"),
        ):
            outcome = runner.execute(name, parameters)
            if not outcome.success:
                raise RuntimeError(f"trial set-up failed: {name}: {outcome.message}")
        before = {name: position for name, (position, _) in sim.world.product_poses().items()}
        sim.watch(PRODUCT)
        sim_start, wall_start = sim.time, time.perf_counter()
        outcome = runner.execute(REPLAY_SKILL, f"{{data_file: '{skill_path}', kind: stiffness}}")
        wall = time.perf_counter() - wall_start
        poses = sim.world.product_poses()
        final = {name: position for name, (position, _) in poses.items()}
        judged = placement.judge(trial_scene, PRODUCT, poses[PRODUCT], before, final, GAP)
        return {
            "success": outcome.success,
            "message": outcome.message,
            "peak_force_n": max(sim.peak_force.values()),
            "peak_shelf_force_n": sim.peak_force["shelf"],
            "peak_neighbour_force_n": sim.peak_force["neighbours"],
            "neighbour_max_move_m": judged.neighbours_max_move_m,
            "distance_m": judged.distance_m,
            "tilt_deg": judged.tilt_deg,
            "sim_s": sim.time - sim_start,
            "wall_s": wall,
        }
    finally:
        sim.close()


def summarise(trials) -> dict:
    """One profile's figures over its trials."""
    peaks = [trial["peak_force_n"] for trial in trials]
    return {
        "trials": len(trials),
        "success_rate": sum(trial["success"] for trial in trials) / len(trials),
        "peak_force_n": max(peaks),
        "median_peak_force_n": float(np.median(peaks)),
        "peak_neighbour_force_n": max(trial["peak_neighbour_force_n"] for trial in trials),
        "neighbour_max_move_m": max(trial["neighbour_max_move_m"] for trial in trials),
        "sim_s": sum(trial["sim_s"] for trial in trials),
        "wall_s": sum(trial["wall_s"] for trial in trials),
    }


def plot(results: dict, path: pathlib.Path) -> None:
    """Success rates, per-trial peak forces (any contact, and the neighbours alone), and each trial's outcome against
    its lateral aim error."""
    figure = Figure(figsize=(17, 4.2), layout="constrained")
    rate_axes, force_axes, neighbour_axes, aim_axes = figure.subplots(1, 4)
    names = list(results["profiles"])
    colours = dict(zip(names, ("#4575b4", "#d73027", "#1a9850")))
    rates = [results["profiles"][name]["success_rate"] for name in names]
    rate_axes.bar(names, rates, color=[colours[name] for name in names])
    rate_axes.set_ylim(0.0, 1.0)
    rate_axes.set_ylabel("success rate")
    rate_axes.set_title(f"upright in the gap, nothing pushed ({results['settings']['trials']} trials)")
    jitter = np.random.default_rng(0)
    for axes, key, title in (
        (force_axes, "peak_force_n", "peak normal force, shelf or neighbours"),
        (neighbour_axes, "peak_neighbour_force_n", "peak normal force from the neighbours"),
    ):
        forces = [[trial[key] for trial in results["trials"][name]] for name in names]
        axes.boxplot(forces, labels=names, showfliers=False)
        for index, (name, values) in enumerate(zip(names, forces), start=1):
            axes.plot(index + jitter.uniform(-0.12, 0.12, len(values)), values, "o", color=colours[name], alpha=0.6)
        axes.set_ylim(bottom=0.0)
        axes.set_ylabel("[N] per trial")
        axes.set_title(title)
    lateral = 1000.0 * np.array([error["aim_lateral_m"] for error in results["errors"]])
    clearance = 1000.0 * results["settings"]["clearance_m"]
    for row, name in enumerate(names):
        success = np.array([trial["success"] for trial in results["trials"][name]])
        aim_axes.plot(lateral[success], np.full(success.sum(), row), "o", color=colours[name])
        aim_axes.plot(lateral[~success], np.full((~success).sum(), row), "x", color=colours[name])
    aim_axes.axvspan(-clearance, clearance, color="0.9", zorder=0)
    aim_axes.set_yticks(range(len(names)), names)
    aim_axes.set_ylim(-0.5, len(names) - 0.5)
    reach = 1.1 * max(np.abs(lateral).max(), clearance)
    aim_axes.set_xlim(-reach, reach)
    aim_axes.set_xlabel("lateral aim error at the gap [mm] (grey: clearance)")
    aim_axes.set_title("o placed, x failed")
    figure.savefig(path, dpi=110)


def print_table(results: dict) -> None:
    """The figures per profile, then the taught profile against each constant one."""
    settings = results["settings"]
    within = sum(abs(error["aim_lateral_m"]) <= settings["clearance_m"] for error in results["errors"])
    print(
        f"\n{settings['trials']} trials per profile; gap {1000 * settings['gap_width_m']:.0f} mm wide, "
        f"{1000 * settings['clearance_m']:.0f} mm clearance; {within} of the sampled base errors aim the product "
        "within the clearance"
    )
    print(
        f"{'profile':14s} {'success':>8s} {'peak force':>11s} {'median peak':>12s} {'from neighbours':>16s} "
        f"{'neighbour move':>15s} {'sim':>7s} {'wall':>7s}"
    )
    for name, row in results["profiles"].items():
        print(
            f"{name:14s} {100 * row['success_rate']:7.0f}% {row['peak_force_n']:9.1f} N "
            f"{row['median_peak_force_n']:10.1f} N {row['peak_neighbour_force_n']:14.1f} N "
            f"{1000 * row['neighbour_max_move_m']:12.1f} mm {row['sim_s']:5.0f} s {row['wall_s']:5.0f} s"
        )
    taught = results["profiles"]["taught"]
    for name in ("constant_low", "constant_high"):
        row = results["profiles"][name]
        print(
            f"taught vs {name}: success {100 * (taught['success_rate'] - row['success_rate']):+.0f} points, "
            f"median peak force {taught['median_peak_force_n'] - row['median_peak_force_n']:+.1f} N, "
            f"peak from the neighbours {taught['peak_neighbour_force_n'] - row['peak_neighbour_force_n']:+.1f} N, "
            f"largest neighbour move {1000 * (taught['neighbour_max_move_m'] - row['neighbour_max_move_m']):+.1f} mm"
        )


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--trials", type=int, default=20, help="trials per stiffness profile (default 20)")
    parser.add_argument("--seed", type=int, default=SEED, help=f"seed of the base pose errors (default {SEED})")
    parser.add_argument(
        "--scene",
        type=pathlib.Path,
        default=SCENE_FILE,
        help="scene file with gap_1, the product and its neighbours (default bench/scenes/tight_gap.yaml)",
    )
    options = parser.parse_args()
    started = time.perf_counter()
    scene = load_scene(str(options.scene))
    taught = skill_file.load(SKILL_FILE)
    config = load_motion_config()
    kinematics = PandaKinematics(scene.robot.mount_height)
    errors = base_pose_errors(options.trials, options.seed)
    taught_pose = scene.base_poses[TAUGHT_BASE_POSE]
    aims = [
        aim_offset(
            BasePose(taught_pose.x + x, taught_pose.y + y, taught_pose.yaw + yaw),
            scene,
            taught.equilibrium_pose[-1, :3],
        )
        for x, y, yaw in errors
    ]
    trials = {}
    with tempfile.TemporaryDirectory() as folder:
        for name, skill in stiffness_profiles(taught).items():
            path = skill_file.save(skill, pathlib.Path(folder) / skill.name)
            trials[name] = []
            for index, (error, aim) in enumerate(zip(errors, aims)):
                trial = run_trial(kinematics, config, scene, path, error)
                trials[name].append(trial)
                print(
                    f"{name:13s} {index + 1:2d}/{len(errors)}: base error ({1000 * error[0]:+5.1f}, "
                    f"{1000 * error[1]:+5.1f}) mm {math.degrees(error[2]):+4.1f} deg, "
                    f"aim {1000 * aim[1]:+5.1f} mm sideways: "
                    f"peak {trial['peak_force_n']:4.1f} N, {'placed' if trial['success'] else trial['message']}",
                    flush=True,
                )
    kinematics.close()
    gap = scene.gap(GAP)
    results = {
        "profiles": {name: summarise(profile_trials) for name, profile_trials in trials.items()},
        "settings": {
            "trials": options.trials,
            "seed": options.seed,
            "scene_file": str(options.scene),
            "skill_file": str(SKILL_FILE.relative_to(BENCH.parent)),
            "gap_width_m": gap.width,
            "clearance_m": (gap.width - scene.product(PRODUCT).size[1]) / 2.0,
            "max_base_offset_m": MAX_OFFSET,
            "max_base_yaw_deg": math.degrees(MAX_YAW),
            "low_stiffness_n_per_m": np.diag(taught.stiffness[0]).tolist(),
            "high_stiffness_n_per_m": HIGH_STIFFNESS,
            "total_wall_s": time.perf_counter() - started,
        },
        "errors": [
            {"x_m": x, "y_m": y, "yaw_deg": math.degrees(yaw), "aim_depth_m": aim[0], "aim_lateral_m": aim[1]}
            for (x, y, yaw), aim in zip(errors.tolist(), np.asarray(aims).tolist())
        ],
        "trials": trials,
    }
    print_table(results)
    path = results_file(options.scene)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(results, indent=2))
    plot(results, path.with_suffix(".png"))
    print(f"wrote {path} and {path.with_suffix('.png')} ({results['settings']['total_wall_s']:.0f} s)")


if __name__ == "__main__":
    main()
