"""Device velocity from successive poses: finite differences, low-pass filtered (the one place it is computed)."""

import collections
import math
from typing import Deque, Optional, Tuple

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


class StampOnWall:
    """The stamp clock (ROS time) as a smooth function of the wall clock, for a hand that moves on the wall clock.

    Under a simulation ROS time advances in /clock ticks (10 ms) that reach a loaded process late and unevenly: a tick
    held back 90 ms, then the next at once. Differentiated over those stamps, a hand's steady motion came out as spikes
    (a drawn wave's 0.07 m/s as 0.4 m/s), and the shared controller named the wave but left it to the operator. The
    stamp returned here advances at the pace of the line through the last ``WINDOW`` seconds of (wall, stamp) pairs and
    drifts onto that line over ``CATCH_UP`` seconds, so the speed is the one the stamps mean (the hand's displacement
    per simulated second, as the robot sees it) without the ticks' jitter. With ROS on the wall clock it is the clock.
    """

    WINDOW = 1.0  # [s] of wall time the line is fitted over: many ticks, short against a change of pace
    SPACING = 0.005  # [s] of wall time between two kept pairs: ROS on the wall clock changes at every read
    CATCH_UP = 0.5  # [s] of wall time to close a gap between the stamp returned and the line (a refit moves it)

    def __init__(self) -> None:
        self._pairs: Deque[Tuple[float, float]] = collections.deque()
        self._line: Optional[Tuple[float, float, float]] = None  # (wall of reference, stamp there, slope)
        self._last: Optional[Tuple[float, float]] = None  # (wall, stamp returned) of the last call

    def __call__(self, wall: float, stamp: float) -> float:
        """The stamp at ``wall`` [s]: ``stamp`` itself until the line has three pairs, then smooth, never decreasing."""
        pairs = self._pairs
        if pairs and stamp < pairs[-1][1]:
            pairs.clear()  # the clock went back (a simulation started again): a new line
            self._line, self._last = None, None
        if not pairs or (stamp != pairs[-1][1] and wall - pairs[-1][0] >= self.SPACING):
            pairs.append((wall, stamp))
            while pairs[0][0] < wall - self.WINDOW:
                pairs.popleft()
            if len(pairs) >= 3:
                walls, stamps = np.array(pairs).T
                slope, at_wall = np.polyfit(walls - wall, stamps, 1)
                self._line = (wall, at_wall, slope)
        if self._line is None or self._last is None:
            moment = stamp
        else:
            reference, at_reference, slope = self._line
            previous_wall, previous = self._last
            step = wall - previous_wall
            on_line = at_reference + slope * (wall - reference)
            moment = previous + slope * step + min(1.0, step / self.CATCH_UP) * (on_line - previous - slope * step)
            moment = max(previous, moment)
        self._last = (wall, moment)
        return moment
