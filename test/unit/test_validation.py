"""Every kind of bad command is rejected with its reason (teleteach.core.validation), and RobotSim keeps the
last good command."""

import math

import numpy as np
import pytest
from sim_support import robot_sim_for_module

from teleteach.control import panda
from teleteach.core import validation as v


@pytest.fixture(scope="module")
def robot_sim():
    yield from robot_sim_for_module()


UNIT = [0.0, 0.0, 0.0, 1.0]


@pytest.mark.parametrize(
    ("call", "reason"),
    [
        (lambda: v.validate_eigenvalues([1.0, math.nan, 1.0], 3000.0), "NaN or inf"),
        (lambda: v.validate_eigenvalues([1.0, math.inf, 1.0], 3000.0), "NaN or inf"),
        (lambda: v.validate_eigenvalues([1.0, -0.1, 1.0], 3000.0), "negative stiffness"),
        (lambda: v.validate_eigenvalues([1.0, 1.0], 3000.0), "must have 3 values"),
        (lambda: v.validate_quaternion([0.0, 0.0, 0.0, 0.0]), "is zero"),
        (lambda: v.validate_quaternion([0.0, 0.0, 0.0, 1.1]), "not unit"),
        (lambda: v.validate_quaternion([0.0, math.nan, 0.0, 1.0]), "NaN or inf"),
        (lambda: v.validate_pose("world", "base_link", [0.0, 0.0, 0.5], UNIT), "frame 'world' is wrong"),
        (lambda: v.validate_pose("base_link", "base_link", [0.0, math.inf, 0.5], UNIT), "NaN or inf"),
        (lambda: v.check_stamp(10.0, 12.5, 1.0), "stale stamp"),
        (lambda: v.check_stamp(15.0, 12.5, 1.0), "stale stamp"),
        (lambda: v.validate_base_goal("base_link", [1.0, 0.0, 0.0], UNIT), "frame 'base_link' is wrong"),
        (lambda: v.validate_base_goal("world", [1.0, 0.0, 0.0], [0.7071068, 0.0, 0.0, 0.7071068]), "about z only"),
    ],
)
def test_rejections_say_why(call, reason):
    with pytest.raises(v.InvalidCommandError, match=reason):
        call()


def test_accepted_values_are_cleaned():
    np.testing.assert_allclose(v.validate_eigenvalues([5000.0, 0.0, 10.0], 3000.0), [3000.0, 0.0, 10.0])
    np.testing.assert_allclose(np.linalg.norm(v.validate_quaternion([0.0, 0.0, 0.0, 1.0005])), 1.0)
    v.check_stamp(0.0, 100.0, 1.0)  # zero stamp = now
    v.check_stamp(99.5, 100.0, 1.0)
    assert v.validate_base_goal("/world", [1.0, 2.0, 0.0], [0.0, 0.0, 1.0, 0.0])[2] == pytest.approx(math.pi)


def _points(*rows):
    return [(positions, velocities, t) for positions, velocities, t in rows]


@pytest.mark.parametrize(
    ("names", "points", "reason"),
    [
        (panda.ARM_JOINTS[:6], _points(([0.0] * 6, [], 1.0)), "joint names"),
        (panda.ARM_JOINTS, [], "no points"),
        (panda.ARM_JOINTS, _points(([0.0] * 3 + [-1.0, 0.0, 1.0, math.nan], [], 1.0)), "NaN or inf"),
        (panda.ARM_JOINTS, _points(([0.0] * 3 + [0.5, 0.0, 1.0, 0.0], [], 1.0)), "joint limits"),
        (
            panda.ARM_JOINTS,
            _points(([0.0, 0.0, 0.0, -1.0, 0.0, 1.0, 0.0], [], 1.0), ([0.0, 0.0, 0.0, -1.0, 0.0, 1.0, 0.0], [], 1.0)),
            "increase strictly",
        ),
        (
            panda.ARM_JOINTS,
            _points(
                ([0.0, 0.0, 0.0, -1.0, 0.0, 1.0, 0.0], [0.0] * 7, 1.0), ([0.0, 0.0, 0.0, -1.0, 0.0, 1.0, 0.0], [], 2.0)
            ),
            "every point or for none",
        ),
    ],
)
def test_trajectory_rejections(names, points, reason):
    with pytest.raises(v.InvalidCommandError, match=reason):
        v.validate_joint_trajectory(names, points, panda.ARM_JOINTS, panda.LOWER_LIMITS, panda.UPPER_LIMITS)


def test_trajectory_columns_are_reordered_to_the_controller_joints():
    names = list(reversed(panda.ARM_JOINTS))
    q = [0.1, -0.2, 0.3, -1.0, 0.5, 1.0, 0.7]
    times, positions, velocities = v.validate_joint_trajectory(
        names, _points((list(reversed(q)), [], 1.0)), panda.ARM_JOINTS, panda.LOWER_LIMITS, panda.UPPER_LIMITS
    )
    np.testing.assert_allclose(positions[0], q)
    assert velocities is None and times.tolist() == [1.0]


def test_robot_sim_keeps_the_last_good_command(robot_sim):
    sim = robot_sim
    controller = sim.impedance
    sim.command_eigenvalues([100.0, 200.0, 300.0])
    sim.command_equilibrium("base_link", [0.3, 0.0, 0.8], UNIT)
    stiffness, position = controller.stiffness_target.copy(), controller.equilibrium_position.copy()
    bad = [
        lambda: sim.command_eigenvalues([100.0, -1.0, 300.0]),
        lambda: sim.command_eigenvectors([0.0, 0.0, 0.0, 0.0]),
        lambda: sim.command_equilibrium("world", [0.5, 0.0, 0.8], UNIT),
        lambda: sim.command_equilibrium("base_link", [0.5, 0.0, math.nan], UNIT),
        lambda: sim.command_equilibrium("base_link", [0.5, 0.0, 0.8], UNIT, stamp=sim.time + 5.0),
        lambda: sim.gripper.move(-0.01, 0.1, sim.time),
        lambda: sim.command_trajectory(["panda_joint1"], [([0.1], [], 1.0)]),
    ]
    for call in bad:
        with pytest.raises(v.InvalidCommandError):
            call()
    np.testing.assert_allclose(controller.stiffness_target, stiffness)
    np.testing.assert_allclose(controller.equilibrium_position, position)


LIMITS = (panda.ARM_JOINTS, panda.LOWER_LIMITS, panda.UPPER_LIMITS)
READY = [0.0, 0.0, 0.0, -1.0, 0.0, 1.0, 0.0]


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: v.check_stamp(math.nan, 12.5, 1.0), "stamp is not finite (nan)"),
        (lambda: v.check_stamp(10.0, 12.5, 1.0), "stale stamp: +2.500 s away from the current time (limit 1.000 s)"),
        (lambda: v.check_stamp(15.0, 12.5, 1.0), "stale stamp: -2.500 s away from the current time (limit 1.000 s)"),
        (lambda: v.check_frame("map", "world"), "frame 'map' is wrong: expected 'world'"),
        (lambda: v.check_frame("Xworld", "world"), "frame 'Xworld' is wrong"),  # only leading slashes are dropped
        (lambda: v.finite_vector([1.0, 2.0], 3, "position"), "position must have 3 values, got 2"),
        (lambda: v.finite_vector([[1.0, 2.0, 3.0]], 3, "position"), "position must have 3 values, got 3"),
        (
            lambda: v.finite_vector([1.0, -math.inf, 3.0], 3, "position"),
            "position contains NaN or inf: [1.0, -inf, 3.0]",
        ),
        (lambda: v.validate_eigenvalues([1.0, -0.1, 2.0], 3000.0), "negative stiffness: [1.0, -0.1, 2.0] N/m"),
        (lambda: v.validate_eigenvalues([1.0, math.nan, 2.0], 3000.0), "eigenvalues contains NaN or inf"),
        (lambda: v.validate_quaternion([0.0, math.nan, 0.0, 1.0]), "quaternion contains NaN or inf"),
        (lambda: v.validate_pose("base_link", "base_link", [0.0, math.inf, 0.5], UNIT), "position contains NaN"),
        (lambda: v.validate_joint_trajectory(panda.ARM_JOINTS, [], *LIMITS), "trajectory has no points"),
        (lambda: v.validate_quaternion([0.0, 0.0, 0.0, 0.0], "eigenvectors"), "eigenvectors is zero"),
        (lambda: v.validate_quaternion([0.0, 0.0, 0.0, 1.0011]), "quaternion is not unit (norm 1.001100)"),
        (lambda: v.validate_pose("base_link", "base_link", [0.0, 0.0, 0.5], [0.0, 0.0, 0.0, 0.5]), "orientation is"),
        (
            lambda: v.validate_base_goal("world", [1.0, 0.0, 0.0], [0.0011, 0.0, 0.0, 1.0]),
            "base goal orientation must be a rotation about z only",
        ),
        (
            lambda: v.validate_base_goal("world", [1.0, 0.0, 0.0], [0.0, 0.0011, 0.0, 1.0]),
            "base goal orientation must be a rotation about z only",
        ),
    ],
)
def test_each_rejection_says_exactly_what_was_wrong(call, message):
    with pytest.raises(v.InvalidCommandError) as error:
        call()
    assert str(error.value).startswith(message)


def test_the_bounds_themselves_are_accepted():
    v.check_stamp(11.5, 12.5, 1.0)  # exactly max_age old, and ahead
    v.check_stamp(13.5, 12.5, 1.0)
    v.check_frame("/world", "world")
    np.testing.assert_allclose(v.validate_eigenvalues([0.0, 3000.0, 2999.0], 3000.0), [0.0, 3000.0, 2999.0])
    np.testing.assert_allclose(v.validate_quaternion([0.0, 0.0, 0.0, 1.0009]), [0.0, 0.0, 0.0, 1.0])
    np.testing.assert_allclose(v.validate_quaternion([0.0, 0.0, 0.0, 0.9991]), [0.0, 0.0, 0.0, 1.0])
    x, y, yaw = v.validate_base_goal("world", [1.0, -2.0, 0.3], [0.0009, 0.0, 0.0, 1.0])
    v.validate_base_goal("world", [0.0, 0.0, 0.0], [0.001, 0.0, 0.0, math.sqrt(1.0 - 1e-6)])  # tilted exactly 1e-3
    assert (x, y, yaw) == (1.0, -2.0, pytest.approx(0.0, abs=1e-9))
    assert v.validate_base_goal("world", [0.0, 0.0, 0.0], [0.0, 0.0, math.sin(0.3), math.cos(0.3)])[2] == pytest.approx(
        0.6
    )


def test_a_pose_is_its_position_and_its_normalised_orientation():
    position, orientation = v.validate_pose("base_link", "base_link", [0.1, 0.2, 0.3], [0.0, 0.0, 0.0, 1.0005])
    np.testing.assert_allclose(position, [0.1, 0.2, 0.3])
    np.testing.assert_allclose(orientation, [0.0, 0.0, 0.0, 1.0])


@pytest.mark.parametrize(
    ("names", "points", "message"),
    [
        ([*panda.ARM_JOINTS[:6], "panda_joint1"], [(READY, [], 1.0)], "joint names"),
        (panda.ARM_JOINTS, [(READY, [], -0.1)], "time_from_start of point 0 is invalid (-0.1)"),
        (panda.ARM_JOINTS, [(READY, [], math.nan)], "time_from_start of point 0 is invalid (nan)"),
        (panda.ARM_JOINTS, [(READY, [], 1.0), (READY, [], 0.5)], "time_from_start must increase strictly (point 1)"),
        (panda.ARM_JOINTS, [(READY, [], 1.0), (READY[:6], [], 2.0)], "positions of point 1 must have 7 values, got 6"),
        (panda.ARM_JOINTS, [(READY, [0.0] * 6, 1.0)], "velocities of point 0 must have 7 values, got 6"),
        (panda.ARM_JOINTS, [(READY, [], 1.0), (READY, [0.0] * 7, 2.0)], "velocities must be given for every point"),
        (panda.ARM_JOINTS, [([*READY[:3], -3.2, *READY[4:]], [], 1.0)], "point 0 is outside the joint limits"),
    ],
)
def test_each_trajectory_rejection_names_the_point_and_what_was_wrong(names, points, message):
    with pytest.raises(v.InvalidCommandError) as error:
        v.validate_joint_trajectory(names, points, *LIMITS)
    assert str(error.value).startswith(message)


def test_a_trajectory_may_start_at_zero_touch_its_limits_and_carry_velocities_reordered():
    lower, upper = list(panda.LOWER_LIMITS), list(panda.UPPER_LIMITS)
    names = list(reversed(panda.ARM_JOINTS))
    velocities = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7]
    points = [(list(reversed(lower)), list(reversed(velocities)), 0.0), (list(reversed(upper)), [0.0] * 7, 1.5)]
    times, positions, speeds = v.validate_joint_trajectory(names, points, *LIMITS)
    assert times.tolist() == [0.0, 1.5]
    np.testing.assert_allclose(positions, [lower, upper])
    np.testing.assert_allclose(speeds, [velocities, [0.0] * 7])


def test_a_rotation_typed_to_a_few_decimals_is_taken_as_the_nearest_rotation():
    from scipy.spatial.transform import Rotation

    # Expect: every rotation typed to 4 decimals is taken (at 6 decimals 2 % were refused), made exactly orthonormal
    for rotation in Rotation.random(200, random_state=2):
        typed = rotation.as_matrix().round(4)
        taken = v.rotation_matrix(typed.tolist(), "axes")
        np.testing.assert_allclose(taken @ taken.T, np.eye(3), atol=1e-12)
        assert np.linalg.det(taken) == pytest.approx(1.0)
        assert (Rotation.from_matrix(taken).inv() * rotation).magnitude() < 1e-3
    for refused, why in (
        ([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]], "not a rotation"),  # a mirror
        ([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.002]], "not a rotation"),  # 2e-3 off: a typo, not rounding
        ([[0.99, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], "not a rotation"),
        ([[1.0, 0.0], [0.0, 1.0]], "a 3x3 matrix of numbers"),
        ([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, float("nan")]], "a 3x3 matrix of numbers"),
        ("up", "a 3x3 matrix of numbers"),
    ):
        with pytest.raises(v.InvalidCommandError, match=why):
            v.rotation_matrix(refused, "axes")
    # within the tolerance: 1.0004 squared is 8e-4 off one, still typed rounding; a row leaning 1e-3 into the next
    # is exactly at the tolerance (M M^T's off-diagonal is that 1e-3), still taken
    v.rotation_matrix([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0004]], "axes")
    v.rotation_matrix([[1.0, 1e-3, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], "axes")
    with pytest.raises(v.InvalidCommandError, match="a 3x3 matrix of numbers"):  # a word where a number belongs
        v.rotation_matrix([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, "one"]], "axes")
