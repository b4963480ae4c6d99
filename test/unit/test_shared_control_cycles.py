"""The shared controller's cycle clock: a fixed grid, late cycles counted, a lost grid restarted and said so."""

import pytest

from teleteach.shared_control.cycles import CycleSchedule, CycleStatistics
from teleteach.shared_control.loop import FALLBACK, MODE_NAMES, SHARED

DT = 0.02


def test_cycles_on_time_are_not_late_and_the_grid_does_not_drift():
    schedule = CycleSchedule(10.0, DT, 1.0)
    for k in range(500):
        # Each cycle starts 3 ms after its nominal time and takes 5 ms: never late, never behind.
        start = schedule.next_time() + 0.003
        assert schedule.next_time() == pytest.approx(10.0 + k * DT)
        assert schedule.wait(start - 0.01) == pytest.approx(0.007)
        assert not schedule.behind(start)
        assert not schedule.finish(start + 0.005)
    assert (schedule.cycles, schedule.late, schedule.skipped) == (500, 0, 0)


def test_a_stall_makes_late_cycles_that_catch_up_without_skipping():
    schedule = CycleSchedule(0.0, DT, 1.0)
    schedule.finish(0.001)
    # Expect: cycle 1 (due 0.02) is stalled until 0.095: it and the cycles due by then are late and behind, each
    # still done (catch-up); once caught up the next is on time again.
    now = 0.095
    late_ones = 0
    while schedule.behind(now):
        assert schedule.finish(now)
        late_ones += 1
    assert late_ones == 3  # cycles due at 0.02, 0.04, 0.06 (their periods ended at 0.04, 0.06, 0.08)
    assert schedule.restart_if_lost(now) == 0
    assert not schedule.finish(now + 0.001)  # due at 0.08, deadline 0.10
    assert (schedule.cycles, schedule.late, schedule.skipped) == (5, 3, 0)


def test_a_lag_beyond_max_lag_skips_counted_cycles_and_restarts_the_grid():
    schedule = CycleSchedule(0.0, DT, 0.5)
    schedule.finish(0.0)
    skipped = schedule.restart_if_lost(3.0)
    assert skipped == 148  # (3.0 - 0.02) / 0.02 cycles behind
    assert schedule.late == skipped and schedule.skipped == skipped
    assert schedule.next_time() == pytest.approx(2.98)
    assert schedule.restart_if_lost(3.0) == 0


def test_bad_periods_are_rejected():
    with pytest.raises(ValueError):
        CycleSchedule(0.0, 0.0, 1.0)
    with pytest.raises(ValueError):
        CycleSchedule(0.0, DT, DT / 2)


def test_the_cycle_report_counts_rate_late_cycles_modes_and_solve_times():
    statistics = CycleStatistics(10.0, MODE_NAMES)
    lines = []
    for k in range(600):
        mode = FALLBACK if k % 100 == 0 else SHARED
        line = statistics.add(k * DT, mode, 0.001 if k % 2 else 0.003, late=k % 250 == 0)
        if line:
            lines.append((k, line))
    # Expect: one report after 10 s, covering cycles 0..500 (501 cycles, 3 late, 6 FALLBACK).
    assert len(lines) == 1
    k, line = lines[0]
    assert k == 500
    assert line.startswith("501 cycles in 10.0 s (50.1 Hz), 3 late; SHARED 98.8 %, FALLBACK 1.2 %; solve 2.00 ms mean")
