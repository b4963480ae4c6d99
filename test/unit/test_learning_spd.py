"""SPD manifold maps checked against independent computations (scipy.linalg.logm/expm/sqrtm, definitions)."""

import numpy as np
import pytest
import scipy.linalg

from teleteach.learning import spd


def random_spd(rng, size, condition=10.0):
    rotation, _ = np.linalg.qr(rng.standard_normal((size, size)))
    eigenvalues = np.exp(rng.uniform(0.0, np.log(condition), size))
    eigenvalues[0], eigenvalues[-1] = 1.0, condition
    return 250.0 * rotation @ np.diag(eigenvalues) @ rotation.T


def random_symmetric(rng, size):
    matrix = rng.standard_normal((size, size))
    return matrix + matrix.T


@pytest.fixture
def rng():
    return np.random.default_rng(42)


@pytest.mark.parametrize("size", [2, 3])
def test_log_and_exp_match_scipy_matrix_functions(rng, size):
    x, y = random_spd(rng, size), random_spd(rng, size)
    root = np.real(scipy.linalg.sqrtm(x))
    inverse_root = np.linalg.inv(root)
    expected_log = root @ np.real(scipy.linalg.logm(inverse_root @ y @ inverse_root)) @ root
    np.testing.assert_allclose(spd.log_map(x, y), expected_log, rtol=1e-8, atol=1e-8 * np.abs(expected_log).max())
    u = random_symmetric(rng, size) * 100.0
    expected_exp = root @ scipy.linalg.expm(inverse_root @ u @ inverse_root) @ root
    np.testing.assert_allclose(spd.exp_map(x, u), expected_exp, rtol=1e-8, atol=1e-9 * np.abs(expected_exp).max())


@pytest.mark.parametrize("size", [2, 3])
@pytest.mark.parametrize("condition", [10.0, 1e4, 1e8])
def test_exp_inverts_log(rng, size, condition):
    x, y = random_spd(rng, size, condition), random_spd(rng, size, condition)
    back = spd.exp_map(x, spd.log_map(x, y))
    # two matrices of condition 1e8 in different axes make X^-1/2 Y X^-1/2 reach 1e16: double precision then
    # keeps the entries (relative to the norm), not the smallest eigen-direction
    assert np.linalg.norm(back - y) / np.linalg.norm(y) < 1e-5
    if condition <= 1e4:
        assert spd.distance(back, y) < 1e-6
        u = spd.log_map(x, y)
        np.testing.assert_allclose(spd.log_map(x, spd.exp_map(x, u)), u, atol=1e-6 * np.abs(u).max())


@pytest.mark.parametrize("condition", [1e4, 1e8])
def test_exp_inverts_log_between_nearby_ill_conditioned_matrices(rng, condition):
    x = random_spd(rng, 3, condition)
    rotation = scipy.linalg.expm(0.01 * (lambda a: a - a.T)(rng.standard_normal((3, 3))))
    y = 1.3 * rotation @ x @ rotation.T
    assert spd.distance(spd.exp_map(x, spd.log_map(x, y)), y) < 1e-6 * spd.distance(x, y)


def test_distance_is_length_of_log_and_symmetric(rng):
    x, y = random_spd(rng, 3, 100.0), random_spd(rng, 3, 100.0)
    u = spd.log_map(x, y)
    length = np.sqrt(spd.inner_product(x, u, u))
    assert spd.distance(x, y) == pytest.approx(length, rel=1e-9)
    assert spd.distance(x, y) == pytest.approx(spd.distance(y, x), rel=1e-9)
    eigenvalues = scipy.linalg.eigvalsh(y, x)  # generalised eigenvalues: independent of the map code
    assert spd.distance(x, y) == pytest.approx(np.sqrt(np.sum(np.log(eigenvalues) ** 2)), rel=1e-9)
    assert spd.distance(x, x) == pytest.approx(0.0, abs=1e-7)


@pytest.mark.parametrize("size", [2, 3])
def test_distance_is_invariant_under_congruence(rng, size):
    x, y = random_spd(rng, size, 1e3), random_spd(rng, size, 1e3)
    for _ in range(5):
        a = rng.standard_normal((size, size)) * 10.0
        assert spd.distance(a @ x @ a.T, a @ y @ a.T) == pytest.approx(spd.distance(x, y), rel=1e-7)
    assert spd.distance(3.0 * x, 3.0 * y) == pytest.approx(spd.distance(x, y), rel=1e-9)


@pytest.mark.parametrize("size", [2, 3])
def test_parallel_transport_preserves_inner_products(rng, size):
    x, y = random_spd(rng, size, 1e3), random_spd(rng, size, 1e3)
    u, v = random_symmetric(rng, size) * 50.0, random_symmetric(rng, size) * 80.0
    moved_u, moved_v = spd.parallel_transport(x, y, u), spd.parallel_transport(x, y, v)
    assert spd.inner_product(y, moved_u, moved_v) == pytest.approx(spd.inner_product(x, u, v), rel=1e-8)
    assert spd.inner_product(y, moved_u, moved_u) == pytest.approx(spd.inner_product(x, u, u), rel=1e-8)
    # the geodesic's own velocity is transported into the reversed velocity at the other end
    np.testing.assert_allclose(
        spd.parallel_transport(x, y, spd.log_map(x, y)), -spd.log_map(y, x), atol=1e-7 * np.abs(y).max()
    )
    # going there and back is the identity
    _, backward = spd.Frame(x).transport_factors(y)
    np.testing.assert_allclose(spd.congruent(backward, moved_u), u, atol=1e-8 * np.abs(u).max())


def test_maps_broadcast_over_stacks(rng):
    xs = np.array([random_spd(rng, 3) for _ in range(4)])
    ys = np.array([random_spd(rng, 3) for _ in range(4)])
    stacked = spd.log_map(xs, ys)
    for index in range(4):
        np.testing.assert_allclose(stacked[index], spd.log_map(xs[index], ys[index]), rtol=1e-10, atol=1e-9)
    np.testing.assert_allclose(spd.distance(xs, ys), [spd.distance(a, b) for a, b in zip(xs, ys)], rtol=1e-10)


@pytest.mark.parametrize("size", [2, 3])
def test_mandel_keeps_the_frobenius_inner_product_and_round_trips(rng, size):
    a, b = random_symmetric(rng, size), random_symmetric(rng, size)
    assert spd.mandel(a) @ spd.mandel(b) == pytest.approx(np.trace(a @ b), rel=1e-12)
    np.testing.assert_allclose(spd.unmandel(spd.mandel(a)), a, rtol=1e-14)
    assert spd.mandel(a).shape == (size * (size + 1) // 2,)
    if size == 3:
        np.testing.assert_allclose(
            spd.mandel(a),
            [a[0, 0], a[1, 1], a[2, 2], np.sqrt(2) * a[0, 1], np.sqrt(2) * a[0, 2], np.sqrt(2) * a[1, 2]],
        )
    with pytest.raises(ValueError, match="Mandel"):
        spd.unmandel(np.zeros(4))


def test_geodesic_and_karcher_mean(rng):
    x, y = random_spd(rng, 3, 4.0), random_spd(rng, 3, 4.0)
    middle = spd.geodesic(x, y, 0.5)
    assert spd.distance(x, middle) == pytest.approx(0.5 * spd.distance(x, y), rel=1e-8)
    assert spd.distance(middle, y) == pytest.approx(0.5 * spd.distance(x, y), rel=1e-8)
    # the mean of two points is their geodesic midpoint; of commuting matrices, the geometric mean
    assert spd.distance(spd.karcher_mean(np.array([x, y])), middle) < 1e-8
    diagonal = np.array([np.diag([1.0, 100.0]), np.diag([100.0, 1.0]), np.diag([10.0, 10.0])])
    np.testing.assert_allclose(spd.karcher_mean(diagonal), np.diag([10.0, 10.0]), rtol=1e-8)


def test_exp_map_is_spd_for_large_steps_and_near_singular_bases(rng):
    base = random_spd(rng, 3, 1e8)
    root = np.real(scipy.linalg.sqrtm(base))
    for largest in (0.1, 2.0, 5.0):  # steps that change stiffness by up to a factor exp(5) = 150
        rotation, _ = np.linalg.qr(rng.standard_normal((3, 3)))
        step = rotation @ np.diag(rng.uniform(-largest, largest, 3)) @ rotation.T
        result = spd.exp_map(base, root @ step @ root)
        assert np.all(np.isfinite(result))
        np.testing.assert_array_equal(result, result.T)
        assert np.linalg.eigvalsh(result)[0] > 0


@pytest.mark.parametrize(
    ("matrix", "message"),
    [
        (np.diag([1.0, -1.0, 2.0]), "not positive definite"),
        (np.diag([1.0, 0.0, 2.0]), "not positive definite"),
        (np.array([[1.0, 0.5], [0.0, 1.0]]), "not symmetric"),
        (np.array([[np.nan, 0.0], [0.0, 1.0]]), "not finite"),
    ],
)
def test_check_spd_names_the_problem(matrix, message):
    with pytest.raises(spd.SPDError, match=message):
        spd.check_spd(np.array([np.eye(matrix.shape[0]), matrix]), "stiffness")


@pytest.mark.parametrize(
    ("matrices", "message"),
    [
        (np.ones(3), "matrix must be square matrices, got shape (3,)"),
        (np.ones((2, 3)), "matrix must be square matrices, got shape (2, 3)"),
        (np.ones((2, 3, 2)), "matrix must be square matrices, got shape (2, 3, 2)"),
        (np.ones((2, 0, 0)), "matrix must be square matrices, got shape (2, 0, 0)"),
        (np.array([np.eye(2), np.eye(2), [[1.0, np.inf], [np.inf, 1.0]]]), "matrix sample 2 is not finite"),
        (np.array([np.eye(2), [[1.0, 0.25], [0.0, 1.0]]]), "matrix sample 1 is not symmetric"),
        (np.array([np.eye(2), np.diag([2.0, -0.5])]), "matrix sample 1 is not positive definite (smallest eigenvalue"),
    ],
)
def test_check_spd_names_the_sample_and_the_shape_it_got(matrices, message):
    with pytest.raises(spd.SPDError) as error:
        spd.check_spd(matrices, tolerance=0.1)
    assert str(error.value).startswith(message)


def test_check_spd_judges_asymmetry_relative_to_each_sample_s_own_largest_entry():
    # tolerance x (1 + largest entry): 0.1 x 2 = 0.2 for a unit matrix, whatever another sample's size
    slightly = np.array([[1.0, 0.15], [0.0, 1.0]])
    assert spd.check_spd(np.array([np.eye(2), slightly]), tolerance=0.1).shape == (2, 2, 2)
    too_much = np.array([[1.0, 0.25], [0.0, 1.0]])
    with pytest.raises(spd.SPDError, match="sample 1 is not symmetric"):
        spd.check_spd(np.array([1000.0 * np.eye(2), too_much]), tolerance=0.1)
    np.testing.assert_array_equal(spd.check_spd(np.eye(3)), np.eye(3))  # one matrix, no stack: returned as given
    # exactly at the bound (0.5 x (1 + 1) = 1.0) is accepted, and a 1 x 1 stiffness is a matrix too
    assert spd.check_spd(np.array([[1.0, 1.0], [0.0, 1.0]]), tolerance=0.5).shape == (2, 2)
    assert spd.check_spd(np.full((4, 1, 1), 300.0)).shape == (4, 1, 1)


def test_symmetric_and_inner_product_work_on_stacks(rng):
    a = rng.standard_normal((4, 3, 3))
    np.testing.assert_allclose(spd.symmetric(a), 0.5 * (a + np.transpose(a, (0, 2, 1))))
    bases = np.array([random_spd(rng, 3) for _ in range(4)])
    u, v = spd.symmetric(rng.standard_normal((2, 4, 3, 3)))
    expected = [np.trace(np.linalg.inv(x) @ p @ np.linalg.inv(x) @ q) for x, p, q in zip(bases, u, v)]
    np.testing.assert_allclose(spd.inner_product(bases, u, v), expected, rtol=1e-12)


@pytest.mark.parametrize("size", [1, 2, 4, 6, 10])
def test_mandel_sizes_round_trip_and_other_lengths_are_refused(rng, size):
    a = random_symmetric(rng, size)
    assert spd.mandel_size(size * (size + 1) // 2) == size
    np.testing.assert_allclose(spd.unmandel(spd.mandel(a)), a, rtol=1e-14)
    with pytest.raises(ValueError, match=f"{size * (size + 1) // 2 + 1} is not the length of a Mandel vector"):
        spd.mandel_size(size * (size + 1) // 2 + 1)
