"""The one roll-pitch-yaw convention (teleteach.core.rotations): a heading is a yaw about the fixed Z axis."""

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from teleteach.core.rotations import (
    quaternion_to_rpy,
    rpy_to_quaternion,
    unyawed_quaternion,
    wrap_angle,
    yaw_matrix,
    yaw_quaternion,
    yaw_rotation,
)


@pytest.mark.parametrize("yaw", [0.0, math.pi / 4, -2.0, math.pi])
def test_a_yaw_is_the_rpy_convention_with_only_yaw(yaw):
    np.testing.assert_allclose(yaw_quaternion(yaw), rpy_to_quaternion(0.0, 0.0, yaw), atol=1e-12)
    np.testing.assert_allclose(yaw_quaternion(yaw), [0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0)], atol=1e-12)
    assert quaternion_to_rpy(yaw_quaternion(yaw))[2] == pytest.approx(math.atan2(math.sin(yaw), math.cos(yaw)))


def test_a_yaw_turns_x_towards_y():
    np.testing.assert_allclose(yaw_rotation(math.pi / 2).apply([1.0, 0.0, 0.0]), [0.0, 1.0, 0.0], atol=1e-12)


@pytest.mark.parametrize("yaw", [0.0, 0.3, -2.0, math.pi])
def test_the_written_out_yaw_forms_are_scipys(yaw):
    np.testing.assert_allclose(yaw_matrix(yaw), yaw_rotation(yaw).as_matrix(), atol=1e-15)
    orientation = Rotation.from_euler("xyz", [0.4, -0.2, 1.1])
    expected = (yaw_rotation(yaw).inv() * orientation).as_matrix()
    unyawed = unyawed_quaternion(orientation.as_quat(), yaw)
    np.testing.assert_allclose(np.linalg.norm(unyawed), 1.0, atol=1e-15)
    np.testing.assert_allclose(Rotation.from_quat(unyawed).as_matrix(), expected, atol=1e-15)


def test_an_angle_wraps_into_minus_pi_to_pi_alone_or_in_an_array():
    # Expect a whole number of turns removed, the sign kept, numbers as numbers and arrays element by element
    assert wrap_angle(0.5 + 4 * math.pi) == pytest.approx(0.5)
    assert wrap_angle(-3.5) == pytest.approx(2 * math.pi - 3.5)
    assert isinstance(wrap_angle(7), float)
    np.testing.assert_allclose(wrap_angle(np.array([3.5, -7.0, 0.1])), [3.5 - 2 * math.pi, 2 * math.pi - 7.0, 0.1])
