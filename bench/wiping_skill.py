#!/usr/bin/env python3
"""Benchmark: a wiping skill taught once, learned, and replayed alone on boards where it was not taught (issue 49).

The demonstration, in one go (teleteach.wiping.teaching): a scripted operator (teleteach.wiping.assistance.human_wipe,
development seed 8: a wave) wipes the counter's whiteboard through the shared controller, pressing with what the GUI's
wipe teaching starts them at (SHARED CONTROL's 500 N/m, config/gui.yaml); over 35-60 % of the wipe they hold the
clutch, the shared controller keeps the wave it recognised, and they shape the stiffness into the taught profile
(3000, 3000, 300) N/m, with which they finish. What the arm executed, and the
stiffness with it, in the perceived board's frame, is the demonstrated skill, which the thesis' learning turns into
DMPs (teleteach.wiping.skill). The learned skill then wipes alone, relative to the board as perceived
there, on the board where it was taught and on three held-out poses of it: tilted 8.6 degrees, 6 cm farther away and
turned 20 degrees (declared below; none was looked at while the task was built). Each pose with N seeds of the base's
and perception's errors.

Per pose: how many replays kept contact >= 95 % of the time, the share of the demonstration's wiped area the replay
wiped too (each in its own board's frame; goal >= 90 %), the force. And the clutch itself, over N held-out operators
of each pattern taught the same way: the share of the clutch's cycles in which the controller kept the operator's
pattern, how far the kept pattern travelled against how far the operator's own hand went on, contact and force before,
during and after the clutch. Prints the tables and the goal, writes bench/results/wiping_skill.json.

    source build/env.sh && python bench/wiping_skill.py [--trials 10] [--processes 2]
"""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import dataclasses
import json
import math
import pathlib
import tempfile
import time

import numpy as np

from teleteach.control.kinematics import PandaKinematics
from teleteach.core import skill_file
from teleteach.core.scene import load_scene
from teleteach.core.wiping import load_wiping_config
from teleteach.run.provenance import provenance
from teleteach.run.trials import (
    add_trial_arguments,
    bootstrap_median_interval,
    run_trials,
    trial_seeds,
    trial_store,
    wilson_interval,
)
from teleteach.shared_control.loop import SharedControlConfig
from teleteach.shared_control.surface import wiping_box
from teleteach.sim.uncertainty import load_uncertainty
from teleteach.wiping.ablation import BASE_POSE, SURFACE, TAUGHT, coverage
from teleteach.wiping.assistance import CONFIG_FILES, human_wipe
from teleteach.wiping.skill import ReplayJob, learned_wiping_skill
from teleteach.wiping.teaching import TeachingJob, clutch_teaching, taught_wipe
from teleteach.wiping.trial import run_wipe

BENCH = pathlib.Path(__file__).resolve().parent
RESULTS = BENCH / "results" / "wiping_skill.json"
DEMONSTRATION_SEED = 8  # development: the operator, the base's and perception's errors of the demonstration
HELD_OUT_SEEDS = 5110  # replay k uses seed HELD_OUT_SEEDS + k; --development: seed k (5100-5109: looked at)
CONTACT_GOAL, COVERAGE_GOAL = 0.95, 0.90
SKILLS = ("wave", "cycloid")  # the operators taught with the clutch, one of each per seed
PARTS = ("before", "clutch", "after")


def poses(board):
    """The board where the skill was taught, and the held-out poses of it."""
    away = board.frame.rotation.apply([0.0, 1.0, 0.0])
    return {
        "taught": board,
        "tilted": dataclasses.replace(board, rpy=(0.0, 0.15, board.rpy[2])),  # about world y: across the robot
        "farther": dataclasses.replace(board, center=tuple(np.array(board.center) + 0.06 * away)),
        "turned": dataclasses.replace(board, rpy=(0.0, 0.0, board.rpy[2] + math.radians(20.0))),
    }


def demonstrate(scene, config, folder: pathlib.Path):
    """The demonstration wipe, its skill and the learned skill (saved in folder), and its covered grid."""
    kinematics = PandaKinematics(scene.robot.mount_height)
    board = scene.surface(SURFACE)
    shared = SharedControlConfig.from_yaml()
    box = wiping_box(board, scene.wiping_tool.size[:2])
    commands, start = human_wipe(DEMONSTRATION_SEED, "wave", box, shared.dt)
    teaching = clutch_teaching(len(commands) * shared.dt, TAUGHT)
    targets, stiffnesses, _ = taught_wipe(commands, start, box, shared, teaching)
    uncertainty = load_uncertainty()
    record, wiper = run_wipe(
        scene, kinematics, uncertainty, config, board, BASE_POSE, DEMONSTRATION_SEED, targets, stiffnesses
    )
    kinematics.close()
    demonstration = wiper.demonstrated_skill(record, "DemonstratedWipe_1")
    learned = learned_wiping_skill(demonstration, "LearnedWipe_1")
    grid = coverage(record, config, scene.wiping_tool.size[:2], board.area)["grid"]
    np.save(folder / "demonstration_grid.npy", grid)
    path = skill_file.save(learned, folder / "LearnedWipe_1")
    contact = float(np.mean(record.normal_forces >= config.contact_threshold))
    return (
        path,
        folder / "demonstration_grid.npy",
        {"contact_fraction": contact, "covered_fraction": float(grid.mean())},
    )


def summarise(rows):
    """A pose's figures: replays that kept contact and that covered the demonstration's area, medians."""
    kept = sum(row["contact_fraction"] >= CONTACT_GOAL for row in rows)
    covered = sum(row["coverage_of_demonstration"] >= COVERAGE_GOAL for row in rows)
    coverage = [row["coverage_of_demonstration"] for row in rows]
    return {
        "trials": len(rows),
        "kept_contact": kept,
        "kept_contact_interval": list(wilson_interval(kept, len(rows))),
        "covered_goal": covered,
        "covered_goal_interval": list(wilson_interval(covered, len(rows))),
        "median_coverage_of_demonstration": float(np.median(coverage)),
        "median_coverage_interval": list(bootstrap_median_interval(coverage)),
        "least_coverage_of_demonstration": float(min(coverage)),
        "median_force_mean_n": float(np.median([row["force_mean_n"] for row in rows])),
        "median_force_spread_n": float(np.median([row["force_spread_n"] for row in rows])),
    }


def summarise_clutch(rows):
    """The clutch's figures over operators: the pattern kept, how far it went, contact and force by part."""
    kept = [row["kept_cycles"] / row["clutch_cycles"] for row in rows]
    travel = [row["kept_travel_m"] / max(row["own_travel_m"], 1e-6) for row in rows]
    through = sum(row["clutch"]["contact_fraction"] >= CONTACT_GOAL for row in rows)
    return {
        "trials": len(rows),
        "median_kept_share": float(np.median(kept)),
        "least_kept_share": float(min(kept)),
        "median_travel_ratio": float(np.median(travel)),
        "travel_ratio_range": [float(min(travel)), float(max(travel))],
        "kept_contact": through,
        "kept_contact_interval": list(wilson_interval(through, len(rows))),
        "median_force_n": {part: float(np.nanmedian([row[part]["force_mean_n"] for row in rows])) for part in PARTS},
        "median_spread_n": {part: float(np.nanmedian([row[part]["force_spread_n"] for row in rows])) for part in PARTS},
    }


def print_now(line: str) -> None:
    print(line, flush=True)


def results_path(arguments) -> pathlib.Path:
    return RESULTS if not arguments.development else RESULTS.with_name("wiping_skill_development.json")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_trial_arguments(parser, 10)
    arguments = parser.parse_args()
    seeds = trial_seeds(parser, arguments, HELD_OUT_SEEDS)
    start, origin = time.perf_counter(), provenance(CONFIG_FILES)
    scene, config = load_scene(), load_wiping_config()
    with tempfile.TemporaryDirectory() as folder:
        skill_path, grid_path, demonstration = demonstrate(scene, config, pathlib.Path(folder))
        print(
            f"demonstration: contact {demonstration['contact_fraction']:.0%}, "
            f"covered {demonstration['covered_fraction']:.0%} of the marked area; learned {skill_path.name}"
        )
        boards = poses(scene.surface(SURFACE))
        jobs = [
            ReplayJob(name, seed, board, str(skill_path), str(grid_path), config, BASE_POSE)
            for seed in seeds
            for name, board in boards.items()
        ]
        jobs += [
            TeachingJob(f"clutch_{skill}", seed, skill, TAUGHT, config, SURFACE, BASE_POSE)
            for seed in seeds
            for skill in SKILLS
        ]
        # the replays' skill file is learned anew in a temporary folder each run: only the clutch wipes resume
        store = trial_store(results_path(arguments), arguments)
        trials = run_trials(jobs, arguments.processes, print_now, cluster=arguments.cluster, store=store)
    clutch = {name: summarise_clutch(trials.pop(name)) for name in [f"clutch_{skill}" for skill in SKILLS]}
    cells = {name: summarise(rows) for name, rows in trials.items()}
    held_out = [cells[name] for name in boards if name != "taught"]
    met = all(cell["kept_contact"] == cell["trials"] and cell["covered_goal"] == cell["trials"] for cell in held_out)
    print(f"\n{arguments.trials} replays per pose, seeds {seeds[0]}-{seeds[-1]}")
    for name, cell in cells.items():
        print(
            f"{name:8s} kept contact {cell['kept_contact']:3d}/{cell['trials']}, covered >= 90 % of the "
            f"demonstration's area {cell['covered_goal']:3d}/{cell['trials']} (median "
            f"{cell['median_coverage_of_demonstration']:.0%}, least {cell['least_coverage_of_demonstration']:.0%}), "
            f"force {cell['median_force_mean_n']:.1f} +- {cell['median_force_spread_n']:.1f} N"
        )
    goal = "every replay at the held-out poses keeps contact >= 95 % and covers >= 90 % of the demonstrated area"
    print(f"  {'met' if met else 'NOT met'}: {goal}")
    print("\nthe clutch (the stiffness shaped from the GUI's start to the taught one, the pattern kept meanwhile)")
    for name, cell in clutch.items():
        print(
            f"{name:15s} pattern kept in {cell['median_kept_share']:.0%} of the clutch's cycles (median; least "
            f"{cell['least_kept_share']:.0%}), travelled {cell['median_travel_ratio']:.2f}x the operator's own "
            f"(range {cell['travel_ratio_range'][0]:.2f}-{cell['travel_ratio_range'][1]:.2f}x); contact >= 95 % "
            f"through the clutch in {cell['kept_contact']}/{cell['trials']}; force before / during / after "
            + " / ".join(f"{cell['median_force_n'][part]:.1f} +- {cell['median_spread_n'][part]:.1f}" for part in PARTS)
            + " N"
        )
    RESULTS.parent.mkdir(exist_ok=True)
    results = {
        "settings": {
            "trials": arguments.trials,
            "seeds": seeds,
            "demonstration_seed": DEMONSTRATION_SEED,
            "poses": {name: {"center": board.center, "rpy": board.rpy} for name, board in boards.items()},
        },
        "demonstration": demonstration,
        "cells": cells,
        "clutch": clutch,
        "goal": {"goal": goal, "met": met},
        "trials": trials,
        "provenance": {**origin, "wall_s": round(time.perf_counter() - start, 1)},
    }
    path = results_path(arguments)
    path.write_text(json.dumps(results, indent=1))
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
