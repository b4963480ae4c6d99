"""Skill and underlying-trajectory models of skill-based shared control (Mower et al., RSS 2021, eqs 2-6).

A state trajectory is x(s; theta_i) = U + S_i U' (eq. 3) and its control u = U' + S_i' U' + S_i U'' (eq. 4), where s is
the spatial parameter of the underlying trajectory U (ds/dt = v0, eq. 2), U' = [cos a, sin a] is a Clothoid
(a' = phi0 + phi1 (s - s_c), eq. 6) and S_i = sigma_i R(omega_i) is a skill (eq. 5, Table I).

Here s is measured in metres along U (|U'| = 1) and v0 [m/s] is estimated with the other parameters, so the
model's velocity in time is dx/dt = v0 u(s). Every cycle restarts s at s_c = 0 at the current state.

Parameter vector of skill i (theta_i = (psi, rho_i), eq. 3), in this order:
``[phi0_1, phi1_1, ..., phi0_K, phi1_K, alpha_c, v0, rho_0, ..., rho_{m_i - 1}]`` for K Clothoid segments.

Skills are added in one place (``SKILLS``); Clothoid segments by ``ClothoidPath(n_segments)``.
"""

import dataclasses
import math
from typing import Callable, Dict, List, Sequence, Tuple

import casadi as ca
import numpy as np


@dataclasses.dataclass(frozen=True)
class SkillModel:
    """A skill S_i = sigma_i(s; rho) R(omega_i(s; rho)) (eq. 5) with its parameter bounds.

    Args:
        name: skill name, as published in the state message.
        sigma: scaling sigma_i(s, rho) [m] (casadi expression).
        omega: rotation angle omega_i(s, rho) [rad] (casadi expression).
        rho_names: names of rho's entries.
        rho_lower: lower bounds of rho.
        rho_upper: upper bounds of rho.
        rho_guess: initial guess of rho for the very first estimation.
        rho_scale: typical magnitude of each entry (the solvers work on theta / scale).
        phase_index: index of the phase entry of rho (wrapped to one period when s_c moves on).
        frequency_index: index of the spatial frequency entry of rho [1/m] (period = 1 / rho[frequency_index]).
        amplitude_index: index of the amplitude (or radius) entry of rho [m].
    """

    name: str
    sigma: Callable
    omega: Callable
    rho_names: Tuple[str, ...]
    rho_lower: Tuple[float, ...]
    rho_upper: Tuple[float, ...]
    rho_guess: Tuple[float, ...]
    rho_scale: Tuple[float, ...]
    phase_index: int
    frequency_index: int
    amplitude_index: int = 0

    def matrix(self, s, rho):
        """S_i(s; rho) as a 2x2 casadi matrix."""
        sigma = self.sigma(s, rho)
        omega = self.omega(s, rho)
        return sigma * ca.vertcat(ca.horzcat(ca.cos(omega), -ca.sin(omega)), ca.horzcat(ca.sin(omega), ca.cos(omega)))


def _wave_sigma(s, rho):
    return rho[0] * ca.sin(2 * math.pi * rho[1] * (s + rho[2]))


def _wave_omega(s, rho):
    return math.pi / 2 + 0 * s


def _cycloid_sigma(s, rho):
    return rho[0] + 0 * s


def _cycloid_omega(s, rho):
    return 2 * math.pi * rho[1] * (s + rho[2])


# Table I. Amplitude/radius rho_0 [m], spatial frequency rho_1 [1/m], phase rho_2 [m].
# The bounds are Theta^SE / Theta^TO for rho; the phase bound covers a period of the lowest frequency both ways.
SKILLS: Dict[str, SkillModel] = {
    "wave": SkillModel(
        name="wave",
        sigma=_wave_sigma,
        omega=_wave_omega,
        rho_names=("amplitude", "frequency", "phase"),
        rho_lower=(0.005, 5.0, -0.25),
        rho_upper=(0.1, 60.0, 0.25),
        rho_guess=(0.03, 20.0, 0.0),
        rho_scale=(0.03, 20.0, 0.05),
        phase_index=2,
        frequency_index=1,
    ),
    "cycloid": SkillModel(
        name="cycloid",
        sigma=_cycloid_sigma,
        omega=_cycloid_omega,
        rho_names=("radius", "frequency", "phase"),
        rho_lower=(0.005, 5.0, -0.25),
        rho_upper=(0.1, 60.0, 0.25),
        rho_guess=(0.03, 20.0, 0.0),
        rho_scale=(0.03, 20.0, 0.05),
        phase_index=2,
        frequency_index=1,
    ),
}


class ClothoidPath:
    """Underlying trajectory U made of Clothoid segments (eq. 6), integrated with RK4.

    Segment k covers s in [k L / K, (k + 1) L / K] of the horizon length L; the first segment extends backwards
    (the estimation window, s < 0) and the last one forwards. Heading and curvature are continuous across segments.

    Args:
        n_segments: number K of Clothoid segments (each adds phi0, phi1).
    """

    def __init__(self, n_segments: int):
        if n_segments < 1:
            raise ValueError(f"n_segments must be >= 1, got {n_segments}")
        self.n_segments = n_segments

    @property
    def psi_names(self) -> List[str]:
        """Names of psi's entries (curvature of each segment, initial heading, speed)."""
        names = []
        for k in range(self.n_segments):
            names += [f"phi0_{k}", f"phi1_{k}"]
        return [*names, "alpha_c", "v0"]

    def curvature(self, s, psi, length):
        """Curvature alpha'(s) [1/m]; segment k starts at s_k = k length / K (eq. 6b per segment)."""
        value = self.segment_curvature(0, s, psi, length)
        for k in range(1, self.n_segments):
            start = k * length / self.n_segments
            value = ca.if_else(s >= start, self.segment_curvature(k, s, psi, length), value)
        return value

    def segment_curvature(self, k, s, psi, length):
        """Curvature of segment k at s: phi0_k + phi1_k (s - s_k)."""
        return psi[2 * k] + psi[2 * k + 1] * (s - k * length / self.n_segments)

    def rk4(self, u0, alpha0, psi, length, n_steps):
        """Integrate (U, alpha)' = ([cos alpha, sin alpha], alpha') from s = 0 to length in n_steps RK4 steps.

        n_steps should be a multiple of the number of segments.

        Returns:
            (U, alpha): 2 x (n_steps + 1) positions and 1 x (n_steps + 1) headings at s_j = j length / n_steps.
        """
        h = length / n_steps

        def rhs(s, z):
            return ca.vertcat(ca.cos(z[2]), ca.sin(z[2]), self.segment_curvature(segment, s, psi, length))

        z = ca.vertcat(u0, alpha0)
        states = [z]
        for j in range(n_steps):
            s = j * h
            # Each step stays in one segment (steps and segments split the horizon evenly), so RK4 never
            # straddles the curvature jump between segments.
            segment = min(j * self.n_segments // n_steps, self.n_segments - 1)
            k1 = rhs(s, z)
            k2 = rhs(s + h / 2, z + h / 2 * k1)
            k3 = rhs(s + h / 2, z + h / 2 * k2)
            k4 = rhs(s + h, z + h * k3)
            z = z + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            states.append(z)
        trajectory = ca.horzcat(*states)
        return trajectory[0:2, :], trajectory[2, :]

    def heading(self, s, psi, length):
        """Closed-form heading alpha(s) with alpha(0) = alpha_c, valid for every s (negative s: first segment)."""
        alpha_c = psi[2 * self.n_segments]
        alpha = alpha_c + psi[0] * s + psi[1] * s**2 / 2
        for k in range(1, self.n_segments):
            start = k * length / self.n_segments
            previous_end = alpha_c + self._heading_change(psi, length, k)
            ds = s - start
            alpha = ca.if_else(s >= start, previous_end + psi[2 * k] * ds + psi[2 * k + 1] * ds**2 / 2, alpha)
        return alpha

    def _heading_change(self, psi, length, k):
        seg = length / self.n_segments
        return sum(psi[2 * j] * seg + psi[2 * j + 1] * seg**2 / 2 for j in range(k))


class ParameterLayout:
    """Where each entry of theta_i sits, with bounds and scales for one skill.

    Args:
        skill: the skill model.
        path: the underlying-trajectory model.
        curvature_bound: |phi0| bound [1/m].
        curvature_rate_bound: |phi1| bound [1/m^2].
        speed_bounds: (min, max) of v0 [m/s].
    """

    def __init__(
        self,
        skill: SkillModel,
        path: ClothoidPath,
        curvature_bound: float,
        curvature_rate_bound: float,
        speed_bounds: Tuple[float, float],
    ):
        self.skill = skill
        self.path = path
        self.names = path.psi_names + list(skill.rho_names)
        self.n = len(self.names)
        self.i_alpha = 2 * path.n_segments
        self.i_v0 = self.i_alpha + 1
        self.i_rho = self.i_v0 + 1
        lower, upper, scale = [], [], []
        for _ in range(path.n_segments):
            lower += [-curvature_bound, -curvature_rate_bound]
            upper += [curvature_bound, curvature_rate_bound]
            scale += [max(curvature_bound, 1e-3), max(curvature_rate_bound, 1e-3)]
        lower += [-np.inf, speed_bounds[0]]
        upper += [np.inf, speed_bounds[1]]
        scale += [1.0, max(speed_bounds[1], 1e-3) / 2]
        self.lower = np.array(lower + list(skill.rho_lower), dtype=float)
        self.upper = np.array(upper + list(skill.rho_upper), dtype=float)
        self.scale = np.array(scale + list(skill.rho_scale), dtype=float)

    def split(self, theta):
        """(psi, rho) of a parameter vector."""
        return theta[: self.i_rho], theta[self.i_rho :]

    def guess(self, alpha_c: float, v0: float) -> np.ndarray:
        """Straight-line initial guess with the skill's default rho."""
        theta = np.zeros(self.n)
        theta[self.i_alpha] = alpha_c
        theta[self.i_v0] = v0
        theta[self.i_rho :] = self.skill.rho_guess
        return np.clip(theta, self.lower, self.upper)

    def shift(self, theta: np.ndarray, ds: float, horizon_length: float) -> np.ndarray:
        """Re-express theta with s_c moved forward by ds (the next cycle), so x_new(s) = x_old(s + ds).

        The heading and curvature move along the first segment; the skill phase advances and is wrapped to one
        period around zero (sigma and omega are periodic in s with period 1 / frequency).
        """
        theta = np.array(theta, dtype=float)
        psi = theta[: self.i_rho]
        phi0, phi1 = psi[0], psi[1]
        theta[self.i_alpha] = psi[self.i_alpha] + phi0 * ds + phi1 * ds**2 / 2
        theta[0] = phi0 + phi1 * ds
        rho = theta[self.i_rho :]
        frequency = rho[self.skill.frequency_index]
        phase = rho[self.skill.phase_index] + ds
        if frequency > 0:
            period = 1.0 / frequency
            phase = (phase + period / 2) % period - period / 2
        theta[self.i_rho + self.skill.phase_index] = phase
        return theta


def skill_state_and_control(layout: ParameterLayout, s, theta, horizon_length):
    """Symbolic heading alpha(s), S_i(s), U'(s), u(s) (eq. 4) for one skill.

    Args:
        layout: parameter layout of the skill.
        s: scalar casadi symbol.
        theta: parameter vector (casadi).
        horizon_length: length L of the horizon in s (segments split it).

    Returns:
        (S, U', u): skill matrix, unit tangent and control at s.
    """
    psi, rho = layout.split(theta)
    alpha = layout.path.heading(s, psi, horizon_length)
    tangent = ca.vertcat(ca.cos(alpha), ca.sin(alpha))
    normal = ca.vertcat(-ca.sin(alpha), ca.cos(alpha))
    curvature = layout.path.curvature(s, psi, horizon_length)
    skill = layout.skill.matrix(s, rho)
    skill_derivative = ca.reshape(ca.jacobian(ca.vec(skill), s), 2, 2)
    control = tangent + skill_derivative @ tangent + skill @ (curvature * normal)
    return skill, tangent, control


def control_function(layout: ParameterLayout, horizon_length: float = 1.0) -> ca.Function:
    """Function u(s, theta) -> u (eq. 4), for checks and metrics.

    ``horizon_length`` [m] is the L that the Clothoid segments split (with one segment it changes nothing).
    """
    s = ca.SX.sym("s")
    theta = ca.SX.sym("theta", layout.n)
    _, _, control = skill_state_and_control(layout, s, theta, horizon_length)
    return ca.Function(f"u_{layout.skill.name}", [s, theta], [control], ["s", "theta"], ["u"])


def state_trajectory(layout: ParameterLayout, x_c, theta, horizon_s, n_points):
    """States x(s_j) = U + S_i U' (eq. 3) at s_j = j L / n_points, j = 0..n_points, with x(0) = x_c.

    U is integrated with RK4 from U_c = x_c - S_i(0) U'(0) (eq. 3 re-arranged). ``horizon_s`` is L (may depend
    on theta, e.g. v0 times the horizon duration).

    Returns:
        (x, alpha): 2 x (n_points + 1) states and 1 x (n_points + 1) headings of U.
    """
    psi, rho = layout.split(theta)
    alpha_c = psi[layout.i_alpha]
    tangent0 = ca.vertcat(ca.cos(alpha_c), ca.sin(alpha_c))
    u_c = x_c - layout.skill.matrix(0, rho) @ tangent0
    positions, headings = layout.path.rk4(u_c, alpha_c, psi, horizon_s, n_points)
    states = []
    h = horizon_s / n_points
    for j in range(n_points + 1):
        alpha = headings[j]
        tangent = ca.vertcat(ca.cos(alpha), ca.sin(alpha))
        states.append(positions[:, j] + layout.skill.matrix(j * h, rho) @ tangent)
    return ca.horzcat(*states), headings


def skill_names(skills: Sequence[str]) -> List[str]:
    """Validate skill names against ``SKILLS``."""
    unknown = [name for name in skills if name not in SKILLS]
    if unknown:
        raise ValueError(f"unknown skills {unknown}; known: {sorted(SKILLS)}")
    return list(skills)


def synthetic_commands(
    skill: str, rho: Sequence[float], heading: float, speed: float, times: np.ndarray, noise: float = 0.0, rng=None
) -> np.ndarray:
    """Operator commands h^r(t) = v0 u(v0 t) (eqs 2, 4) of a skill along a straight line, plus white noise.

    Args:
        skill: key of ``SKILLS``.
        rho: skill parameters.
        heading: direction of the underlying trajectory [rad].
        speed: v0 [m/s].
        times: sample times [s].
        noise: standard deviation of the added noise per axis [m/s].
        rng: numpy random generator (for the noise).

    Returns:
        len(times) x 2 commands [m/s].
    """
    layout = ParameterLayout(SKILLS[skill], ClothoidPath(1), 0.0, 0.0, (speed, speed))
    theta = np.zeros(layout.n)
    theta[layout.i_alpha] = heading
    theta[layout.i_v0] = speed
    theta[layout.i_rho :] = rho
    control = control_function(layout)
    times = np.asarray(times, dtype=float)
    velocities = speed * np.asarray(control.map(len(times))(speed * times[None, :], theta), dtype=float).T
    if noise > 0:
        rng = rng if rng is not None else np.random.default_rng()
        velocities = velocities + noise * rng.standard_normal(velocities.shape)
    return velocities
