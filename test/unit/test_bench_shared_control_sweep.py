"""bench/shared_control_sweep.py's figures of the executed motion, on states with a known motion."""

import numpy as np
import pytest
from bench_scripts import bench_module

sweep = bench_module("shared_control_sweep")


def states(positions, cycles):
    return [{"cycle": cycle, "x": x, "y": 0.0} for x, cycle in zip(positions, cycles)]


def test_the_executed_motion_is_measured_over_consecutive_cycles_only():
    dt = sweep.DT
    steady = [0.1 * dt * k for k in range(10)]  # 0.1 m/s along x
    # a state message lost (cycle 10): the 0.5 m between cycles 9 and 11 is no step of one cycle
    top_speed, acceleration = sweep.executed_motion(states([*steady, 0.5, 0.5 + 0.1 * dt], [*range(10), 11, 12]))
    assert top_speed == pytest.approx(0.1)
    assert acceleration == pytest.approx(0.0, abs=1e-9)
    # one step of 1 m/s after the steady motion: the top speed, and a jump of 0.9 m/s in one cycle
    top_speed, acceleration = sweep.executed_motion(states([*steady, steady[-1] + 1.0 * dt], range(11)))
    assert top_speed == pytest.approx(1.0)
    assert acceleration == pytest.approx(np.percentile([0.0] * 8 + [0.9 / dt], 99))


@pytest.mark.parametrize("wall_clock", [False, True])
def test_in_process_cycles_wait_for_their_slot_only_on_the_wall_clock(wall_clock):
    params = sweep.yaml.safe_load((sweep.ROOT / "config" / "shared_control.yaml").read_text())
    params["solver"] = "fast"
    box = sweep.Box(*params["boundary"])
    cell = sweep.synthetic_cells()[0]
    cell = sweep.dataclasses.replace(cell, commands=cell.commands[:25])
    runner = sweep.InProcess(params, box, wall_clock)
    started = sweep.time.perf_counter()
    states, _, duration = runner.run(cell, np.random.default_rng(0))
    elapsed = sweep.time.perf_counter() - started
    # Expect: 25 cycles either way; on the wall clock they take their 0.5 s, on the simulated clock far less.
    assert len(states) == 25 and duration == pytest.approx(0.5)
    assert elapsed >= 0.5 if wall_clock else elapsed < 0.25
