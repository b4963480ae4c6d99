"""Euclidean and SPD DMPs: reproduction of smooth demonstrations, new durations, goal switching, adversarial data."""

import numpy as np
import pytest
import scipy.sparse
from scipy.spatial.transform import Rotation

from teleteach.learning import spd
from teleteach.learning.dmp import DMP, SPDDMP, Basis, DMPParameters, Regression, uniform_step
from teleteach.learning.synthetic import minimum_jerk_between

DT = 0.02
TEN = DMPParameters.from_yaml(basis_count=10)  # a small basis, where the fit itself does not matter


def smooth_curve(times):
    s = times / times[-1]
    return np.column_stack(
        [0.3 + 0.2 * minimum_jerk_between(times, 2.0, 6.0), 0.1 * np.sin(np.pi * s) ** 2, 0.5 - 0.1 * s]
    )


def stiffness(kx, ky, kz, yaw):
    rotation = Rotation.from_euler("z", yaw).as_matrix()
    return rotation @ np.diag([kx, ky, kz]) @ rotation.T


def smooth_spd_demo(times, size=3):
    ky = 300 + 1200 * minimum_jerk_between(times, 3.0, 6.0)
    yaw = np.radians(45.0) * minimum_jerk_between(times, 5.0, 9.0)
    matrices = np.array([stiffness(300 + 100 * np.sin(t / 3.0), k, 1000, a) for t, k, a in zip(times, ky, yaw)])
    return matrices[:, :size, :size]


def assert_all_spd(matrices):
    assert np.all(np.isfinite(matrices))
    for matrix in matrices:
        np.linalg.cholesky(matrix)  # raises LinAlgError unless positive definite
    assert np.linalg.eigvalsh(matrices)[:, 0].min() > 0


def test_dmp_reproduces_a_smooth_demonstration_and_keeps_its_shape_with_a_new_duration():
    times = np.arange(0.0, 12.0 + DT / 2, DT)
    demo = smooth_curve(times)
    model = DMP.learn(times, demo, DMPParameters.from_yaml(basis_count=30))
    reproduced_times, reproduced = model.rollout(dt=DT)
    np.testing.assert_allclose(reproduced_times, times, atol=1e-9)
    assert np.abs(reproduced - demo).max() < 2e-3 * np.abs(demo).max()
    slow_times, slow = model.rollout(duration=24.0, dt=DT)
    expected = np.column_stack([np.interp(slow_times / 2.0, times, demo[:, axis]) for axis in range(3)])
    assert np.abs(slow - expected).max() < 5e-3
    np.testing.assert_allclose(slow[-1], demo[-1], atol=2e-3)


def test_dmp_goal_switching_converges_to_the_new_goal():
    times = np.arange(0.0, 10.0 + DT / 2, DT)
    model = DMP.learn(times, smooth_curve(times), DMPParameters.from_yaml(basis_count=25))
    new_goal = np.array([0.2, -0.1, 0.7])
    _, trajectory = model.rollout(duration=30.0, dt=DT, switch=(4.0, new_goal))
    np.testing.assert_allclose(trajectory[-1], new_goal, atol=1e-3)
    _, unswitched = model.rollout(duration=30.0, dt=DT)
    np.testing.assert_allclose(trajectory[:200], unswitched[:200], atol=1e-12)  # nothing changes before the switch


@pytest.mark.parametrize("size", [2, 3])
def test_spd_dmp_reproduces_a_smooth_demonstration(size):
    times = np.arange(0.0, 12.0 + DT / 2, DT)
    demo = smooth_spd_demo(times, size)
    model = SPDDMP.learn(times, demo, DMPParameters.from_yaml(basis_count=40))
    reproduced_times, reproduced = model.rollout(dt=DT)
    assert reproduced.shape == demo.shape
    errors = spd.distance(demo, reproduced)
    spread = np.sqrt(np.mean(spd.distance(spd.karcher_mean(demo), demo) ** 2))
    assert errors.mean() < 0.01 * spread
    assert errors.max() < 0.05 * spread
    assert_all_spd(reproduced)


def test_spd_dmp_with_a_new_duration_and_goal():
    times = np.arange(0.0, 12.0 + DT / 2, DT)
    demo = smooth_spd_demo(times)
    model = SPDDMP.learn(times, demo, DMPParameters.from_yaml(basis_count=40))
    slow_times, slow = model.rollout(duration=18.0, dt=DT)
    index = np.round(slow_times / 1.5 / DT).astype(int)
    assert spd.distance(slow, demo[index]).max() < 0.05
    goal = stiffness(500, 900, 1000, np.radians(45.0))
    _, moved = model.rollout(goal=goal, dt=DT)
    assert spd.distance(moved[-1], goal) < 0.05
    assert_all_spd(moved)


@pytest.mark.parametrize("size", [2, 3])
def test_spd_dmp_goal_switching_converges_to_the_new_goal(size):
    times = np.arange(0.0, 10.0 + DT / 2, DT)
    model = SPDDMP.learn(times, smooth_spd_demo(times, size), DMPParameters.from_yaml(basis_count=30))
    new_goal = stiffness(2000, 400, 800, np.radians(-30.0))[:size, :size]
    switched_times, switched = model.rollout(duration=30.0, dt=DT, switch=(5.0, new_goal))
    assert spd.distance(switched[-1], new_goal) < 1e-2
    _, original = model.rollout(duration=30.0, dt=DT)
    before = switched_times <= 5.0
    np.testing.assert_allclose(switched[before], original[before], rtol=1e-12)
    assert spd.distance(original[-1], model.goal) < 1e-2
    # the goal moves smoothly: no jump in the state right after the switch
    steps = spd.distance(switched[:-1], switched[1:])
    assert steps.max() < 5 * np.abs(spd.distance(original[:-1], original[1:])).max() + 1e-3
    assert_all_spd(switched)


def adversarial_demo(times, rng, condition):
    """Near-singular stiffness with condition numbers up to ``condition``, rotating fast, with jittery samples."""
    count = times.size
    angles = np.cumsum(rng.normal(0.0, 0.05, (count, 3)), axis=0) + np.column_stack(
        [np.zeros(count), np.zeros(count), 2 * np.pi * times / times[-1]]
    )
    rotations = Rotation.from_euler("xyz", angles).as_matrix()
    exponent = np.log10(condition) * (0.5 + 0.5 * np.sin(2 * np.pi * times / times[-1] * 3))
    principal = np.column_stack([10.0 ** (-exponent), np.full(count, 0.3), np.ones(count)]) * 1000.0
    principal *= np.exp(rng.normal(0.0, 0.02, principal.shape))
    return rotations @ (principal[:, :, None] * np.swapaxes(rotations, 1, 2))


@pytest.mark.parametrize("condition", [1e4, 1e8])
def test_spd_dmp_stays_spd_on_adversarial_data(condition):
    rng = np.random.default_rng(7)
    times = np.arange(0.0, 4.0 + DT / 2, DT)
    demo = adversarial_demo(times, rng, condition)
    assert np.linalg.cond(demo).max() > 0.5 * condition
    for basis_count in (5, 40):
        model = SPDDMP.learn(times, demo, DMPParameters.from_yaml(basis_count=basis_count, alpha_z=100.0))
        for rollout in (
            model.rollout(dt=DT),
            model.rollout(duration=2.0, dt=DT),
            model.rollout(dt=DT, goal=np.diag([1e-5, 1.0, 1e3])),
            model.rollout(dt=DT, switch=(1.0, demo[0])),
        ):
            assert_all_spd(rollout[1])


def test_spd_dmp_stays_spd_on_abrupt_steps_2x2():
    times = np.arange(0.0, 6.0 + DT / 2, DT)
    levels = np.where((times // 0.5) % 2 == 0, 1.0, 1e-8)
    demo = np.array([np.diag([level, 1.0]) for level in levels]) * 500.0
    model = SPDDMP.learn(times, demo, DMPParameters.from_yaml(basis_count=12))
    assert_all_spd(model.rollout(dt=DT)[1])


def test_models_round_trip_through_their_description():
    times = np.arange(0.0, 5.0 + DT / 2, DT)
    model = SPDDMP.learn(times, smooth_spd_demo(times, 2), DMPParameters.from_yaml(basis_count=10))
    copy = SPDDMP.from_dict(model.to_dict())
    np.testing.assert_allclose(copy.rollout(dt=DT)[1], model.rollout(dt=DT)[1], rtol=1e-12)
    euclidean = DMP.learn(times, smooth_curve(times), DMPParameters.from_yaml(basis_count=10))
    np.testing.assert_allclose(DMP.from_dict(euclidean.to_dict()).rollout(dt=DT)[1], euclidean.rollout(dt=DT)[1])


def test_bad_parameters_and_grids_are_rejected():
    with pytest.raises(ValueError, match="basis_count"):
        DMPParameters.from_yaml(basis_count=1)
    assert DMPParameters.from_yaml(basis_count=2).basis_count == 2
    with pytest.raises(ValueError, match="alpha_z"):
        DMPParameters.from_yaml(basis_count=10, alpha_z=-1.0)
    for name in ("alpha_z", "alpha_x", "width", "alpha_goal"):
        with pytest.raises(ValueError, match=f"^{name} must be finite and > 0, got 0.0$"):
            DMPParameters.from_yaml(basis_count=10, **{name: 0.0})
    for ridge in (0.0, -1.0, np.inf):
        with pytest.raises(ValueError, match=f"^ridge must be finite and > 0, got {ridge}$"):
            DMPParameters.from_yaml(basis_count=10, ridge=ridge)
    times = np.array([0.0, 0.1, 0.3, 0.4])
    with pytest.raises(ValueError, match="uniform"):
        DMP.learn(times, np.zeros((4, 1)), TEN)
    with pytest.raises(ValueError, match="at least 3"):
        DMP.learn(np.array([0.0, 1.0]), np.zeros((2, 1)), TEN)
    grid = np.arange(5) * 0.1
    with pytest.raises(spd.SPDError, match="sample 2 is not positive definite"):
        SPDDMP.learn(grid, np.array([np.eye(2), np.eye(2), np.diag([1.0, -1.0]), np.eye(2), np.eye(2)]), TEN)


def dense_features(phase, parameters):
    """Eq C.4-C.5 with every one of the N Gaussians (Basis keeps only the nearest ones): centres equally spaced in
    time, each sigma ``width`` times the spacing to the next centre (the last one's repeated)."""
    centres = np.exp(-parameters.alpha_x * np.linspace(0.0, 1.0, parameters.basis_count))
    spacing = np.abs(np.diff(centres))
    sigma = parameters.width * np.append(spacing, spacing[-1])
    exponent = -((phase[:, None] - centres) ** 2) / (2.0 * sigma**2)
    psi = np.exp(exponent - exponent.max(axis=1, keepdims=True))
    return psi / psi.sum(axis=1, keepdims=True) * phase[:, None]


@pytest.mark.parametrize("basis_count, width", [(30, 0.75), (150, 0.75), (40, 0.4), (20, 2.0)])
def test_sparse_features_are_eq_c4_with_all_basis_functions(basis_count, width):
    parameters = DMPParameters.from_yaml(basis_count=basis_count, width=width)
    basis = Basis(parameters)
    # from the start of a demonstration to twice its duration (a rollout may run past tau)
    phase = basis.phase(np.linspace(0.0, 2.0, 801), 1.0)
    np.testing.assert_allclose(basis.features(phase).toarray(), dense_features(phase, parameters), rtol=0, atol=1e-12)
    # a stretch near the start alone still has one column per basis function
    early = basis.phase(np.linspace(0.0, 0.05, 11), 1.0)
    np.testing.assert_allclose(basis.features(early).toarray(), dense_features(early, parameters), rtol=0, atol=1e-12)


def test_regression_is_ridge_least_squares_relative_to_the_mean_diagonal():
    rng = np.random.default_rng(3)
    design = 0.1 * rng.random((40, 6))  # mean diagonal of A^T A below 1
    targets = rng.normal(size=(40, 2))
    normal = design.T @ design
    ridge = 0.5
    expected = np.linalg.solve(normal + ridge * np.mean(np.diag(normal)) * np.eye(6), design.T @ targets)
    weights = Regression(scipy.sparse.csr_matrix(design), ridge).fit(targets)
    np.testing.assert_allclose(weights, expected, rtol=1e-10)


def test_uniform_step_takes_three_samples_and_refuses_a_still_or_jittered_grid():
    assert uniform_step([1.0, 1.02, 1.04]) == pytest.approx(0.02)
    refusal = r"^a DMP is learned from a uniform, increasing time grid \(resample first\)$"
    with pytest.raises(ValueError, match=refusal):
        uniform_step([1.0, 1.0, 1.0])
    jittered = np.arange(10) * 0.02
    jittered[5] += 1e-6  # 50 ppm of a step: more than rounding
    with pytest.raises(ValueError, match=refusal):
        uniform_step(jittered)
    stamped = 100.0 + np.arange(10) * 0.001
    stamped[5] += 1e-9  # a ROS stamp's nanosecond rounding on a 1 kHz grid is still uniform
    assert uniform_step(stamped) == pytest.approx(0.001)


def test_a_demonstration_learns_the_same_whenever_it_was_recorded():
    times = np.arange(0.0, 6.0 + DT / 2, DT)
    parameters = DMPParameters.from_yaml(basis_count=20)
    # recordings carry ROS time stamps: learning from t = 100 s must give the model learned from t = 0
    for kind, demo in ((DMP, smooth_curve(times)), (SPDDMP, smooth_spd_demo(times, 2))):
        at_zero, later = kind.learn(times, demo, parameters), kind.learn(times + 100.0, demo, parameters)
        assert later.duration == pytest.approx(6.0)
        np.testing.assert_allclose(later.weights, at_zero.weights, rtol=1e-6, atol=1e-9 * np.abs(at_zero.weights).max())
        np.testing.assert_allclose(later.rollout(dt=DT)[1], at_zero.rollout(dt=DT)[1], rtol=1e-6, atol=1e-9)


def test_a_dmp_starts_where_its_demonstration_starts_and_heads_for_where_it_ends():
    times = np.arange(0.0, 6.0 + DT / 2, DT)
    demo = smooth_curve(times) + np.array([0.0, 0.05, 0.0]) * times[:, None]  # moving at the start
    model = DMP.learn(times, demo, DMPParameters.from_yaml(basis_count=20))
    np.testing.assert_array_equal(model.start, demo[0])
    np.testing.assert_array_equal(model.goal, demo[-1])
    # z(0) = tau y'(0), the demonstration's first velocity (one-sided difference)
    np.testing.assert_allclose(model.start_velocity, 6.0 * (demo[1] - demo[0]) / DT, rtol=1e-9)
    matrices = smooth_spd_demo(times, 2)
    spd_model = SPDDMP.learn(times, matrices, DMPParameters.from_yaml(basis_count=20))
    np.testing.assert_array_equal(spd_model.start, matrices[0])
    np.testing.assert_array_equal(spd_model.goal, matrices[-1])
    first_velocity = spd.mandel(spd.Frame(matrices[0]).log(matrices[1])) / DT
    np.testing.assert_allclose(spd_model.start_velocity, 6.0 * first_velocity, rtol=1e-9)


def test_a_dmp_rolls_out_to_a_new_goal_and_samples_where_asked():
    times = np.arange(0.0, 10.0 + DT / 2, DT)
    model = DMP.learn(times, smooth_curve(times), DMPParameters.from_yaml(basis_count=25))
    new_goal = [0.45, 0.05, 0.3]
    _, moved = model.rollout(goal=new_goal, dt=DT)
    np.testing.assert_allclose(moved[-1], new_goal, atol=2e-3)
    default_times, _ = model.rollout()
    np.testing.assert_allclose(np.diff(default_times), 0.01)  # 100 Hz unless asked
    # a coarse output step is integrated in sub-steps: the same path, sampled at the coarse times, from the start
    coarse_times, coarse = model.rollout(dt=0.5)
    fine_times, fine = model.rollout(dt=DT)
    np.testing.assert_array_equal(coarse[0], model.start)
    for time, sample in zip(coarse_times, coarse):
        np.testing.assert_allclose(sample, fine[np.argmin(np.abs(fine_times - time))], atol=2e-3)
    short_times, short = model.rollout(duration=0.01, dt=DT)  # shorter than one step: its start and its end
    assert short_times.tolist() == [0.0, 0.01] and len(short) == 2
    assert np.diff(
        SPDDMP.learn(times, smooth_spd_demo(times, 2), DMPParameters.from_yaml(basis_count=150)).rollout()[0]
    ) == pytest.approx(0.02)


@pytest.mark.parametrize(
    "duration, dt, refusal",
    [
        (0.0, DT, "duration must be finite and > 0, got 0.0"),
        (np.inf, DT, "duration must be finite and > 0, got inf"),
        (0.5, 0.0, "time step must be finite and > 0, got 0.0"),
        (0.5, np.nan, "time step must be finite and > 0, got nan"),
    ],
)
def test_a_rollout_refuses_a_bad_duration_or_step(duration, dt, refusal):
    times = np.arange(0.0, 2.0 + DT / 2, DT)
    model = DMP.learn(times, smooth_curve(times), DMPParameters.from_yaml(basis_count=10))
    with pytest.raises(ValueError, match=f"^{refusal}$"):
        model.rollout(duration=duration, dt=dt)
    assert model.rollout(duration=0.5, dt=DT)[0][-1] == pytest.approx(0.5)  # half a second is a duration


def test_models_name_their_type_and_what_was_wrong():
    times = np.arange(0.0, 2.0 + DT / 2, DT)
    matrices = smooth_spd_demo(times, 2)
    assert DMP.learn(times, smooth_curve(times), DMPParameters.from_yaml(basis_count=10)).to_dict()["type"] == "dmp"
    model = SPDDMP.learn(times, matrices, DMPParameters.from_yaml(basis_count=10))
    description = model.to_dict()
    assert description["type"] == "spd_dmp"
    not_spd = np.diag([1.0, -1.0])
    for key, name in (("start", "DMP start"), ("goal", "DMP goal")):
        with pytest.raises(spd.SPDError, match=f"^{name} sample 0 is not positive definite"):
            SPDDMP.from_dict(dict(description, **{key: not_spd.tolist()}))
    with pytest.raises(spd.SPDError, match="^stiffness sample 1 is not symmetric"):
        SPDDMP.learn(times[:3], np.array([np.eye(2), [[1.0, 0.5], [0.0, 1.0]], np.eye(2)]), TEN)
    with pytest.raises(ValueError, match=r"^need one matrix per time sample, got \(100, 2, 2\) for 101 times$"):
        SPDDMP.learn(times, matrices[:-1], TEN)
    with pytest.raises(spd.SPDError, match="^goal stiffness sample 0 is not positive definite"):
        model.rollout(goal=not_spd)
    with pytest.raises(ValueError, match=r"^goal must be 2x2, got \(3, 3\)$"):
        model.rollout(goal=np.eye(3))
    with pytest.raises(spd.SPDError, match="^new goal stiffness sample 0 is not positive definite"):
        model.rollout(switch=(0.5, not_spd))


def test_a_coarse_demonstration_is_reproduced_on_its_own_grid():
    """41 samples at 10 Hz: the regression's phase spans exactly the demonstration (tau = last - first stamp), and the
    SPD velocity at the last sample is its backward difference (a geodesic at constant speed, reproduced to 1e-5)."""
    step = 0.1
    times = np.arange(0.0, 4.0 + step / 2, step)
    s = times / times[-1]
    curve = np.column_stack([np.sin(2.0 * s), s**2])
    model = DMP.learn(times, curve, DMPParameters.from_yaml(basis_count=10))
    assert np.abs(model.rollout(dt=step)[1] - curve).max() < 1e-2  # about 5e-3; tau one step short: 4e-2
    start = np.diag([400.0, 900.0])
    direction = np.array([[0.5, 0.3], [0.3, -0.4]])
    geodesic = np.array([spd.Frame(start).exp(fraction * direction) for fraction in s])
    spd_model = SPDDMP.learn(times, geodesic, DMPParameters.from_yaml(basis_count=10))
    assert spd.distance(spd_model.rollout(dt=step)[1], geodesic).max() < 1e-5  # about 3e-6; a still last sample: 4e-5
