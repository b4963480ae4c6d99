"""Smooth joint trajectories: minimum-jerk timing of point-to-point moves and of paths through IK waypoints."""

import math
from dataclasses import dataclass

import numpy as np

from teleteach.core.trajectories import MINIMUM_JERK_PEAK, minimum_jerk, minimum_jerk_rate


def move_duration(distance, peak_speed, min_duration):
    """Duration [s] of a minimum-jerk move over distance whose peak speed stays at or below peak_speed."""
    return max(float(min_duration), MINIMUM_JERK_PEAK * float(distance) / float(peak_speed))


@dataclass
class JointTrajectory:
    """Points of a joint trajectory: times from start [s] (N), positions [rad] (N, 7), velocities [rad/s] (N, 7)."""

    times: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray

    @property
    def duration(self):
        """Time of the last point [s]."""
        return float(self.times[-1])

    @property
    def goal(self):
        """The last point [rad]."""
        return self.positions[-1]


def _sample_times(duration, sample_period):
    count = max(2, math.ceil(duration / sample_period) + 1)
    return np.linspace(0.0, duration, count)


def point_to_point(start, goal, duration, sample_period):
    """Straight joint-space move from start to goal [rad] with a minimum-jerk profile."""
    start, goal = np.asarray(start, dtype=float), np.asarray(goal, dtype=float)
    times = _sample_times(duration, sample_period)
    phase, rate = minimum_jerk(times / duration), minimum_jerk_rate(times / duration)
    positions = start + np.outer(phase, goal - start)
    velocities = np.outer(rate / duration, goal - start)
    return JointTrajectory(times, positions, velocities)


def along_path(waypoints, duration, sample_period):
    """Minimum-jerk timing of a path given by joint waypoints [rad] equally spaced in the path parameter.

    The path parameter follows the minimum-jerk phase, so the move starts and ends at rest; between waypoints the
    joints are interpolated linearly (the waypoints are dense, the IK solutions of a straight TCP line).
    """
    waypoints = np.asarray(waypoints, dtype=float)
    segments = len(waypoints) - 1
    if segments < 1:
        raise ValueError("a path needs at least 2 waypoints")
    times = _sample_times(duration, sample_period)
    phase, rate = minimum_jerk(times / duration), minimum_jerk_rate(times / duration)
    position_on_path = phase * segments
    index = np.minimum(position_on_path.astype(int), segments - 1)
    within = (position_on_path - index)[:, None]
    slopes = waypoints[index + 1] - waypoints[index]
    positions = waypoints[index] + within * slopes
    velocities = slopes * (rate * segments / duration)[:, None]
    return JointTrajectory(times, positions, velocities)
