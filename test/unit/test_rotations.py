"""The one roll-pitch-yaw convention (teleteach.core.rotations): a heading is a yaw about the fixed Z axis."""

import math

import numpy as np
import pytest

from teleteach.core.rotations import quaternion_to_rpy, rpy_to_quaternion, yaw_quaternion, yaw_rotation


@pytest.mark.parametrize("yaw", [0.0, math.pi / 4, -2.0, math.pi])
def test_a_yaw_is_the_rpy_convention_with_only_yaw(yaw):
    np.testing.assert_allclose(yaw_quaternion(yaw), rpy_to_quaternion(0.0, 0.0, yaw), atol=1e-12)
    np.testing.assert_allclose(yaw_quaternion(yaw), [0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0)], atol=1e-12)
    assert quaternion_to_rpy(yaw_quaternion(yaw))[2] == pytest.approx(math.atan2(math.sin(yaw), math.cos(yaw)))


def test_a_yaw_turns_x_towards_y():
    np.testing.assert_allclose(yaw_rotation(math.pi / 2).apply([1.0, 0.0, 0.0]), [0.0, 1.0, 0.0], atol=1e-12)
