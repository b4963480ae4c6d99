"""bench/wiping_rate.py's figures from a made-up stream of states and forces, against counts done by hand."""

import sys
import types

import numpy as np
from bench_scripts import BENCH, bench_module

sys.path.insert(0, str(BENCH))  # the bench imports its neighbours (cpu_budget, stress) as python runs it would
rate = bench_module("wiping_rate")
NORMAL = np.array([0.0, 0.0, 1.0])


def state(cycle, late, solve_ms):
    return types.SimpleNamespace(
        cycle=cycle, late_cycles=late, estimation_time=solve_ms / 2e3, optimisation_time=solve_ms / 2e3
    )


def test_contact_is_the_force_sample_nearest_each_stamp_along_the_normal():
    forces = [(0.0, np.array([5.0, 0.0, 0.2])), (0.01, np.array([0.0, 0.0, 2.0])), (0.02, np.array([0.0, 0.0, 0.5]))]
    stamps = np.array([-1.0, 0.004, 0.006, 0.016, 5.0])
    assert rate.in_contact(stamps, forces, NORMAL, 1.0).tolist() == [False, False, True, False, False]
    assert rate.in_contact(stamps, [], NORMAL, 1.0).tolist() == [False] * 5


def test_late_cycles_count_in_contact_only_where_the_tool_pressed_and_skipped_cycles_count_with_the_next_state():
    # Stamps every 20 ms; the first state is the one before the window (its counters are the base). The state at
    # 0.08 s comes with a skipped cycle (two cycles, both late); the tool leaves the board from 0.07 s on, so only the
    # states at 0.02 and 0.04 s are in contact: 2 cycles, 1 late.
    states = [
        (0.00, state(1, 0, 1.0), 100.00),
        (0.02, state(2, 0, 1.0), 100.02),
        (0.04, state(3, 1, 2.0), 100.05),
        (0.08, state(5, 3, 0.0), 100.10),
        (0.10, state(6, 4, 3.0), 100.12),
        (0.12, state(7, 4, 4.0), 100.14),
    ]
    forces = [(0.01 * k, np.array([0.0, 0.0, 10.0 if k < 7 else 0.0])) for k in range(14)]
    result = rate.figures(states, forces, NORMAL, 0.0, 0.12, 1.0)
    assert result["states"] == 5
    assert (result["cycles"], result["late"], result["late_fraction"]) == (6, 4, round(4 / 6, 4))
    assert (result["contact_cycles"], result["contact_late"], result["contact_late_fraction"]) == (2, 1, 0.5)
    assert result["contact_fraction"] == 0.4
    assert result["sim_s"] == 0.1 and result["wall_s"] == 0.12
    assert result["rate_hz"] == 40.0 and result["real_time_factor"] == round(0.1 / 0.12, 3)
    assert result["solve_ms_in_contact"]["max"] == 2.0 and result["solved_in_contact"] == 2
    assert result["state_gap_ms_in_contact"]["max"] == 20.0
    assert result["gaps_over_40_ms_in_contact"] == 0


def test_too_few_states_give_only_their_count():
    assert rate.figures([(0.0, state(1, 0, 1.0), 0.0)], [], NORMAL, 0.0, 1.0, 1.0) == {"states": 0}


def test_a_condition_meets_the_goal_only_with_cycles_in_contact():
    rows = {
        "as_is": {"rate_hz": 50.0, "contact_late_fraction": 0.005, "contact_late": 1, "contact_cycles": 200},
        "busy_2": {"rate_hz": 50.0, "contact_late_fraction": 0.02, "contact_late": 4, "contact_cycles": 200},
        "none": {"rate_hz": 50.0, "contact_late_fraction": 0.0, "contact_late": 0, "contact_cycles": 0},
        "slow": {"rate_hz": 45.0, "contact_late_fraction": 0.0, "contact_late": 0, "contact_cycles": 100},
    }
    assert [line["met"] for line in rate.goal_lines(rows)] == [True, False, False, False]
