"""Discrete dynamic movement primitives: Euclidean (thesis eqs C.1-C.5) and geometry-aware on SPD matrices (C.6-C.7).

Both share the canonical system tau x' = -alpha_x x (C.3, integrated exactly: x = exp(-alpha_x t / tau)) and the
forcing term f(x) = sum_i w_i Psi_i(x) / sum_i Psi_i(x) * x (C.4) with Gaussian basis functions
Psi_i = exp(-h_i (x - c_i)^2) (C.5) whose centres are equally spaced in time. Weights are fitted by ridge-regularised
least squares over all samples at once (:class:`Regression`; a global fit is more accurate than per-kernel locally
weighted regression at the same N, and just as fast). beta_z = alpha_z / 4 (critical damping).

The SPD DMP (Abu-Dakka & Kyrki 2020) keeps its velocity sigma as a Mandel vector in the tangent space at the start
X_1, so that it can be integrated like a Euclidean state:

    tau sigma' = alpha_z (beta_z vec(B_X->X1(Log_X(X_g))) - sigma) + F(x)       (C.6)
    X <- Exp_X(dt / tau * B_X1->X(mat(sigma)))                                   (C.7, one step)

Every step ends in an exponential map, so every state is SPD by construction. Goal switching moves the goal along
the geodesic towards the new goal with tau g' = alpha_g Log_g(g_new) (and g' = alpha_g (g_new - g) / tau in R^n),
so the attractor changes smoothly and the state converges to the new goal.
"""

import dataclasses
from typing import Any, Dict, Optional, Tuple

import numpy as np
import scipy.linalg
import scipy.sparse

from teleteach.learning import spd


@dataclasses.dataclass
class DMPParameters:
    """Gains and basis of a DMP (the gains, width and ridge: config/learning.yaml, the one place of their values).

    For skills, :class:`teleteach.learning.skill.LearningParameters` sets N from the demonstration's duration.

    Attributes:
        basis_count: N, number of Gaussian basis functions (eq C.4).
        alpha_z: spring gain of the transformation system (eq C.1); beta_z = alpha_z / 4.
        alpha_x: decay of the canonical system (eq C.3): x(tau) = exp(-alpha_x).
        width: standard deviation of each Gaussian as a fraction of the spacing of the centres.
        ridge: Tikhonov regularisation of the weight fit, relative to the mean diagonal of the normal matrix.
        alpha_goal: gain of the goal filter used for goal switching.
    """

    basis_count: int
    alpha_z: float
    alpha_x: float
    width: float
    ridge: float
    alpha_goal: float

    def __post_init__(self):
        if int(self.basis_count) < 2:
            raise ValueError(f"basis_count must be >= 2, got {self.basis_count}")
        for name in ("alpha_z", "alpha_x", "width", "alpha_goal"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be finite and > 0, got {value}")
        if not (np.isfinite(self.ridge) and self.ridge > 0):
            raise ValueError(f"ridge must be finite and > 0, got {self.ridge}")
        self.basis_count = int(self.basis_count)

    @classmethod
    def from_yaml(cls, basis_count: int, **changes: float) -> "DMPParameters":
        """``basis_count`` functions, config/learning.yaml's gains, width and ridge, and ``changes``."""
        from teleteach.core.paths import config_values

        values = config_values("learning.yaml")
        names = ("alpha_z", "alpha_x", "width", "ridge", "alpha_goal")
        return cls(basis_count=basis_count, **{**{name: values[name] for name in names}, **changes})

    @property
    def beta_z(self) -> float:
        """Critical damping: beta_z = alpha_z / 4."""
        return self.alpha_z / 4.0


class Basis:
    """The normalised, phase-weighted Gaussian features of eq C.4, centres equally spaced in time.

    Each Gaussian is negligible (< exp(-32)) beyond 8 of its widths, so a sample only gets the features of the centres
    within a window of the nearest one: the feature matrix is sparse and banded, which keeps learning hundreds of
    basis functions from thousands of samples well under a second. The spacing of the centres in x shrinks by a
    constant factor from one to the next, so an early (wide) Gaussian spans more of the later centres: the window is
    the number of centres its 8 widths span, all of them for a wide basis of few functions, whose early Gaussians
    never fall below exp(-32) (20 functions 2 spacings wide: exp(-11)).
    """

    def __init__(self, parameters: DMPParameters):
        self.alpha_x = parameters.alpha_x
        self.count = parameters.basis_count
        self.centres = np.exp(-parameters.alpha_x * np.linspace(0.0, 1.0, self.count))
        spacing = np.abs(np.diff(self.centres))
        sigmas = parameters.width * np.append(spacing, spacing[-1])
        self.widths = 1.0 / (2.0 * sigmas**2)
        # c_i - c_(i+k) = sigma_i (1 - shrink^k) / ((1 - shrink) width): 8 sigma_i after k centres, or never
        shrink = np.exp(-parameters.alpha_x / (self.count - 1))
        reach = 1.0 - 8.0 * parameters.width * (1.0 - shrink)
        spanned = self.count if reach <= 0.0 else int(np.ceil(np.log(reach) / np.log(shrink)))
        self.window = min(spanned, self.count) + 2  # 2 more: the nearest centre is found by rounding

    def phase(self, times, tau: float):
        """Eq C.3 integrated: x(t) = exp(-alpha_x t / tau)."""
        return np.exp(-self.alpha_x * np.asarray(times, dtype=float) / tau)

    def features(self, phase) -> scipy.sparse.csr_matrix:
        """Rows Psi_i(x) x / sum_j Psi_j(x) for each phase value (eq C.4 without the weights), sparse."""
        phase = np.atleast_1d(np.asarray(phase, dtype=float))
        # the centres are equally spaced in log(x): the index of the nearest one, then its neighbours
        position = -np.log(np.maximum(phase, 1e-300)) / self.alpha_x * (self.count - 1)
        nearest = np.clip(np.round(position).astype(int), 0, self.count - 1)
        candidates = nearest[:, None] + np.arange(-self.window, self.window + 1)
        valid = (candidates >= 0) & (candidates < self.count)
        columns = np.clip(candidates, 0, self.count - 1)
        exponent = np.where(valid, -self.widths[columns] * (phase[:, None] - self.centres[columns]) ** 2, -np.inf)
        psi = np.exp(exponent - exponent.max(axis=1, keepdims=True))
        values = psi / psi.sum(axis=1, keepdims=True) * phase[:, None]
        rows = np.broadcast_to(np.arange(phase.size)[:, None], candidates.shape)
        return scipy.sparse.csr_matrix((values[valid], (rows[valid], columns[valid])), shape=(phase.size, self.count))


class Regression:
    """Ridge least squares W = argmin ||A W - F||^2 + lambda ||W||^2 for one design matrix A and many targets F.

    lambda is ``ridge`` times the mean diagonal of A^T A. The normal matrix is factorised once (Cholesky), so every
    DoF of every DMP learned from one demonstration shares the work.
    """

    def __init__(self, features: scipy.sparse.spmatrix, ridge: float):
        self.transposed = features.T.tocsr()
        normal = (self.transposed @ features).toarray()
        regulariser = ridge * max(float(np.mean(np.diag(normal))), 1e-300)
        self.factor = scipy.linalg.cho_factor(normal + regulariser * np.eye(normal.shape[0]))

    def fit(self, targets) -> np.ndarray:
        """Weights (N, dofs) for targets (n, dofs)."""
        return scipy.linalg.cho_solve(self.factor, self.transposed @ np.asarray(targets, dtype=float))


def uniform_step(times) -> float:
    """The step of a uniform time grid; raise ValueError if the grid is not uniform and increasing."""
    times = np.asarray(times, dtype=float)
    if times.ndim != 1 or times.size < 3:
        raise ValueError(f"a DMP needs at least 3 samples on a uniform grid, got {times.size}")
    steps = np.diff(times)
    step = float(np.mean(steps))
    if not step > 0 or np.abs(steps - step).max() > 1e-6 * step + 1e-9:
        raise ValueError("a DMP is learned from a uniform, increasing time grid (resample first)")
    return step


def demonstration_regression(times, parameters: DMPParameters) -> "Regression":
    """The regression of eq C.4's weights for a demonstration on ``times`` (tau = its duration)."""
    times = np.asarray(times, dtype=float)
    basis = Basis(parameters)
    return Regression(basis.features(basis.phase(times - times[0], float(times[-1] - times[0]))), parameters.ridge)


STABLE_STEP = 0.1
"""Largest alpha_z * h / tau of one integration step h: the semi-implicit Euler step of the spring-damper stays
accurate and stable well below 1 (it diverges from about 2); a rollout takes sub-steps to stay below this."""


def _rollout_grid(duration: float, dt: float, alpha_z: float):
    """Output times, the integration step and the number of integration steps per output step."""
    if not (np.isfinite(duration) and duration > 0):
        raise ValueError(f"duration must be finite and > 0, got {duration}")
    if not (np.isfinite(dt) and dt > 0):
        raise ValueError(f"time step must be finite and > 0, got {dt}")
    count = max(int(round(duration / dt)), 1)
    output_step = duration / count
    substeps = max(1, int(np.ceil(alpha_z * output_step / duration / STABLE_STEP)))
    return np.linspace(0.0, duration, count + 1), output_step / substeps, substeps


class _Primitive:
    """What a learned DMP stores (parameters, start, goal, start velocity, weights, duration) and its JSON form."""

    TYPE = ""

    def to_dict(self) -> Dict[str, Any]:
        """JSON-ready description that :meth:`from_dict` restores."""
        return {
            "type": self.TYPE,
            "parameters": dataclasses.asdict(self.parameters),
            "start": self.start.tolist(),
            "goal": self.goal.tolist(),
            "start_velocity": self.start_velocity.tolist(),
            "weights": self.weights.tolist(),
            "duration": self.duration,
        }

    @classmethod
    def from_dict(cls, data: Dict[str, Any]):
        """Inverse of :meth:`to_dict`."""
        return cls(
            DMPParameters(**data["parameters"]),
            data["start"],
            data["goal"],
            data["start_velocity"],
            data["weights"],
            data["duration"],
        )


class DMP(_Primitive):
    """A discrete DMP for a vector y in R^n (eqs C.1-C.5), one transformation system per DoF, one phase."""

    TYPE = "dmp"

    def __init__(self, parameters: DMPParameters, start, goal, start_velocity, weights, duration: float):
        self.parameters = parameters
        self.basis = Basis(parameters)
        self.start = np.asarray(start, dtype=float)
        self.goal = np.asarray(goal, dtype=float)
        self.start_velocity = np.asarray(start_velocity, dtype=float)
        self.weights = np.asarray(weights, dtype=float)
        self.duration = float(duration)

    @classmethod
    def learn(cls, times, trajectory, parameters: DMPParameters, regression=None) -> "DMP":
        """Fit the forcing term to a demonstration sampled on a uniform grid.

        Args:
            times: (n,) uniform, increasing [s].
            trajectory: (n, dofs) or (n,).
            parameters: gains and basis.
            regression: :func:`demonstration_regression` of ``times`` (made if None; pass it to share it).
        """
        times = np.asarray(times, dtype=float)
        trajectory = np.asarray(trajectory, dtype=float).reshape(times.shape[0], -1)
        dt = uniform_step(times)
        tau = float(times[-1] - times[0])
        velocity = np.gradient(trajectory, dt, axis=0)
        acceleration = np.gradient(velocity, dt, axis=0)
        goal = trajectory[-1]
        # Eq C.1-C.2 solved for f with z = tau y'
        target = tau**2 * acceleration - parameters.alpha_z * (parameters.beta_z * (goal - trajectory) - tau * velocity)
        regression = regression or demonstration_regression(times, parameters)
        weights = regression.fit(target)
        return cls(parameters, trajectory[0], goal, tau * velocity[0], weights, tau)

    def rollout(
        self,
        duration: Optional[float] = None,
        dt: float = 0.01,
        goal=None,
        switch: Optional[Tuple[float, Any]] = None,
    ):
        """Integrate eqs C.1-C.3 (semi-implicit Euler, sub-stepped for stability); return (times, trajectory (n, dofs)).

        Args:
            duration: tau of the reproduction [s] (the demonstration's if None).
            dt: integration step [s].
            goal: goal g (the demonstration's if None).
            switch: (time [s], new goal): from that time on the goal moves smoothly to the new goal.
        """
        tau = self.duration if duration is None else float(duration)
        parameters = self.parameters
        times, step, substeps = _rollout_grid(tau, dt, parameters.alpha_z)
        goal = self.goal.copy() if goal is None else np.asarray(goal, dtype=float).reshape(self.goal.shape)
        new_goal = None if switch is None else np.asarray(switch[1], dtype=float).reshape(self.goal.shape)
        fine_times = np.arange((times.size - 1) * substeps) * step
        forcing = self.basis.features(self.basis.phase(fine_times, tau)) @ self.weights
        position = self.start.copy()
        velocity = self.start_velocity.copy()
        trajectory = np.empty((times.size, position.size))
        trajectory[0] = position
        for index, now in enumerate(fine_times):
            acceleration = parameters.alpha_z * (parameters.beta_z * (goal - position) - velocity) + forcing[index]
            velocity = velocity + step / tau * acceleration
            position = position + step / tau * velocity
            if new_goal is not None and now >= switch[0]:
                goal = goal + step / tau * parameters.alpha_goal * (new_goal - goal)
            if (index + 1) % substeps == 0:
                trajectory[(index + 1) // substeps] = position
        return times, trajectory


class SPDDMP(_Primitive):
    """A geometry-aware DMP for a trajectory of SPD matrices (eqs C.6-C.7), m x m for any m (2 and 3 in use)."""

    TYPE = "spd_dmp"

    def __init__(self, parameters: DMPParameters, start, goal, start_velocity, weights, duration: float):
        self.parameters = parameters
        self.basis = Basis(parameters)
        self.start = spd.check_spd(start, "DMP start")
        self.goal = spd.check_spd(goal, "DMP goal")
        self.start_velocity = np.asarray(start_velocity, dtype=float)
        self.weights = np.asarray(weights, dtype=float)
        self.duration = float(duration)

    @classmethod
    def learn(cls, times, matrices, parameters: DMPParameters, regression=None) -> "SPDDMP":
        """Fit F(x) of eq C.6 to a demonstration of SPD matrices on a uniform grid.

        Velocities are central differences on the manifold, (Log_Xk(X_k+1) - Log_Xk(X_k-1)) / 2 dt, transported to
        the start X_1 and vectorised; accelerations are finite differences there (one common tangent space).
        ``regression`` as in :meth:`DMP.learn`.
        """
        times = np.asarray(times, dtype=float)
        matrices = spd.check_spd(matrices, "stiffness")
        if matrices.ndim != 3 or matrices.shape[0] != times.shape[0]:
            raise ValueError(f"need one matrix per time sample, got {matrices.shape} for {times.shape[0]} times")
        dt = uniform_step(times)
        tau = float(times[-1] - times[0])
        start, goal = matrices[0], matrices[-1]
        frames = spd.Frame(matrices)
        forward = frames.log(np.concatenate([matrices[1:], matrices[-2:-1]]))
        backward = frames.log(np.concatenate([matrices[1:2], matrices[:-1]]))
        tangent = (forward - backward) / (2.0 * dt)
        tangent[0] = forward[0] / dt
        tangent[-1] = -backward[-1] / dt
        to_start, _ = frames.transport_factors(start)
        velocity = spd.mandel(spd.congruent(to_start, tangent))
        attractor = spd.mandel(spd.congruent(to_start, frames.log(goal)))
        acceleration = np.gradient(velocity, dt, axis=0)
        # Eq C.6 solved for F with sigma = tau * velocity
        target = (
            tau**2 * acceleration
            + parameters.alpha_z * tau * velocity
            - parameters.alpha_z * parameters.beta_z * attractor
        )
        regression = regression or demonstration_regression(times, parameters)
        weights = regression.fit(target)
        return cls(parameters, start, goal, tau * velocity[0], weights, tau)

    def rollout(
        self,
        duration: Optional[float] = None,
        dt: float = 0.02,
        goal=None,
        switch: Optional[Tuple[float, Any]] = None,
    ):
        """Integrate eqs C.6-C.7 (sub-stepped like :meth:`DMP.rollout`); return (times, matrices (n, m, m)), all SPD.

        Args:
            duration: tau of the reproduction [s] (the demonstration's if None).
            dt: integration step [s].
            goal: goal SPD matrix X_g (the demonstration's if None).
            switch: (time [s], new goal SPD matrix): goal switching from that time on.
        """
        tau = self.duration if duration is None else float(duration)
        parameters = self.parameters
        times, step, substeps = _rollout_grid(tau, dt, parameters.alpha_z)
        goal = self.goal.copy() if goal is None else spd.check_spd(goal, "goal stiffness")
        if goal.shape != self.goal.shape:
            raise ValueError(f"goal must be {self.goal.shape[0]}x{self.goal.shape[1]}, got {goal.shape}")
        new_goal = None if switch is None else spd.check_spd(switch[1], "new goal stiffness").reshape(goal.shape)
        fine_times = np.arange((times.size - 1) * substeps) * step
        forcing = self.basis.features(self.basis.phase(fine_times, tau)) @ self.weights
        state = self.start.copy()
        sigma = self.start_velocity.copy()
        matrices = np.empty((times.size, *state.shape))
        matrices[0] = state
        for index, now in enumerate(fine_times):
            frame = spd.Frame(state)
            to_start, from_start = frame.transport_factors(self.start)
            attractor = spd.mandel(spd.congruent(to_start, frame.log(goal)))
            sigma = sigma + step / tau * (parameters.alpha_z * (parameters.beta_z * attractor - sigma) + forcing[index])
            state = frame.exp(spd.congruent(from_start, spd.unmandel(sigma)) * (step / tau))
            if new_goal is not None and now >= switch[0]:
                goal_frame = spd.Frame(goal)
                goal = goal_frame.exp(goal_frame.log(new_goal) * (step / tau * parameters.alpha_goal))
            if (index + 1) % substeps == 0:
                matrices[(index + 1) // substeps] = state
        return times, matrices
