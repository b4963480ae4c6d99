#!/usr/bin/env python3
"""Benchmark: does the shared-control loop hold 50 Hz while the eraser is on the board, on this machine? (issue 49)

Question: through the real nodes, with the eraser pressed on the counter's whiteboard, does the shared controller
publish a state every 20 ms with at most 1 % of its cycles late, with the machine as it is and with a declared
background load?

Method: a roscore of its own, ``sim.launch wiping_tool:=true initial_controller:=cartesian_impedance_controller
skills:=false`` and ``shared_control.launch surface:=counter_board enabled:=false`` (the compiled solvers, the
launch's default), as test/ros/shared_control_wipe.test brings them up. The bench drives the base to the counter and
wipes as that test's operator does (``teleteach.wiping.ros``: the taught stiffness 3000/3000/300 N/m, a wave at 5 cm/s
on /shared_control/operator_command), for ``--seconds`` of simulated time per condition, reversing the wave's heading
every ``--segment`` s so that it sweeps the board back and forth. Then it stops commanding: the node retracts the tool
and disables itself, and the next condition enables it again. Conditions, in one run:

- ``as_is``: the machine as it is (other work on it is not stopped: the load average is printed and stored);
- ``busy_N``: N busy loops (bench/stress.py's, pinned two per core for N = 4; default one per core) beside it.

Per condition, from /shared_control/state (each cycle's ``cycle`` and ``late_cycles``, the node's own count: a cycle
is late when its state is ready more than one period after its slot on the ROS clock) and from the world (the force
the board puts on the tool along its true normal, /force_torque_ext: a state counts as in contact when the force
sample nearest its stamp is >= 1 N): the states per second of simulated time, their gaps, the late-cycle fraction in
contact and overall, the solve time (estimation + optimisation, wall time inside the node) percentiles in contact,
the simulation's real-time factor over the wipe, and the CPU of robot_sim and shared_control (% of one core, from
/proc). The node's clock is ROS time (robot_sim's /clock): a simulation that falls behind real time slows the loop's
deadlines with it, which is why the real-time factor is printed beside the rate. ``--profile`` samples both nodes
with py-spy during each condition (bench/cpu_budget.py's sampler) and prints their hottest functions.

The node runs as shared_control.launch starts it: its threads at SCHED_FIFO ``realtime_priority`` (10) when the
machine allows it (teleteach.runtime.realtime); ``--realtime-priority 0`` runs it as any process, for the comparison
(stored as wiping_rate_realtime_0.json). The policy each node ran at is printed and stored.

Goal (issue 49): >= 49.5 states per simulated second and <= 1 % late cycles in contact, in both conditions. Writes
bench/results/wiping_rate.json with its provenance; exit status 0 when both conditions met the goal.

    source build/env.sh && python bench/wiping_rate.py [--seconds 60] [--hogs 2] [--realtime-priority N] [--profile]
"""

import argparse
import json
import math
import os
import pathlib
import tempfile
import time
from typing import Optional

import numpy as np
from cpu_budget import cpu_seconds, hot_functions, node_pids, start_profiles, stop_profile
from stress import busy_loop, hog_cores

from teleteach.core.paths import config_file
from teleteach.run.provenance import provenance
from teleteach.runtime.experiment import Experiment
from teleteach.wiping.assistance import CONFIG_FILES

RESULTS = pathlib.Path(__file__).resolve().parent / "results" / "wiping_rate.json"  # --realtime-priority N: _N
GOAL_RATE = 49.5  # [states per simulated second]
GOAL_LATE = 0.01  # [-] late cycles in contact
SETTLE = 1.0  # [s] after the first commanded cycle: the node's direct-control window lands the pattern
NODES = ("shared_control", "robot_sim")


def percentiles(values, quantiles=(50, 90, 99, 100)) -> dict:
    """{"p50": ..., "max": ...} of values [ms], None each when there are none."""
    names = [f"p{q}" if q < 100 else "max" for q in quantiles]
    if len(values) == 0:
        return dict.fromkeys(names)
    return {name: round(float(np.percentile(values, q)), 2) for name, q in zip(names, quantiles)}


def in_contact(stamps: np.ndarray, forces: list, normal: np.ndarray, contact: float) -> np.ndarray:
    """Per stamp: whether the force sample nearest it pushes the tool off the board by >= ``contact`` [N]."""
    if not forces:
        return np.zeros(len(stamps), dtype=bool)
    force_stamps = np.array([stamp for stamp, _ in forces])
    pressing = np.array([value for _, value in forces]) @ normal
    index = np.clip(np.searchsorted(force_stamps, stamps), 1, len(force_stamps) - 1)
    nearer = np.where(stamps - force_stamps[index - 1] < force_stamps[index] - stamps, index - 1, index)
    return pressing[nearer] >= contact


def figures(states: list, forces: list, normal: np.ndarray, start: float, end: float, contact: float) -> dict:
    """The loop's figures over the states stamped in [start, end] (``states``: one enable's (stamp, message, wall)).

    Each state's cycles and late cycles are the increase of its counters over the state before it (so cycles that
    published no state, skipped after a long stall, count with the next one).
    """
    chosen = [k for k in range(1, len(states)) if start <= states[k][0] <= end]
    if len(chosen) < 2:
        return {"states": len(chosen)}
    stamps = np.array([states[k][0] for k in chosen])
    walls = np.array([states[k][2] for k in chosen])
    cycles = np.array([states[k][1].cycle - states[k - 1][1].cycle for k in chosen])
    late = np.array([states[k][1].late_cycles - states[k - 1][1].late_cycles for k in chosen])
    solve = np.array([1e3 * (states[k][1].estimation_time + states[k][1].optimisation_time) for k in chosen])
    touching = in_contact(stamps, forces, normal, contact)
    sim_s, wall_s = float(stamps[-1] - stamps[0]), float(walls[-1] - walls[0])
    gaps = 1e3 * np.diff(stamps)
    contact_gaps = gaps[touching[1:] & touching[:-1]]
    return {
        "states": len(chosen),
        "sim_s": round(sim_s, 2),
        "wall_s": round(wall_s, 2),
        "real_time_factor": round(sim_s / wall_s, 3) if wall_s > 0 else None,
        "rate_hz": round((len(chosen) - 1) / sim_s, 2) if sim_s > 0 else None,
        "wall_rate_hz": round((len(chosen) - 1) / wall_s, 2) if wall_s > 0 else None,
        "contact_fraction": round(float(np.mean(touching)), 4),
        "cycles": int(cycles.sum()),
        "late": int(late.sum()),
        "late_fraction": round(float(late.sum() / max(cycles.sum(), 1)), 4),
        "contact_cycles": int(cycles[touching].sum()),
        "contact_late": int(late[touching].sum()),
        "contact_late_fraction": round(float(late[touching].sum() / max(cycles[touching].sum(), 1)), 4),
        "solve_ms_in_contact": percentiles(solve[touching & (solve > 0)]),
        "solved_in_contact": int(np.sum(touching & (solve > 0))),
        "state_gap_ms_in_contact": percentiles(contact_gaps),
        "gaps_over_40_ms_in_contact": int(np.sum(contact_gaps > 40.0 + 1e-6)),
    }


class System(Experiment):
    """The sim with the eraser and the shared controller on the board, on a roscore of its own."""

    def __init__(self, folder: pathlib.Path, solver: str, priority: Optional[int]):
        super().__init__(folder)
        log = folder / "processes.log"
        try:
            self.own_roscore(log, host="127.0.0.1")
            self.start(
                "sim",
                [
                    "roslaunch",
                    "teleteach",
                    "sim.launch",
                    "skills:=false",
                    "initial_controller:=cartesian_impedance_controller",
                    "wiping_tool:=true",
                ],
                folder / "sim.log",
                watched=True,
            )
            # Every node must see /use_sim_time (sim.launch sets it) when it starts, or it runs on the wall clock
            # and robot_sim rejects its stale stamps: the rest starts after it, as one launch file would order it.
            if not self.wait_until(self._sim_time_set, 120.0, poll=0.2):
                raise RuntimeError(f"sim.launch did not set /use_sim_time (see {folder / 'sim.log'})")
            self.start(
                "shared_control",
                [
                    "roslaunch",
                    "teleteach",
                    "shared_control.launch",
                    f"solver:={solver}",
                    "surface:=counter_board",
                    "enabled:=false",
                    *([] if priority is None else [f"realtime_priority:={priority}"]),
                ],
                folder / "shared_control.log",
                watched=True,
            )
            self.join("wiping_rate_bench")
        except BaseException:
            self.close()
            raise

    def _sim_time_set(self) -> bool:
        import rosgraph

        try:
            return bool(rosgraph.Master("/wiping_rate_bench", master_uri=self.master_uri).hasParam("/use_sim_time"))
        except (OSError, rosgraph.MasterError):
            return False

    def pids(self) -> dict:
        """{node: pid} of robot_sim and shared_control once both registered."""
        found = {}

        def registered():
            found.update({name: pid for name, pid in node_pids(self.master_uri).items() if name in NODES})
            return len(found) == len(NODES)

        if not self.wait_until(registered, 600.0, poll=1.0):
            raise RuntimeError(f"the nodes did not register: {found} (see {self.folder})")
        return found


def scheduling(pid: int) -> str:
    """A process's scheduling policy, e.g. "SCHED_FIFO 10" or "SCHED_OTHER nice 0"."""
    policy = os.sched_getscheduler(pid)
    if policy in (os.SCHED_FIFO, os.SCHED_RR):
        name = "SCHED_FIFO" if policy == os.SCHED_FIFO else "SCHED_RR"
        return f"{name} {os.sched_getparam(pid).sched_priority}"
    return f"SCHED_OTHER nice {os.getpriority(os.PRIO_PROCESS, pid)}"


def wipe(operator, seconds: float, segment: float, rng) -> tuple:
    """The wave for ``seconds`` of ROS time, its heading reversed every ``segment`` s; (first, last) stamps [s]."""
    first = last = None
    heading, left = math.pi, seconds
    while left > 1e-9:
        start, end = operator.pattern("wave", min(segment, left), heading, rng)
        first = start if first is None else first
        last, heading, left = end, heading + math.pi, left - segment
    return first, last


def run_condition(system, record, operator, pids, name, hogs, arguments, normal) -> dict:
    """One condition: the load started, an enable, the wipe, the figures; the load stopped."""
    import rospy

    cores = hog_cores(hogs, os.cpu_count() or 1)
    busy = [busy_loop(core) for core in cores]
    try:
        time.sleep(2.0 if busy else 0.0)  # the load is running before the wipe starts
        load_before = os.getloadavg()[0]
        with record.lock:
            first_state = len(record.states)
        operator.enable()
        if not system.wait_until(lambda: len(record.states) > first_state, 120.0, poll=0.05):
            raise RuntimeError(f"{name}: no /shared_control/state after enabling (see {system.folder})")
        samplers = start_profiles(pids, arguments.seconds, f"wiping_rate_{name}") if arguments.profile else {}
        cpu_before = {node: cpu_seconds(pid) for node, pid in pids.items()}
        wall_before = time.monotonic()
        start, end = wipe(operator, arguments.seconds, arguments.segment, np.random.default_rng(49))
        wall = time.monotonic() - wall_before
        cpu = {
            node: round(100.0 * ((cpu_seconds(pid) or 0.0) - (cpu_before[node] or 0.0)) / wall, 1)
            for node, pid in pids.items()
        }
        profiles = {node: hot_functions(stop_profile(*sampler)) for node, sampler in samplers.items()}
        load_after = os.getloadavg()[0]
        # Input lost: the node retracts the tool and disables itself (input_loss_time, then the retract).
        ended = system.wait_until(lambda: record.states[-1][0] < rospy.get_time() - 1.0, 30.0, poll=0.2)
    finally:
        for process in busy:
            process.kill()
            process.wait()
    with record.lock:
        states = list(record.states[first_state:])
    forces = record.stamped_between("forces", start - 1.0, end + 1.0)
    result = figures(states, forces, normal, start + SETTLE, end, arguments.contact)
    result.update(
        {
            "load": {"busy_loops": hogs, "cores": cores},
            "load_average": [round(load_before, 2), round(load_after, 2)],
            "cpu_percent": cpu,
            "wipe_wall_s": round(wall, 1),
            "stopped_after_input_loss": bool(ended),
        }
    )
    if profiles:
        result["profiles"] = profiles
    return result


def goal_lines(conditions: dict) -> list:
    lines = []
    for name, row in conditions.items():
        rate, late = row.get("rate_hz"), row.get("contact_late_fraction")
        met = bool(row.get("contact_cycles")) and rate >= GOAL_RATE and late <= GOAL_LATE
        lines.append(
            {
                "condition": name,
                "goal": f">= {GOAL_RATE} Hz and <= {100 * GOAL_LATE:.0f} % late cycles in contact",
                "measured": f"{rate} Hz, {row.get('contact_late')} of {row.get('contact_cycles')} cycles late in "
                f"contact ({100 * (late or 0.0):.2f} %)",
                "met": met,
            }
        )
    return lines


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=60.0, help="wipe per condition [s of simulated time]")
    parser.add_argument("--segment", type=float, default=8.0, help="the wave's heading reverses this often [s]")
    parser.add_argument("--hogs", type=int, default=os.cpu_count() or 1, help="busy loops of the loaded condition")
    parser.add_argument("--solver", default="compiled", choices=("compiled", "fast", "ipopt"))
    parser.add_argument("--contact", type=float, default=1.0, help="normal force counted as contact [N]")
    parser.add_argument("--profile", action="store_true", help="sample both nodes with py-spy in each condition")
    parser.add_argument("--only", choices=("as_is", "busy"), help="run one condition only")
    parser.add_argument(
        "--realtime-priority",
        type=int,
        help="shared_control.launch's realtime_priority (default: the launch's; 0: the ordinary scheduler)",
    )
    arguments = parser.parse_args()
    origin = provenance([*CONFIG_FILES, config_file("controllers.yaml")])
    started = time.perf_counter()
    folder = pathlib.Path(tempfile.mkdtemp(prefix="wiping_rate_"))
    print(f"logs in {folder}; load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores", flush=True)
    plan = {"as_is": 0, f"busy_{arguments.hogs}": arguments.hogs}
    if arguments.only:
        plan = {name: hogs for name, hogs in plan.items() if name.startswith(arguments.only)}
    conditions = {}
    with System(folder, arguments.solver, arguments.realtime_priority) as system:
        import rospy

        from teleteach.wiping.ros import ScriptedWipe, WorldRecord, board_in_base, drive_to

        pids = system.pids()
        policies = {node: scheduling(pid) for node, pid in pids.items()}
        print(f"scheduling: {policies}", flush=True)
        record = WorldRecord(poses=False)
        if not drive_to():
            raise RuntimeError("the base did not arrive at the counter")
        seen_in_base, true_in_base = board_in_base()
        normal = true_in_base.rotation.apply([0.0, 0.0, 1.0])
        operator = ScriptedWipe()
        operator.press_with(seen_in_base)
        rospy.sleep(0.5)
        for name, hogs in plan.items():
            print(f"--- {name}: {hogs} busy loops; wiping {arguments.seconds:.0f} s", flush=True)
            row = run_condition(system, record, operator, pids, name, hogs, arguments, normal)
            conditions[name] = row
            solve = row.get("solve_ms_in_contact", {})
            print(
                f"{name}: {row.get('rate_hz')} states/s (sim), real-time factor {row.get('real_time_factor')}, in "
                f"contact {100 * row.get('contact_fraction', 0.0):.0f} %; late in contact {row.get('contact_late')} "
                f"of {row.get('contact_cycles')} ({100 * row.get('contact_late_fraction', 0.0):.2f} %), overall "
                f"{row.get('late')} of {row.get('cycles')}; solve in contact p50 {solve.get('p50')} p90 "
                f"{solve.get('p90')} p99 {solve.get('p99')} max {solve.get('max')} ms; state gap p99 "
                f"{row.get('state_gap_ms_in_contact', {}).get('p99')} ms, {row.get('gaps_over_40_ms_in_contact')} "
                f"over 40 ms; CPU {row['cpu_percent']} % of a core; load average {row['load_average']}",
                flush=True,
            )
            for node, hot in row.get("profiles", {}).items():
                print(f"  {node}: " + "; ".join(f"{function} {share} %" for function, share in hot), flush=True)
        record.close()
        rospy.signal_shutdown("wiping_rate done")
    checks = goal_lines(conditions)
    for check in checks:
        print(f"  {'met' if check['met'] else 'NOT met'} ({check['condition']}): {check['goal']}: {check['measured']}")
    results = {
        "settings": {
            "seconds": arguments.seconds,
            "segment": arguments.segment,
            "hogs": arguments.hogs,
            "solver": arguments.solver,
            "contact_n": arguments.contact,
            "realtime_priority": arguments.realtime_priority,
            "scheduling": policies,
        },
        "conditions": conditions,
        "goals": checks,
        "provenance": {**origin, "wall_s": round(time.perf_counter() - started, 1)},
    }
    path = RESULTS
    if arguments.realtime_priority is not None:
        path = RESULTS.with_name(f"wiping_rate_realtime_{arguments.realtime_priority}.json")
    if arguments.only:
        path = path.with_name(f"{path.stem}_{arguments.only}.json")
    path.parent.mkdir(exist_ok=True)
    path.write_text(json.dumps(results, indent=1))
    print(f"wrote {path}")
    return 0 if all(check["met"] for check in checks) else 1


if __name__ == "__main__":
    raise SystemExit(main())
