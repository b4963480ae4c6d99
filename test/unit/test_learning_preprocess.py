"""Preprocessing of recorded streams: clear errors, GUI-sample recovery, alignment, resampling, smoothing."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from teleteach.control.stiffness import translational_stiffnesses
from teleteach.learning import spd
from teleteach.learning.preprocess import (
    LearningError,
    gui_samples,
    prepare,
    resample_geodesic,
    smooth_at_mean,
)
from teleteach.learning.synthetic import minimum_jerk_between

DOWN = np.array([1.0, 0.0, 0.0, 0.0])


def poses(times):
    positions = np.column_stack([0.4 + 0.01 * times, np.zeros_like(times), np.full_like(times, 0.5)])
    return np.hstack([positions, np.tile(DOWN, (times.size, 1))])


def staircase(pose_times, publish_times, truth):
    """What a recorder at the pose rate stores when the GUI publishes truth(publish time) at publish_times."""
    latest = np.clip(np.searchsorted(publish_times, pose_times, side="right") - 1, 0, None)
    return truth(publish_times)[latest]


def truth(times):
    principal = np.column_stack(
        [np.full_like(times, 300.0), 300 + 1200 * minimum_jerk_between(times, 2.0, 5.0), np.full_like(times, 1000.0)]
    )
    return translational_stiffnesses(
        principal, Rotation.from_euler("z", np.radians(45.0) * minimum_jerk_between(times, 4.0, 8.0))
    )


def test_gui_samples_are_recovered_from_a_zero_order_hold_staircase():
    pose_times = np.arange(0.0, 10.0, 0.01)
    publish_times = np.arange(0.0, 10.0, 0.25)
    publish_times = np.concatenate([publish_times[:12], publish_times[20:]])  # a 2 s pause in publishing
    recorded = staircase(pose_times, publish_times, truth)
    knot_times, knots = gui_samples(pose_times, recorded)
    changing = np.flatnonzero(np.abs(np.diff(truth(publish_times), axis=0)).max(axis=(1, 2)) > 1e-9) + 1
    for index in changing:
        assert np.isclose(knot_times, publish_times[index]).any()
    # the pause gets an extra knot where the held value was last valid, one GUI period before the next change
    pause_end = publish_times[12]
    assert np.isclose(knot_times, pause_end - 0.25).any()
    assert np.all(np.diff(knot_times) > 0)
    # a recording without steps keeps every changing sample; constant stretches shrink to their two ends
    smooth = truth(pose_times)
    same_times, same = gui_samples(pose_times, smooth)
    assert same_times.size > 0.5 * pose_times.size
    assert spd.distance(resample_geodesic(same_times, same, pose_times), smooth).max() < 1e-9


def test_geodesic_resampling_passes_through_the_knots_and_stays_on_geodesics():
    knot_times = np.array([0.0, 1.0, 3.0])
    knots = truth(np.array([0.0, 4.0, 9.0]))
    resampled = resample_geodesic(knot_times, knots, np.array([-1.0, 0.0, 0.5, 1.0, 2.0, 3.0, 5.0]))
    np.testing.assert_allclose(resampled[[0, 1]], knots[[0, 0]], rtol=1e-9)
    np.testing.assert_allclose(resampled[[3, 5, 6]], knots[[1, 2, 2]], rtol=1e-9)
    assert spd.distance(resampled[2], spd.geodesic(knots[0], knots[1], 0.5)) < 1e-9
    assert spd.distance(resampled[4], spd.geodesic(knots[1], knots[2], 0.5)) < 1e-9


def test_smoothing_on_the_manifold_removes_steps_keeps_spd_and_levels():
    dt = 0.02
    times = np.arange(0.0, 10.0, dt)
    steps = np.where(times < 5.0, 1.0, 1e-6)
    matrices = np.array([np.diag([level * 500.0, 800.0, 1000.0]) for level in steps])
    smoothed = smooth_at_mean(matrices, dt, 0.3)
    assert np.linalg.eigvalsh(smoothed)[:, 0].min() > 0
    jumps = spd.distance(smoothed[:-1], smoothed[1:])
    assert jumps.max() < 0.1 * spd.distance(matrices[0], matrices[-1])
    np.testing.assert_allclose(smoothed[0], matrices[0], rtol=1e-6)  # far from the step nothing moves
    np.testing.assert_allclose(smoothed[-1], matrices[-1], rtol=1e-6)
    np.testing.assert_array_equal(smooth_at_mean(matrices, dt, 0.0), matrices)


def test_streams_at_different_rates_are_aligned_on_their_shared_window():
    stiffness_times = np.arange(0.5, 9.0, 0.2)  # GUI at 5 Hz, starts late
    cartesian_times = np.arange(0.0, 10.0, 0.01)  # controller at 100 Hz
    equilibrium_times = np.arange(0.2, 8.0, 0.05)  # player at 20 Hz, ends early
    demo = prepare(
        stiffness_times,
        truth(stiffness_times),
        {
            "cartesian_pose": (cartesian_times, poses(cartesian_times)),
            "equilibrium_pose": (equilibrium_times, poses(equilibrium_times)),
        },
        rate=50.0,
        smoothing=0.0,
    )
    assert demo.start_time == pytest.approx(0.5)
    assert demo.time[0] == 0.0
    assert demo.time[-1] == pytest.approx(7.45, abs=0.02)
    np.testing.assert_allclose(np.diff(demo.time), 0.02, rtol=1e-9)
    assert demo.stiffness.shape == (demo.time.size, 3, 3)
    for name in ("cartesian_pose", "equilibrium_pose"):
        np.testing.assert_allclose(demo.poses[name][:, 0], 0.4 + 0.01 * (demo.time + 0.5), atol=1e-9)
    # the GUI samples, re-timed to the grid, are passed through exactly
    at_samples = resample_geodesic(demo.time, demo.stiffness, demo.sample_time)
    assert spd.distance(at_samples, demo.samples).max() < 1e-6
    assert demo.sample_time[0] == pytest.approx(0.0)


def good_streams(count=50):
    times = np.arange(count) * 0.1
    return times, truth(times), {"cartesian_pose": (times, poses(times))}


@pytest.mark.parametrize(
    ("spoil", "message"),
    [
        (lambda t, k, p: (t[:3], k[:3], p), "stiffness has too few samples: 3"),
        (
            lambda t, k, p: (t, k, {"cartesian_pose": (p["cartesian_pose"][0][:2], p["cartesian_pose"][1][:2])}),
            "cartesian_pose has too few samples",
        ),
        (lambda t, k, p: (t[[0, 1, 2, 4, 3, *range(5, t.size)]], k, p), "non-monotonic\\) at sample 4"),
        (
            lambda t, k, p: (t, np.concatenate([k[:7], -k[7:8], k[8:]]), p),
            "non-SPD sample: stiffness sample 7 is not positive definite",
        ),
        (
            lambda t, k, p: (t, np.concatenate([k[:2], k[2:3] + np.triu(np.ones((3, 3)), 1), k[3:]]), p),
            "sample 2 is not symmetric",
        ),
        (lambda t, k, p: (t, k[:, :, :2], p), "2x2 or 3x3"),
        (
            lambda t, k, p: (np.where(np.arange(t.size) == 5, np.nan, t), k, p),
            "stiffness time is not finite at sample 5",
        ),
        (
            lambda t, k, p: (t, k, {"cartesian_pose": (p["cartesian_pose"][0], p["cartesian_pose"][1] * 2)}),
            "not unit length at sample 0",
        ),
        (
            lambda t, k, p: (t, k, {"cartesian_pose": (p["cartesian_pose"][0] + 100.0, p["cartesian_pose"][1])}),
            "share only 0.000 s",
        ),
    ],
)
def test_bad_recordings_raise_one_clear_error(spoil, message):
    times, stiffness, pose_streams = spoil(*good_streams())
    with pytest.raises(LearningError, match=message):
        prepare(times, stiffness, pose_streams, rate=50.0, smoothing=0.1)


def test_bad_settings_are_rejected():
    times, stiffness, pose_streams = good_streams()
    with pytest.raises(LearningError, match="rate"):
        prepare(times, stiffness, pose_streams, rate=0.0, smoothing=0.1)
    with pytest.raises(LearningError, match="smoothing"):
        prepare(times, stiffness, pose_streams, rate=50.0, smoothing=-1.0)


def test_orientations_are_resampled_by_slerp():
    times = np.array([0.0, 1.0, 2.0, 3.0, 4.0])
    quaternions = Rotation.from_euler("z", [0, 10, 20, 30, 40], degrees=True).as_quat()
    stream = np.hstack([np.zeros((5, 3)), quaternions])
    demo = prepare(times, truth(times), {"cartesian_pose": (times, stream)}, rate=4.0, smoothing=0.0)
    yaw = Rotation.from_quat(demo.poses["cartesian_pose"][:, 3:]).as_euler("zyx", degrees=True)[:, 0]
    np.testing.assert_allclose(yaw, 10.0 * demo.time, atol=1e-9)
