"""Benchmark of learning stiffness skills with geometry-aware DMPs (thesis Appendix C), and the sweep behind defaults.

Reproduction error (what the targets refer to). For a demonstration whose recorded stiffness samples are D_k at times
t_k (the samples the GUI published, recovered from the recorder's zero-order-hold staircase) and a reproduction R(t)
of the same duration and goal (R between its 50 Hz samples taken on geodesics):

    e_k    = d(D_k, R(t_k)),   d(A, B) = ||logm(A^-1/2 B A^-1/2)||_F   (affine-invariant Riemannian distance)
    spread = sqrt(mean_k d(D_k, M)^2),  M = Karcher mean of the D_k  (the demonstration's geodesic std deviation)
    mean relative error = mean_k e_k / spread,  max relative error = max_k e_k / spread.

Targets: mean <= 5 %, max <= 15 % on (a) a 45-degree placement demonstration recorded at a low GUI rate (4 Hz with
+-30 % jitter and 0.3 s lag, zero-order hold at 100 Hz, 102 s like thesis Fig. C.1) and (b) a smooth perpendicular
placement demonstration (GUI at the recorder rate); learning time (preprocessing + all DMPs) for the 102 s demo
<= 1 s (judged on the fastest of 5 runs or the median CPU time: the machine is shared, wall times swing with load).
Also reported: the error against the operator's intended (smooth) stiffness, and the thesis' setting
(staircase fitted as recorded, N = 40, alpha_z = 48/3, the defaults of the code the thesis used) for comparison.

The sweep (stiffness DMP only) varies basis functions per second, smoothing width and alpha_z on (a), (b) and (c),
a fast operator (the 45-degree demo compressed to 30 s at 4 Hz: transitions of about 1 s). The rule that picks the
defaults: among settings whose worst case over (a)-(c) keeps mean <= 2.5 % and max <= 7.5 % (half the targets),
take the largest smoothing (smoothest reproduction), then the fewest basis functions, then the best worst-case max.
Then alpha_z: the best worst-case max among the gains that reach a goal switched at 70 % of the duration (1.5x
stiffer, rotated 20 degrees about Z) to within 5 % of the switch distance by the end (a soft spring reaches it late).

Run: ``source build/env.sh && python bench/learning.py`` (writes bench/results/learning.json and the PNGs).
"""

import itertools
import json
import os
import pathlib
import statistics
import time

import numpy as np

from teleteach.core.rotations import yaw_rotation
from teleteach.learning import spd
from teleteach.learning.dmp import SPDDMP
from teleteach.learning.plot import write_figure_c1
from teleteach.learning.preprocess import prepare
from teleteach.learning.skill import LearningParameters, learn_skill, reproduction_error
from teleteach.learning.synthetic import placement_demo

RESULTS = pathlib.Path(__file__).resolve().parent / "results"
TARGET_MEAN, TARGET_MAX, TARGET_TIME = 0.05, 0.15, 1.0
SMOOTHING = (0.0, 0.05, 0.1, 0.2, 0.4)  # [s]
DENSITY = (40 / 102, 1.0, 2.0, 4.0, 6.0)  # basis functions per second (40 / 102 s: the thesis' N = 40)
ALPHA_Z = (48 / 3, 48.0, 100.0)
GUI_RATES = (1.0, 2.0, 4.0, 10.0)  # [Hz]
GOAL_RESIDUAL = 0.05  # a goal switched at 70 % of the duration must be reached to within 5 % by the end


def demos():
    return {
        "a_gui_rate_45deg": placement_demo(angle=45.0, duration=102.0, gui_rate=4.0, seed=1),
        "b_smooth_perpendicular": placement_demo(angle=0.0, duration=102.0, gui_rate=None, seed=2),
        "c_fast_operator_45deg": placement_demo(angle=45.0, duration=30.0, gui_rate=4.0, seed=3),
    }


def peak_rate(times, matrices):
    """Largest rate of change of the stiffness along the trajectory, d(X_k, X_k+1) / dt [1/s]."""
    return float(np.max(spd.distance(matrices[:-1], matrices[1:]) / np.diff(times)))


def stiffness_only(skill, truth_times, truth, parameters):
    """Error and timing of the stiffness DMP alone (what the sweep varies)."""
    started = time.perf_counter()
    demo = prepare(
        skill.time,
        skill.stiffness,
        {"cartesian_pose": (skill.time, skill.cartesian_pose)},
        parameters.rate,
        parameters.smoothing,
        recover_gui_samples=parameters.recover_gui_samples,
    )
    model = SPDDMP.learn(demo.time, demo.stiffness, parameters.dmp_parameters(demo.duration))
    learned = time.perf_counter() - started
    times, reproduced = model.rollout(dt=1.0 / parameters.rate)
    error = reproduction_error(demo.sample_time, demo.samples, times, reproduced)
    # goal response: switch at 70 % of the duration to a goal 1.5x stiffer and rotated 20 degrees about Z
    turn = yaw_rotation(np.radians(20.0)).as_matrix()
    new_goal = 1.5 * turn @ model.goal @ turn.T
    _, switched = model.rollout(dt=1.0 / parameters.rate, switch=(0.7 * demo.duration, new_goal))
    goal_residual = spd.distance(switched[-1], new_goal) / spd.distance(model.goal, new_goal)
    versus_truth = reproduction_error(truth_times - demo.start_time, truth, times, reproduced)
    return {
        "mean_relative": error["mean_relative"],
        "max_relative": error["max_relative"],
        "truth_mean_relative": versus_truth["mean_relative"],
        "truth_max_relative": versus_truth["max_relative"],
        "peak_rate": peak_rate(times, reproduced),
        "goal_residual": float(goal_residual),
        "learning_time": learned,
        "basis_count": model.parameters.basis_count,
    }


def sweep(cases):
    rows = []
    for smoothing, density in itertools.product(SMOOTHING, DENSITY):
        parameters = LearningParameters.from_yaml(smoothing=smoothing, basis_per_second=density)
        rows.append(
            {
                "smoothing": smoothing,
                "basis_per_second": density,
                "alpha_z": parameters.alpha_z,
                **{name: stiffness_only(*case, parameters) for name, case in cases.items()},
            }
        )
        print_row(rows[-1], cases)
    return rows


def worst(row, cases, key):
    return max(row[name][key] for name in cases)


def print_row(row, cases):
    cells = "  ".join(
        f"{name[:1]}: {100 * row[name]['mean_relative']:5.2f}/{100 * row[name]['max_relative']:6.2f}%" for name in cases
    )
    cells += f"  goal residual {100 * worst(row, cases, 'goal_residual'):5.1f}%"
    print(
        f"  smoothing {row['smoothing']:4.2f} s  N/s {row['basis_per_second']:4.2f}  alpha_z {row['alpha_z']:5.1f}"
        f"  {cells}",
        flush=True,
    )


def choose(rows, cases):
    acceptable = [
        row
        for row in rows
        if worst(row, cases, "mean_relative") <= TARGET_MEAN / 2 and worst(row, cases, "max_relative") <= TARGET_MAX / 2
    ]
    if not acceptable:
        return min(rows, key=lambda row: worst(row, cases, "max_relative"))
    return min(
        acceptable, key=lambda row: (-row["smoothing"], row["basis_per_second"], worst(row, cases, "max_relative"))
    )


def full_learning(name, case, parameters, runs=5):
    skill, truth_times, truth = case
    timings, cpu_timings = [], []
    for _ in range(runs):
        learned = learn_skill(skill, "Bench", parameters)
        timings.append(learned.learning_time)
        cpu_timings.append(learned.learning_cpu_time)
    started = time.perf_counter()
    reproduction = learned.reproduce()
    rollout_time = time.perf_counter() - started
    error = learned.error(reproduction)
    versus_truth = reproduction_error(
        truth_times - learned.demonstration.start_time, truth, reproduction.time, reproduction.stiffness
    )
    return (
        learned,
        reproduction,
        {
            "demo": name,
            "duration": learned.demonstration.duration,
            "recorded_samples": int(skill.time.size),
            "gui_samples": error["samples"],
            "basis_count": learned.stiffness.parameters.basis_count,
            "spread": error["spread"],
            "mean_relative": error["mean_relative"],
            "max_relative": error["max_relative"],
            "truth_mean_relative": versus_truth["mean_relative"],
            "truth_max_relative": versus_truth["max_relative"],
            "peak_rate": peak_rate(reproduction.time, reproduction.stiffness),
            "learning_time_min": min(timings),
            "learning_time_median": statistics.median(timings),
            "learning_time_max": max(timings),
            "learning_cpu_time_median": statistics.median(cpu_timings),
            "load_average_1min": os.getloadavg()[0],
            "reproduction_time": rollout_time,
            "meets_targets": error["mean_relative"] <= TARGET_MEAN and error["max_relative"] <= TARGET_MAX,
        },
    )


def main():
    RESULTS.mkdir(parents=True, exist_ok=True)
    cases = demos()
    defaults = LearningParameters.from_yaml()
    print("sweep (mean/max relative error per demo: a GUI-rate 45 deg, b smooth, c fast operator)")
    rows = sweep(cases)
    chosen = choose(rows, cases)
    print(f"sweep choice: smoothing {chosen['smoothing']} s, {chosen['basis_per_second']} basis functions per second")
    gain_rows = []
    for alpha_z in ALPHA_Z:
        parameters = LearningParameters.from_yaml(
            smoothing=chosen["smoothing"], basis_per_second=chosen["basis_per_second"], alpha_z=alpha_z
        )
        gain_rows.append(
            {
                "smoothing": chosen["smoothing"],
                "basis_per_second": chosen["basis_per_second"],
                "alpha_z": alpha_z,
                **{name: stiffness_only(*case, parameters) for name, case in cases.items()},
            }
        )
        print_row(gain_rows[-1], cases)
    responsive = [row for row in gain_rows if worst(row, cases, "goal_residual") <= GOAL_RESIDUAL] or gain_rows
    best_gain = min(responsive, key=lambda row: worst(row, cases, "max_relative"))["alpha_z"]
    print(f"alpha_z choice: {best_gain}")
    defaults_match = (defaults.smoothing, defaults.basis_per_second, defaults.alpha_z) == (
        chosen["smoothing"],
        chosen["basis_per_second"],
        best_gain,
    )
    print(
        f"library defaults (smoothing {defaults.smoothing}, N/s {defaults.basis_per_second}, alpha_z "
        f"{defaults.alpha_z}) {'match' if defaults_match else 'DIFFER FROM'} the sweep's choice"
    )

    print("robustness to the GUI rate (45 deg, 102 s, library defaults; mean/max relative error)")
    gui_rates = {}
    for rate in GUI_RATES:
        case = placement_demo(angle=45.0, duration=102.0, gui_rate=rate, seed=4)
        row = gui_rates[rate] = stiffness_only(*case, defaults)
        print(f"  GUI {rate:4.1f} Hz: {100 * row['mean_relative']:5.2f}/{100 * row['max_relative']:6.2f}%")

    thesis = LearningParameters.from_yaml(
        smoothing=0.0, basis_per_second=40 / 102, alpha_z=48 / 3, recover_gui_samples=False
    )
    results = {}
    for name in ("a_gui_rate_45deg", "b_smooth_perpendicular"):
        learned, reproduction, summary = full_learning(name, cases[name], defaults)
        results[name] = summary
        demo = learned.demonstration
        png = RESULTS / f"learning_fig_c1_{name}.png"
        write_figure_c1(png, demo.sample_time, demo.samples, reproduction.time, reproduction.stiffness, title=name)
        summary["figure"] = str(png)
        baseline, baseline_reproduction, baseline_summary = full_learning(name, cases[name], thesis, runs=1)
        results[f"{name}_thesis_setting"] = baseline_summary
        png = RESULTS / f"learning_fig_c1_{name}_thesis_setting.png"
        write_figure_c1(
            png,
            baseline.demonstration.sample_time,
            baseline.demonstration.samples,
            baseline_reproduction.time,
            baseline_reproduction.stiffness,
            title=f"{name}: thesis setting (staircase as recorded, N = 40, alpha_z = 16)",
        )
        baseline_summary["figure"] = str(png)
    print()
    print(f"load average (1 min) {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores: wall times are inflated by it")
    print(
        f"{'demo':40s} {'N':>4s} {'mean %':>7s} {'max %':>7s} {'truth mean %':>12s} {'learn s (min/med)':>18s}"
        f" {'learn cpu s':>11s} {'rollout s':>9s}"
    )
    for name, row in results.items():
        print(
            f"{name:40s} {row['basis_count']:4d} {100 * row['mean_relative']:7.2f} {100 * row['max_relative']:7.2f} "
            f"{100 * row['truth_mean_relative']:12.2f} {row['learning_time_min']:8.3f}/"
            f"{row['learning_time_median']:.3f} {row['learning_cpu_time_median']:11.3f} {row['reproduction_time']:9.3f}"
        )
    timing = results["a_gui_rate_45deg"]
    passed = all(results[name]["meets_targets"] for name in ("a_gui_rate_45deg", "b_smooth_perpendicular")) and (
        min(timing["learning_time_min"], timing["learning_cpu_time_median"]) <= TARGET_TIME
    )
    print(f"targets (mean <= 5 %, max <= 15 %, learning <= 1 s for 102 s): {'MET' if passed else 'NOT MET'}")
    report = {
        "definition": __doc__.split("Targets:")[0].strip(),
        "targets": {"mean_relative": TARGET_MEAN, "max_relative": TARGET_MAX, "learning_time": TARGET_TIME},
        "defaults": {
            "rate": defaults.rate,
            "smoothing": defaults.smoothing,
            "basis_per_second": defaults.basis_per_second,
            "alpha_z": defaults.alpha_z,
            "alpha_x": defaults.alpha_x,
        },
        "sweep": rows,
        "sweep_choice": {"smoothing": chosen["smoothing"], "basis_per_second": chosen["basis_per_second"]},
        "alpha_z_sweep": gain_rows,
        "alpha_z_choice": best_gain,
        "gui_rate_robustness": {str(rate): row for rate, row in gui_rates.items()},
        "defaults_match_sweep": defaults_match,
        "results": results,
        "targets_met": passed,
    }
    (RESULTS / "learning.json").write_text(json.dumps(report, indent=2))
    print(f"wrote {RESULTS / 'learning.json'}")


if __name__ == "__main__":
    main()
