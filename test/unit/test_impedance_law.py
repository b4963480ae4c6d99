"""The Cartesian impedance law (thesis eq 5) on a made-up arm state, against the formula written out here.

The physics tests (test_impedance_physics.py) judge the controller through the simulated Panda; these read one
tick's torques, the reference's velocity and acceleration, the gain filter and the parameter checks exactly.
"""

import dataclasses
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from teleteach.control.impedance import (
    FILTER_DONE,
    CartesianImpedanceController,
    ImpedanceParams,
    RobotState,
    orientation_error,
)

PARAMS = ImpedanceParams(
    rotational_stiffness=30.0,
    max_stiffness=3000.0,
    initial_eigenvalues=(800.0, 600.0, 400.0),
    damping="mass_aware",
    translational_damping_ratio=1.0,
    rotational_damping_ratio=0.7,
    nullspace_stiffness=2.0,
    max_position_error=0.05,
    max_orientation_error=0.15,
    stiffness_filter=0.25,
    max_torque_step=1e6,  # no rate limit unless a test sets one
    model_update_period=1,
    reference_velocity_timeout=0.0625,  # [s] times in these tests are binary fractions: exact sums and differences
    max_reference_acceleration=5.0,
)


def arm_state(time=1.0, seed=0):
    """A made-up arm: a full-rank Jacobian, an SPD mass matrix, arbitrary joints, velocities and model torques."""
    rng = np.random.default_rng(seed)
    root = rng.normal(size=(7, 7))
    mass = root @ root.T + 7.0 * np.eye(7)
    return RobotState(
        time=time,
        q=rng.normal(size=7),
        dq=0.1 * rng.normal(size=7),
        position=np.array([0.4, 0.1, 0.5]),
        quaternion=np.array([0.0, 0.0, 0.0, 1.0]),
        jacobian=rng.normal(size=(6, 7)),
        model_torque=rng.normal(size=7),
        mass_matrix=lambda: mass,
    )


def started(params=PARAMS, state=None):
    controller = CartesianImpedanceController(params)
    controller.starting(state if state is not None else arm_state())
    return controller


def expected_torque(gains, state, reference_velocity, reference_acceleration, posture):
    """tau = N (k_ns (q_ns - q) - 2 sqrt(k_ns) dq) + g + C dq - J^T (K e + D (J dq - x_dot_r) - Lambda x_ddot_r).

    ``gains``: (K, D, Lambda, x_r position, x_r quaternion) as they were when the tick began.
    """
    stiffness, damping, inertia, equilibrium_position, equilibrium_quaternion = gains
    rotation = Rotation.from_quat(state.quaternion) * Rotation.from_quat(equilibrium_quaternion).inv()
    error = np.concatenate((state.position - equilibrium_position, rotation.as_rotvec()))
    limit = np.array([PARAMS.max_position_error] * 3 + [PARAMS.max_orientation_error] * 3)
    error = np.clip(error, -limit, limit)
    jacobian = state.jacobian
    projector = np.eye(7) - np.linalg.pinv(jacobian) @ jacobian
    k_ns = PARAMS.nullspace_stiffness
    nullspace = projector @ (k_ns * (posture - state.q) - 2.0 * math.sqrt(k_ns) * state.dq)
    wrench = stiffness @ error + damping @ (jacobian @ state.dq - reference_velocity) - inertia @ reference_acceleration
    return nullspace + state.model_torque - jacobian.T @ wrench


def gains(controller):
    return (
        controller.stiffness.copy(),
        controller.damping.copy(),
        controller.cartesian_inertia.copy(),
        controller.equilibrium_position.copy(),
        controller.equilibrium_quaternion.copy(),
    )


TORQUE = {"rel": 1e-6, "abs": 1e-5}  # the controller's nullspace uses a damped inverse (1e-6): pinv here


def test_one_tick_is_eq_5_with_the_error_clipped_per_axis_and_the_posture_held_in_the_nullspace():
    start = arm_state()
    controller = started(state=start)
    # a reference 3 cm away in x (inside the clip), 20 cm in z (clipped to 5 cm), turned 0.4 rad about z (clipped)
    controller.set_equilibrium(
        start.position + np.array([0.03, 0.0, -0.2]), Rotation.from_rotvec([0, 0, 0.4]).as_quat()
    )
    # the same arm a moment later, turned 0.1 rad about x and moved 1 cm
    state = dataclasses.replace(
        start, time=1.001, position=start.position + 0.01, quaternion=Rotation.from_rotvec([0.1, 0, 0]).as_quat()
    )
    before = gains(controller)
    torque = controller.update(state).effort
    assert torque == pytest.approx(expected_torque(before, state, np.zeros(6), np.zeros(6), start.q), **TORQUE)
    assert controller.last_torque is torque


def test_a_fresh_reference_velocity_is_tracked_with_its_acceleration_times_the_cartesian_inertia():
    start = arm_state(seed=2)
    controller = started(state=start)
    controller.set_reference_velocity([0.1, 0.0, 0.0], [0.0, 0.0, 0.2], time=2.0 - 2 / 128)
    controller.set_reference_velocity([0.11, 0.0, -0.01], [0.0, 0.01, 0.2], time=2.0 - 1 / 128)
    # the acceleration of two velocities 1/128 s apart
    acceleration = np.array([1.28, 0.0, -1.28, 0.0, 1.28, 0.0])
    assert controller.reference_acceleration == pytest.approx(acceleration)
    velocity = np.array([0.11, 0.0, -0.01, 0.0, 0.01, 0.2])
    state = dataclasses.replace(start, time=2.0)
    before = gains(controller)
    torque = controller.update(state).effort
    assert torque == pytest.approx(expected_torque(before, state, velocity, acceleration, start.q), **TORQUE)
    # the same velocity, stale (older than the timeout): no reference motion at all
    stale = dataclasses.replace(start, time=2.0 - 1 / 128 + 0.0625 + 1 / 1024)
    before = gains(controller)
    torque = controller.update(stale).effort
    assert torque == pytest.approx(expected_torque(before, stale, np.zeros(6), np.zeros(6), start.q), **TORQUE)
    # exactly at the timeout it still counts
    assert controller._reference_motion(2.0 - 1 / 128 + 0.0625)[1] == pytest.approx(acceleration)


def test_the_reference_acceleration_is_capped_per_part_and_zero_without_a_recent_velocity():
    controller = started()
    controller.set_reference_velocity([0.0, 0.0, 0.0], [0.0, 0.0, 0.0], time=1.0)
    # linear jump 1 m/s in 1/128 s (128 m/s^2): capped to 5 along its direction; angular 2.56 and 3.84 rad/s^2, kept
    controller.set_reference_velocity([0.6, 0.8, 0.0], [0.02, 0.0, 0.03], time=1.0 + 1 / 128)
    assert controller.reference_acceleration == pytest.approx([3.0, 4.0, 0.0, 2.56, 0.0, 3.84])
    # the angular part capped alone, along its direction
    controller.set_reference_velocity([0.6, 0.8, 0.0], [-0.58, -0.8, 0.03], time=1.0 + 2 / 128)
    assert controller.reference_acceleration == pytest.approx([0.0, 0.0, 0.0, -3.0, -4.0, 0.0], abs=1e-9)
    # exactly the timeout after the last: still an acceleration; later, or at the same time: none
    controller.set_reference_velocity([0.6, 0.8, 0.01], [-0.58, -0.8, 0.03], time=1.0 + 2 / 128 + 0.0625)
    assert controller.reference_acceleration == pytest.approx([0.0, 0.0, 0.16, 0.0, 0.0, 0.0])
    late = 1.0 + 2 / 128 + 2 * 0.0625 + 1 / 1024
    controller.set_reference_velocity([0.6, 0.8, 0.5], [-0.58, -0.8, 0.03], time=late)
    assert list(controller.reference_acceleration) == [0.0] * 6
    controller.set_reference_velocity([0.6, 0.8, 0.9], [-0.58, -0.8, 0.03], time=late)
    assert list(controller.reference_acceleration) == [0.0] * 6
    assert controller.reference_velocity == pytest.approx([0.6, 0.8, 0.9, -0.58, -0.8, 0.03])
    assert controller.reference_velocity_time == late


def test_a_zero_acceleration_cap_the_validation_allows_turns_the_feed_forward_off_without_dividing_by_zero():
    # Expect: max_reference_acceleration 0 (>= 0 is valid): no reference acceleration, a steady velocity included
    controller = started(dataclasses.replace(PARAMS, max_reference_acceleration=0.0))
    for time in (1.0, 1.0 + 1 / 128, 1.0 + 2 / 128):  # the same velocity again: zero acceleration, zero cap
        controller.set_reference_velocity([0.1, 0.0, 0.0], [0.0, 0.0, 0.0], time=time)
        assert list(controller.reference_acceleration) == [0.0] * 6
    controller.set_reference_velocity([0.3, 0.0, 0.0], [0.0, 0.2, 0.0], time=1.0 + 3 / 128)
    assert list(controller.reference_acceleration) == [0.0] * 6


def test_the_torque_rate_is_limited_per_joint_from_the_model_torque_at_the_start():
    params = dataclasses.replace(PARAMS, max_torque_step=0.5)
    start = arm_state(seed=3)
    controller = started(params, start)
    controller.set_equilibrium(start.position + 0.05, start.quaternion)
    state = dataclasses.replace(start, time=1.001)
    unlimited = expected_torque(gains(controller), state, np.zeros(6), np.zeros(6), start.q)
    torque = controller.update(state).effort
    assert torque == pytest.approx(start.model_torque + np.clip(unlimited - start.model_torque, -0.5, 0.5), **TORQUE)
    assert np.any(np.abs(unlimited - start.model_torque) > 0.5)  # the limit acted


def test_a_new_ellipsoid_is_clamped_reached_through_the_filter_then_snapped_onto():
    # the model (and with it the snap onto the targets) renewed every 50 ticks: the filter runs between
    controller = started(dataclasses.replace(PARAMS, model_update_period=50))
    before = controller.stiffness.copy()
    controller.set_stiffness([2000.0, 5000.0, 100.0], Rotation.from_rotvec([0.0, 0.0, 0.3]).as_quat())
    target = controller.stiffness_target.copy()
    assert list(controller.eigenvalues) == [2000.0, 3000.0, 100.0]  # max_stiffness 3000 N/m
    assert target[:3, :3] == pytest.approx(
        Rotation.from_rotvec([0, 0, 0.3]).as_matrix()
        @ np.diag([2000.0, 3000.0, 100.0])
        @ Rotation.from_rotvec([0, 0, 0.3]).as_matrix().T
    )
    state = arm_state(time=1.001)
    controller.update(state)
    # one tick: a quarter of the way (stiffness_filter 0.25)
    assert controller.stiffness == pytest.approx(before + 0.25 * (target - before))
    for _ in range(199):
        controller.update(state)
    assert np.max(np.abs(controller.stiffness - target)) < FILTER_DONE
    assert np.array_equal(controller.stiffness, target) and np.array_equal(
        controller.damping, controller.damping_target
    )


def test_a_new_damping_target_alone_is_filtered_too():
    # the arm moved: a mass-aware damping target of the new inertia, the stiffness target unchanged
    start = arm_state()
    controller = started(state=start)
    stiffness, damping = controller.stiffness.copy(), controller.damping.copy()
    controller.update(arm_state(time=1.001, seed=5))
    assert not np.allclose(controller.damping_target, damping)
    assert controller.damping == pytest.approx(damping + 0.25 * (controller.damping_target - damping))
    assert np.array_equal(controller.stiffness, stiffness)


def test_the_model_is_renewed_every_period_ticks():
    params = dataclasses.replace(PARAMS, model_update_period=4)
    controller = started(params)
    first = controller.nullspace_projector.copy()
    moved = arm_state(time=1.001, seed=4)
    for _ in range(3):
        controller.update(moved)
    assert np.array_equal(controller.nullspace_projector, first)  # ticks 1 to 3: the model of the start
    controller.update(moved)
    assert controller.nullspace_projector == pytest.approx(
        np.eye(7) - np.linalg.pinv(moved.jacobian) @ moved.jacobian, abs=1e-5
    )


def test_unit_mass_damping_is_eq_7_of_the_stiffness_target():
    controller = started(dataclasses.replace(PARAMS, damping="unit_mass"))
    ratios = np.array([1.0, 1.0, 1.0, 0.7, 0.7, 0.7])
    stiffness = controller.stiffness_target
    eigenvalues, vectors = np.linalg.eigh(stiffness[:3, :3])
    translational = vectors @ np.diag(2.0 * np.sqrt(eigenvalues)) @ vectors.T
    assert controller.damping[:3, :3] == pytest.approx(translational * ratios[0])
    assert np.diag(controller.damping)[3:] == pytest.approx(2.0 * 0.7 * np.sqrt(30.0) * np.ones(3))


def test_near_a_singularity_the_nullspace_projector_stays_a_contraction():
    # a Jacobian with one singular value of 1e-3 (s^2 = the damping 1e-6): damped, that direction counts half
    rng = np.random.default_rng(6)
    left, _ = np.linalg.qr(rng.normal(size=(6, 6)))
    right, _ = np.linalg.qr(rng.normal(size=(7, 7)))
    singular = np.array([2.0, 1.5, 1.0, 0.8, 0.5, 1e-3])
    jacobian = left @ np.hstack((np.diag(singular), np.zeros((6, 1)))) @ right.T
    controller = started(state=dataclasses.replace(arm_state(), jacobian=jacobian))
    expected = np.eye(7) - right[:, :6] @ np.diag(singular**2 / (singular**2 + 1e-6)) @ right[:, :6].T
    assert controller.nullspace_projector == pytest.approx(expected, abs=1e-9)
    assert np.all(np.abs(np.linalg.eigvalsh(controller.nullspace_projector)) <= 1.0 + 1e-9)


@pytest.mark.parametrize(
    "rotation, reference",
    [
        ([0.1, -0.2, 0.05], [0.0, 0.0, 0.0]),
        ([0.0, 0.0, 3.0], [0.0, 0.0, -3.0]),  # across pi: the short way
        ([0.0, 2.2, 0.0], [0.0, -1.8, 0.0]),  # about y, across pi
        ([0.3, 0.2, -0.1], [-0.2, 0.4, 0.6]),
    ],
)
def test_the_orientation_error_is_the_rotation_vector_from_the_reference(rotation, reference):
    quaternion = Rotation.from_rotvec(rotation).as_quat()
    reference_quaternion = Rotation.from_rotvec(reference).as_quat()
    expected = (Rotation.from_quat(quaternion) * Rotation.from_quat(reference_quaternion).inv()).as_rotvec()
    # q and -q are one orientation, for either quaternion
    for sign, reference_sign in ((1, 1), (-1, 1), (1, -1), (-1, -1)):
        error = orientation_error(sign * quaternion, reference_sign * reference_quaternion)
        assert error == pytest.approx(expected, abs=1e-12), (sign, reference_sign)


def test_a_rotation_too_small_for_its_sine_is_still_measured():
    for tiny in ([1e-14, 0.0, 0.0], [0.0, -3e-15, 0.0], [0.0, 0.0, 2e-13]):
        quaternion = Rotation.from_rotvec(tiny).as_quat()
        assert orientation_error(quaternion, [0.0, 0.0, 0.0, 1.0]) == pytest.approx(tiny, rel=1e-9, abs=1e-30)


@pytest.mark.parametrize(
    "change, message",
    [
        ({"damping": "critical"}, "damping must be one of ('unit_mass', 'mass_aware'), got 'critical'"),
        ({"stiffness_filter": 0.0}, "stiffness_filter must be in (0, 1]"),
        ({"stiffness_filter": 1.01}, "stiffness_filter must be in (0, 1]"),
        ({"model_update_period": 0}, "model_update_period must be >= 1 tick"),
        ({"reference_velocity_timeout": -0.001}, "reference_velocity_timeout must be >= 0 s"),
        ({"reference_velocity_timeout": math.nan}, "reference_velocity_timeout must be >= 0 s"),
        ({"max_reference_acceleration": -1.0}, "max_reference_acceleration must be >= 0"),
        ({"max_reference_acceleration": math.nan}, "max_reference_acceleration must be >= 0"),
    ],
)
def test_bad_parameters_are_refused_with_what_is_wrong(change, message):
    with pytest.raises(ValueError) as raised:
        dataclasses.replace(PARAMS, **change)
    assert str(raised.value) == message


def test_the_bounds_of_the_parameters_are_accepted():
    edge = dataclasses.replace(
        PARAMS,
        damping="unit_mass",
        stiffness_filter=1.0,
        model_update_period=1,
        reference_velocity_timeout=0.0,
        max_reference_acceleration=0.0,
    )
    assert (edge.stiffness_filter, edge.model_update_period, edge.reference_velocity_timeout) == (1.0, 1, 0.0)


def test_an_update_before_starting_fails_instead_of_pulling_toward_a_made_up_pose():
    controller = CartesianImpedanceController(PARAMS)
    with pytest.raises(AttributeError):
        controller.update(arm_state())
    # before any reference velocity: no reference motion
    assert controller._reference_motion(5.0)[0] == pytest.approx(np.zeros(6))
