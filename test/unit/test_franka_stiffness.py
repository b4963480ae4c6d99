"""The seven values of franka_human_friendly_controllers' /stiffness from the thesis' eigenvalues and eigenvectors,
checked against the stiffness along each base axis worked out by hand (K_xx = sum_i lambda_i (a_i . x)^2)."""

import math

import numpy as np
import pytest

from teleteach.control.franka_stiffness import STIFFNESS_VALUES, franka_stiffness
from teleteach.core.validation import InvalidCommandError

VALUES = (1000.0, 3000.0, 2000.0)  # [N/m] along the ellipsoid's own x, y, z


def about(axis, angle):
    """Quaternion (x, y, z, w) of a rotation by angle [rad] about a unit axis."""
    return (*np.multiply(axis, math.sin(angle / 2.0)), math.cos(angle / 2.0))


def test_an_ellipsoid_turned_a_quarter_about_z_swaps_x_and_y():
    values, left_out = franka_stiffness(VALUES, about((0, 0, 1), math.pi / 2), 30.0, 0.5, 3000.0)
    # Expect: the ellipsoid's y (3000) along base x, its x (1000) along base y; rotational 30 each; nullspace last
    np.testing.assert_allclose(values, [3000.0, 1000.0, 2000.0, 30.0, 30.0, 30.0, 0.5], atol=1e-9)
    assert left_out == pytest.approx(0.0, abs=1e-9)


def test_a_quarter_about_y_swaps_x_and_z():
    values, _ = franka_stiffness(VALUES, about((0, 1, 0), math.pi / 2), 30.0, 0.5, 3000.0)
    np.testing.assert_allclose(values[:3], [2000.0, 3000.0, 1000.0], atol=1e-9)


def test_an_ellipsoid_at_45_degrees_keeps_its_diagonal_and_reports_what_it_leaves_out():
    values, left_out = franka_stiffness(VALUES, about((0, 0, 1), math.pi / 4), 30.0, 0.5, 3000.0)
    # Expect: K_xx = K_yy = (1000 + 3000) / 2; the off-diagonal K_xy = (3000 - 1000) / 2 cannot be sent
    np.testing.assert_allclose(values[:3], [2000.0, 2000.0, 2000.0], atol=1e-9)
    assert left_out == pytest.approx(1000.0)
    assert len(values) == STIFFNESS_VALUES and np.all(np.isfinite(values))


def test_a_stiffness_above_the_maximum_is_clamped():
    values, _ = franka_stiffness((5000.0, 0.0, 100.0), (0.0, 0.0, 0.0, 1.0), 30.0, 0.5, 3000.0)
    np.testing.assert_allclose(values[:3], [3000.0, 0.0, 100.0])


@pytest.mark.parametrize(
    ("eigenvalues", "eigenvectors", "reason"),
    [
        ((math.nan, 1.0, 1.0), (0.0, 0.0, 0.0, 1.0), "NaN or inf"),
        ((1.0, -1.0, 1.0), (0.0, 0.0, 0.0, 1.0), "negative stiffness"),
        ((1.0, 1.0), (0.0, 0.0, 0.0, 1.0), "must have 3 values"),
        ((1.0, 1.0, 1.0), (0.0, 0.0, 0.0, 0.0), "eigenvectors is zero"),
        ((1.0, 1.0, 1.0), (0.0, 0.0, 0.0, 2.0), "not unit"),
    ],
)
def test_bad_input_is_refused_saying_why(eigenvalues, eigenvectors, reason):
    with pytest.raises(InvalidCommandError, match=reason):
        franka_stiffness(eigenvalues, eigenvectors, 30.0, 0.5, 3000.0)
