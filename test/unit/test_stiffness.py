"""Eqs 1-7 of the thesis against hand computations (teleteach.control.stiffness)."""

import math

import numpy as np
import pytest
import scipy.linalg
from scipy.spatial.transform import Rotation

from teleteach.control import stiffness as ellipsoid

Z45 = [0.0, 0.0, math.sin(math.pi / 8), math.cos(math.pi / 8)]  # 45 degrees about z, (x, y, z, w)


def test_diagonal_ellipsoid_gives_diagonal_stiffness():
    k = ellipsoid.stiffness_matrix([100.0, 200.0, 300.0], [0.0, 0.0, 0.0, 1.0], 30.0)
    expected = np.diag([100.0, 200.0, 300.0, 30.0, 30.0, 30.0])
    np.testing.assert_allclose(k, expected, atol=1e-12)


def test_rotated_45_degrees_about_z_by_hand():
    # V = Rz(45): K_T = [[(a+b)/2, (a-b)/2, 0], [(a-b)/2, (a+b)/2, 0], [0, 0, c]]
    k_t = ellipsoid.translational_stiffness([300.0, 100.0, 500.0], Z45)
    np.testing.assert_allclose(k_t, [[200.0, 100.0, 0.0], [100.0, 200.0, 0.0], [0.0, 0.0, 500.0]], atol=1e-9)
    # eq 4 with an anisotropic K_R = diag(10, 20, 30): [[15, -5, 0], [-5, 15, 0], [0, 0, 30]]
    k_r = ellipsoid.rotational_stiffness(Z45, [10.0, 20.0, 30.0])
    np.testing.assert_allclose(k_r, [[15.0, -5.0, 0.0], [-5.0, 15.0, 0.0], [0.0, 0.0, 30.0]], atol=1e-9)
    # the isotropic thesis K_R = 30 Nm/rad stays isotropic
    np.testing.assert_allclose(ellipsoid.rotational_stiffness(Z45, 30.0), 30.0 * np.eye(3), atol=1e-9)


def test_eq2_quaternion_is_rz_ry_rx():
    phi, theta, psi = 0.3, -0.5, 1.1
    rx = np.array([[1, 0, 0], [0, math.cos(phi), -math.sin(phi)], [0, math.sin(phi), math.cos(phi)]])
    ry = np.array([[math.cos(theta), 0, math.sin(theta)], [0, 1, 0], [-math.sin(theta), 0, math.cos(theta)]])
    rz = np.array([[math.cos(psi), -math.sin(psi), 0], [math.sin(psi), math.cos(psi), 0], [0, 0, 1]])
    quaternion = Rotation.from_matrix(rz @ ry @ rx).as_quat()
    np.testing.assert_allclose(ellipsoid.rotation_from_quaternion(quaternion), rz @ ry @ rx, atol=1e-12)


def test_principal_axes_are_eigenvectors_with_the_commanded_eigenvalues():
    quaternion = Rotation.from_euler("xyz", [0.3, -0.5, 1.1]).as_quat()
    sigma = np.array([50.0, 700.0, 2500.0])
    k_t = ellipsoid.translational_stiffness(sigma, quaternion)
    v = ellipsoid.rotation_from_quaternion(quaternion)
    for i in range(3):
        np.testing.assert_allclose(k_t @ v[:, i], sigma[i] * v[:, i], atol=1e-9)
    np.testing.assert_allclose(k_t, k_t.T, atol=1e-12)


def test_clamp_per_axis():
    np.testing.assert_allclose(ellipsoid.clamp_eigenvalues([5000.0, 10.0, -3.0], 3000.0), [3000.0, 10.0, 0.0])


def test_eq7_damping_diagonal_by_hand():
    k = ellipsoid.stiffness_matrix([100.0, 400.0, 900.0], [0.0, 0.0, 0.0, 1.0], 30.0)
    d = ellipsoid.damping_unit_mass(k, [0.7, 0.7, 0.7, 0.5, 0.5, 0.5])
    expected = np.diag([2 * 0.7 * 10.0, 2 * 0.7 * 20.0, 2 * 0.7 * 30.0] + [2 * 0.5 * math.sqrt(30.0)] * 3)
    np.testing.assert_allclose(d, expected, atol=1e-9)


def test_eq7_damping_rotated_is_symmetric_pd_and_squares_to_4_xi2_k():
    k = ellipsoid.stiffness_matrix([300.0, 100.0, 500.0], Z45, 30.0)
    d = ellipsoid.damping_unit_mass(k, 0.8)
    np.testing.assert_allclose(d, d.T, atol=1e-12)
    assert np.all(np.linalg.eigvalsh(d) > 0.0)
    np.testing.assert_allclose(d @ d, 4 * 0.8**2 * k, atol=1e-8)
    # off-diagonal coupling appears exactly as in K: D_xy = 2 xi (sqrt(300) - sqrt(100)) / 2
    assert d[0, 1] == pytest.approx(0.8 * (math.sqrt(300.0) - 10.0))


def test_mass_aware_damping_with_unit_inertia_is_eq7():
    k = ellipsoid.stiffness_matrix([300.0, 100.0, 500.0], Z45, 30.0)
    d = ellipsoid.damping_mass_aware(k, (np.eye(3), np.eye(3)), 0.9)
    np.testing.assert_allclose(d, ellipsoid.damping_unit_mass(k, 0.9), atol=1e-9)


def test_mass_aware_damping_renders_the_ratio_for_the_real_inertia():
    rng = np.random.default_rng(3)
    a = rng.normal(size=(3, 3))
    inertia_v = a @ a.T + 2.0 * np.eye(3)  # [kg]
    b = rng.normal(size=(3, 3)) * 0.1
    inertia_w = b @ b.T + 0.05 * np.eye(3)  # [kg m^2]
    k = ellipsoid.stiffness_matrix([300.0, 100.0, 500.0], Z45, 30.0)
    d = ellipsoid.damping_mass_aware(k, (inertia_v, inertia_w), [1.0, 1.0, 1.0, 0.5, 0.5, 0.5])
    np.testing.assert_allclose(d, d.T, atol=1e-9)
    assert np.all(np.linalg.eigvalsh(d) > 0.0)
    for block, inertia, ratio in ((slice(0, 3), inertia_v, 1.0), (slice(3, 6), inertia_w, 0.5)):
        # each mode q of K q = w Lambda q is damped with ratio xi: q^T D q = 2 xi sqrt(q^T K q q^T Lambda q)
        _, modes = scipy.linalg.eigh(k[block, block], inertia)
        for q in modes.T:
            rendered = (q @ d[block, block] @ q) / (2.0 * math.sqrt((q @ k[block, block] @ q) * (q @ inertia @ q)))
            assert rendered == pytest.approx(ratio, rel=1e-9)
    # a scalar mass m gives D = 2 xi sqrt(m K) on the diagonal
    d_scalar = ellipsoid.damping_mass_aware(np.diag([400.0] * 3 + [30.0] * 3), (4.0 * np.eye(3), np.eye(3)), 1.0)
    assert d_scalar[0, 0] == pytest.approx(2.0 * math.sqrt(4.0 * 400.0))


def test_cartesian_inertia_blocks_are_blocks_of_lambda():
    rng = np.random.default_rng(5)
    a = rng.normal(size=(7, 7))
    mass = a @ a.T + np.eye(7)
    jacobian = rng.normal(size=(6, 7))
    full = np.linalg.inv(jacobian @ np.linalg.inv(mass) @ jacobian.T)
    inertia_v, inertia_w = ellipsoid.cartesian_inertia_blocks(jacobian, mass, max_inertia=(np.inf, np.inf))
    np.testing.assert_allclose(inertia_v, full[:3, :3], rtol=1e-9)
    np.testing.assert_allclose(inertia_w, full[3:, 3:], rtol=1e-9)


def test_cartesian_inertia_is_capped_at_a_singularity():
    mass = np.diag([2.0, 2.0, 1.5, 1.5, 1.0, 0.5, 0.2])
    jacobian = np.random.default_rng(7).normal(size=(6, 7))
    jacobian[0] = 1e-5 * jacobian[1]  # x lost: the arm cannot move along x any more
    inertia_v, inertia_w = ellipsoid.cartesian_inertia_blocks(jacobian, mass)
    assert np.max(np.linalg.eigvalsh(inertia_v)) == pytest.approx(ellipsoid.MAX_TRANSLATIONAL_INERTIA)
    assert np.max(np.linalg.eigvalsh(inertia_w)) <= ellipsoid.MAX_ROTATIONAL_INERTIA + 1e-9
    damping = ellipsoid.damping_mass_aware(np.diag([800.0] * 3 + [30.0] * 3), (inertia_v, inertia_w), 1.0)
    assert np.all(np.isfinite(damping)) and np.max(damping) <= 2.0 * np.sqrt(800.0 * 50.0) + 1e-6


def test_bad_eigenvector_shape_is_refused_with_the_shape_it_got():
    with pytest.raises(ValueError, match=r"a quaternion \(x, y, z, w\) or a 3x3 matrix, got shape \(2,\)"):
        ellipsoid.translational_stiffness([1.0, 2.0, 3.0], [1.0, 0.0])


def test_damping_of_a_principal_stiffness_below_one_is_its_square_root_and_of_a_negative_one_none():
    # Eq 7 takes sqrt(K0) of the principal stiffnesses, clipped at 0 (a numerically negative one): 0.25 N/m -> 0.5
    k = np.diag([0.25, 0.04, -1e-9, 1.0, 1.0, 1.0])
    expected = np.diag([2 * 0.5, 2 * 0.2, 0.0, 2.0, 2.0, 2.0])
    np.testing.assert_allclose(ellipsoid.damping_unit_mass(k, 1.0), expected, atol=1e-9)
    np.testing.assert_allclose(ellipsoid.damping_mass_aware(k, (np.eye(3), np.eye(3)), 1.0), expected, atol=1e-9)


def test_a_series_is_eq_1_row_by_row_whatever_form_its_axes_take():
    eigenvalues = np.array([[300.0, 100.0, 500.0], [50.0, 3000.0, 800.0]])
    rotations = Rotation.from_euler("zyx", [[45.0, 0.0, 0.0], [10.0, 20.0, 30.0]], degrees=True)
    expected = [
        ellipsoid.translational_stiffness(values, quaternion)
        for values, quaternion in zip(eigenvalues, rotations.as_quat())
    ]
    np.testing.assert_allclose(expected[0], [[200.0, 100.0, 0.0], [100.0, 200.0, 0.0], [0.0, 0.0, 500.0]], atol=1e-9)
    for axes in (rotations, rotations.as_quat(), rotations.as_matrix()):
        np.testing.assert_allclose(ellipsoid.translational_stiffnesses(eigenvalues, axes), expected, atol=1e-9)
    # Expect: as many axes as eigenvalue rows, or a clear error
    with pytest.raises(ValueError, match=r"must be 2 quaternions \(x, y, z, w\) or 3x3 matrices, got shape \(1, 4\)"):
        ellipsoid.translational_stiffnesses(eigenvalues, rotations.as_quat()[:1])
    # Expect one 3x3 matrix (no series axis) to be refused as such, not read as quaternions
    with pytest.raises(ValueError, match=r"must be 1 quaternions .* got shape \(3, 3\)"):
        ellipsoid.translational_stiffnesses(eigenvalues[0], rotations.as_matrix()[0])
