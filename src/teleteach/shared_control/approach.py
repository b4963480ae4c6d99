"""Taking the arm to the task plane when shared control is switched on, without a jump of its reference.

The MPC works in the task plane, inside the boundary; the arm may be anywhere when the operator opens SHARED CONTROL.
Starting the MPC where the arm is (its projection, moved inside the boundary) and moving the reference there from
the arm's pose along a minimum-jerk path keeps the impedance controller's spring short: a step of the reference by
10 cm at 1500 N/m would pull with 150 N.
"""

import dataclasses
from typing import Sequence, Tuple

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from teleteach.core.trajectories import MINIMUM_JERK_PEAK, minimum_jerk, minimum_jerk_rate
from teleteach.shared_control.constraints import Box


def start_in_plane(plane_point: Sequence[float], box: Box, margin: float) -> np.ndarray:
    """The task-plane point nearest ``plane_point`` that is ``margin`` inside ``box`` [m]."""
    low = np.array([box.x_min, box.y_min]) + margin
    high = np.array([box.x_max, box.y_max]) - margin
    return np.clip(np.asarray(plane_point, dtype=float), low, np.maximum(low, high))


@dataclasses.dataclass
class Approach:
    """A minimum-jerk move of the reference pose from ``start`` to ``goal`` over ``duration`` [s].

    Positions [m] and xyzw quaternions in base_link.
    """

    start_position: np.ndarray
    start_orientation: np.ndarray
    goal_position: np.ndarray
    goal_orientation: np.ndarray
    duration: float

    def __post_init__(self):
        for name in ("start_position", "start_orientation", "goal_position", "goal_orientation"):
            value = np.asarray(getattr(self, name), dtype=float)
            if not np.all(np.isfinite(value)):
                raise ValueError(f"{name} must be finite, got {value}")
            setattr(self, name, value)
        if not self.duration > 0.0:
            raise ValueError(f"duration must be > 0 s, got {self.duration}")
        rotations = Rotation.from_quat([self.start_orientation, self.goal_orientation])
        self._slerp = Slerp([0.0, 1.0], rotations)

    @classmethod
    def at_most(cls, start_position, start_orientation, goal_position, goal_orientation, speed, turn_rate):
        """The approach whose peak speed is ``speed`` [m/s] and peak turn rate ``turn_rate`` [rad/s].

        A minimum-jerk move peaks at MINIMUM_JERK_PEAK (15/8) times its mean speed; the approach takes at least a tenth
        of a second.
        """
        distance = float(np.linalg.norm(np.subtract(goal_position, start_position)))
        angle = (Rotation.from_quat(start_orientation).inv() * Rotation.from_quat(goal_orientation)).magnitude()
        duration = max(MINIMUM_JERK_PEAK * distance / speed, MINIMUM_JERK_PEAK * angle / turn_rate, 0.1)
        return cls(start_position, start_orientation, goal_position, goal_orientation, duration)

    def at(self, elapsed: float) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(position, orientation, linear velocity [m/s]) ``elapsed`` seconds after the start (held at the goal)."""
        progress = minimum_jerk(elapsed / self.duration)
        rate = minimum_jerk_rate(elapsed / self.duration) / self.duration
        offset = self.goal_position - self.start_position
        return self.start_position + progress * offset, self._slerp(progress).as_quat(), rate * offset

    def done(self, elapsed: float) -> bool:
        """Whether the reference has arrived."""
        return elapsed >= self.duration
