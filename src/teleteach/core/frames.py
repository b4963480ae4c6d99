"""Rigid transforms between the frames the skills speak of: world, base_link, a target (a shelf gap), the TCP.

One home for composing and inverting poses and for turning a stiffness with its frame (K' = R K R^T). A pose array
is (x, y, z, qx, qy, qz, qw), as in geometry_msgs and the skill files; a stack of them is (N, 7).
"""

import dataclasses
from typing import Sequence

import numpy as np
from scipy.spatial.transform import Rotation

from teleteach.core.rotations import yaw_rotation


@dataclasses.dataclass(frozen=True)
class Transform:
    """The pose of a frame B in a frame A: maps points of B into A (p_A = position + rotation p_B)."""

    position: np.ndarray
    rotation: Rotation

    @classmethod
    def identity(cls) -> "Transform":
        """The frame itself."""
        return cls(np.zeros(3), Rotation.identity())

    @classmethod
    def from_pose(cls, pose: Sequence[float]) -> "Transform":
        """From a pose array (x, y, z, qx, qy, qz, qw)."""
        pose = np.asarray(pose, dtype=float)
        return cls(pose[:3].copy(), Rotation.from_quat(pose[3:7]))

    @classmethod
    def from_planar(cls, x: float, y: float, yaw: float, z: float = 0.0) -> "Transform":
        """A frame turned about the vertical only: a mobile base's base_link, or a shelf gap."""
        return cls(np.array([x, y, z], dtype=float), yaw_rotation(yaw))

    def as_pose(self) -> np.ndarray:
        """The pose array (x, y, z, qx, qy, qz, qw)."""
        return np.concatenate([self.position, self.rotation.as_quat()])

    def inverse(self) -> "Transform":
        """The pose of A in B."""
        inverse = self.rotation.inv()
        return Transform(-inverse.apply(self.position), inverse)

    def __mul__(self, other: "Transform") -> "Transform":
        """Composition: (A<-B) * (B<-C) = (A<-C)."""
        return Transform(self.position + self.rotation.apply(other.position), self.rotation * other.rotation)

    def apply_point(self, point: Sequence[float]) -> np.ndarray:
        """A point of B in A."""
        return self.position + self.rotation.apply(np.asarray(point, dtype=float))

    def apply_poses(self, poses: np.ndarray) -> np.ndarray:
        """Poses (N, 7) given in B, expressed in A; each quaternion on the side of the one before.

        q and -q are the same rotation: a sequence that flips between them would make an interpolation turn the long
        way.
        """
        poses = np.asarray(poses, dtype=float)
        positions = self.position + self.rotation.apply(poses[:, :3])
        quaternions = (self.rotation * Rotation.from_quat(poses[:, 3:7])).as_quat()
        return np.hstack([positions, continuous_quaternions(quaternions)])

    def turn_stiffness(self, stiffness: np.ndarray) -> np.ndarray:
        """Stiffness matrices (N, 3, 3) or (3, 3) given in B's axes, in A's: R K R^T."""
        matrix = self.rotation.as_matrix()
        return matrix @ np.asarray(stiffness, dtype=float) @ matrix.T

    def planar(self) -> np.ndarray:
        """(x, y, yaw) of a frame turned about the vertical only."""
        x_axis = self.rotation.apply([1.0, 0.0, 0.0])
        return np.array([self.position[0], self.position[1], np.arctan2(x_axis[1], x_axis[0])])


def continuous_quaternions(quaternions: np.ndarray) -> np.ndarray:
    """Quaternions (N, 4) with signs flipped so that each lies on the side of the one before."""
    quaternions = np.array(quaternions, dtype=float)
    if len(quaternions) > 1:
        signs = np.cumprod(np.where(np.einsum("ij,ij->i", quaternions[1:], quaternions[:-1]) < 0.0, -1.0, 1.0))
        quaternions[1:] *= signs[:, None]
    return quaternions
