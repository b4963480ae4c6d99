"""Cartesian impedance control (thesis eq 5) with the safety features of franka_human_friendly_controllers.

tau = J^T (Lambda x_ddot_r - K e - D (J dq - x_dot_r)) + N (k_ns (q_ns - q) - 2 sqrt(k_ns) dq) + g(q) + C(q, dq) dq,
with the pose error e clipped per axis (attractor clipping), K and D filtered toward their targets each tick, the
torque rate limited, and the stiffness from the ellipsoid (eqs 1-4) with eq 7 or mass-aware damping. The reference
velocity x_dot_r and acceleration x_ddot_r are zero unless a fresh velocity came with the reference (x_ddot_r from
successive ones); a moving reference (shared control's plan) then obeys eq 5 in the tracking error,
Lambda e_ddot + D e_dot + K e = f_ext, instead of lagging by D/K and by Lambda x_ddot_r / K.
"""

import math
from dataclasses import dataclass, field
from typing import Callable, Optional

import numpy as np
import scipy.linalg

from teleteach.control import stiffness as ellipsoid

UNIT_MASS = "unit_mass"
MASS_AWARE = "mass_aware"
DAMPING_KINDS = (UNIT_MASS, MASS_AWARE)
FILTER_DONE = 1e-6  # [N/m, Ns/m, ...] gains this close to their targets count as arrived


@dataclass
class RobotState:
    """What a controller reads each tick, in base_link.

    Attributes:
        time: simulated time [s].
        q: arm joint positions [rad] (7).
        dq: arm joint velocities [rad/s] (7).
        position: TCP position [m].
        quaternion: TCP orientation (x, y, z, w).
        jacobian: 6x7 TCP Jacobian (linear rows first).
        model_torque: g(q) + C(q, dq) dq [Nm] (7).
        mass_matrix: returns the 7x7 joint-space inertia [kg m^2]; called only when a controller needs it.
    """

    time: float
    q: np.ndarray
    dq: np.ndarray
    position: np.ndarray
    quaternion: np.ndarray
    jacobian: np.ndarray
    model_torque: np.ndarray
    mass_matrix: Callable[[], np.ndarray] = field(repr=False, default=None)


@dataclass
class JointCommand:
    """A controller's output: joint torques [Nm] (effort) or joint targets [rad] with velocities [rad/s]."""

    effort: Optional[np.ndarray] = None
    position: Optional[np.ndarray] = None
    velocity: Optional[np.ndarray] = None


@dataclass
class ImpedanceParams:
    """Gains and limits of the Cartesian impedance controller, each set and documented in config/controllers.yaml."""

    rotational_stiffness: float
    max_stiffness: float
    initial_eigenvalues: tuple
    damping: str
    translational_damping_ratio: float
    rotational_damping_ratio: float
    nullspace_stiffness: float
    max_position_error: float
    max_orientation_error: float
    stiffness_filter: float
    max_torque_step: float
    model_update_period: int
    reference_velocity_timeout: float
    max_reference_acceleration: float

    def __post_init__(self):
        if self.damping not in DAMPING_KINDS:
            raise ValueError(f"damping must be one of {DAMPING_KINDS}, got '{self.damping}'")
        if not 0.0 < self.stiffness_filter <= 1.0:
            raise ValueError("stiffness_filter must be in (0, 1]")
        if self.model_update_period < 1:
            raise ValueError("model_update_period must be >= 1 tick")
        if not self.reference_velocity_timeout >= 0.0:
            raise ValueError("reference_velocity_timeout must be >= 0 s")
        if not self.max_reference_acceleration >= 0.0:
            raise ValueError("max_reference_acceleration must be >= 0")


def orientation_error(quaternion, reference):
    """Axis-angle vector [rad] of the rotation from reference to quaternion, in the base frame (both x, y, z, w)."""
    x, y, z, w = quaternion
    rx, ry, rz, rw = reference
    if x * rx + y * ry + z * rz + w * rw < 0.0:
        x, y, z, w = -x, -y, -z, -w
    # q * conj(q_ref)
    ex = -w * rx + x * rw - y * rz + z * ry
    ey = -w * ry + x * rz + y * rw - z * rx
    ez = -w * rz - x * ry + y * rx + z * rw
    ew = w * rw + x * rx + y * ry + z * rz
    sine = math.sqrt(ex * ex + ey * ey + ez * ez)
    if sine < 1e-12:
        return np.array([2.0 * ex, 2.0 * ey, 2.0 * ez])
    scale = 2.0 * math.atan2(sine, ew) / sine
    return np.array([ex * scale, ey * scale, ez * scale])


class CartesianImpedanceController:
    """The impedance law; commands arrive already validated (teleteach.core.validation).

    Args:
        params: gains and limits.
    """

    type = "teleteach/CartesianImpedanceController"
    hardware_interface = "hardware_interface::EffortJointInterface"

    def __init__(self, params: ImpedanceParams):
        self.params = params
        self._ratios = np.array([params.translational_damping_ratio] * 3 + [params.rotational_damping_ratio] * 3)
        self._error_limit = np.array([params.max_position_error] * 3 + [params.max_orientation_error] * 3)
        self._negative_error_limit = -self._error_limit
        self._nullspace_damping = 2.0 * math.sqrt(params.nullspace_stiffness)
        self.set_stiffness(params.initial_eigenvalues, np.eye(3))
        # No reference velocity yet: none counts as fresh, so its velocity and acceleration are never read
        self.reference_velocity_time = -math.inf

    def set_stiffness(self, eigenvalues, eigenvectors):
        """New ellipsoid: principal stiffnesses [N/m] and principal axes (quaternion or 3x3); K filters toward it."""
        self.eigenvalues = ellipsoid.clamp_eigenvalues(eigenvalues, self.params.max_stiffness)
        self.eigenvectors = ellipsoid.as_rotation(eigenvectors)
        self.stiffness_target = ellipsoid.stiffness_matrix(
            self.eigenvalues, self.eigenvectors, self.params.rotational_stiffness
        )
        if self.params.damping == UNIT_MASS:
            self.damping_target = ellipsoid.damping_unit_mass(self.stiffness_target, self._ratios)
        self._filtering = True

    def set_equilibrium(self, position, quaternion):
        """New reference pose x_r in base_link (position [m], unit quaternion x, y, z, w)."""
        self.equilibrium_position = np.array(position, dtype=float)
        self.equilibrium_quaternion = np.array(quaternion, dtype=float)

    def set_reference_velocity(self, linear, angular, time):
        """Velocity x_dot_r of the reference in base_link (linear [m/s], angular [rad/s]), valid at ``time`` [s].

        It is used for ``reference_velocity_timeout`` after ``time``, then counts as zero, so a reference that comes
        without one (e.g. a trajectory player) is held as before. The reference acceleration is the difference of
        two velocities that arrive within that time, its norm capped at ``max_reference_acceleration``.
        """
        velocity = np.concatenate((np.asarray(linear, dtype=float), np.asarray(angular, dtype=float)))
        elapsed = float(time) - self.reference_velocity_time
        if 0.0 < elapsed <= self.params.reference_velocity_timeout:
            acceleration = (velocity - self.reference_velocity) / elapsed
            # A jump of the reference velocity (a mode change, a missed cycle) must not become a force impulse.
            limit = self.params.max_reference_acceleration
            for part in (acceleration[:3], acceleration[3:]):
                norm = float(np.linalg.norm(part))
                if norm > limit:
                    part *= limit / norm
            self.reference_acceleration = acceleration
        else:
            self.reference_acceleration = np.zeros(6)
        self.reference_velocity = velocity
        self.reference_velocity_time = float(time)

    def _reference_motion(self, now):
        """(x_dot_r, x_ddot_r) while the reference velocity is fresh, else zeros."""
        if now - self.reference_velocity_time <= self.params.reference_velocity_timeout:
            return self.reference_velocity, self.reference_acceleration
        return np.zeros(6), np.zeros(6)

    def starting(self, state: RobotState):
        """Bumpless start: hold the current pose and posture, gains already at their targets, torque = model.

        The pose, posture, model and gains exist from here on: an update before it (which the controller manager
        never does) fails instead of pulling the arm toward a made-up pose.
        """
        self.set_equilibrium(state.position, state.quaternion)
        self.nullspace_posture = state.q.copy()
        self._update_model(state)
        self.stiffness = self.stiffness_target.copy()
        self.damping = self.damping_target.copy()
        self._filtering = False
        self.last_torque = state.model_torque.copy()
        self._ticks = 0

    def _update_model(self, state):
        jacobian = state.jacobian
        self.nullspace_projector = np.eye(7) - jacobian.T @ np.linalg.solve(
            jacobian @ jacobian.T + 1e-6 * np.eye(6), jacobian
        )
        inertia = ellipsoid.cartesian_inertia_blocks(jacobian, state.mass_matrix())
        self.cartesian_inertia = scipy.linalg.block_diag(*inertia)
        if self.params.damping == MASS_AWARE:
            self.damping_target = ellipsoid.damping_mass_aware(self.stiffness_target, inertia, self._ratios)

    def update(self, state: RobotState) -> JointCommand:
        """One control tick: joint torques [Nm] for the state."""
        params = self.params
        self._ticks += 1
        if self._ticks % params.model_update_period == 0:
            self._update_model(state)
            self._check_filter()
        # Pose error, clipped per axis so a far reference pulls with a bounded force (attractor clipping)
        error = np.concatenate(
            (
                state.position - self.equilibrium_position,
                orientation_error(state.quaternion, self.equilibrium_quaternion),
            )
        )
        error = np.minimum(np.maximum(error, self._negative_error_limit), self._error_limit)
        # Cartesian spring-damper (eq 5): the arm is pushed with -(K e + D (x_dot - x_dot_r))
        reference_velocity, reference_acceleration = self._reference_motion(state.time)
        velocity_error = state.jacobian @ state.dq - reference_velocity
        spring_damper = (
            self.stiffness @ error + self.damping @ velocity_error - self.cartesian_inertia @ reference_acceleration
        )
        # Posture spring in the nullspace of the task
        nullspace = self.nullspace_projector @ (
            params.nullspace_stiffness * (self.nullspace_posture - state.q) - self._nullspace_damping * state.dq
        )
        # Gravity and Coriolis from the model
        torque = nullspace + state.model_torque - state.jacobian.T @ spring_damper
        # Saturate the torque rate to avoid discontinuities
        step = params.max_torque_step
        torque = self.last_torque + np.minimum(np.maximum(torque - self.last_torque, -step), step)
        self.last_torque = torque
        # Filter the gains toward their targets (until they arrive)
        if self._filtering:
            rate = params.stiffness_filter
            self.stiffness += rate * (self.stiffness_target - self.stiffness)
            self.damping += rate * (self.damping_target - self.damping)
        return JointCommand(effort=torque)

    def _check_filter(self):
        """Snap the gains onto their targets once they are there, so converged ticks skip the filter."""
        if (
            np.max(np.abs(self.stiffness_target - self.stiffness)) < FILTER_DONE
            and np.max(np.abs(self.damping_target - self.damping)) < FILTER_DONE
        ):
            self.stiffness[:] = self.stiffness_target
            self.damping[:] = self.damping_target
            self._filtering = False
        else:
            self._filtering = True
