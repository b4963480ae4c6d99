"""Benchmark of skill-based shared control: the RSS paper's experiments IV-B, IV-C, IV-D and solve times.

Runs our formulation (Levenberg-Marquardt skill estimation + SQP/qpOASES trajectory optimisation, compiled and
cached) and the plain formulation (the same problems with IPOPT, default options) on the same synthetic operator
input, prints the figures and writes bench/results/shared_control.json and plots (PNG) next to it.

    source build/env.sh && python bench/shared_control.py [--quick]
"""

import argparse
import json
import math
import os
import pathlib
import platform
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from teleteach.shared_control.constraints import Box, StraightEdge, violation
from teleteach.shared_control.loop import FALLBACK, SHARED, SharedControl, SharedControlConfig
from teleteach.shared_control.metrics import position_fit
from teleteach.shared_control.models import synthetic_commands

RESULTS = pathlib.Path(__file__).resolve().parent / "results"
DT = 0.02
SPEED = 0.05  # v0 of the synthetic operator [m/s]
RHO = (0.03, 20.0, 0.0)  # amplitude/radius [m], spatial frequency [1/m] (1 Hz at 5 cm/s), phase [m]
NOISE = 0.02  # operator noise per axis [m/s]
START = (0.5, 0.0)
BOX = Box(-1.0, -0.06, 1.0, 0.2)
TARGETS = {
    "mean_total_ms": 1.0,
    "p99_total_ms": 3.0,
    "max_total_ms": 10.0,
    "speed_up": 10.0,
    "switch_delay_s": 0.5,
    "violation_m": 1e-6,
}


def run(controller, commands, obstacle_at=None):
    """Feed commands one per cycle; returns records, step wall times and the worst violation."""
    records, step_times, worst = [], [], 0.0
    for k, command in enumerate(commands):
        obstacle = obstacle_at(k) if obstacle_at else None
        controller.set_obstacle(obstacle)
        start = time.perf_counter()
        record = controller.step(command)
        step_times.append(time.perf_counter() - start)
        records.append(record)
        worst = max(worst, violation(np.array(record.state), controller.box, obstacle))
    return records, np.array(step_times), worst


def timing(records, step_times):
    """Solve-time statistics over the cycles that solved (estimation ran), CPU time (as the paper) and wall time."""
    solved = [i for i, r in enumerate(records) if r.fitting_errors]
    estimation = np.array([records[i].cpu_times[0] for i in solved]) * 1e3
    optimisation = np.array([records[i].cpu_times[1] for i in solved]) * 1e3
    total = estimation + optimisation
    wall = np.array([records[i].estimation_time + records[i].optimisation_time for i in solved]) * 1e3

    def stats(values):
        return {
            "mean": float(np.mean(values)),
            "std": float(np.std(values)),
            "p99": float(np.percentile(values, 99)),
            "max": float(np.max(values)),
        }

    return {
        "cycles": len(solved),
        "estimation_cpu_ms": stats(estimation),
        "optimisation_cpu_ms": stats(optimisation),
        "total_ms": stats(total),
        "total_wall_ms": stats(wall),
        "step_call_wall_ms": stats(step_times[solved] * 1e3),
        "cycles_over_10ms": int(np.sum(total > 10.0)),
        "cycles_over_10ms_wall": int(np.sum(wall > 10.0)),
        "estimation_iterations": stats(np.array([records[i].iterations[0] for i in solved], dtype=float)),
        "optimisation_iterations": stats(np.array([records[i].iterations[1] for i in solved], dtype=float)),
        "fallback_cycles": int(sum(r.mode == FALLBACK for r in records)),
        "fallback_messages": sorted({r.message for r in records if r.mode == FALLBACK})[:5],
        "optimisation_solved_fraction": float(np.mean([records[i].iterations[1] > 0 for i in solved])),
    }


def chunked_position_fit(skill, positions, seconds=2.0):
    """Mean F_x (eq. 12) over consecutive chunks, each with its own straight underlying trajectory."""
    size = int(round(seconds / DT))
    values = []
    for start in range(0, len(positions) - size + 1, size):
        chunk = positions[start : start + size]
        values.append(position_fit(skill, np.arange(size) * DT, chunk).value)
    return float(np.mean(values))


def switch_experiment(controller, switch_time, duration, seed):
    """IV-B: wave for switch_time seconds, then cycloid."""
    rng = np.random.default_rng(seed)
    first = synthetic_commands("wave", RHO, math.pi, SPEED, np.arange(0, switch_time, DT), NOISE, rng)
    second = synthetic_commands("cycloid", RHO, math.pi, SPEED, np.arange(0, duration - switch_time, DT), NOISE, rng)
    commands = np.vstack([first, second])
    controller.reset(START)
    controller.set_boundary(None)
    records, step_times, worst = run(controller, commands)
    switch = len(first)
    skills = [r.skill for r in records]
    detected = next((k for k in range(switch, len(skills)) if skills[k] == "cycloid"), None)
    before = sum(1 for k in range(switch) if records[k].mode == SHARED and skills[k] != "wave")
    after = None if detected is None else sum(1 for k in range(detected, len(skills)) if skills[k] != "cycloid")
    window = controller.config.n_window
    states = np.array([r.state for r in records])
    direct = np.array(START) + np.cumsum(commands, axis=0) * DT
    result = {
        "fit_x_wave_part_shared": chunked_position_fit("wave", states[window:switch]),
        "fit_x_wave_part_direct": chunked_position_fit("wave", direct[window:switch]),
        "fit_x_cycloid_part_shared": chunked_position_fit("cycloid", states[switch + window :]),
        "fit_x_cycloid_part_direct": chunked_position_fit("cycloid", direct[switch + window :]),
        "switch_cycle": switch,
        "detected_cycle": detected,
        "delay_cycles": None if detected is None else detected - switch,
        "delay_s": None if detected is None else (detected - switch) * DT,
        "misidentified_before": before,
        "misidentified_after": after,
        "worst_violation_m": worst,
    }
    return result, records, step_times, commands


def boundary_experiment(controller, duration, seed):
    """IV-C: the operator drifts towards the boundary y = BOX.y_min while waving."""
    rng = np.random.default_rng(seed)
    commands = synthetic_commands("wave", RHO, math.pi + 0.2, SPEED, np.arange(0, duration, DT), NOISE, rng)
    direct = np.array(START) + np.cumsum(commands, axis=0) * DT
    controller.reset(START)
    controller.set_boundary(BOX)
    records, step_times, worst = run(controller, commands)
    states = np.array([r.state for r in records])
    window = controller.config.n_window
    shared = [r for r in records if r.mode == SHARED]
    result = {
        "direct_violation_m": violation(direct.T, BOX, None),
        "direct_cycles_outside": int(sum(violation(p, BOX, None) > 0 for p in direct)),
        "shared_violation_m": worst,
        "wave_identified_fraction": sum(r.skill == "wave" for r in shared) / max(len(shared), 1),
        "mean_fitting_error_wave": float(np.mean([r.fitting_errors[0] for r in shared])),
        "fit_x_chunked_shared": chunked_position_fit("wave", states[window:]),
        "fit_x_chunked_direct": chunked_position_fit("wave", direct[window:]),
    }
    return result, records, step_times, direct


def obstacle_edge(k, duration):
    """IV-D: a straight edge comes down from y = 0.08 m to 0.01 m and goes back (free side below)."""
    return StraightEdge(0.0, 0.08 - 0.07 * math.sin(math.pi * k * DT / duration), -math.pi / 2)


def obstacle_experiment(controller, duration, seed):
    rng = np.random.default_rng(seed)
    commands = synthetic_commands("wave", RHO, math.pi, SPEED, np.arange(0, duration, DT), NOISE, rng)
    controller.reset(START)
    controller.set_boundary(BOX)
    records, step_times, worst = run(controller, commands, lambda k: obstacle_edge(k, duration))
    controller.set_obstacle(None)
    return {"worst_violation_m": worst}, records, step_times


def plot_switch(records, switch, path):
    states = np.array([r.state for r in records])
    times = np.arange(len(records)) * DT
    errors = np.array([r.fitting_errors if r.fitting_errors else [np.nan, np.nan] for r in records])
    figure, (top, bottom) = plt.subplots(2, 1, figsize=(9, 7))
    for skill, colour in (("wave", "tab:blue"), ("cycloid", "tab:orange"), ("", "grey")):
        mask = np.array([r.skill == skill for r in records])
        top.plot(states[mask, 0], states[mask, 1], ".", ms=2, color=colour, label=skill or "direct")
    top.set_aspect("equal")
    top.set_xlabel("x [m]")
    top.set_ylabel("y [m]")
    top.legend()
    top.set_title("IV-B skill switch: executed trajectory (moves right to left)")
    bottom.semilogy(times, errors[:, 0], label="epsilon wave")
    bottom.semilogy(times, errors[:, 1], label="epsilon cycloid")
    bottom.axvline(switch * DT, color="red", ls="--", label="operator switches")
    bottom.set_xlabel("t [s]")
    bottom.set_ylabel("fitting error [(m/s)^2]")
    bottom.legend()
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)


def plot_boundary(records, direct, path):
    states = np.array([r.state for r in records])
    figure, axis = plt.subplots(figsize=(9, 4))
    axis.plot(direct[:, 0], direct[:, 1], "k:", label="direct control")
    axis.plot(states[:, 0], states[:, 1], "tab:blue", label="shared control")
    axis.axhline(BOX.y_min, color="red", label="boundary")
    axis.set_aspect("equal")
    axis.set_xlabel("x [m]")
    axis.set_ylabel("y [m]")
    axis.legend()
    axis.set_title("IV-C static boundary")
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)


def plot_obstacle(records, duration, path):
    states = np.array([r.state for r in records])
    figure, axis = plt.subplots(figsize=(9, 4))
    axis.plot(states[:, 0], states[:, 1], "tab:blue", label="shared control")
    for k in np.linspace(0, len(records) - 1, 5).astype(int):
        edge = obstacle_edge(k, duration)
        axis.axhline(edge.y, color="red", alpha=0.3 + 0.7 * k / len(records))
        axis.plot(*states[k], "o", color="red", ms=4)
    axis.axhline(BOX.y_min, color="black")
    axis.set_aspect("equal")
    axis.set_xlabel("x [m]")
    axis.set_ylabel("y [m]")
    axis.set_title("IV-D moving straight edge (red lines: edge at the marked states)")
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)


def plot_times(ours, plain, path):
    figure, axis = plt.subplots(figsize=(9, 4))
    for label, records in (("ours (compiled LM + SQP)", ours), ("plain (IPOPT)", plain)):
        total = [1e3 * (r.estimation_time + r.optimisation_time) for r in records if r.fitting_errors]
        axis.semilogy(total, ".", ms=2, label=label)
    axis.axhline(10.0, color="red", ls="--", label="10 ms")
    axis.set_xlabel("cycle")
    axis.set_ylabel("estimation + optimisation [ms]")
    axis.legend()
    axis.set_title("Solve time per 50 Hz cycle (IV-C)")
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="shorter experiments (smoke run)")
    args = parser.parse_args()
    switch_time, duration = (8.0, 14.0) if args.quick else (20.0, 35.0)
    boundary_duration = 8.0 if args.quick else 20.0
    RESULTS.mkdir(parents=True, exist_ok=True)
    load = os.getloadavg()

    start = time.perf_counter()
    ours = SharedControl(SharedControlConfig.paper(solver="compiled"), START)
    build_s = time.perf_counter() - start
    start = time.perf_counter()
    ours_again = SharedControl(SharedControlConfig.paper(solver="compiled"), START)
    cached_build_s = time.perf_counter() - start
    del ours_again
    # The plain formulation solves both problems every cycle, as a straightforward implementation would.
    plain = SharedControl(SharedControlConfig.paper(solver="ipopt", skip_feasible_optimisation=False), START)

    switch, switch_records, switch_times, _ = switch_experiment(ours, switch_time, duration, seed=1)
    boundary, boundary_records, boundary_times, direct = boundary_experiment(ours, boundary_duration, seed=2)
    obstacle, obstacle_records, obstacle_times = obstacle_experiment(ours, boundary_duration, seed=3)
    always = SharedControl(SharedControlConfig.paper(solver="compiled", skip_feasible_optimisation=False), START)
    _, always_switch_records, always_switch_times, _ = switch_experiment(always, switch_time, duration, seed=1)
    _, always_records, always_times, _ = boundary_experiment(always, boundary_duration, seed=2)
    always_timing = timing(always_switch_records + always_records, np.concatenate([always_switch_times, always_times]))
    plain_switch, plain_switch_records, plain_switch_times, _ = switch_experiment(plain, switch_time, duration, seed=1)
    plain_boundary, plain_records, plain_times, _ = boundary_experiment(plain, boundary_duration, seed=2)

    all_ours = switch_records + boundary_records + obstacle_records
    all_times = np.concatenate([switch_times, boundary_times, obstacle_times])
    ours_timing = timing(all_ours, all_times)
    plain_timing = timing(plain_switch_records + plain_records, np.concatenate([plain_switch_times, plain_times]))
    speed_up = plain_timing["total_ms"]["mean"] / ours_timing["total_ms"]["mean"]
    speed_up_wall = plain_timing["total_wall_ms"]["mean"] / ours_timing["total_wall_ms"]["mean"]

    plot_switch(switch_records, switch["switch_cycle"], RESULTS / "shared_control_switch.png")
    plot_boundary(boundary_records, direct, RESULTS / "shared_control_boundary.png")
    plot_obstacle(obstacle_records, boundary_duration, RESULTS / "shared_control_obstacle.png")
    plot_times(boundary_records, plain_records, RESULTS / "shared_control_times.png")

    worst = max(switch["worst_violation_m"], boundary["shared_violation_m"], obstacle["worst_violation_m"])
    checks = {
        "mean_total_ms": ours_timing["total_ms"]["mean"] <= TARGETS["mean_total_ms"],
        "p99_total_ms": ours_timing["total_ms"]["p99"] <= TARGETS["p99_total_ms"],
        "max_total_ms": ours_timing["total_ms"]["max"] <= TARGETS["max_total_ms"],
        "speed_up": speed_up >= TARGETS["speed_up"],
        "switch_delay_s": switch["delay_s"] is not None and switch["delay_s"] <= TARGETS["switch_delay_s"],
        "no_misidentification": switch["misidentified_before"] == 0 and switch["misidentified_after"] == 0,
        "violation_m": worst <= TARGETS["violation_m"],
        "direct_control_crosses": boundary["direct_violation_m"] > 0,
    }
    results = {
        "machine": {"platform": platform.platform(), "python": platform.python_version(), "cpus": os.cpu_count()},
        "setup": {"dt_s": DT, "window_s": 1.0, "horizon_s": 1.0, "horizon_points": 50, "speed_m_s": SPEED,
                  "rho": RHO, "noise_m_s": NOISE, "quick": args.quick},
        "build_s": {"first_in_this_run": build_s, "with_cache": cached_build_s},
        "iv_b_switch": {"ours": switch, "plain_ipopt": plain_switch},
        "iv_c_boundary": {"ours": boundary, "plain_ipopt": plain_boundary},
        "iv_d_obstacle": {"ours": obstacle},
        "timing": {"ours": ours_timing, "ours_solving_eq9_every_cycle": always_timing, "plain_ipopt": plain_timing,
                   "speed_up_mean_cpu": speed_up, "speed_up_mean_wall": speed_up_wall,
                   "load_average": [load[0], os.getloadavg()[0]]},
        "targets": TARGETS,
        "checks": checks,
    }  # fmt: skip
    (RESULTS / "shared_control.json").write_text(json.dumps(results, indent=2))

    def line(name, t):
        total, est, opt, wall = t["total_ms"], t["estimation_cpu_ms"], t["optimisation_cpu_ms"], t["total_wall_ms"]
        return (
            f"  {name}:\n         CPU total {total['mean']:.3f} +- {total['std']:.3f} ms (p99 {total['p99']:.3f}, max "
            f"{total['max']:.3f}; {t['cycles_over_10ms']} cycles > 10 ms) = estimation {est['mean']:.3f} + "
            f"optimisation {opt['mean']:.3f} ms\n"
            f"         wall total {wall['mean']:.3f} ms (p99 {wall['p99']:.3f}, max {wall['max']:.3f}; "
            f"{t['cycles_over_10ms_wall']} cycles > 10 ms); step() call {t['step_call_wall_ms']['mean']:.3f} ms; "
            f"iterations {t['estimation_iterations']['mean']:.1f} (both skills, max "
            f"{t['estimation_iterations']['max']:.0f}) + {t['optimisation_iterations']['mean']:.1f} (max "
            f"{t['optimisation_iterations']['max']:.0f}); eq. 9 solved (plan of theta_hat infeasible) in "
            f"{100 * t['optimisation_solved_fraction']:.1f} % of cycles; fallback cycles {t['fallback_cycles']}"
        )

    print(f"load average during the run: {load[0]:.2f} -> {os.getloadavg()[0]:.2f} (2 cores are shared)")
    print(f"start-up: {build_s:.2f} s (first in this run), {cached_build_s:.2f} s with the compiled cache")
    print(
        f"IV-B switch: delay {switch['delay_cycles']} cycles ({switch['delay_s']} s); misidentified "
        f"{switch['misidentified_before']} before / {switch['misidentified_after']} after; "
        f"plain IPOPT: delay {plain_switch['delay_cycles']} cycles, misidentified "
        f"{plain_switch['misidentified_before']} / {plain_switch['misidentified_after']}"
    )
    print(
        f"  F_x (2 s chunks) wave part: shared {switch['fit_x_wave_part_shared']:.3e}, direct "
        f"{switch['fit_x_wave_part_direct']:.3e}; cycloid part: shared {switch['fit_x_cycloid_part_shared']:.3e}, "
        f"direct {switch['fit_x_cycloid_part_direct']:.3e} m^2/s"
    )
    print(
        f"IV-C boundary: direct control crosses by {boundary['direct_violation_m']:.4f} m "
        f"({boundary['direct_cycles_outside']} cycles outside); shared worst violation "
        f"{boundary['shared_violation_m']:.2e} m (plain {plain_boundary['shared_violation_m']:.2e} m); "
        f"wave kept in {100 * boundary['wave_identified_fraction']:.1f} % of cycles, mean epsilon_wave "
        f"{boundary['mean_fitting_error_wave']:.2e} (m/s)^2 (plain {plain_boundary['mean_fitting_error_wave']:.2e}); "
        f"F_x (2 s chunks) shared {boundary['fit_x_chunked_shared']:.3e}, direct "
        f"{boundary['fit_x_chunked_direct']:.3e} m^2/s"
    )
    print(f"IV-D moving edge: worst violation {obstacle['worst_violation_m']:.2e} m")
    print("solve time per 50 Hz cycle (both skills estimated + trajectory optimisation):")
    print(line("ours (IV-B + IV-C + IV-D)", ours_timing))
    print(line("ours, eq. 9 solved every cycle (IV-B + IV-C)", always_timing))
    print(line("plain IPOPT, eq. 9 solved every cycle (IV-B + IV-C)", plain_timing))
    print(f"  speed-up (mean CPU total): {speed_up:.1f}x (wall: {speed_up_wall:.1f}x); solving eq. 9 every cycle: "
          f"{plain_timing['total_ms']['mean'] / always_timing['total_ms']['mean']:.1f}x")  # fmt: skip
    print("checks: " + ", ".join(f"{k}={'PASS' if v else 'FAIL'}" for k, v in checks.items()))
    print(f"wrote {RESULTS / 'shared_control.json'} and plots")


if __name__ == "__main__":
    main()
