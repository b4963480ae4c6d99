"""Switching shared control on: the MPC starts where the arm is (inside the boundary) and the reference moves there
smoothly, so the impedance controller's spring never jumps."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from teleteach.shared_control.approach import Approach, start_in_plane
from teleteach.shared_control.constraints import Box

BOX = Box(-0.25, -0.15, 0.25, 0.15)


def test_start_is_the_arms_projection_moved_inside_the_boundary():
    np.testing.assert_allclose(start_in_plane([0.1, 0.05], BOX, 0.005), [0.1, 0.05])
    np.testing.assert_allclose(start_in_plane([0.0, -0.4], BOX, 0.005), [0.0, -0.145])
    np.testing.assert_allclose(start_in_plane([1.0, 1.0], BOX, 0.005), [0.245, 0.145])


def test_the_reference_moves_from_the_arm_to_the_plane_without_a_jump():
    tool_down = Rotation.from_euler("y", 180, degrees=True).as_quat()
    tilted = Rotation.from_euler("xy", [20, 160], degrees=True).as_quat()
    approach = Approach.at_most([0.3, 0.0, 0.5], tilted, [0.55, 0.0, 0.65], tool_down, speed=0.2, turn_rate=0.5)
    assert approach.duration == pytest.approx(1.875 * np.linalg.norm([0.25, 0.0, 0.15]) / 0.2)
    times = np.arange(0.0, approach.duration + 0.5, 0.02)  # the node's 50 Hz cycles
    positions = np.array([approach.at(t)[0] for t in times])
    # Expect: it starts at the arm, ends at the plane's start, and no cycle moves the reference faster than 0.2 m/s
    np.testing.assert_allclose(positions[0], [0.3, 0.0, 0.5])
    np.testing.assert_allclose(positions[-1], [0.55, 0.0, 0.65])
    assert np.max(np.linalg.norm(np.diff(positions, axis=0), axis=1)) <= 0.2 * 0.02 + 1e-9
    # ... with the orientation turning the same way, and the velocity matching the positions
    turn = [(Rotation.from_quat(approach.at(t)[1]).inv() * Rotation.from_quat(tool_down)).magnitude() for t in times]
    whole = (Rotation.from_quat(tilted).inv() * Rotation.from_quat(tool_down)).magnitude()
    assert turn[0] == pytest.approx(whole) and turn[-1] < 1e-9
    assert np.all(np.diff(turn) <= 1e-12)  # always nearer the plane's orientation
    velocities = np.array([approach.at(t)[2] for t in times])
    np.testing.assert_allclose(np.gradient(positions, times, axis=0), velocities, atol=0.01)
    assert approach.done(approach.duration) and not approach.done(approach.duration - 0.01)


def test_a_bad_approach_is_refused():
    with pytest.raises(ValueError, match="start_position must be finite"):
        Approach([np.nan, 0, 0], [0, 0, 0, 1], [0, 0, 0], [0, 0, 0, 1], 1.0)
    with pytest.raises(ValueError, match="duration must be > 0 s"):
        Approach([0, 0, 0], [0, 0, 0, 1], [0, 0, 0], [0, 0, 0, 1], 0.0)
