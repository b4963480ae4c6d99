"""Rigid transforms (teleteach.core.frames), each checked against an independent computation with 4x4 matrices."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from teleteach.core.frames import Transform, continuous_quaternions


def matrix(transform: Transform) -> np.ndarray:
    """The homogeneous 4x4 matrix of a transform, built by hand."""
    result = np.eye(4)
    result[:3, :3] = transform.rotation.as_matrix()
    result[:3, 3] = transform.position
    return result


A = Transform(np.array([0.3, -0.2, 0.5]), Rotation.from_euler("xyz", [0.2, -0.4, 1.1]))
B = Transform(np.array([-1.0, 0.4, 0.05]), Rotation.from_euler("xyz", [-0.7, 0.1, -2.0]))


def test_composition_and_inverse_are_those_of_homogeneous_matrices():
    np.testing.assert_allclose(matrix(A * B), matrix(A) @ matrix(B), atol=1e-12)
    np.testing.assert_allclose(matrix(A.inverse()), np.linalg.inv(matrix(A)), atol=1e-12)
    np.testing.assert_allclose(matrix(A * A.inverse()), np.eye(4), atol=1e-12)


def test_poses_are_mapped_as_frames_and_stay_continuous():
    poses = np.array([[0.1, 0.2, 0.3, *Rotation.from_euler("z", angle).as_quat()] for angle in np.linspace(0, 6, 40)])
    mapped = A.apply_poses(poses)
    for pose, result in zip(poses, mapped):
        np.testing.assert_allclose(matrix(Transform.from_pose(result)), matrix(A) @ matrix(Transform.from_pose(pose)))
    # Expect: no sign flips between neighbouring quaternions, so an interpolation never turns the long way
    assert np.all(np.einsum("ij,ij->i", mapped[1:, 3:], mapped[:-1, 3:]) > 0.0)


def test_stiffness_turns_with_its_frame():
    stiffness = np.diag([300.0, 2000.0, 1200.0])
    turned = A.turn_stiffness(stiffness)
    # Expect: the force for a displacement d in A's axes is the force for R^T d in B's, turned back
    displacement = np.array([0.01, -0.02, 0.005])
    expected = A.rotation.apply(stiffness @ A.rotation.inv().apply(displacement))
    np.testing.assert_allclose(turned @ displacement, expected, atol=1e-10)
    np.testing.assert_allclose(np.linalg.eigvalsh(turned), [300.0, 1200.0, 2000.0])


def test_a_planar_frame_reads_back_its_planar_pose():
    frame = Transform.from_planar(1.2, -0.4, 2.9, z=0.72)
    assert frame.planar() == pytest.approx([1.2, -0.4, 2.9])
    assert frame.position[2] == 0.72


def test_continuous_quaternions_flip_only_signs():
    rotations = Rotation.from_euler("z", np.linspace(0.0, 3.0, 10))
    raw = rotations.as_quat() * np.where(np.arange(10) % 3 == 0, -1.0, 1.0)[:, None]
    fixed = continuous_quaternions(raw)
    assert np.all(np.einsum("ij,ij->i", fixed[1:], fixed[:-1]) > 0.0)
    np.testing.assert_allclose(Rotation.from_quat(fixed).as_matrix(), rotations.as_matrix(), atol=1e-12)
