"""Authority that follows confidence against the paper's always-shared control, on known and unknown patterns.

The operator draws a wave or a cycloid (skills the models know) or a zig-zag or a circle (they do not), with noise,
drifting across the top of the boundary. Both controllers run on the same commands: the paper's (the plan always,
``blend_authority: false``) and the blend of config/shared_control.yaml. Per pattern: deviation of the executed
path from the operator's intended one (the noise-free commands integrated, clipped to the boundary), fraction of
cycles where the executed step overrode the operator's (differs from their command by more than half of it), mean
authority, UNKNOWN cycles, constraint violations (must be zero). Prints a table, writes
bench/results/shared_control_authority.json.

    source build/env.sh && python bench/shared_control_authority.py [--seconds S]
"""

import argparse
import dataclasses
import json
import math
import pathlib

import numpy as np
import yaml

from teleteach.shared_control.constraints import Box, violation
from teleteach.shared_control.loop import DIRECT, UNKNOWN, SharedControl, SharedControlConfig
from teleteach.shared_control.models import synthetic_commands

ROOT = pathlib.Path(__file__).resolve().parent.parent
RESULTS = ROOT / "bench" / "results"
DT = 0.02
SPEED = 0.05  # the paper's v0 [m/s]
HEADING = 0.25  # [rad]: the drift crosses the top of the boundary
BOX = Box(-0.25, -0.15, 0.25, 0.06)
START = (-0.2, 0.0)
NOISE = 0.005  # per axis [m/s]


def zigzag(times):
    """Straight strokes alternating +-45 degrees about the heading, 0.5 s each: no skill has corners."""
    side = np.where(np.floor(times / 0.5) % 2 == 0, 1.0, -1.0)
    angle = HEADING + side * math.pi / 4
    return SPEED * math.sqrt(2) * np.column_stack([np.cos(angle), np.sin(angle)])


def circle(times):
    """A 4 cm circle at 0.5 Hz drawn on the spot: no forward motion for the skills' underlying trajectory."""
    w = 2 * math.pi * 0.5
    return 0.04 * w * np.column_stack([-np.sin(w * times), np.cos(w * times)])


def patterns(times):
    rho = (0.03, 20.0, 0.0)
    return {
        "wave (known)": synthetic_commands("wave", rho, HEADING, SPEED, times),
        "cycloid (known)": synthetic_commands("cycloid", rho, HEADING, SPEED, times),
        "zig-zag (unknown)": zigzag(times),
        "circle (unknown)": circle(times),
    }


def config_from_yaml(**changes):
    with open(ROOT / "config" / "shared_control.yaml") as stream:
        params = yaml.safe_load(stream)
    return dataclasses.replace(SharedControlConfig.from_parameters(params), solver="fast", **changes)


def intended_path(clean):
    """The operator's intended positions: the noise-free commands integrated, held inside the boundary."""
    positions, position = [], np.array(START, dtype=float)
    for command in clean:
        position = np.clip(position + command * DT, [BOX.x_min, BOX.y_min], [BOX.x_max, BOX.y_max])
        positions.append(position)
    return np.array(positions)


def measure(controller, clean, noisy):
    controller.reset(START)
    controller.set_boundary(BOX)
    records = [controller.step(command) for command in noisy]
    states = np.array([r.state for r in records])
    executed = np.diff(np.vstack([START, states]), axis=0) / DT
    judged = np.array([r.mode != DIRECT for r in records])
    deviation = np.linalg.norm(states - intended_path(clean), axis=1)[judged]
    speeds = np.linalg.norm(noisy, axis=1)
    overridden = (np.linalg.norm(executed - noisy, axis=1) > 0.5 * np.maximum(speeds, 1e-6))[judged]
    return {
        "mean_deviation_mm": 1e3 * float(np.mean(deviation)),
        "p95_deviation_mm": 1e3 * float(np.percentile(deviation, 95)),
        "overridden_fraction": float(np.mean(overridden)),
        "mean_authority": float(np.mean([r.authority for r in records if r.mode != DIRECT])),
        "unknown_fraction": float(np.mean([r.mode == UNKNOWN for r in records if r.mode != DIRECT])),
        "violations": int(sum(violation(np.array(r.state), BOX, None) > 1e-9 for r in records)),
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seconds", type=float, default=8.0, help="length of each pattern [s]")
    parser.add_argument("--seed", type=int, default=15)
    args = parser.parse_args()
    times = np.arange(0.0, args.seconds, DT)
    rng = np.random.default_rng(args.seed)
    controllers = {
        "paper (always shared)": SharedControl(config_from_yaml(blend_authority=False), START),
        "authority follows confidence": SharedControl(config_from_yaml(), START),
    }
    result = {"box": dataclasses.asdict(BOX), "noise_m_s": NOISE, "seconds": args.seconds, "patterns": {}}
    print(f"{'pattern':>18} {'controller':>29} {'dev mean/p95 [mm]':>18} {'overridden':>10} {'authority':>9} "
          f"{'unknown':>8} {'violations':>10}")  # fmt: skip
    for name, clean in patterns(times).items():
        noisy = clean + NOISE * rng.standard_normal(clean.shape)
        result["patterns"][name] = {}
        for label, controller in controllers.items():
            figures = measure(controller, clean, noisy)
            result["patterns"][name][label] = figures
            print(
                f"{name:>18} {label:>29} {figures['mean_deviation_mm']:8.1f} /{figures['p95_deviation_mm']:6.1f}   "
                f"{100 * figures['overridden_fraction']:8.1f} % {figures['mean_authority']:9.2f} "
                f"{100 * figures['unknown_fraction']:6.1f} % {figures['violations']:10d}",
                flush=True,
            )
    RESULTS.mkdir(parents=True, exist_ok=True)
    path = RESULTS / "shared_control_authority.json"
    path.write_text(json.dumps(result, indent=2))
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
