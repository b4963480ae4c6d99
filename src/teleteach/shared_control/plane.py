"""The task plane: where the shared controller's 2-D state lies in ``base_link``, and how the tool is held there.

The MPC (teleteach.shared_control.loop) plans in the plane's coordinates; the node maps each state to an equilibrium
pose in ``base_link`` through it. A fixed plane comes from the node's parameters; a surface to wipe gives one through
its perceived pose (teleteach.shared_control.surface).
"""

import dataclasses
from typing import Sequence

import numpy as np


@dataclasses.dataclass
class TaskPlane:
    """The task plane in ``base_link``: x_base = origin + x e_x + y e_y, end-effector orientation fixed.

    Attributes:
        origin: plane origin in base_link [m].
        x_axis: plane x direction in base_link (normalised here).
        y_axis: plane y direction in base_link (made orthogonal to x_axis and normalised here).
        orientation: end-effector orientation quaternion (x, y, z, w) in base_link.
    """

    origin: Sequence[float]
    x_axis: Sequence[float]
    y_axis: Sequence[float]
    orientation: Sequence[float]

    def __post_init__(self):
        origin = np.asarray(self.origin, dtype=float)
        x_axis = np.asarray(self.x_axis, dtype=float)
        y_axis = np.asarray(self.y_axis, dtype=float)
        quaternion = np.asarray(self.orientation, dtype=float)
        if origin.shape != (3,) or x_axis.shape != (3,) or y_axis.shape != (3,) or quaternion.shape != (4,):
            raise ValueError("origin, x_axis, y_axis need 3 numbers and orientation 4")
        if not all(np.all(np.isfinite(v)) for v in (origin, x_axis, y_axis, quaternion)):
            raise ValueError("task plane values must be finite")
        if np.linalg.norm(x_axis) < 1e-9 or np.linalg.norm(quaternion) < 1e-9:
            raise ValueError("x_axis and orientation must be non-zero")
        x_axis = x_axis / np.linalg.norm(x_axis)
        y_axis = y_axis - (y_axis @ x_axis) * x_axis
        if np.linalg.norm(y_axis) < 1e-9:
            raise ValueError("y_axis must not be parallel to x_axis")
        self.origin = origin
        self.x_axis = x_axis
        self.y_axis = y_axis / np.linalg.norm(y_axis)
        self.orientation = quaternion / np.linalg.norm(quaternion)

    def to_base(self, point: Sequence[float]) -> np.ndarray:
        """Task-plane point (x, y) [m] -> base_link position [m]."""
        return self.origin + self.vector_to_base(point)

    def vector_to_base(self, vector: Sequence[float]) -> np.ndarray:
        """Task-plane vector (x, y) (e.g. a velocity) -> base_link vector."""
        return vector[0] * self.x_axis + vector[1] * self.y_axis

    def to_plane(self, position: Sequence[float]) -> np.ndarray:
        """base_link position [m] -> task-plane point (x, y) [m] (the orthogonal projection)."""
        offset = np.asarray(position, dtype=float) - self.origin
        return np.array([offset @ self.x_axis, offset @ self.y_axis])

    @classmethod
    def from_params(cls, params: dict) -> "TaskPlane":
        """From the node's ``plane`` parameter: its four keys (config/shared_control.yaml; a missing one: TypeError)."""
        return cls(**{key: params[key] for key in ("origin", "x_axis", "y_axis", "orientation") if key in params})
