"""Fitting metrics of the user study (eqs 11-12): how well recorded commands and positions follow a skill.

F_h = (1/T) min_theta sum_k ||v0 u(s(t_k); theta) - h_k||^2 and F_x = (1/T) min_theta sum_k ||x(s(t_k); theta) - x_k||^2
with s_c = 0, s(t) = v0 (t - t_0), zero Clothoid curvature (a straight underlying trajectory) and the other
parameters unconstrained. The fit is non-convex (frequency and phase), so a grid of starts is evaluated and the
best few are polished with IPOPT.
"""

import dataclasses
import math
from typing import List, Sequence

import casadi as ca
import numpy as np

from teleteach.shared_control.models import SKILLS


@dataclasses.dataclass
class Fit:
    """A metric value and the parameters that achieve it.

    Attributes:
        value: F_h [(m/s)^2 / s] or F_x [m^2 / s].
        skill: the skill model fitted.
        parameters: (alpha_c, v0, rho..., and for F_x the start U_c = (x, y)).
    """

    value: float
    skill: str
    parameters: List[float]


def _validate(times, values):
    times = np.asarray(times, dtype=float).ravel()
    values = np.asarray(values, dtype=float)
    if values.ndim != 2 or values.shape[1] != 2 or values.shape[0] != times.size:
        raise ValueError(f"need N times and N x 2 values, got {times.shape} and {values.shape}")
    if times.size < 3:
        raise ValueError("need at least 3 samples")
    if not (np.all(np.isfinite(times)) and np.all(np.isfinite(values))):
        raise ValueError("times and values must be finite")
    duration = float(times[-1] - times[0])
    if duration <= 0:
        raise ValueError("times must increase")
    return times - times[0], values, duration


def _model(skill_name: str, times: np.ndarray, positions: bool):
    """Symbolic model samples (2 x N) for parameters q = (alpha, v0, rho, [U_c])."""
    skill = SKILLS[skill_name]
    m = len(skill.rho_names)
    q = ca.SX.sym("q", 2 + m + (2 if positions else 0))
    alpha, v0, rho = q[0], q[1], q[2 : 2 + m]
    s = ca.SX.sym("s")
    tangent = ca.vertcat(ca.cos(alpha), ca.sin(alpha))
    matrix = skill.matrix(s, rho)
    if positions:
        value = q[2 + m :] + s * tangent + matrix @ tangent
    else:
        derivative = ca.reshape(ca.jacobian(ca.vec(matrix), s), 2, 2)
        value = v0 * (tangent + derivative @ tangent)  # U'' = 0 without curvature (eq. 4)
    sample = ca.Function("sample", [s, q], [value])
    return q, sample.map(times.size)(v0 * ca.DM(times).T, q)


def _dominant_frequency(times: np.ndarray, values: np.ndarray) -> float:
    """Strongest temporal frequency [Hz] of the samples after removing a straight-line trend."""
    uniform = np.linspace(times[0], times[-1], times.size)
    resampled = np.column_stack([np.interp(uniform, times, values[:, k]) for k in range(2)])
    design = np.column_stack([np.ones_like(uniform), uniform])
    trend = design @ np.linalg.lstsq(design, resampled, rcond=None)[0]
    spectrum = np.abs(np.fft.rfft(resampled - trend, axis=0)) ** 2
    frequencies = np.fft.rfftfreq(uniform.size, uniform[1] - uniform[0])
    power = spectrum.sum(axis=1)
    power[0] = 0.0
    return float(frequencies[int(np.argmax(power))]) if power.max() > 0 else 1.0


def fit_metric(skill: str, times: Sequence[float], values: np.ndarray, positions: bool, n_polish: int = 2) -> Fit:
    """F_x (``positions``) or F_h of ``values`` (N x 2) at ``times`` [s] for one skill."""
    times, values, duration = _validate(times, values)
    q, model = _model(skill, times, positions)
    objective = ca.sumsqr(model - ca.DM(values.T)) / duration
    evaluate = ca.Function("objective", [q], [objective])
    solver = ca.nlpsol(
        "fit", "ipopt", {"x": q, "f": objective}, {"print_time": False, "ipopt": {"print_level": 0, "sb": "yes"}}
    )
    model_skill = SKILLS[skill]
    if positions:
        travel = values[-1] - values[0]
        start = values[0]
    else:
        travel = values.mean(axis=0) * duration
        start = np.zeros(2)
    alpha = math.atan2(travel[1], travel[0])
    v0 = max(float(np.linalg.norm(travel)) / duration, 1e-3)
    starts = []
    for frequency in _dominant_frequency(times, values) / v0 * np.array([0.8, 0.9, 1.0, 1.1, 1.25]):
        for fraction in np.arange(8) / 8:
            rho = np.array(model_skill.rho_guess, dtype=float)
            rho[model_skill.frequency_index] = frequency
            rho[model_skill.phase_index] = fraction / frequency
            guess = [alpha, v0, *rho] + ([*start] if positions else [])
            starts.append(np.array(guess))
    ranked = sorted(starts, key=lambda g: float(evaluate(g)))
    best = Fit(math.inf, skill, [])
    for guess in ranked[:n_polish]:
        result = solver(x0=guess)
        value = float(result["f"])
        if np.isfinite(value) and value < best.value:
            best = Fit(value, skill, np.asarray(result["x"], dtype=float).ravel().tolist())
    if not math.isfinite(best.value):
        guess = ranked[0]
        best = Fit(float(evaluate(guess)), skill, guess.tolist())
    return best


def command_fit(skill: str, times: Sequence[float], commands: np.ndarray) -> Fit:
    """F_h (eq. 11) of operator commands h^r [m/s]."""
    return fit_metric(skill, times, commands, positions=False)


def position_fit(skill: str, times: Sequence[float], positions: np.ndarray) -> Fit:
    """F_x (eq. 12) of positions x^r [m]."""
    return fit_metric(skill, times, positions, positions=True)
