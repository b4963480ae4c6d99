"""Device velocity from successive poses: finite differences, low-pass filtered (the one place it is computed)."""

import math
from typing import Optional, Tuple

import numpy as np
from scipy.spatial.transform import Rotation


def rotation_vector_between(previous: np.ndarray, current: np.ndarray) -> np.ndarray:
    """Rotation vector [rad] of ``current * previous^-1`` (quaternions x, y, z, w), in the fixed (device) frame.

    scipy returns the shorter way round, so q and -q give the same result.
    """
    return (Rotation.from_quat(current) * Rotation.from_quat(previous).inv()).as_rotvec()


class TwistEstimator:
    """Linear [m/s] and angular [rad/s] velocity of the device, in the device frame.

    Each update differentiates the pose against the previous one and passes the result through a first-order
    low-pass filter with cutoff ``cutoff_frequency`` [Hz], which removes the quantisation noise that raw
    1 kHz differences of an encoder-based position carry.
    """

    def __init__(self, cutoff_frequency: float):
        if not (math.isfinite(cutoff_frequency) and cutoff_frequency > 0.0):
            raise ValueError(f"twist cutoff frequency must be a positive number of Hz, got {cutoff_frequency}")
        self._time_constant = 1.0 / (2.0 * math.pi * cutoff_frequency)
        self.reset()

    def reset(self) -> None:
        """Forgets the previous pose (after a gap in the data); the next twist is zero."""
        self._previous: Optional[Tuple[float, np.ndarray, np.ndarray]] = None
        self._linear = np.zeros(3)
        self._angular = np.zeros(3)

    def update(self, time: float, position: np.ndarray, orientation: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
        """Feeds the pose taken at ``time`` [s]; returns the filtered (linear, angular) velocity."""
        if self._previous is not None:
            previous_time, previous_position, previous_orientation = self._previous
            step = time - previous_time
            if step <= 0.0:
                # Same instant again (e.g. simulated time not advanced yet): nothing new to differentiate.
                return self._linear.copy(), self._angular.copy()
            linear = (position - previous_position) / step
            angular = rotation_vector_between(previous_orientation, orientation) / step
            weight = step / (step + self._time_constant)
            self._linear += weight * (linear - self._linear)
            self._angular += weight * (angular - self._angular)
        self._previous = (time, np.array(position, dtype=float), np.array(orientation, dtype=float))
        return self._linear.copy(), self._angular.copy()
