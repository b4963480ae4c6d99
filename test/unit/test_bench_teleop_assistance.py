"""bench/teleop_assistance.py's paired ratio: the interval of mean(on) / mean(off) over paired trials."""

import math

import numpy as np
import pytest
from bench_scripts import bench_module


@pytest.fixture(scope="module")
def bench():
    return bench_module("teleop_assistance")


def test_the_ratio_interval_holds_the_ratio_and_narrows_with_agreeing_pairs(bench):
    off = np.array([2.0, 1.0, 0.0, 3.0, 2.0, 1.0, 0.5, 2.5])
    low, high = bench.paired_ratio_interval(off, off / 2.0)
    # Expect: every pair halved: every resample's ratio is exactly 0.5
    assert (low, high) == pytest.approx((0.5, 0.5))
    rng = np.random.default_rng(1)
    on = off * rng.uniform(0.0, 1.0, off.size)
    low, high = bench.paired_ratio_interval(off, on)
    assert low <= on.mean() / off.mean() <= high and 0.0 <= low < high <= 1.0


def test_no_force_without_assistance_gives_no_ratio(bench):
    assert all(math.isnan(value) for value in bench.paired_ratio_interval([0.0, 0.0], [1.0, 0.0]))
