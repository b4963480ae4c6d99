"""Joint trajectory position controller (ros_control's position_controllers/JointTrajectoryController semantics).

A new trajectory replaces the current one from the current setpoint: linear interpolation between points given by
positions only, cubic Hermite when velocities are given; after the last point the controller holds it.
"""

import numpy as np

from teleteach.control.impedance import JointCommand, RobotState
from teleteach.core.validation import InvalidCommandError


class JointTrajectoryController:
    """Follows joint trajectories and holds the last point."""

    type = "position_controllers/JointTrajectoryController"
    hardware_interface = "hardware_interface::PositionJointInterface"

    def __init__(self):
        self._times = np.zeros(1)
        self._positions = np.zeros((1, 7))
        self._velocities = np.zeros((1, 7))
        self._cubic = False

    def starting(self, state: RobotState):
        """Bumpless start: hold the current joint positions."""
        self.hold(state.q, state.time)

    def hold(self, positions, now):
        """Replace any trajectory by holding positions [rad] from now [s]."""
        self._times = np.array([now])
        self._positions = np.array([positions], dtype=float)
        self._velocities = np.zeros((1, 7))
        self._cubic = False

    def set_trajectory(self, start_time, times_from_start, positions, velocities, now):
        """Replace the trajectory (validated positions/velocities in joint order; times relative to start_time [s]).

        Points already in the past are dropped; the trajectory starts from the current setpoint at now.

        Raises:
            InvalidCommandError: the whole trajectory lies in the past.
        """
        times = start_time + np.asarray(times_from_start, dtype=float)
        future = times > now
        if not np.any(future):
            raise InvalidCommandError(f"trajectory ends in the past ({times[-1] - now:+.3f} s)")
        current_position, current_velocity = self.sample(now)
        self._times = np.concatenate([[now], times[future]])
        self._positions = np.vstack([current_position, np.asarray(positions)[future]])
        self._cubic = velocities is not None
        if self._cubic:
            self._velocities = np.vstack([current_velocity, np.asarray(velocities)[future]])
        else:
            self._velocities = np.zeros_like(self._positions)

    @property
    def goal(self):
        """The last point of the trajectory [rad]."""
        return self._positions[-1].copy()

    @property
    def end_time(self):
        """When the last point is reached [s]."""
        return float(self._times[-1])

    def sample(self, now):
        """Setpoint (positions [rad], velocities [rad/s]) at time now [s]."""
        times = self._times
        if now >= times[-1] or len(times) == 1:
            return self._positions[-1].copy(), np.zeros(7)
        if now <= times[0]:
            return self._positions[0].copy(), self._velocities[0].copy()
        segment = int(np.searchsorted(times, now, side="right")) - 1
        duration = times[segment + 1] - times[segment]
        s = (now - times[segment]) / duration
        p0, p1 = self._positions[segment], self._positions[segment + 1]
        if not self._cubic:
            return p0 + s * (p1 - p0), (p1 - p0) / duration
        v0 = self._velocities[segment] * duration
        v1 = self._velocities[segment + 1] * duration
        h00, h10, h01, h11 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2, s**3 - s**2
        d00, d10, d01, d11 = 6 * s**2 - 6 * s, 3 * s**2 - 4 * s + 1, -6 * s**2 + 6 * s, 3 * s**2 - 2 * s
        position = h00 * p0 + h10 * v0 + h01 * p1 + h11 * v1
        velocity = (d00 * p0 + d10 * v0 + d01 * p1 + d11 * v1) / duration
        return position, velocity

    def update(self, state: RobotState) -> JointCommand:
        """Joint targets for this tick."""
        position, velocity = self.sample(state.time)
        return JointCommand(position=position, velocity=velocity)
