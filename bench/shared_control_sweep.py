"""Sweep of skill identification through the node's message path (issue 15): does it depend on the operator only?

Each cell: the operator waves then loops (or the reverse) with an amplitude and spatial frequency away from the
paper's (0.03 m, 20 1/m), white noise, and messages at 50 Hz delivered with a random delay and some dropped. The
controller reads them as the node does (``CommandTimeline`` by header stamp, sampled ``command_delay`` before each
cycle, on a cycle grid offset from the operator's), so the bench runs the node's code without a roscore; a simulated
clock makes the figures independent of the machine's load, which ``--busy`` demonstrates by running them again with
a busy loop on one core. ``--latest`` uses the node's previous reading (the latest message that has arrived) and
``--paper`` the paper's identification (no hysteresis, a uniform 1 s window), for comparison.

Per cell: misidentified cycles (estimation cycles, SHARED or UNKNOWN, whose skill is off the operator's pattern,
outside the 0.5 s allowed after the switch), flicker (returns to a skill the identification had left), switch
delay. Prints a table, writes bench/results/shared_control_sweep.json.

    source build/env.sh && python bench/shared_control_sweep.py [--quick] [--busy] [--latest] [--paper]
"""

import argparse
import dataclasses
import itertools
import json
import math
import os
import pathlib
import platform
import subprocess
import sys
import time

import numpy as np
import yaml

from teleteach.shared_control.loop import SHARED, UNKNOWN, SharedControl, SharedControlConfig
from teleteach.shared_control.models import synthetic_commands
from teleteach.shared_control.timeline import CommandTimeline

ROOT = pathlib.Path(__file__).resolve().parent.parent
RESULTS = ROOT / "bench" / "results"
DT = 0.02
SPEED = 0.05  # the paper's v0 [m/s]
AMPLITUDES = (0.015, 0.045)  # [m] (paper: 0.03)
FREQUENCIES = (12.0, 30.0)  # spatial [1/m] (paper: 20; 0.6 and 1.5 Hz at 5 cm/s)
NOISES = (0.0, 0.01)  # per axis [m/s]
MAX_DELAY = 0.015  # delivery delay, uniform in [0, MAX_DELAY] [s]
DROPPED = 0.05  # fraction of messages lost
SEGMENT = 4.0  # seconds of each pattern
GOALS = {"misidentified_fraction": 0.01, "flicker": 0, "switch_delay_s": 0.5}


def node_parameters():
    """The node's parameters from config/shared_control.yaml (the defaults the bench must hold for)."""
    with open(ROOT / "config" / "shared_control.yaml") as stream:
        return yaml.safe_load(stream)


def deliveries(commands, rng, operator_offset):
    """(arrival, stamp, command) of each message that arrives, in arrival order."""
    stamps = operator_offset + DT * np.arange(len(commands))
    arrivals = stamps + rng.uniform(0.0, MAX_DELAY, len(stamps))
    kept = rng.random(len(stamps)) >= DROPPED
    order = np.argsort(arrivals[kept], kind="stable")
    return [(arrivals[kept][i], stamps[kept][i], commands[kept][i]) for i in order]


def run_through_message_path(controller, commands, rng, params, latest):
    """Feed the commands as ROS would deliver them and the node would read them; returns the records."""
    messages = deliveries(commands, rng, operator_offset=rng.uniform(0.0, DT))
    timeline = CommandTimeline(params["command_timeout"])
    newest = (-math.inf, np.zeros(2))  # the previous reading: latest arrival, counted from when it arrived
    records, received = [], 0
    for k in range(len(commands)):
        cycle_time = DT * (k + 1)
        while received < len(messages) and messages[received][0] <= cycle_time:
            arrival, stamp, command = messages[received]
            timeline.add(stamp, command)
            newest = (arrival, command)
            received += 1
        if latest:
            command = newest[1] if cycle_time - newest[0] <= params["command_timeout"] else np.zeros(2)
        else:
            command = timeline.sample(cycle_time - params["command_delay"])
        records.append(controller.step(command))
    return records


def score(records, first, second, switch):
    """Misidentified cycles, flicker and switch delay of one run (switch: index of the first cycle of ``second``)."""
    limit = int(round(GOALS["switch_delay_s"] / DT))
    skills = [r.skill if r.mode in (SHARED, UNKNOWN) else None for r in records]
    judged = [(k, s) for k, s in enumerate(skills) if s is not None and not switch <= k < switch + limit]
    wrong = sum(s != (first if k < switch else second) for k, s in judged)
    detected = next((k for k in range(switch, len(skills)) if skills[k] == second), None)
    flicker, left, current = 0, set(), None
    for skill in (s for s in skills if s is not None):
        if skill != current:
            if skill in left:
                flicker += 1
            if current is not None:
                left.add(current)
            current = skill
    return {
        "shared_cycles": len(judged),
        "misidentified": wrong,
        "flicker": flicker,
        "switch_delay_s": None if detected is None else (detected - switch) * DT,
    }


def sweep(controller, params, latest, quick, seed):
    rng = np.random.default_rng(seed)
    cells = []
    amplitudes, frequencies, noises = (AMPLITUDES[:1], FREQUENCIES, NOISES[1:]) if quick else (
        AMPLITUDES, FREQUENCIES, NOISES
    )  # fmt: skip
    for (first, second), amplitude, frequency, noise in itertools.product(
        (("wave", "cycloid"), ("cycloid", "wave")), amplitudes, frequencies, noises
    ):
        heading = rng.uniform(-math.pi, math.pi)
        rho = (amplitude, frequency, 0.0)
        times = np.arange(0.0, SEGMENT, DT)
        commands = np.vstack(
            [
                synthetic_commands(first, rho, heading, SPEED, times, noise, rng),
                synthetic_commands(second, rho, heading, SPEED, times, noise, rng),
            ]
        )
        controller.reset((0.0, 0.0))
        start = time.perf_counter()
        records = run_through_message_path(controller, commands, rng, params, latest)
        elapsed = time.perf_counter() - start
        cell = {
            "patterns": f"{first}->{second}",
            "amplitude_m": amplitude,
            "frequency_per_m": frequency,
            "noise_m_s": noise,
            **score(records, first, second, len(times)),
            "mean_step_ms": 1e3 * elapsed / len(records),
        }
        cell["misidentified_fraction"] = cell["misidentified"] / max(cell["shared_cycles"], 1)
        cell["meets_goals"] = bool(
            cell["misidentified_fraction"] <= GOALS["misidentified_fraction"]
            and cell["flicker"] <= GOALS["flicker"]
            and cell["switch_delay_s"] is not None
            and cell["switch_delay_s"] <= GOALS["switch_delay_s"]
        )
        cells.append(cell)
        delay = None if cell["switch_delay_s"] is None else round(cell["switch_delay_s"], 2)
        print(
            f"{cell['patterns']:>14} A {amplitude:.3f} f {frequency:4.0f} noise {noise:.3f}: "
            f"misidentified {cell['misidentified']:3d}/{cell['shared_cycles']:3d} "
            f"({100 * cell['misidentified_fraction']:4.1f} %), flicker {cell['flicker']}, "
            f"delay {delay} s, "
            f"{cell['mean_step_ms']:.1f} ms/cycle {'ok' if cell['meets_goals'] else 'MISSES GOAL'}",
            flush=True,
        )
    return cells


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="a quarter of the cells")
    parser.add_argument("--busy", action="store_true", help="run the sweep again with a busy loop on one core")
    parser.add_argument("--latest", action="store_true", help="read the latest message (the node's old reading)")
    parser.add_argument(
        "--paper", action="store_true", help="the paper's identification: no hysteresis, a uniform 1 s window"
    )
    parser.add_argument("--solver", default="fast", help="compiled | fast | ipopt (fast needs no compiled cache)")
    parser.add_argument("--seed", type=int, default=15)
    parser.add_argument("--switch-confidence", type=float, help="override config/shared_control.yaml")
    parser.add_argument("--switch-hold", type=float, help="override config/shared_control.yaml [s]")
    parser.add_argument("--window-time", type=float, help="override config/shared_control.yaml [s]")
    parser.add_argument("--recency-half-life", type=float, help="override config/shared_control.yaml [s]")
    args = parser.parse_args()
    params = node_parameters()
    config = dataclasses.replace(SharedControlConfig.from_parameters(params), solver=args.solver)
    for name in ("switch_confidence", "switch_hold", "window_time", "recency_half_life"):
        if getattr(args, name) is not None:
            config = dataclasses.replace(config, **{name: getattr(args, name)})
    if args.paper:
        config = dataclasses.replace(
            config, switch_confidence=0.0, switch_hold=0.0, window_time=1.0, recency_half_life=0.0
        )
    controller = SharedControl(config, (0.0, 0.0))
    runs = {"idle": None}
    if args.busy:
        runs["busy_one_core"] = [sys.executable, "-c", "while True: pass"]
    result = {
        "reading": "latest arrival" if args.latest else f"by stamp, {params['command_delay']} s before each cycle",
        "identification": "paper (no hysteresis)"
        if args.paper
        else (f"hysteresis: confidence {config.switch_confidence}, hold {config.switch_hold} s"),  # fmt: skip
        "solver": args.solver,
        "delivery": {"max_delay_s": MAX_DELAY, "dropped": DROPPED, "rate_hz": 1.0 / DT},
        "goals": GOALS,
        "machine": {"cpus": os.cpu_count(), "python": platform.python_version()},
    }
    for name, busy_command in runs.items():
        print(f"--- {name}: {result['reading']}; {result['identification']}")
        busy = subprocess.Popen(busy_command) if busy_command else None
        try:
            cells = sweep(controller, params, args.latest, args.quick, args.seed)
        finally:
            if busy:
                busy.kill()
                busy.wait()
        delays = [c["switch_delay_s"] for c in cells if c["switch_delay_s"] is not None]
        summary = {
            "cells": len(cells),
            "cells_meeting_goals": sum(c["meets_goals"] for c in cells),
            "worst_misidentified_fraction": max(c["misidentified_fraction"] for c in cells),
            "total_flicker": sum(c["flicker"] for c in cells),
            "worst_switch_delay_s": max(delays) if len(delays) == len(cells) else None,
        }
        print(f"{name}: {summary}")
        result[name] = {"summary": summary, "cells": cells}
    RESULTS.mkdir(parents=True, exist_ok=True)
    suffix = ("_latest" if args.latest else "") + ("_paper" if args.paper else "") + ("_quick" if args.quick else "")
    path = RESULTS / f"shared_control_sweep{suffix}.json"
    path.write_text(json.dumps(result, indent=2))
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
