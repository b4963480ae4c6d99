"""The physical check of eqs 1-4: push the end effector with a known force in pybullet and compare the static
displacement with K^-1 f along each principal axis of the commanded ellipsoid (within 10 %)."""

import math

import numpy as np
import pytest
from sim_support import robot_sim_for_module, to_impedance

from teleteach.control.stiffness import rotation_from_quaternion, translational_stiffness


@pytest.fixture(scope="module")
def robot_sim():
    yield from robot_sim_for_module()


FORCE = 10.0  # [N]
Z45 = [0.0, 0.0, math.sin(math.pi / 8), math.cos(math.pi / 8)]


def mean_position(sim, seconds, force=None):
    samples = []
    for _ in range(int(seconds * 1000)):
        if force is not None:
            sim.world.apply_tcp_force(force)
        sim.tick()
        samples.append(sim.state.position.copy())
    return np.mean(samples[-200:], axis=0)


@pytest.mark.parametrize(
    ("eigenvalues", "quaternion", "base_pose"),
    [
        ([300.0, 600.0, 1000.0], [0.0, 0.0, 0.0, 1.0], "start"),  # diagonal (thesis III-C)
        ([300.0, 900.0, 600.0], Z45, "place_45deg"),  # rotated 45 degrees about z, base at 45 degrees (III-D)
    ],
)
def test_static_displacement_matches_inverse_stiffness(robot_sim, eigenvalues, quaternion, base_pose):
    sim = robot_sim
    sim.world.teleport_base(sim.scene.base_poses[base_pose])
    to_impedance(sim)
    sim.command_eigenvalues(eigenvalues)
    sim.command_eigenvectors(quaternion)
    sim.command_equilibrium("base_link", sim.state.position, sim.state.quaternion)
    rest = mean_position(sim, 1.5)  # the stiffness filter converges (time constant 0.2 s)
    stiffness = translational_stiffness(eigenvalues, quaternion)
    axes = rotation_from_quaternion(quaternion)
    for axis in range(3):
        force = FORCE * axes[:, axis]
        displacement = mean_position(sim, 2.0, force) - rest
        expected = np.linalg.solve(stiffness, force)
        # Expect, along each principal axis, the displacement f / sigma_i within 10 %, nothing along the others
        along = axes.T @ displacement
        assert along[axis] == pytest.approx(FORCE / eigenvalues[axis], rel=0.10), (axis, along)
        assert np.linalg.norm(displacement - expected) < 0.10 * np.linalg.norm(expected), (axis, displacement)
        mean_position(sim, 1.0)  # spring back
