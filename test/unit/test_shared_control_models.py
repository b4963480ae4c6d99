"""Models of skill-based shared control (eqs 2-6) checked against independent computations."""

import math

import casadi as ca
import numpy as np
import pytest
from scipy import integrate, special

from teleteach.shared_control.constraints import (
    Box,
    StraightEdge,
    free_polygon,
    nearest_free_point,
    stopped_at_constraints,
    violation,
    violations,
)
from teleteach.shared_control.models import (
    SKILLS,
    ClothoidPath,
    ParameterLayout,
    control_function,
    state_trajectory,
    synthetic_commands,
)


def layout(skill="wave", segments=1):
    return ParameterLayout(SKILLS[skill], ClothoidPath(segments), 50.0, 500.0, (0.001, 1.0))


def rk4_path(psi, length, n_steps, segments=1):
    path = ClothoidPath(segments)
    u, alpha = path.rk4(ca.DM([0.0, 0.0]), psi[2 * segments], ca.DM(psi), length, n_steps)
    return np.asarray(u, dtype=float), np.asarray(alpha, dtype=float).ravel()


def test_clothoid_rk4_matches_fresnel_integrals():
    # Pure clothoid alpha = phi1 s^2 / 2: U(s) = sqrt(pi / phi1) (C(z), S(z)), z = s sqrt(phi1 / pi).
    phi1, length = 40.0, 0.5
    u, _ = rk4_path([0.0, phi1, 0.0, 0.1], length, 50)
    s = np.linspace(0, length, 51)
    fresnel_s, fresnel_c = special.fresnel(s * math.sqrt(phi1 / math.pi))
    expected = math.sqrt(math.pi / phi1) * np.vstack([fresnel_c, fresnel_s])
    assert np.max(np.abs(u - expected)) < 1e-7


def test_clothoid_rk4_matches_quadrature_with_fourth_order_convergence():
    phi0, phi1, alpha_c, length = 3.0, -25.0, 0.7, 0.4

    def heading(s):
        return alpha_c + phi0 * s + phi1 * s**2 / 2

    errors = []
    for n_steps in (40, 80):
        u, alpha = rk4_path([phi0, phi1, alpha_c, 0.1], length, n_steps)
        error = 0.0
        for j, s_end in enumerate(np.linspace(0, length, n_steps + 1)):
            x = integrate.quad(lambda s: math.cos(heading(s)), 0, s_end, epsabs=1e-14)[0]
            y = integrate.quad(lambda s: math.sin(heading(s)), 0, s_end, epsabs=1e-14)[0]
            error = max(error, float(np.max(np.abs(u[:, j] - [x, y]))))
            assert alpha[j] == pytest.approx(heading(s_end), abs=1e-12)
        errors.append(error)
    assert errors[0] < 1e-7
    assert errors[0] / errors[1] > 12  # halving the step divides the error by ~2^4


def test_two_segments_keep_heading_continuous_and_match_closed_form():
    psi = [2.0, 10.0, -4.0, 30.0, 0.3, 0.1]
    length = 0.6
    _, alpha = rk4_path(psi, length, 60, segments=2)
    path = ClothoidPath(2)
    s = ca.SX.sym("s")
    heading = ca.Function("h", [s], [path.heading(s, ca.DM(psi), length)])
    closed = np.array([float(heading(v)) for v in np.linspace(0, length, 61)])
    assert np.max(np.abs(alpha - closed)) < 1e-9
    assert np.max(np.abs(np.diff(alpha))) < 0.05


@pytest.mark.parametrize("segments", (1, 2))
@pytest.mark.parametrize("skill", sorted(SKILLS))
def test_control_is_the_derivative_of_the_state(skill, segments):
    # eq. 4 (product rule) against a Richardson-extrapolated central difference of eq. 3 (RK4 states); the
    # frequency is not a whole number, so S_i(0) differs from S_i(1)
    lay = layout(skill, segments)
    psi = [4.0, -30.0] + [2.0, 10.0] * (segments - 1) + [0.4, 0.05]
    theta = np.array([*psi, 0.02, 12.5, 0.01])
    x_c = np.array([0.2, -0.1])
    n = 400
    length = 0.2
    states, _ = state_trajectory(lay, ca.DM(x_c), ca.DM(theta), length, n)
    states = np.asarray(states, dtype=float)
    assert states[:, 0] == pytest.approx(x_c, abs=1e-12)
    h = length / n
    control = control_function(lay, length)
    for j in (50, 150, 350):  # away from the segments' joint at j = 200, where the curvature jumps
        fine = (states[:, j + 1] - states[:, j - 1]) / (2 * h)
        coarse = (states[:, j + 2] - states[:, j - 2]) / (4 * h)
        numeric = (4 * fine - coarse) / 3
        assert np.asarray(control(j * h, theta)).ravel() == pytest.approx(numeric, abs=1e-5)


def test_wave_and_cycloid_shapes_follow_table_one():
    # Straight underlying trajectory along +x: the wave moves only across it, the cycloid stays on a circle.
    x_c = np.zeros(2)
    for skill in ("wave", "cycloid"):
        lay = layout(skill)
        theta = np.array([0.0, 0.0, 0.0, 0.05, 0.03, 10.0, 0.0])
        states, _ = state_trajectory(lay, ca.DM(x_c), ca.DM(theta), 0.3, 300)
        states = np.asarray(states, dtype=float)
        s = np.linspace(0, 0.3, 301)
        if skill == "wave":
            u_c = x_c - np.array([0.0, 0.0])  # sin(0) = 0: U_c = x_c
            assert states[0] - u_c[0] == pytest.approx(s, abs=1e-9)
            assert states[1] == pytest.approx(0.03 * np.sin(2 * math.pi * 10.0 * s), abs=1e-9)
        else:
            centre = np.vstack([s - 0.03, np.zeros_like(s)])  # U_c = x_c - rho0 [1, 0]
            assert np.linalg.norm(states - centre, axis=0) == pytest.approx(np.full(301, 0.03), abs=1e-9)


@pytest.mark.parametrize("skill", sorted(SKILLS))
def test_shift_moves_the_model_along_s(skill):
    lay = layout(skill)
    theta = np.array([3.0, -20.0, 0.4, 0.05, 0.02, 15.0, 0.01])
    ds = 0.013
    shifted = lay.shift(theta, ds, 0.05)
    control = control_function(lay)
    for s in (-0.04, -0.01, 0.0, 0.02):
        assert np.asarray(control(s, shifted)).ravel() == pytest.approx(
            np.asarray(control(s + ds, theta)).ravel(), abs=1e-10
        )
    period = 1.0 / shifted[lay.i_rho + 1]
    assert abs(shifted[lay.i_rho + 2]) <= period / 2 + 1e-12


def test_synthetic_commands_are_the_velocity_of_the_model():
    times = np.arange(0, 1.0, 0.001)
    commands = synthetic_commands("cycloid", (0.03, 20.0, 0.0), 1.0, 0.05, times)
    positions = np.cumsum(commands, axis=0) * 0.001
    # The motion advances on average at v0 along the heading, and loops (speed above v0 at times).
    assert positions[-1] == pytest.approx(0.05 * np.array([math.cos(1.0), math.sin(1.0)]), abs=2e-3)
    assert np.max(np.linalg.norm(commands, axis=1)) > 0.15


def test_unknown_skill_and_bad_segment_count_are_rejected():
    from teleteach.shared_control.models import skill_names

    with pytest.raises(ValueError, match="unknown skills"):
        skill_names(["wave", "spiral"])
    with pytest.raises(ValueError, match=r"^n_segments must be >= 1, got 0$"):
        ClothoidPath(0)


def test_three_segments_curvature_heading_and_path_match_an_integration_of_eq_6():
    psi = [2.0, 10.0, -4.0, 30.0, 1.0, -20.0, 0.3, 0.1]
    length = 0.9  # segments start at 0, 0.3, 0.6
    path = ClothoidPath(3)
    assert path.psi_names == ["phi0_0", "phi1_0", "phi0_1", "phi1_1", "phi0_2", "phi1_2", "alpha_c", "v0"]

    def curvature(s):  # eq. 6b per segment, the first reaching back, the last forward
        k = 0 if s < 0.3 else 1 if s < 0.6 else 2
        return psi[2 * k] + psi[2 * k + 1] * (s - 0.3 * k)

    s = ca.SX.sym("s")
    symbolic = ca.Function("c", [s], [path.curvature(s, ca.DM(psi), length), path.heading(s, ca.DM(psi), length)])
    for value in (-0.1, 0.0, 0.1, 0.3, 0.45, 0.6, 0.75, 1.0):  # each segment's start exactly, before and after
        modelled_curvature, modelled_heading = (float(v) for v in symbolic(value))
        assert modelled_curvature == pytest.approx(curvature(value), abs=1e-12), value
        heading = psi[6] + integrate.quad(curvature, 0.0, value, points=[0.3, 0.6], epsabs=1e-13)[0]
        assert modelled_heading == pytest.approx(heading, abs=1e-10), value
    u, alpha = rk4_path(psi, length, 90, segments=3)
    for j in (20, 45, 70, 90):
        s_end = j * length / 90

        def heading(t):
            return psi[6] + integrate.quad(curvature, 0.0, t, points=[0.3, 0.6], epsabs=1e-13)[0]

        x = integrate.quad(lambda t: math.cos(heading(t)), 0, s_end, points=[0.3, 0.6], epsabs=1e-12)[0]
        y = integrate.quad(lambda t: math.sin(heading(t)), 0, s_end, points=[0.3, 0.6], epsabs=1e-12)[0]
        assert u[:, j] == pytest.approx([x, y], abs=1e-7) and alpha[j] == pytest.approx(heading(s_end), abs=1e-10)


def test_control_function_s_inputs_are_named_and_its_segments_split_one_metre_by_default():
    lay = layout("wave", 2)
    theta = np.array([4.0, -30.0, -6.0, 10.0, 0.4, 0.05, 0.02, 12.5, 0.01])
    by_name = np.asarray(control_function(lay)(s=0.7, theta=theta)["u"]).ravel()
    assert by_name == pytest.approx(np.asarray(control_function(lay, 1.0)(0.7, theta)).ravel(), abs=1e-12)
    assert by_name != pytest.approx(np.asarray(control_function(lay, 2.0)(0.7, theta)).ravel(), abs=1e-3)


def test_the_layout_s_bounds_scales_and_guess_for_two_segments():
    lay = ParameterLayout(SKILLS["cycloid"], ClothoidPath(2), 50.0, 500.0, (0.001, 1.0))
    assert lay.names == ["phi0_0", "phi1_0", "phi0_1", "phi1_1", "alpha_c", "v0", "radius", "frequency", "phase"]
    assert (lay.n, lay.i_alpha, lay.i_v0, lay.i_rho) == (9, 4, 5, 6)
    assert list(lay.lower) == [-50.0, -500.0, -50.0, -500.0, -math.inf, 0.001, 0.005, 5.0, -0.25]
    assert list(lay.upper) == [50.0, 500.0, 50.0, 500.0, math.inf, 1.0, 0.1, 60.0, 0.25]
    assert list(lay.scale) == [50.0, 500.0, 50.0, 500.0, 1.0, 0.5, 0.03, 20.0, 0.05]
    # a zero bound still gives the solver a scale to divide by
    assert list(ParameterLayout(SKILLS["wave"], ClothoidPath(1), 0.0, 0.0, (0.0, 0.0)).scale[:4]) == [
        1e-3,
        1e-3,
        1.0,
        5e-4,
    ]
    # a straight line at the heading given, the speed within its bounds, the skill's own first guess
    assert list(lay.guess(-7.0, 3.0)) == [0.0, 0.0, 0.0, 0.0, -7.0, 1.0, 0.03, 20.0, 0.0]
    assert lay.guess(0.2, 0.0)[lay.i_v0] == 0.001
    psi, rho = lay.split(lay.guess(0.2, 0.5))
    assert list(psi) == [0.0, 0.0, 0.0, 0.0, 0.2, 0.5] and list(rho) == [0.03, 20.0, 0.0]


def test_shift_wraps_the_phase_to_one_period_around_zero_and_keeps_numbers_as_floats():
    lay = layout("wave")
    # a frequency below 1 / m: period 2 m, phase 0.7 + 0.5 = 1.2 -> -0.8
    shifted = lay.shift(np.array([0.0, 0.0, 0.0, 0.1, 0.02, 0.5, 0.7]), 0.5, 1.0)
    assert shifted[lay.i_rho + 2] == pytest.approx(-0.8, abs=1e-12)
    shifted = lay.shift(np.array([0.0, 0.0, 0.0, 0.1, 0.02, 40.0, 0.0]), 0.03, 1.0)
    assert shifted[lay.i_rho + 2] == pytest.approx(0.005, abs=1e-12)  # period 0.025 m
    # no frequency, no period: the phase only advances
    unwrapped = lay.shift(np.array([0.0, 0.0, 0.0, 0.1, 0.02, 0.0, 0.7]), 0.5, 1.0)
    assert unwrapped[lay.i_rho + 2] == pytest.approx(1.2, abs=1e-12)
    # an integer vector is shifted as numbers, not truncated
    shifted = lay.shift([2, 10, 1, 0, 0, 20, 0], 0.013, 1.0)
    assert list(shifted) == pytest.approx([2.13, 10.0, 1.0 + 0.026 + 0.000845, 0.0, 0.0, 20.0, 0.013], abs=1e-12)


def test_synthetic_commands_add_the_noise_of_the_generator_given():
    times = np.arange(0, 0.5, 0.01)
    clean = synthetic_commands("wave", (0.02, 10.0, 0.0), 0.3, 0.05, times)
    assert synthetic_commands("wave", (0.02, 10.0, 0.0), 0.3, 0.05, times, noise=0.0) == pytest.approx(clean)
    # no noise draws nothing from the caller's generator: its next numbers are still the caller's
    generator = np.random.default_rng(4)
    synthetic_commands("wave", (0.02, 10.0, 0.0), 0.3, 0.05, times, 0.0, generator)
    assert generator.random() == np.random.default_rng(4).random()
    noisy = synthetic_commands("wave", (0.02, 10.0, 0.0), 0.3, 0.05, times, 0.5, np.random.default_rng(3))
    assert noisy == pytest.approx(clean + 0.5 * np.random.default_rng(3).standard_normal((len(times), 2)))
    unseeded = synthetic_commands("wave", (0.02, 10.0, 0.0), 0.3, 0.05, times, 0.5)
    assert unseeded.shape == clean.shape and 0.3 < np.std(unseeded - clean) < 0.7


@pytest.mark.slow
def test_nearest_free_point_matches_a_brute_force_search():
    box = Box(-0.2, -0.1, 0.3, 0.25)
    edge = StraightEdge(0.05, 0.0, 2.3)
    grid = np.stack(np.meshgrid(np.linspace(-0.2, 0.3, 501), np.linspace(-0.1, 0.25, 351)), axis=0).reshape(2, -1)
    free = grid[:, violation_mask(grid, box, edge)]
    rng = np.random.default_rng(3)
    for point in rng.uniform([-0.4, -0.3], [0.5, 0.4], size=(20, 2)):
        nearest = nearest_free_point(point, box, edge, 0.0)
        assert violation(nearest, box, edge) < 1e-12
        brute = np.min(np.linalg.norm(free - point[:, None], axis=0))
        assert np.linalg.norm(nearest - point) <= brute + 1e-9
        assert np.linalg.norm(nearest - point) >= brute - 2e-3


def violation_mask(points, box, edge):
    return np.array([violation(p, box, edge) == 0.0 for p in points.T])


def test_no_free_region_when_the_edge_covers_the_box():
    box = Box(0.0, 0.0, 1.0, 1.0)
    edge = StraightEdge(2.0, 0.0, 0.0)  # free side is x >= 2
    assert free_polygon(box, edge, 0.0) == []
    assert nearest_free_point(np.array([0.5, 0.5]), box, edge, 0.0) is None


def test_violations_are_per_point_and_the_largest_is_the_violation():
    box, edge = Box(0.0, 0.0, 1.0, 1.0), StraightEdge(0.0, 0.5, math.pi / 2)  # free side: y >= 0.5
    points = np.array([[0.5, 1.2, 0.5, -0.1, float("nan")], [0.7, 0.7, 0.4, 0.9, 0.5]])
    assert violations(points, box, edge) == pytest.approx([0.0, 0.2, 0.1, 0.1, math.inf])
    assert violations(points[:, :4], box, edge, 0.05) == pytest.approx([0.0, 0.25, 0.15, 0.15])
    assert violation(points[:, :4], box, edge) == pytest.approx(0.2)
    assert violation(np.zeros((2, 0)), box, None) == 0.0


def test_a_path_stopped_at_the_constraints_keeps_its_free_points_and_moves_the_others_to_the_nearest_free_one():
    box, edge = Box(0.0, 0.0, 1.0, 1.0), StraightEdge(0.0, 0.5, math.pi / 2)
    path = np.array([[0.5, 1.2, 0.3], [0.7, 0.7, 0.3]])
    stopped = stopped_at_constraints(path, box, edge, 0.05)
    assert stopped == pytest.approx(np.array([[0.5, 0.95, 0.3], [0.7, 0.7, 0.55]]))
    assert path[0, 1] == 1.2  # the input is not changed
    covered = StraightEdge(2.0, 0.0, 0.0)  # no free region: nothing to stop at
    assert stopped_at_constraints(path, box, covered, 0.0) == pytest.approx(path)
    # a point inside the box but within the margin moves too; integer input gives float points, not truncated ones
    assert stopped_at_constraints([[0.98], [0.7]], box, None, 0.05) == pytest.approx(np.array([[0.95], [0.7]]))
    assert stopped_at_constraints(np.array([[2], [0]]), box, None, 0.25) == pytest.approx(np.array([[0.75], [0.25]]))


def test_violations_count_the_margin_on_every_side():
    box = Box(0.0, 0.0, 1.0, 1.0)
    points = np.array([[0.02, 0.98, 0.5, 0.5, 0.5], [0.5, 0.5, 0.02, 0.98, 0.5]])
    assert violations(points, box, None, 0.05) == pytest.approx([0.03, 0.03, 0.03, 0.03, 0.0])
    assert violation(points, box, None, 0.05) == pytest.approx(0.03)
    assert violation(points, box, None) == 0.0


def test_free_polygon_is_the_box_shrunk_by_the_margin_and_cut_by_the_edge():
    box = Box(0.0, 0.0, 1.0, 2.0)
    expected = [(0.1, 0.1), (0.9, 0.1), (0.9, 1.9), (0.1, 1.9)]
    assert np.array(free_polygon(box, None, 0.1)) == pytest.approx(np.array(expected))
    # an edge along the box's side, free side inward, cuts nothing: its vertices on the edge are free
    side = StraightEdge(0.0, 0.0, 0.0)
    assert np.array(free_polygon(box, side, 0.0)) == pytest.approx(np.array([(0, 0), (1, 0), (1, 2), (0, 2)]))
    half = StraightEdge(0.5, 0.0, 0.0)  # free side x >= 0.5
    assert sorted(map(tuple, np.round(free_polygon(box, half, 0.0), 9))) == [(0.5, 0.0), (0.5, 2.0), (1, 0), (1, 2)]
    # an edge touching the box from outside leaves one side free, each of its vertices once
    square, touching = Box(0.0, 0.0, 1.0, 1.0), StraightEdge(1.0, 0.0, 0.0)  # free side x >= 1
    assert np.array(free_polygon(square, touching, 0.0)) == pytest.approx(np.array([(1, 0), (1, 1)]))
    assert nearest_free_point(np.array([0.2, 0.5]), square, touching, 0.0) == pytest.approx([1.0, 0.5])
    # a box narrower than two margins has no free region; one exactly two margins wide has one free point
    assert free_polygon(square, None, 0.6) == []
    assert len(free_polygon(square, None, 0.5)) == 4
    assert nearest_free_point(np.array([0.9, 0.2]), square, None, 0.5) == pytest.approx([0.5, 0.5])


def test_nearest_free_point_keeps_the_margin_and_sends_a_non_finite_point_to_the_middle():
    box = Box(0.0, 0.0, 1.0, 2.0)
    assert nearest_free_point(np.array([0.05, 1.0]), box, None, 0.1) == pytest.approx([0.1, 1.0])
    assert nearest_free_point(np.array([0.5, 1.5]), box, None, 0.1) == pytest.approx([0.5, 1.5])
    assert nearest_free_point(np.array([float("nan"), 1.0]), box, None, 0.1) == pytest.approx([0.5, 1.0])


def test_the_optimisation_s_parameters_of_the_box_and_the_edge():
    assert Box(-0.2, -0.1, 0.3, 0.25).as_array() == pytest.approx([-0.2, -0.1, 0.3, 0.25])
    assert StraightEdge(0.05, -0.02, 2.3).as_array() == pytest.approx([0.05, -0.02, 2.3, 1.0])  # (px, py, yaw, active)


def test_bad_geometry_is_rejected():
    with pytest.raises(ValueError, match="x_min < x_max and y_min < y_max"):
        Box(1.0, 0.0, 0.0, 1.0)
    with pytest.raises(ValueError, match="x_min < x_max and y_min < y_max"):
        Box(0.0, 0.0, 0.0, 1.0)
    with pytest.raises(ValueError, match="x_min < x_max and y_min < y_max"):
        Box(0.0, 1.0, 1.0, 1.0)
    with pytest.raises(ValueError, match="box bounds must be finite"):
        Box(0.0, 0.0, float("inf"), 1.0)
    with pytest.raises(ValueError, match="obstacle pose must be finite"):
        StraightEdge(float("nan"), 0.0, 0.0)
