#!/usr/bin/env python3
"""Benchmark: does shared control in the placement spare the neighbours? A scripted operator teleoperates the held
product into a gap through TELEOP (teleteach.run.teleop_trials), with the placement's assistance off and on.

The operator aims with an error drawn once per trial (3 mm in depth, 5 mm across, 3 mm in height, standard
deviations), a 0.5 mm tremor, and does not react to the robot; the world has its default uncertainty (the base where
MoveBase stopped, the gap perceived with its bias and noise, the product off-centre in the fingers). Both conditions
of a seed draw the same errors, so they are paired. Per gap and condition: the peak contact force on the neighbours
(mean, median with its bootstrap 95 % interval, how many trials touched them), success judged from the true world
(Wilson 95 % interval), the peak force on the shelf. The goal (issue 34): with assistance, the mean peak neighbour
force is at most 50 % of that without (a paired bootstrap 95 % interval of the ratio is printed).

Held out: seeds 3000-3002 were looked at in development (a first 3-trial run at gap_1 and gap_3 led to the grasp's
place of the held product in the assistance and to rotation_scale 1); the goal line is computed on the other seeds
(3003 + k) only, at gap_1 and the gaps 3-5 (2-8 mm of clearance per side, the base at other distances and angles). The
table per gap shows every seed.

    source build/env.sh && python bench/teleop_assistance.py [--trials 20] [--processes 2] [--gaps gap_1 gap_3 ...]
        [--uncertainty FILE] [--output FILE]
"""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import json
import pathlib
import time

import numpy as np
from matplotlib.figure import Figure

from teleteach.core.gui_config import GuiConfig
from teleteach.core.paths import config_file
from teleteach.core.scene import load_scene
from teleteach.run.teleop_trials import OperatorModel, TeleopJob, summarise_forces
from teleteach.run.trials import TrialSetup, add_engine_arguments, placement_provenance, run_trials, trial_store
from teleteach.sim.uncertainty import DEFAULT_UNCERTAINTY_FILE

RESULTS = pathlib.Path(__file__).resolve().parent / "results" / "teleop_assistance.json"
PRODUCT = "product_pick_1"
BASE_POSES = {"gap_1": "place_perpendicular", **{f"gap_{number}": f"place_gap_{number}" for number in range(3, 8)}}
SEEDS = 3000  # trial k uses seed SEEDS + k
DEVELOPMENT_SEEDS = (3000, 3001, 3002)  # looked at while the assistance was built: left out of the goal line
GOAL_RATIO = 0.5
CONDITIONS = {"off": False, "on": True}


def paired_ratio_interval(off, on, seed: int = 0, resamples: int = 4000) -> tuple:
    """Percentile bootstrap 95 % interval of mean(on) / mean(off), resampling the paired trials together."""
    off, on = np.asarray(off, dtype=float), np.asarray(on, dtype=float)
    rng = np.random.default_rng(seed)
    picks = rng.integers(0, off.size, (resamples, off.size))
    means_off, means_on = off[picks].mean(axis=1), on[picks].mean(axis=1)
    ratios = np.where(means_off > 0, means_on / np.where(means_off > 0, means_off, 1.0), np.nan)
    ratios = ratios[np.isfinite(ratios)]
    if ratios.size == 0:
        return (float("nan"), float("nan"))
    return float(np.quantile(ratios, 0.025)), float(np.quantile(ratios, 0.975))


def plot(results: dict, path: pathlib.Path) -> None:
    """Per gap, the peak neighbour force of each trial, assistance off and on."""
    gaps = list(results["gaps"])
    figure = Figure(figsize=(11, 4.2), layout="constrained")
    axes = figure.subplots()
    for offset, (condition, colour) in zip((-0.18, 0.18), (("off", "#d73027"), ("on", "#1a9850"))):
        for index, gap in enumerate(gaps):
            forces = [trial["peak_neighbour_force_n"] for trial in results["trials"][f"{gap} {condition}"]]
            jitter = np.linspace(-0.08, 0.08, len(forces))
            axes.scatter(index + offset + jitter, forces, s=14, color=colour, label=condition if index == 0 else None)
            axes.hlines(np.mean(forces), index + offset - 0.12, index + offset + 0.12, color=colour, linewidth=2)
    axes.set_xticks(
        range(len(gaps)), [f"{gap}\n{results['settings']['clearance_m'][gap] * 1000:.0f} mm" for gap in gaps]
    )
    axes.set_ylabel("peak force on the neighbours per trial [N] (bar: mean)")
    axes.set_title(f"teleoperated placement, assistance off and on ({results['settings']['trials']} trials each)")
    axes.legend(title="assistance")
    figure.savefig(path, dpi=110)


def print_now(line: str) -> None:
    print(line, flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--trials", type=int, default=20, help="trials per gap and condition (20)")
    add_engine_arguments(parser, os.cpu_count() or 1)
    parser.add_argument("--gaps", nargs="+", default=["gap_1", "gap_3", "gap_4", "gap_5"], choices=sorted(BASE_POSES))
    parser.add_argument(
        "--uncertainty",
        type=pathlib.Path,
        default=None,
        help="the world's uncertainty (default config/uncertainty.yaml)",
    )
    parser.add_argument("--output", type=pathlib.Path, default=RESULTS, help=f"results file ({RESULTS})")
    options = parser.parse_args()
    started = time.perf_counter()
    origin = placement_provenance(options.uncertainty or DEFAULT_UNCERTAINTY_FILE, config_file("gui.yaml"))
    scene, gui = load_scene(), GuiConfig.load()
    model = OperatorModel()
    seeds = list(range(SEEDS, SEEDS + options.trials))
    jobs = [
        TeleopJob(
            f"{gap} {condition}",
            TrialSetup(PRODUCT, gap, BASE_POSES[gap], seed),
            gui,
            assisted,
            model,
        )
        for seed in seeds
        for gap in options.gaps
        for condition, assisted in CONDITIONS.items()
    ]
    print(f"{len(options.gaps)} gaps x 2 conditions x {options.trials} trials on {options.processes} processes")
    uncertainty = None if options.uncertainty is None else str(options.uncertainty)
    store = trial_store(options.output, options)
    trials = run_trials(jobs, options.processes, print_now, uncertainty, options.cluster, store)
    wall = time.perf_counter() - started
    results = {"gaps": {}, "settings": {}, "trials": trials}
    print(f"\nseeds {seeds[0]}-{seeds[-1]}; peak force on the neighbours per trial, mean and median [95 % interval]")
    print(f"{'gap':6s} {'clear':>6s} {'cond':>4s} {'touched':>8s} {'mean':>7s} {'median':>20s} {'success':>17s}")
    ratios = []
    for gap in options.gaps:
        rows = {condition: summarise_forces(trials[f"{gap} {condition}"]) for condition in CONDITIONS}
        off = [trial["peak_neighbour_force_n"] for trial in trials[f"{gap} off"]]
        on = [trial["peak_neighbour_force_n"] for trial in trials[f"{gap} on"]]
        ratio = np.mean(on) / np.mean(off) if np.mean(off) > 0 else float("nan")
        interval = paired_ratio_interval(off, on)
        results["gaps"][gap] = {**rows, "ratio_of_means": ratio, "ratio_interval": list(interval)}
        clearance = (scene.gap(gap).width - scene.product(PRODUCT).size[1]) / 2.0
        for condition, row in rows.items():
            low, high = row["median_peak_neighbour_force_interval"]
            success_low, success_high = row["success_interval"]
            print(
                f"{gap:6s} {1000 * clearance:3.0f} mm {condition:>4s} "
                f"{row['touched_neighbours']:5d}/{row['trials']:<2d} {row['mean_peak_neighbour_force_n']:6.2f} N "
                f"{row['median_peak_neighbour_force_n']:6.2f} N "
                f"[{low:5.2f},{high:5.2f}] {100 * row['success_rate']:4.0f} % [{100 * success_low:3.0f},"
                f"{100 * success_high:4.0f}]"
            )
        print(f"{'':6s} on/off mean ratio {ratio:.2f} [{interval[0]:.2f}, {interval[1]:.2f}]")
        ratios.append((gap, ratio))
    held_out = [  # (off, on) of each pair of trials whose seed was not looked at in development
        (off["peak_neighbour_force_n"], on["peak_neighbour_force_n"])
        for gap in options.gaps
        for off, on in zip(trials[f"{gap} off"], trials[f"{gap} on"])
        if off["seed"] not in DEVELOPMENT_SEEDS
    ]
    all_off, all_on = [pair[0] for pair in held_out], [pair[1] for pair in held_out]
    overall = np.mean(all_on) / np.mean(all_off) if np.mean(all_off) > 0 else float("nan")
    overall_interval = paired_ratio_interval(all_off, all_on)
    results["overall"] = {"ratio_of_means": overall, "ratio_interval": list(overall_interval)}
    results["provenance"] = {**origin, "wall_s": round(wall, 1)}
    results["settings"] = {
        "trials": options.trials,
        "seeds": seeds,
        "gaps": options.gaps,
        "base_poses": {gap: BASE_POSES[gap] for gap in options.gaps},
        "clearance_m": {gap: (scene.gap(gap).width - scene.product(PRODUCT).size[1]) / 2.0 for gap in options.gaps},
        "assistance": vars(gui.teleop.assistance),
        "operator": vars(model),
        "stiffness_n_per_m": gui.initial_stiffness,
        "uncertainty_file": uncertainty,
        "processes": options.processes,
        "total_wall_s": wall,
    }
    met = np.isfinite(overall) and overall <= GOAL_RATIO
    results["goal"] = (
        f"{'met' if met else 'not met'}: with assistance the mean peak force on the neighbours is "
        f"{100 * overall:.0f} % of that without (95 % interval {100 * overall_interval[0]:.0f}-"
        f"{100 * overall_interval[1]:.0f} %; goal <= {100 * GOAL_RATIO:.0f} %), over "
        f"{len(all_off)} paired held-out trials (seeds not in {DEVELOPMENT_SEEDS}) at {', '.join(options.gaps)}"
    )
    print(f"{wall / 60:.1f} min wall")
    print(results["goal"])
    options.output.parent.mkdir(parents=True, exist_ok=True)
    options.output.write_text(json.dumps(results, indent=2, default=list))
    plot(results, options.output.with_suffix(".png"))
    print(f"wrote {options.output} and {options.output.with_suffix('.png')}")


if __name__ == "__main__":
    main()
