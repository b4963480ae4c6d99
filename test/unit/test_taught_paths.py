"""Paths taught in TELEOP: recorded, put in the target's frame, averaged over demonstrations (with a spread), saved."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from teleteach.core.frames import Transform
from teleteach.core.trajectories import Trajectory, TrajectoryError, mean_trajectory
from teleteach.gui.recording import PathRecorder

DOWN = Rotation.from_euler("x", np.pi).as_quat()


def straight(start, end, duration, name="demo", frame="base_link", target=None, count=21, turn=0.0):
    """A straight path from ``start`` to ``end`` at constant speed, turning ``turn`` [rad] about z on the way."""
    times = np.linspace(0.0, duration, count)
    fraction = (times / duration)[:, None]
    positions = np.asarray(start) + fraction * (np.asarray(end) - np.asarray(start))
    quaternions = (Rotation.from_euler("z", turn * fraction[:, 0]) * Rotation.from_quat(DOWN)).as_quat()
    return Trajectory(times, positions, quaternions, frame, name, target)


def test_a_saved_path_loads_back_with_its_spread(tmp_path):
    path = straight([0.0, 0.0, 0.0], [0.1, 0.0, 0.0], 2.0, frame="target", target="gap_1")
    mean = mean_trajectory([path, path], "TaughtPath_1", points=11)
    loaded = Trajectory.load(mean.save(tmp_path / "TaughtPath_1.yaml"))
    assert (loaded.name, loaded.frame, loaded.target, loaded.demonstrations) == ("TaughtPath_1", "target", "gap_1", 2)
    np.testing.assert_allclose(loaded.positions, mean.positions, atol=1e-5)
    np.testing.assert_allclose(loaded.spread, np.zeros(11), atol=1e-9)
    np.testing.assert_allclose(loaded.sample(1.0), mean.sample(1.0), atol=1e-5)


def test_the_mean_of_two_parallel_paths_lies_between_them_and_their_spread_is_half_the_gap():
    left = straight([0.0, 0.01, 0.0], [0.1, 0.01, 0.0], 2.0)
    right = straight([0.0, -0.01, 0.0], [0.1, -0.01, 0.0], 2.0)
    mean = mean_trajectory([left, right], "mean", points=11)
    # Expect: the middle line, each demonstration 1 cm from it (the RMS of 1 cm and 1 cm)
    np.testing.assert_allclose(mean.positions[:, 1], 0.0, atol=1e-12)
    np.testing.assert_allclose(mean.positions[:, 0], np.linspace(0.0, 0.1, 11), atol=1e-12)
    np.testing.assert_allclose(mean.spread, 0.01, atol=1e-12)
    np.testing.assert_allclose(mean.times, np.linspace(0.0, 2.0, 11) + np.arange(11) * 1e-4, atol=1e-9)


def test_demonstrations_at_different_paces_line_up_by_distance_travelled():
    slow_start = Trajectory(
        [0.0, 3.0, 4.0], [[0.0, 0.0, 0.0], [0.05, 0.0, 0.0], [0.1, 0.0, 0.0]], [DOWN] * 3, name="slow start"
    )
    even = straight([0.0, 0.0, 0.0], [0.1, 0.0, 0.0], 2.0)
    mean = mean_trajectory([slow_start, even], "mean", points=3)
    # Expect: halfway along the path both are at x = 5 cm (no spread), reached at the mean of 3 s and 1 s
    np.testing.assert_allclose(mean.positions[:, 0], [0.0, 0.05, 0.1], atol=1e-12)
    np.testing.assert_allclose(mean.spread, 0.0, atol=1e-12)
    np.testing.assert_allclose(mean.times, [0.0, 2.0 + 1e-4, 3.0 + 2e-4], atol=1e-9)


def test_the_mean_orientation_is_between_the_demonstrations():
    turned = straight([0.0, 0.0, 0.0], [0.1, 0.0, 0.0], 2.0, turn=0.4)
    straight_on = straight([0.0, 0.0, 0.0], [0.1, 0.0, 0.0], 2.0)
    mean = mean_trajectory([turned, straight_on], "mean", points=5)
    expected = Rotation.from_euler("z", 0.2) * Rotation.from_quat(DOWN)
    assert (Rotation.from_quat(mean.quaternions[-1]) * expected.inv()).magnitude() < 1e-6


def test_demonstrations_at_other_targets_are_not_averaged():
    one = straight([0, 0, 0], [0.1, 0, 0], 1.0, frame="target", target="gap_1")
    other = straight([0, 0, 0], [0.1, 0, 0], 1.0, frame="target", target="gap_2")
    with pytest.raises(TrajectoryError, match="not in one frame"):
        mean_trajectory([one, other], "mixed")


def test_a_path_in_base_link_moves_into_the_gaps_frame():
    path = straight([0.5, 0.2, 0.8], [0.6, 0.2, 0.8], 1.0)
    gap = Transform.from_pose([0.6, 0.2, 0.8, *Rotation.from_euler("z", np.pi / 2).as_quat()])
    relative = path.relative_to("gap_2", gap)
    assert (relative.frame, relative.target) == ("target", "gap_2")
    # Expect: the end at the gap's origin; the start 10 cm behind it along base x, which is the gap's -y
    np.testing.assert_allclose(relative.positions[-1], [0.0, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(relative.positions[0], [0.0, 0.1, 0.0], atol=1e-12)
    np.testing.assert_allclose(relative.resolve(gap, None).positions, path.positions, atol=1e-12)


def test_the_path_recorder_leaves_out_the_time_the_arm_held_still():
    recorder = PathRecorder()
    recorder.start()
    pose = np.array([0.3, 0.0, 0.8, *DOWN])
    for step in range(100):  # 0.5 s still, then 1 s moving 5 cm, then 2 s still, then 1 s moving 5 cm
        recorder.add(step * 0.005, pose)
    for step in range(200):
        pose = pose + np.array([0.05 / 200, 0, 0, 0, 0, 0, 0])
        recorder.add(0.5 + (step + 1) * 0.005, pose)
    for step in range(400):
        recorder.add(1.5 + (step + 1) * 0.005, pose)
    for step in range(200):
        pose = pose + np.array([0.0, 0.05 / 200, 0, 0, 0, 0, 0])
        recorder.add(3.5 + (step + 1) * 0.005, pose)
    recorder.stop()
    path = recorder.to_trajectory("path")
    # Expect 2 s of motion, 10 cm travelled, waypoints every 50 ms at most
    assert path.duration == pytest.approx(2.0, abs=0.01)
    np.testing.assert_allclose(path.positions[-1], [0.35, 0.05, 0.8], atol=1e-9)
    assert np.all(np.diff(path.times) <= 0.05 + 1e-9) and path.frame == "base_link"


def test_a_device_reporting_less_often_than_the_gui_commands_keeps_the_pace():
    recorder = PathRecorder()
    recorder.start()
    for step in range(400):  # 2 s at 200 Hz; the pose changes every 4th sample (a device at 50 Hz)
        recorder.add(step * 0.005, np.array([0.3 + 0.02 * (step // 4) / 100, 0.0, 0.8, *DOWN]))
    path = recorder.to_trajectory("quantised")
    assert path.duration == pytest.approx(2.0, abs=0.03)


def test_a_path_that_hardly_moved_is_refused():
    recorder = PathRecorder()
    recorder.start()
    for step in range(400):
        recorder.add(step * 0.005, np.array([0.3, 0.0, 0.8 + step * 1e-5, *DOWN]))
    with pytest.raises(TrajectoryError, match="moved 4.0 mm"):
        recorder.to_trajectory("tiny")
