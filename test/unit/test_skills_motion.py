import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from teleteach.control.kinematics import PandaKinematics
from teleteach.core.trajectories import MINIMUM_JERK_PEAK, minimum_jerk, minimum_jerk_rate
from teleteach.skills import trajectory
from teleteach.skills.config import DEFAULT_MOTION_FILE, MotionConfigError, load_motion_config
from teleteach.skills.motion import TOP_DOWN, InverseKinematics, base_to_world, world_to_base
from teleteach.skills.robot import Execution, SkillError

READY = np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])


@pytest.fixture(scope="module")
def kinematics():
    model = PandaKinematics(0.40)
    yield model
    model.close()


def test_min_jerk_starts_and_ends_at_rest():
    phase, rate = minimum_jerk(np.array([0.0, 0.5, 1.0])), minimum_jerk_rate(np.array([0.0, 0.5, 1.0]))
    np.testing.assert_allclose(phase, [0.0, 0.5, 1.0])
    np.testing.assert_allclose(rate[[0, 2]], [0.0, 0.0])
    assert rate[1] == pytest.approx(MINIMUM_JERK_PEAK)
    # Expect the rate to be the profile's derivative (a central difference), and the profile held outside [0, 1]
    tau = np.linspace(0.05, 0.95, 19)
    np.testing.assert_allclose(minimum_jerk_rate(tau), (minimum_jerk(tau + 1e-6) - minimum_jerk(tau - 1e-6)) / 2e-6)
    assert (minimum_jerk(-0.5), minimum_jerk(1.5)) == (0.0, 1.0)


def test_point_to_point_velocities_match_finite_differences_and_respect_the_peak_speed():
    start, goal = READY, READY + np.array([0.6, -0.3, 0.2, 0.5, -0.1, 0.0, 0.9])
    duration = trajectory.move_duration(np.abs(goal - start).max(), 0.6, 0.5)
    path = trajectory.point_to_point(start, goal, duration, 0.001)
    np.testing.assert_allclose(path.positions[0], start)
    np.testing.assert_allclose(path.positions[-1], goal)
    numeric = np.gradient(path.positions, path.times, axis=0)
    np.testing.assert_allclose(path.velocities[1:-1], numeric[1:-1], atol=1e-3)
    assert np.abs(path.velocities).max() <= 0.6 + 1e-6
    np.testing.assert_allclose(path.velocities[[0, -1]], 0.0, atol=1e-9)


def test_along_path_passes_every_waypoint_in_order():
    waypoints = np.cumsum(np.full((11, 7), 0.01), axis=0)
    path = trajectory.along_path(waypoints, 2.0, 0.002)
    np.testing.assert_allclose(path.positions[0], waypoints[0])
    np.testing.assert_allclose(path.positions[-1], waypoints[-1])
    assert np.all(np.diff(path.positions[:, 0]) >= -1e-12)
    numeric = np.gradient(path.positions, path.times, axis=0)
    np.testing.assert_allclose(path.velocities[5:-5], numeric[5:-5], atol=2e-3)


def test_ik_reaches_the_pose_checked_by_pybullet_forward_kinematics(kinematics):
    ik = InverseKinematics(kinematics, tolerance=1e-4)
    target_rotation = Rotation.from_euler("z", 0.3) * TOP_DOWN
    joints = ik.solve([0.62, -0.1, 0.535], target_rotation, READY)
    position, quaternion = kinematics.forward(joints)
    np.testing.assert_allclose(position, [0.62, -0.1, 0.535], atol=2e-4)
    angle = (Rotation.from_quat(quaternion) * target_rotation.inv()).magnitude()
    assert angle < 2e-4


def test_ik_of_an_unreachable_pose_says_how_far_it_stayed(kinematics):
    ik = InverseKinematics(kinematics, max_iterations=50)
    with pytest.raises(SkillError, match=r"no arm posture reaches \[2.0, 0.0, 0.5\] m"):
        ik.solve([2.0, 0.0, 0.5], TOP_DOWN, READY)


def test_base_and_world_frames_are_inverse():
    base = (1.565, -0.495, math.pi / 4)
    point = np.array([0.7, 0.0, 0.72])
    world = base_to_world(base, point)
    np.testing.assert_allclose(world, [1.565 + 0.7 / math.sqrt(2), -0.495 + 0.7 / math.sqrt(2), 0.72])
    np.testing.assert_allclose(world_to_base(base, world), point)


def test_execution_progress_spans_the_phases():
    reports = []
    execution = Execution(feedback=lambda progress, phase: reports.append((round(progress, 6), phase)))
    execution.phase("a", 0.25)
    execution.report(1.0)
    execution.phase("b", 0.75)
    execution.report(0.5)
    execution.complete("done")
    assert reports == [(0.0, "a"), (0.25, "a"), (0.25, "b"), (0.625, "b"), (1.0, "done")]


def test_execution_progress_never_goes_back_within_a_phase():
    # a grasp's progress is how far the fingers have closed: on a product they give a little and spring back
    reports = []
    execution = Execution(feedback=lambda progress, phase: reports.append(round(progress, 6)))
    execution.phase("grasp", 0.5)
    for fraction in (0.4, 0.9, 0.85, 0.95):
        execution.report(fraction)
    execution.phase("lift", 0.5)
    execution.report(0.2)
    assert reports == [0.0, 0.2, 0.45, 0.45, 0.475, 0.5, 0.6]


def test_motion_config_loads_and_rejects_bad_values(tmp_path):
    config = load_motion_config()
    assert config.replay.rate >= 100.0
    assert config.skills["PickItem2"]["product"] == "product_pick_2"
    bad = tmp_path / "motion.yaml"
    bad.write_text(DEFAULT_MOTION_FILE.read_text().replace("rate: 200.0", "rate: 50.0"))
    with pytest.raises(MotionConfigError, match="replay.rate must be >= 100 Hz"):
        load_motion_config(bad)
    bad.write_text(DEFAULT_MOTION_FILE.read_text().replace("open_width: 0.08 ", "open_width: 0.2 "))
    with pytest.raises(MotionConfigError, match="open_width must be within"):
        load_motion_config(bad)
    with pytest.raises(MotionConfigError, match="does-not-exist"):
        load_motion_config(tmp_path / "does-not-exist.yaml")
