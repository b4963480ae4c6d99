"""Twist from successive poses: finite differences (checked against known motions) and the low-pass filter."""

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from teleteach.haptics.twist import StampOnWall, TwistEstimator, rotation_vector_between

STEP = 0.001


def settle(estimator, poses):
    twist = None
    for index, (position, orientation) in enumerate(poses):
        twist = estimator.update(index * STEP, np.asarray(position), np.asarray(orientation))
    return twist


def test_constant_linear_velocity():
    velocity = np.array([0.05, -0.02, 0.01])
    identity = [0.0, 0.0, 0.0, 1.0]
    poses = [(velocity * index * STEP, identity) for index in range(1000)]
    linear, angular = settle(TwistEstimator(20.0), poses)
    np.testing.assert_allclose(linear, velocity, atol=1e-9)
    np.testing.assert_allclose(angular, 0.0, atol=1e-12)


def test_constant_angular_velocity_is_in_the_fixed_frame():
    # R(t) = exp([w] t) R0: the spatial angular velocity is w, whatever R0 is
    omega = np.array([0.3, -0.4, 1.2])
    start = Rotation.from_euler("xyz", [0.4, -0.3, 1.0])
    poses = [(np.zeros(3), (Rotation.from_rotvec(omega * index * STEP) * start).as_quat()) for index in range(1000)]
    _, angular = settle(TwistEstimator(20.0), poses)
    np.testing.assert_allclose(angular, omega, atol=1e-9)


def test_rotation_vector_ignores_the_quaternion_sign():
    first = Rotation.from_euler("z", 0.1).as_quat()
    second = Rotation.from_euler("z", 0.3).as_quat()
    np.testing.assert_allclose(rotation_vector_between(first, -second), [0, 0, 0.2], atol=1e-12)
    np.testing.assert_allclose(rotation_vector_between(first, first), 0.0, atol=1e-12)


def test_filter_is_first_order_with_the_given_cutoff():
    cutoff = 10.0
    estimator = TwistEstimator(cutoff)
    identity = np.array([0.0, 0.0, 0.0, 1.0])
    estimator.update(0.0, np.zeros(3), identity)
    # A step to 1 m/s: after one time constant tau = 1 / (2 pi fc) the output is ~63 % of the step
    tau = 1.0 / (2.0 * math.pi * cutoff)
    steps = int(round(tau / STEP))
    for index in range(1, steps + 1):
        linear, _ = estimator.update(index * STEP, np.array([index * STEP, 0.0, 0.0]), identity)
    assert linear[0] == pytest.approx(1.0 - math.exp(-1.0), abs=0.02)


def test_filter_smooths_quantisation_noise():
    rng = np.random.default_rng(0)
    identity = [0.0, 0.0, 0.0, 1.0]
    poses = [(np.array([0.01 * index * STEP + rng.uniform(-1e-5, 1e-5), 0, 0]), identity) for index in range(2000)]
    estimator = TwistEstimator(20.0)
    outputs = []
    for index, (position, orientation) in enumerate(poses):
        outputs.append(estimator.update(index * STEP, position, np.asarray(orientation))[0][0])
    raw = np.diff([position[0] for position, _ in poses]) / STEP
    assert np.std(outputs[1000:]) < 0.2 * np.std(raw[1000:])
    assert np.mean(outputs[1000:]) == pytest.approx(0.01, abs=0.002)


def test_repeated_time_and_reset():
    estimator = TwistEstimator(20.0)
    identity = np.array([0.0, 0.0, 0.0, 1.0])
    estimator.update(0.0, np.zeros(3), identity)
    first, _ = estimator.update(0.001, np.array([0.001, 0, 0]), identity)
    again, _ = estimator.update(0.001, np.array([0.5, 0, 0]), identity)  # same instant: nothing to differentiate
    np.testing.assert_allclose(again, first)
    estimator.reset()
    linear, angular = estimator.update(0.002, np.array([1.0, 0, 0]), identity)
    np.testing.assert_allclose(linear, 0.0)
    np.testing.assert_allclose(angular, 0.0)


@pytest.mark.parametrize("cutoff", [0.0, -1.0, float("nan")])
def test_bad_cutoff_is_refused(cutoff):
    with pytest.raises(ValueError):
        TwistEstimator(cutoff)


def test_the_stamp_on_wall_is_the_line_of_a_late_and_uneven_simulated_clock():
    """Ticks of 10 ms at half real time, a fifth of them arriving 30-90 ms late: the line gives the stamps' pace
    (0.5 s per wall second) at every read, where the stamps themselves stand still and then jump."""
    rng = np.random.default_rng(3)
    produced = np.arange(400) * 0.02  # tick k (stamp 0.01 k) is made at wall 0.02 k
    arrival = np.maximum.accumulate(produced + np.where(rng.random(400) < 0.2, rng.uniform(0.03, 0.09, 400), 0.0))
    line, moments, walls = StampOnWall(), [], np.arange(0.5, 7.5, 0.001)
    for wall in walls:
        stamp = 0.01 * (np.searchsorted(arrival, wall, side="right") - 1)
        moments.append(line(wall, stamp))
    pace = np.diff(moments[-4000::10]) / 0.01  # over 10 ms of wall time, a twist filter's time constant
    # Expect: a steady pace of 0.5 (the stamps' own are 0 or 1 over 10 ms, and 3-9 ms behind), never back
    assert np.all(np.diff(moments) >= 0.0)
    np.testing.assert_allclose(np.median(pace), 0.5, rtol=0.05)
    assert 0.4 < np.percentile(pace, 1) and np.percentile(pace, 99) < 0.6, np.percentile(pace, [1, 99])


def test_the_stamp_on_wall_is_the_wall_clock_itself_and_starts_over_when_the_clock_goes_back():
    line = StampOnWall()
    walls = np.arange(100.0, 102.0, 0.001)
    # Expect: ROS on the wall clock passes through (the first reads are the stamps themselves)
    np.testing.assert_allclose([line(wall, wall) for wall in walls], walls, atol=1e-6)
    # Expect: a clock that went back (a simulation started again) is followed from there, not from the old line
    assert line(102.0, 0.0) == 0.0 and line(102.001, 0.0) == 0.0
