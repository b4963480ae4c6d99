"""Sweep of shared control over ROS (issue 31): does it hold for operators nobody tuned it to, at the boundary?

Question: with operator commands at 50 Hz into the real node (``shared_control.launch``, compiled solvers, its own
roscore), does every cell keep <= 1 % misidentified cycles, no flicker, a switch recognised within 0.5 s, 50 Hz with
<= 0.5 % late cycles, <= 1 % FALLBACK, no state outside the boundary and a solve time p99 <= 2 ms?

Cells (each: one pattern, then a switch to the other, the hand blending over 0.2 s where the path is human):
- ``synthetic``: the identifier's own model family (``synthetic_commands``), amplitude and spatial frequency away
  from the paper's, 1 cm/s noise: what the identification was tuned on before.
- ``push``: the issue's operator (wave 0.7 Hz / 1.5 cm, then cycloid 1.1 Hz / 1.2 cm, 0.8 cm/s noise, 5 cm/s) heading
  into the boundary, meeting it after 3-5 s and pushing 20 s before switching, and the reverse order.
- ``lasa-tuned`` and ``lasa-held-out``: the same patterns drawn around a human handwriting stroke of the LASA data
  set (``operators.lasa_path``: scaled to fill the boundary from the start, 3 cm inside it, mean speed 5 cm/s, the
  human speed profile and curvature kept). Development looked at the shapes in ``TUNED_SHAPES`` only; the held-out
  cells are every other shape (first demonstration), and they are what the README reports.
- ``minimum-jerk``: the patterns around overlapping minimum-jerk reaches to random targets (seeded).

Per cell it prints the figures, and it ends with one line per goal (met / not met over every cell). ``--busy`` runs
the sweep again with a busy loop on one core; ``--in-process`` runs the node's code without ROS on a simulated clock
(quick, for development: rate and lateness are then not measured), with ``--wall-clock`` each cycle waiting for its
20 ms slot as the node's loop does (what a periodic loop pays in solve time, without ROS). Writes
bench/results/shared_control_sweep.json.

    source build/env.sh && python bench/shared_control_sweep.py [--busy] [--in-process [--wall-clock]] [--groups G ...]
"""

import argparse
import collections
import dataclasses
import json
import math
import os
import pathlib
import platform
import subprocess
import sys
import tempfile
import threading
import time
from typing import List, Optional

import numpy as np
import yaml

from teleteach.shared_control.constraints import Box, violation
from teleteach.shared_control.loop import FALLBACK, SHARED, UNKNOWN, SharedControl, SharedControlConfig
from teleteach.shared_control.models import synthetic_commands
from teleteach.shared_control.operators import (
    commands_around_path,
    lasa_path,
    lasa_shapes,
    reaching_path,
    retime,
)
from teleteach.shared_control.timeline import CommandTimeline

ROOT = pathlib.Path(__file__).resolve().parent.parent
RESULTS = ROOT / "bench" / "results"
DT = 0.02
SPEED = 0.05  # the operator's base speed [m/s] (the paper's v0)
WAVE = ("wave", (0.015, 0.7 / SPEED, 0.0))  # 0.7 Hz at 5 cm/s, 1.5 cm (issue 31's operator)
CYCLOID = ("cycloid", (0.012, 1.1 / SPEED, 0.0))  # 1.1 Hz, 1.2 cm
HUMAN_NOISE = 0.008  # [m/s] per axis
TUNED_SHAPES = ("Sine", "Worm", "GShape")
CLEARANCE = 0.03  # human paths are fitted this far inside the boundary (pattern amplitude and margin) [m]
PUSH_SECONDS = 20.0  # pushing into the boundary before the switch [s]
AFTER_SWITCH = 8.0  # [s]
GOALS = {
    "misidentified_fraction": 0.01,
    "flicker": 0,
    "switch_delay_s": 0.5,
    "rate_hz": 49.5,
    "late_fraction": 0.005,
    "fallback_fraction": 0.01,
    "violation_m": 0.0,
    "solve_p99_ms": 2.0,
}


@dataclasses.dataclass
class Cell:
    """One operator: commands every DT (n x 2) [m/s], the skill before and after ``switch`` (a command index).

    ``path`` is the underlying path U the patterns were drawn around, every DT (n x 2) [m], where there is one.
    """

    group: str
    name: str
    commands: np.ndarray
    first: str
    second: str
    switch: int
    path: Optional[np.ndarray] = None


def synthetic_cells() -> List[Cell]:
    rng = np.random.default_rng(15)
    cells = []
    for first, second in (("wave", "cycloid"), ("cycloid", "wave")):
        for amplitude, frequency in ((0.015, 12.0), (0.045, 30.0)):
            heading = rng.uniform(-math.pi, math.pi)
            times = np.arange(0.0, 4.0, DT)
            rho = (amplitude, frequency, 0.0)
            commands = np.vstack(
                [synthetic_commands(skill, rho, heading, SPEED, times, 0.01, rng) for skill in (first, second)]
            )
            cells.append(
                Cell(
                    "synthetic",
                    f"{first}->{second} A {amplitude} f {frequency:.0f}",
                    commands,
                    first,
                    second,
                    len(times),
                )
            )
    return cells


def push_cells(box: Box) -> List[Cell]:
    """The issue's operator heading into the boundary from the origin, pushing PUSH_SECONDS before switching."""
    rng = np.random.default_rng(31)
    cells = []
    for heading, (first, second) in (
        (math.pi, (WAVE, CYCLOID)),
        (-math.pi / 2, (CYCLOID, WAVE)),
        (math.pi + 0.5, (WAVE, CYCLOID)),
    ):
        # Time to the boundary along the heading, then the push.
        reach = (
            min(
                (box.x_min / math.cos(heading)) if math.cos(heading) < -1e-9 else math.inf,
                (box.x_max / math.cos(heading)) if math.cos(heading) > 1e-9 else math.inf,
                (box.y_min / math.sin(heading)) if math.sin(heading) < -1e-9 else math.inf,
                (box.y_max / math.sin(heading)) if math.sin(heading) > 1e-9 else math.inf,
            )
            / SPEED
        )
        before = np.arange(0.0, reach + PUSH_SECONDS, DT)
        after = np.arange(0.0, AFTER_SWITCH, DT)
        commands = np.vstack(
            [
                synthetic_commands(first[0], first[1], heading, SPEED, before, HUMAN_NOISE, rng),
                synthetic_commands(second[0], second[1], heading, SPEED, after, HUMAN_NOISE, rng),
            ]
        )
        cells.append(
            Cell(
                "push",
                f"{first[0]}->{second[0]} heading {heading:.2f} rad, boundary after {reach:.1f} s",
                commands,
                first[0],
                second[0],
                len(before),
            )
        )
    return cells


def around(group: str, name: str, path: np.ndarray, order: int, rng) -> Cell:
    """The issue's patterns around ``path``, switching halfway (order 0: wave first)."""
    first, second = (WAVE, CYCLOID) if order == 0 else (CYCLOID, WAVE)
    switch = len(path) // 2
    commands = commands_around_path(path, DT, (first, second), switch * DT, HUMAN_NOISE, rng)
    return Cell(group, name, commands, first[0], second[0], switch, path)


def fit_in_box(path: np.ndarray, box: Box, clearance: float) -> np.ndarray:
    """The path turned (quarter turns, mirrored) and shrunk to fit, from the origin, ``clearance`` inside the box.

    The node starts at the origin; a path that left the box would add a boundary push to the cell.
    """
    low = np.array([box.x_min, box.y_min]) + clearance
    high = np.array([box.x_max, box.y_max]) - clearance
    best, best_scale = path, 0.0
    for swap in (False, True):
        for signs in ((1, 1), (1, -1), (-1, 1), (-1, -1)):
            candidate = (path[:, ::-1] if swap else path) * np.array(signs)
            upper, lower = candidate.max(axis=0), candidate.min(axis=0)
            scale = min(
                min(h / u for h, u in zip(high, upper) if u > 1e-9) if np.any(upper > 1e-9) else np.inf,
                min(lo / lw for lo, lw in zip(low, lower) if lw < -1e-9) if np.any(lower < -1e-9) else np.inf,
            )
            if scale > best_scale:
                best, best_scale = candidate, scale
    return best * min(best_scale, 1.0)


def lasa_cells(held_out: bool, box: Box) -> List[Cell]:
    rng = np.random.default_rng(2011)
    shapes = [s for s in lasa_shapes() if (s not in TUNED_SHAPES) == held_out]
    cells = []
    for index, shape in enumerate(shapes):
        path = retime(fit_in_box(lasa_path(shape, 0, DT, 1.0, SPEED), box, CLEARANCE), DT, DT, SPEED)
        group = "lasa-held-out" if held_out else "lasa-tuned"
        cells.append(around(group, shape, path, index % 2, rng))
    return cells


def minimum_jerk_cells(box: Box) -> List[Cell]:
    """Five reaches of 6-10 cm, each turning up to 0.5 rad from the last, 1.2-2.4 s each, 40 % overlapping."""
    rng = np.random.default_rng(1985)
    cells = []
    for index in range(3):
        headings = rng.uniform(-math.pi, math.pi) + np.cumsum(rng.uniform(-0.5, 0.5, 5))
        steps = rng.uniform(0.06, 0.1, 5)[:, None] * np.column_stack([np.cos(headings), np.sin(headings)])
        path = reaching_path(np.cumsum(steps, axis=0), rng.uniform(1.2, 2.4, 5), 0.4, DT)
        path = retime(fit_in_box(path, box, CLEARANCE), DT, DT, SPEED)
        cells.append(around("minimum-jerk", f"5 reaches, seed 1985 #{index}", path, index % 2, rng))
    return cells


def cell_makers(box: Box) -> dict:
    """Group name -> a function making that group's cells (``box``: the node's boundary)."""
    return {
        "synthetic": synthetic_cells,
        "push": lambda: push_cells(box),
        "lasa-tuned": lambda: lasa_cells(False, box),
        "lasa-held-out": lambda: lasa_cells(True, box),
        "minimum-jerk": lambda: minimum_jerk_cells(box),
    }


def executed_motion(states) -> tuple:
    """Top speed [m/s] and p99 acceleration [m/s^2] of the executed states, from consecutive cycles (dt each).

    No goal: they show what a faster solve costs the motion (a last iterate at the iteration cap can ask for a fast
    step where the operator moved slowly).
    """
    if len(states) < 3:
        return None, None
    cycles = np.array([s["cycle"] for s in states])
    xy = np.array([(s["x"], s["y"]) for s in states])
    consecutive = np.diff(cycles) == 1
    velocity = np.diff(xy, axis=0) / DT
    speeds = np.linalg.norm(velocity[consecutive], axis=1)
    both = consecutive[1:] & consecutive[:-1]
    accelerations = np.linalg.norm(np.diff(velocity, axis=0)[both], axis=1) / DT
    return (
        float(speeds.max()) if speeds.size else None,
        float(np.percentile(accelerations, 99)) if accelerations.size else None,
    )


def score(states, cell: Cell, box: Box, switch_time: float, duration: float) -> dict:
    """The goals' figures of one cell from its states (time [s], mode, skill, x, y, solve [s], cycle, late)."""
    limit = GOALS["switch_delay_s"]
    judged = [s for s in states if s["mode"] in (SHARED, UNKNOWN)]
    truth = [(cell.first if s["time"] < switch_time else cell.second) for s in judged]
    counted = [(s, t) for s, t in zip(judged, truth) if not switch_time <= s["time"] < switch_time + limit]
    wrong = sum(s["skill"] != t for s, t in counted)
    detected = next((s["time"] for s in judged if s["time"] >= switch_time and s["skill"] == cell.second), None)
    flicker, left, current = 0, set(), None
    for skill in (s["skill"] for s in judged):
        if skill != current:
            flicker += skill in left
            if current is not None:
                left.add(current)
            current = skill
    solves = [1e3 * s["solve"] for s in states if s["solve"] > 0]
    cycles = states[-1]["cycle"] - states[0]["cycle"] + 1 if states else 0
    late = states[-1]["late"] - states[0]["late"] if states else 0
    top_speed, acceleration_p99 = executed_motion(states)
    return {
        "group": cell.group,
        "cell": cell.name,
        "seconds": duration,
        "states": len(states),
        "rate_hz": len(states) / duration if duration > 0 else None,
        "late_fraction": late / max(cycles, 1),
        "fallback_fraction": sum(s["mode"] == FALLBACK for s in states) / max(len(states), 1),
        "judged": len(counted),
        "misidentified": wrong,
        "misidentified_fraction": wrong / max(len(counted), 1),
        "flicker": flicker,
        "switch_delay_s": None if detected is None else detected - switch_time,
        "violation_m": max((violation(np.array([s["x"], s["y"]]), box, None) for s in states), default=0.0),
        "solve_p99_ms": float(np.percentile(solves, 99)) if solves else None,
        "top_speed_m_s": top_speed,
        "acceleration_p99_m_s2": acceleration_p99,
        "fallback_reasons": collections.Counter(
            s["message"].split("; ")[-1] for s in states if s["mode"] == FALLBACK
        ).most_common(3),
    }


def meets(cell: dict, measured_rate: bool) -> dict:
    """Goal name -> met, for one cell."""
    checks = {
        "misidentified_fraction": cell["misidentified_fraction"] <= GOALS["misidentified_fraction"],
        "flicker": cell["flicker"] <= GOALS["flicker"],
        "switch_delay_s": cell["switch_delay_s"] is not None and cell["switch_delay_s"] <= GOALS["switch_delay_s"],
        "fallback_fraction": cell["fallback_fraction"] <= GOALS["fallback_fraction"],
        "violation_m": cell["violation_m"] <= GOALS["violation_m"],
        "solve_p99_ms": cell["solve_p99_ms"] is not None and cell["solve_p99_ms"] <= GOALS["solve_p99_ms"],
    }
    if measured_rate:
        checks["rate_hz"] = cell["rate_hz"] >= GOALS["rate_hz"]
        checks["late_fraction"] = cell["late_fraction"] <= GOALS["late_fraction"]
    return checks


class InProcess:
    """The node's code without ROS: commands by stamp with random delivery delays, a simulated clock.

    ``wall_clock``: each cycle also waits for its 20 ms slot on the wall clock, as the node's loop does, so the solve
    times include what a periodic loop pays after each sleep (without ROS).
    """

    def __init__(self, params: dict, box: Box, wall_clock: bool = False):
        config = SharedControlConfig.from_parameters(params)
        self.controller = SharedControl(config, tuple(params["initial_state"]), box)
        self.params = params
        self.wall_clock = wall_clock

    def run(self, cell: Cell, rng) -> tuple:
        self.controller.reset(tuple(self.params["initial_state"]))
        timeline = CommandTimeline(self.params["command_timeout"])
        arrivals = DT * np.arange(len(cell.commands)) + rng.uniform(0.0, 0.015, len(cell.commands))
        states, received = [], 0
        start = time.perf_counter()
        for k in range(len(cell.commands)):
            cycle_time = DT * (k + 1)
            if self.wall_clock:
                time.sleep(max(start + cycle_time - time.perf_counter(), 0.0))
            while received < len(cell.commands) and arrivals[received] <= cycle_time:
                timeline.add(DT * received, cell.commands[received])
                received += 1
            record = self.controller.step(timeline.sample(cycle_time - self.params["command_delay"]))
            solve = record.cpu_times[0] + record.cpu_times[1] if record.fitting_errors else 0.0
            states.append(
                {
                    "time": cycle_time,
                    "mode": record.mode,
                    "skill": record.skill,
                    "x": record.state[0],
                    "y": record.state[1],
                    "solve": solve,
                    "cycle": k,
                    "message": record.message,
                    "late": 0,
                }
            )
        return states, cell.switch * DT, len(cell.commands) * DT

    def close(self):
        pass


class OverRos:
    """``shared_control.launch`` on a roscore of its own; commands published at 50 Hz, stamped when sent."""

    def __init__(self, log_dir: pathlib.Path, overrides: dict):
        from teleteach.runtime.experiment import Experiment

        self.experiment = Experiment(log_dir)
        log = log_dir / "processes.log"
        try:
            self.experiment.own_roscore(log, host="127.0.0.1")
            self._start(log_dir, overrides, log)
        except BaseException:
            self.experiment.close()
            raise

    def _start(self, log_dir: pathlib.Path, overrides: dict, log: pathlib.Path) -> None:
        config = ROOT / "config" / "shared_control.yaml"
        if overrides:
            config = log_dir / "shared_control.yaml"
            config.write_text(
                yaml.safe_dump({**yaml.safe_load((ROOT / "config" / "shared_control.yaml").read_text()), **overrides})
            )
        self.experiment.start(
            "shared_control",
            [
                "roslaunch",
                "teleteach",
                "shared_control.launch",
                "enabled:=false",
                "solver:=compiled",
                f"config:={config}",
            ],
            log,
            watched=True,
        )
        import rospy
        from geometry_msgs.msg import Vector3Stamped
        from std_msgs.msg import Bool

        from teleteach.msg import SharedControlState

        self.rospy = rospy
        self.experiment.join("shared_control_sweep")
        self.message = Vector3Stamped
        self.command = rospy.Publisher("/shared_control/operator_command", Vector3Stamped, queue_size=100)
        self.enable = rospy.Publisher("/shared_control/enable", Bool, queue_size=1, latch=True)
        self.lock = threading.Lock()
        self.states = []
        rospy.Subscriber("/shared_control/state", SharedControlState, self._on_state, queue_size=1000)
        self.log = log
        # A first start without the cache compiles (minutes); the node reads commands only while enabled.
        self._wait(lambda: self.enable.get_num_connections() > 0, 600.0, "the node")

    def _wait(self, condition, timeout: float, what: str) -> None:
        if not self.experiment.wait_until(condition, timeout, poll=0.05):
            raise RuntimeError(f"{what} did not come up (see {self.log})")

    def _on_state(self, message):
        with self.lock:
            self.states.append(
                {
                    "time": message.header.stamp.to_sec(),
                    "mode": message.mode,
                    "skill": message.skill,
                    "x": message.state.x,
                    "y": message.state.y,
                    "solve": message.estimation_time + message.optimisation_time if message.fitting_errors else 0.0,
                    "cycle": message.cycle,
                    "message": message.message,
                    "late": message.late_cycles,
                }
            )

    def run(self, cell: Cell, rng) -> tuple:
        from std_msgs.msg import Bool

        rospy = self.rospy
        self.enable.publish(Bool(False))
        time.sleep(0.3)
        self.enable.publish(Bool(True))
        self._wait(lambda: self.command.get_num_connections() > 0, 30.0, "the node's command subscriber")
        time.sleep(1.0)  # the node waits up to 0.5 s for an arm pose, then starts at initial_state
        with self.lock:
            self.states = []
        start = rospy.get_time()
        end = start + len(cell.commands) * DT
        message = self.message()
        while True:
            now = rospy.get_time()
            if now >= end:
                break
            # The hand's velocity at the time this sample is taken (a late wake-up skips samples, as a device would).
            message.header.stamp = rospy.Time.from_sec(now)
            message.vector.x, message.vector.y = cell.commands[min(int((now - start) / DT), len(cell.commands) - 1)]
            self.command.publish(message)
            time.sleep(max(start + DT * (int((now - start) / DT) + 1) - rospy.get_time(), 0.0))
        time.sleep(0.2)
        with self.lock:
            states = [s for s in self.states if start <= s["time"] <= end]
        self.enable.publish(Bool(False))
        return states, start + cell.switch * DT, end - start

    def close(self):
        self.rospy.signal_shutdown("sweep done")
        self.experiment.close()


def sweep(runner, cells, box, measured_rate) -> list:
    rng = np.random.default_rng(0)
    rows = []
    for cell in cells:
        states, switch_time, duration = runner.run(cell, rng)
        row = score(states, cell, box, switch_time, duration)
        row["meets"] = meets(row, measured_rate)
        rows.append(row)
        missed = [goal for goal, met in row["meets"].items() if not met]
        delay = "none" if row["switch_delay_s"] is None else f"{row['switch_delay_s']:.2f} s"
        solve = "-" if row["solve_p99_ms"] is None else f"{row['solve_p99_ms']:.2f}"
        print(
            f"{row['group']:>13} {row['cell'][:46]:<46} misid {row['misidentified']:3d}/{row['judged']:4d} "
            f"flicker {row['flicker']} delay {delay:>6} {row['rate_hz']:5.1f} Hz late "
            f"{100 * row['late_fraction']:4.1f} % FALLBACK {100 * row['fallback_fraction']:4.1f} % "
            f"viol {1e3 * row['violation_m']:.1f} mm solve p99 {solve} ms "
            f"vmax {row['top_speed_m_s'] or 0.0:.2f} m/s acc p99 {row['acceleration_p99_m_s2'] or 0.0:.1f} m/s2 "
            f"{'ok' if not missed else 'MISSES ' + ','.join(missed)}",
            flush=True,
        )
    return rows


def goal_lines(rows, measured_rate) -> List[str]:
    """One line per goal over every cell: met or not, with the worst cell's figure."""
    lines = []
    for goal, bound in GOALS.items():
        if goal in ("rate_hz", "late_fraction") and not measured_rate:
            lines.append(f"{goal}: not measured (in-process)")
            continue
        missing = [r for r in rows if not r["meets"][goal]]
        values = [r[goal] for r in rows if r[goal] is not None]
        worst = (min(values) if goal == "rate_hz" else max(values)) if values else None
        state = "met" if not missing else f"NOT MET in {len(missing)} of {len(rows)} cells"
        lines.append(f"{goal} (goal {'>=' if goal == 'rate_hz' else '<='} {bound}): {state}; worst {worst}")
    return lines


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--busy", action="store_true", help="run the sweep again with a busy loop on one core")
    parser.add_argument("--in-process", action="store_true", help="the node's code without ROS, simulated clock")
    parser.add_argument(
        "--wall-clock", action="store_true", help="with --in-process: each cycle waits for its 20 ms slot, as the node"
    )
    groups = ("synthetic", "push", "lasa-tuned", "lasa-held-out", "minimum-jerk")
    parser.add_argument("--groups", nargs="+", choices=groups, default=list(groups))
    parser.add_argument("--set", nargs="+", default=[], metavar="NAME=YAML", help="override shared_control.yaml")
    args = parser.parse_args()
    if args.wall_clock and not args.in_process:
        parser.error("--wall-clock is an option of --in-process (over ROS the node keeps its own clock)")
    with open(ROOT / "config" / "shared_control.yaml") as stream:
        params = yaml.safe_load(stream)
    overrides = {name: yaml.safe_load(value) for name, value in (item.split("=", 1) for item in args.set)}
    params.update(overrides)
    box = Box(*params["boundary"])
    makers = cell_makers(box)
    cells = [cell for group in args.groups for cell in makers[group]()]
    runs = {"idle": None}
    if args.busy:
        runs["busy_one_core"] = [sys.executable, "-c", "while True: pass"]
    result = {
        "mode": (
            ("in-process (20 ms slots on the wall clock)" if args.wall_clock else "in-process (simulated clock)")
            if args.in_process
            else "over ROS (shared_control.launch, compiled)"
        ),
        "goals": GOALS,
        "tuned_shapes": TUNED_SHAPES,
        "overrides": overrides,
        "machine": {"cpus": os.cpu_count(), "python": platform.python_version()},
    }
    log_dir = pathlib.Path(tempfile.mkdtemp(prefix="sweep_"))
    runner = InProcess(params, box, args.wall_clock) if args.in_process else OverRos(log_dir, overrides)
    print(f"logs in {log_dir}", flush=True)
    try:
        for name, busy_command in runs.items():
            load = os.getloadavg()[0]
            print(f"--- {name} ({result['mode']}); load average {load:.1f} on {os.cpu_count()} cores", flush=True)
            busy = subprocess.Popen(busy_command) if busy_command else None
            try:
                rows = sweep(runner, cells, box, not args.in_process)
            finally:
                if busy:
                    busy.kill()
                    busy.wait()
            lines = goal_lines(rows, not args.in_process)
            held_out = [r for r in rows if r["group"] == "lasa-held-out"]
            if held_out:
                lines.append(
                    f"held-out LASA shapes: {sum(all(r['meets'].values()) for r in held_out)} of "
                    f"{len(held_out)} cells meet every goal"
                )
            result[name] = {"load_average": [load, os.getloadavg()[0]], "cells": rows, "goals": lines}
            print(f"{name}:", *lines, sep="\n  ", flush=True)
    finally:
        runner.close()
    RESULTS.mkdir(parents=True, exist_ok=True)
    path = RESULTS / f"shared_control_sweep{'_in_process' if args.in_process else ''}.json"
    path.write_text(json.dumps(result, indent=2))
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
