"""The two optimisation problems of skill-based shared control, built once and solved every cycle.

``SkillEstimation`` is eqs 7-8 for one skill over the window of operator commands; ``TrajectoryOptimisation`` is
eqs 9-10 for one skill over the horizon, with a box boundary and a straight-edge obstacle. Each class builds its
NLP in ``__init__`` from named casadi Functions and solves it with an explicit warm start and a return-status
check. Solvers (``SOLVERS``):

- ``fast``: estimation by a projected Levenberg-Marquardt method written as one casadi Function (a fixed number of
  iterations, no Python in the loop); trajectory optimisation by casadi's SQP (``sqpmethod``) with qpOASES and the
  objective's Hessian (convex QPs); everything evaluated by casadi's virtual machine.
- ``compiled``: the same, with every function compiled to a shared library, cached on disk (``cache.py``).
- ``ipopt``: the plain formulation, both problems as NLPs for IPOPT with default options (the benchmark's
  baseline).

Decision variables are theta / scale (scales from ``ParameterLayout``), so all are of order one.
"""

import contextlib
import dataclasses
import math
import os
import sys
import time
from typing import Optional

import casadi as ca
import numpy as np

from teleteach.shared_control import cache
from teleteach.shared_control.models import ParameterLayout, skill_state_and_control, state_trajectory

SOLVERS = ("fast", "compiled", "ipopt")
# Unit of the trajectory optimisation's slack variable [m], so that it is of order one like theta / scale.
SLACK_UNIT = 1e-3


@dataclasses.dataclass
class SolveResult:
    """Outcome of one solve.

    Attributes:
        theta: parameters at the solution (unscaled).
        cost: objective value at the solution.
        success: the solver reported success and the solution passed our own checks.
        status: solver return status (or our reason for rejecting the solution).
        iterations: solver iterations.
        time: wall time of the solve [s].
        lam_x: multipliers of the bounds (warm start of the next solve; None: no solver ran).
        lam_g: multipliers of the constraints (warm start of the next solve; None: no solver ran).
        cpu_time: CPU time of this thread during the solve [s] (what the paper reports; robust to machine load).
        slack: the trajectory optimisation's largest violation of its constraints [m] (0: eq. 9 was feasible).
    """

    theta: np.ndarray
    cost: float
    success: bool
    status: str
    iterations: int
    time: float
    lam_x: Optional[np.ndarray]
    lam_g: Optional[np.ndarray]
    cpu_time: float = 0.0
    slack: float = 0.0


@contextlib.contextmanager
def _quiet_stdout():
    """Silence C-level stdout (qpOASES prints its licence banner whenever a solver is built)."""
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "w") as devnull:
            os.dup2(devnull.fileno(), 1)
            yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)


def _sqp_options(max_iter: int, hessian: Optional[ca.Function]) -> dict:
    options = {
        "qpsol": "qpoases",
        "qpsol_options": {"printLevel": "none", "error_on_fail": False},
        "max_iter": max_iter,
        "print_header": False,
        "print_iteration": False,
        "print_status": False,
        "print_time": False,
        "error_on_fail": False,
    }
    if hessian is not None:
        options["hess_lag"] = hessian
    return options


def _make_solver(
    name: str, nlp: dict, solver: str, max_iter: int, cache_dir: Optional[str], hessian: Optional[ca.Function] = None
) -> ca.Function:
    """Build an nlpsol for ``nlp``: IPOPT with default options, or sqpmethod + qpOASES (compiled if asked)."""
    if solver not in SOLVERS:
        raise ValueError(f"unknown solver {solver!r}; choose one of {SOLVERS}")
    if solver == "ipopt":
        # Default IPOPT options; only its printing is silenced.
        return ca.nlpsol(name, "ipopt", nlp, {"print_time": False, "ipopt": {"print_level": 0, "sb": "yes"}})
    options = _sqp_options(max_iter, hessian)
    with _quiet_stdout():
        reference = ca.nlpsol(name, "sqpmethod", nlp, options)
    if solver == "fast":
        return reference
    library = cache.compiled_dependencies(reference, name, cache_dir)
    if hessian is not None:
        hessian = cache.compiled_function(hessian, cache_dir)
    with _quiet_stdout():
        return ca.nlpsol(name, "sqpmethod", library, _sqp_options(max_iter, hessian))


def _solve(solver: ca.Function, scale, x0, lbx, ubx, p, lbg, ubg, lam_x0, lam_g0) -> SolveResult:
    args = {"x0": x0 / scale, "lbx": lbx / scale, "ubx": ubx / scale, "p": p, "lbg": lbg, "ubg": ubg}
    if lam_x0 is not None:
        args["lam_x0"] = lam_x0
    if lam_g0 is not None:
        args["lam_g0"] = lam_g0
    start, cpu_start = time.perf_counter(), time.thread_time()
    out = solver(**args)
    elapsed, cpu = time.perf_counter() - start, time.thread_time() - cpu_start
    stats = solver.stats()
    z = np.asarray(out["x"], dtype=float).ravel()
    theta = z * scale
    success = bool(stats.get("success", False)) and bool(np.all(np.isfinite(theta)))
    return SolveResult(
        theta=theta,
        cost=float(out["f"]),
        success=success,
        status=str(stats.get("return_status", "unknown")),
        iterations=int(stats.get("iter_count", -1)),
        time=elapsed,
        lam_x=np.asarray(out["lam_x"], dtype=float).ravel(),
        lam_g=np.asarray(out["lam_g"], dtype=float).ravel(),
        cpu_time=cpu,
    )


def recency_weights(n_window: int, dt: float, half_life: float) -> np.ndarray:
    """Weight of each command of the window in the fit, oldest first, with a mean of 1 (uniform without a half-life)."""
    if half_life <= 0.0:
        return np.ones(n_window)
    ages = dt * np.arange(n_window - 1, -1, -1)
    weights = 0.5 ** (ages / half_life)
    return weights / weights.mean()


class SkillEstimation:
    """Skill estimation for one skill (eqs 7-8) over a window of n_window operator commands.

    epsilon_i(theta) = mean_k w_k ||v0 u(s_k; theta) - h_k||^2 + ||theta - theta_prev||^2_W + ||phi||^2_W_phi, with
    s_k = -v0 (n_window - 1 - k) dt (the newest command at s_c = 0) and theta within bounds. The recency weights
    w_k = 2^(-age_k / half_life), normalised to a mean of 1, let a new pattern outweigh the old one sooner after the
    operator changes it (all 1 without a half-life: the paper's uniform window). The alpha_c
    continuity constraint and the regularisation towards theta_prev are set per solve (relaxed on the first one);
    the curvature penalty (the paper's alternative R = ||phi||^2_W) always applies.

    Eq. 7 is a bound-constrained nonlinear least-squares problem: ``fast``/``compiled`` solve it with a projected
    Levenberg-Marquardt (Gauss-Newton) method on one casadi Function that returns residuals and their Jacobian;
    ``ipopt`` solves the same objective as a plain NLP.

    Args:
        layout: parameter layout of the skill.
        n_window: number of commands in the window.
        dt: command period [s].
        speed_scale: typical operator speed [m/s]; residuals are divided by it.
        solver: one of ``SOLVERS``.
        max_iter: iteration cap.
        cache_dir: folder of compiled code (``compiled``), default ``cache.cache_dir()``.
        recency_half_life: age at which a command counts half as much as the newest one in the fit [s] (0: all
            commands count the same).
    """

    def __init__(
        self,
        layout: ParameterLayout,
        n_window: int,
        dt: float,
        speed_scale: float,
        solver: str = "fast",
        max_iter: int = 15,
        cache_dir: Optional[str] = None,
        recency_half_life: float = 0.0,
    ):
        if solver not in SOLVERS:
            raise ValueError(f"unknown solver {solver!r}; choose one of {SOLVERS}")
        self.layout = layout
        self.n_window = n_window
        self.dt = dt
        self.speed_scale = speed_scale
        self.solver_name = solver
        self.max_iter = max_iter
        n = layout.n
        z = ca.SX.sym("z", n)
        commands = ca.SX.sym("h", 2, n_window)
        z_prev = ca.SX.sym("z_prev", n)
        root_weights = ca.SX.sym("root_w_reg", n)
        theta = z * ca.DM(layout.scale)
        s = ca.SX.sym("s")
        _, _, control = skill_state_and_control(layout, s, theta, 1.0)
        self.control = ca.Function("control", [s, z], [control], ["s", "z"], ["u"])
        v0 = theta[layout.i_v0]
        s_window = -v0 * dt * ca.DM(np.arange(n_window - 1, -1, -1)).T
        velocity = v0 * self.control.map(n_window)(s_window, z)
        root_recency = np.sqrt(recency_weights(n_window, dt, recency_half_life))
        fit_residuals = ca.vec((velocity - commands) * ca.repmat(ca.DM(root_recency).T, 2, 1)) / np.sqrt(n_window)
        name = f"estimation_{layout.skill.name}_{n_window}"
        self.fit = ca.Function(f"{name}_fit", [z, commands], [ca.sumsqr(fit_residuals)], ["z", "h"], ["fit"])
        if solver == "compiled":
            # The seeds' grid search maps it over hundreds of candidates (on the virtual machine: ~6 ms a grid).
            self.fit = cache.compiled_function(self.fit, cache_dir)
        self._mapped_fits = {}
        residuals = ca.vertcat(fit_residuals / speed_scale, root_weights * (z - z_prev))
        p = ca.vertcat(ca.vec(commands), z_prev, root_weights)
        if solver == "ipopt":
            nlp = {"x": z, "p": p, "f": ca.sumsqr(residuals)}
            self.solver = _make_solver(name, nlp, solver, max_iter, cache_dir)
            return
        self.solver = self._levenberg_marquardt_function(name, z, p, residuals, max_iter)
        if solver == "compiled":
            self.solver = cache.compiled_function(self.solver, cache_dir)

    @staticmethod
    def _levenberg_marquardt_function(name, z, p, residuals, n_iterations) -> ca.Function:
        """max_iter projected Levenberg-Marquardt iterations as one casadi Function (no Python in the loop).

        An iteration solves (J^T J + mu diag(J^T J)) dz = -J^T r over the free variables, projects z + dz on the
        bounds, and accepts it if the cost does not rise (then mu /= 10, else mu *= 10): the cost never increases,
        and the fixed iteration count bounds the solve time.
        """
        n = z.numel()
        lower, upper, free = ca.SX.sym("lower", n), ca.SX.sym("upper", n), ca.SX.sym("free", n)
        damping = ca.SX.sym("damping")
        cost = ca.sumsqr(residuals)
        jacobian = ca.jacobian(residuals, z)
        normal = jacobian.T @ jacobian
        gradient = free * (jacobian.T @ residuals)
        mask = ca.diag(free)
        system = mask @ (normal + damping * ca.diag(ca.diag(normal) + 1e-9)) @ mask + ca.diag(1 - free)
        step = -ca.solve(system, gradient)
        candidate = ca.fmin(ca.fmax(z + free * step, lower), upper)
        cost_function = ca.Function("cost", [z, p], [cost])
        candidate_cost = cost_function(candidate, p)
        accept = ca.logic_and(candidate_cost <= cost, candidate_cost == candidate_cost)
        z_next = ca.if_else(accept, candidate, z)
        damping_next = ca.if_else(accept, ca.fmax(damping / 10, 1e-9), ca.fmin(damping * 10, 1e8))
        moved = ca.mmax(ca.fabs(z_next - z)) > 1e-6
        iteration = ca.Function(f"{name}_iteration", [z, damping, p, lower, upper, free], [z_next, damping_next, moved])
        z0 = ca.MX.sym("z0", n)
        pm = ca.MX.sym("p", p.numel())
        lower_m, upper_m, free_m = ca.MX.sym("lower", n), ca.MX.sym("upper", n), ca.MX.sym("free", n)
        zk = ca.fmin(ca.fmax(z0, lower_m), upper_m)
        mu = ca.MX(1e-3)
        iterations = ca.MX(0)
        for _ in range(n_iterations):
            zk, mu, moved_k = iteration(zk, mu, pm, lower_m, upper_m, free_m)
            iterations = iterations + moved_k
        final_cost = cost_function(zk, pm)
        return ca.Function(
            name,
            [z0, pm, lower_m, upper_m, free_m],
            [zk, final_cost, iterations],
            ["z0", "p", "lower", "upper", "free"],
            ["z", "cost", "iterations"],
        )

    def solve(
        self,
        commands: np.ndarray,
        guess: np.ndarray,
        theta_prev: Optional[np.ndarray],
        weights: np.ndarray,
        alpha_c: Optional[float],
        curvature_weights: Optional[np.ndarray] = None,
        heading_tolerance: float = 0.0,
    ) -> SolveResult:
        """Estimate theta_hat from ``commands`` (n_window x 2 [m/s]).

        Args:
            commands: the window of operator commands, oldest first.
            guess: warm start (previous solution, shifted to the current s_c).
            theta_prev: regularisation target; None on the first iteration (relaxed).
            weights: diagonal of W_R (on theta / scale).
            alpha_c: required initial heading (previous trajectory optimisation); None relaxes it.
            heading_tolerance: allowed |alpha_c - alpha_c_prev| [rad] (0: the paper's equality).
            curvature_weights: diagonal weights always applied towards zero curvature (phi entries only).

        Returns:
            The result; ``cost`` is epsilon_i (eq. 8) in (m/s)^2, regularisation included.
        """
        commands = np.asarray(commands, dtype=float)
        if commands.shape != (self.n_window, 2):
            raise ValueError(f"commands must be {self.n_window} x 2, got {commands.shape}")
        layout = self.layout
        lower, upper = layout.lower.copy(), layout.upper.copy()
        if alpha_c is not None:
            lower[layout.i_alpha] = alpha_c - heading_tolerance
            upper[layout.i_alpha] = alpha_c + heading_tolerance
        target = np.zeros(layout.n)
        total_weights = np.zeros(layout.n)
        if theta_prev is not None:
            target = np.asarray(theta_prev, dtype=float) / layout.scale
            total_weights = np.asarray(weights, dtype=float).copy()
        if curvature_weights is not None:
            # Combine the two quadratic terms into one: w1 (z - a)^2 + w2 z^2 = (w1 + w2) (z - w1 a / (w1 + w2))^2 + c
            combined = total_weights + curvature_weights
            target = np.where(combined > 0, total_weights * target / np.maximum(combined, 1e-300), 0.0)
            total_weights = combined
        x0 = np.clip(guess, lower, upper)
        p = np.concatenate([commands.ravel(), target, np.sqrt(total_weights)])
        if self.solver_name == "ipopt":
            result = _solve(self.solver, layout.scale, x0, lower, upper, p, [], [], None, None)
        else:
            result = self._levenberg_marquardt(x0 / layout.scale, lower / layout.scale, upper / layout.scale, p)
        result.cost *= self.speed_scale**2
        return result

    def _levenberg_marquardt(self, z, lower, upper, p) -> SolveResult:
        start, cpu_start = time.perf_counter(), time.thread_time()
        free = (lower < upper).astype(float)
        z_out, cost, iterations = self.solver(z, p, lower, upper, free)
        elapsed, cpu = time.perf_counter() - start, time.thread_time() - cpu_start
        theta = z_out.full().ravel() * self.layout.scale
        cost = float(cost)
        iterations = int(float(iterations))
        success = bool(np.all(np.isfinite(theta))) and np.isfinite(cost)
        status = "Solve_Succeeded" if iterations < self.max_iter else "Maximum_Iterations_Exceeded"
        if not success:
            status = "Non_Finite_Solution"
        n = self.layout.n
        return SolveResult(theta, cost, success, status, iterations, elapsed, np.zeros(n), np.zeros(0), cpu)

    def fitting_error(self, theta: np.ndarray, commands: np.ndarray) -> float:
        """Mean squared velocity error of ``theta`` on ``commands`` (eq. 8 without regularisation) [(m/s)^2]."""
        return float(self.fit(theta / self.layout.scale, np.asarray(commands, dtype=float).T))

    def fitting_errors(self, thetas: np.ndarray, commands: np.ndarray) -> np.ndarray:
        """``fitting_error`` of each row of ``thetas`` (m x n) on the same commands, in one mapped call."""
        thetas = np.atleast_2d(np.asarray(thetas, dtype=float))
        mapped = self._mapped_fits.get(len(thetas))
        if mapped is None:
            mapped = self.fit.map(len(thetas), [False, True], [False])
            self._mapped_fits[len(thetas)] = mapped
        scaled = (thetas / self.layout.scale).T
        return np.asarray(mapped(scaled, np.asarray(commands, dtype=float).T), dtype=float).ravel()


def _kept_inside(future: ca.SX, box: ca.SX, obstacle: ca.SX, margin: ca.SX) -> ca.SX:
    """g_j >= 0 for each future state: inside the box shrunk by ``margin`` and on the edge's free side if active."""
    normal = ca.vertcat(ca.cos(obstacle[2]), ca.sin(obstacle[2]))
    distance = normal.T @ (future - obstacle[0:2])
    return ca.vertcat(
        ca.vec(future - box[0:2] - margin),
        ca.vec(box[2:4] - future - margin),
        ca.vec(obstacle[3] * (distance - margin)),
    )


def _objective_hessian(name: str, variables: ca.SX, p: ca.SX, weights: ca.SX, n_constraints: int) -> ca.Function:
    """The objective's Hessian only (constraint curvature left out): every QP is convex and qpOASES is reliable."""
    lam_f = ca.SX.sym("lam_f")
    lam_g = ca.SX.sym("lam_g", n_constraints)
    return ca.Function(
        f"{name}_hessian",
        [variables, p, lam_f, lam_g],
        [2 * lam_f * ca.diag(ca.vertcat(weights, 1)) + 1e-8 * ca.SX.eye(variables.numel()) + 0 * ca.sum1(lam_g)],
        ["x", "p", "lam_f", "lam_g"],
        ["hess_gamma_x_x"],
    )


class TrajectoryOptimisation:
    """Trajectory optimisation for one skill (eqs 9-10) over a horizon of n_horizon cycles, with soft constraints.

    min ||theta - theta_hat||^2_W + penalty t + t^2 s.t. g_j(theta) + t >= 0, t >= 0, where g_j >= 0 keeps x(s_j;
    theta) in the box shrunk by ``margin`` and on the free side of the straight edge, j = 1..n_horizon, with x(s_c)
    = x_c; s_j = j v0 dt. The obstacle is a line through (px, py) whose free side is along [cos yaw, sin yaw];
    d(x) = (x - p) . [cos yaw, sin yaw] >= margin when active.

    The one slack t [m] (in units of ``SLACK_UNIT``) is an exact L-infinity penalty: when a plan that keeps every
    constraint exists and ``penalty`` exceeds the constraints' multipliers, t = 0 and the solution is eq. 9's;
    when none exists (an operator pushing into the boundary, heading fixed into it), the problem stays feasible
    and returns the plan that violates least instead of exhausting its iterations (issue 31: 60 % FALLBACK at the
    boundary). Every warm start is feasible: t starts at the guess's own violation.

    Args:
        layout: parameter layout of the skill (Theta^TO bounds).
        n_horizon: number of horizon points after the current one.
        dt: cycle period [s].
        solver: one of ``SOLVERS``.
        max_iter: iteration cap of the SQP (real-time iteration: the last iterate is used when it is reached).
        penalty: cost of a violation of one ``SLACK_UNIT`` [-], against W_TO's cost on theta / scale.
        cache_dir: folder of compiled code (``sqp_compiled``).
    """

    def __init__(
        self,
        layout: ParameterLayout,
        n_horizon: int,
        dt: float,
        solver: str = "fast",
        max_iter: int = 15,
        penalty: float = 1e3,
        cache_dir: Optional[str] = None,
    ):
        self.layout = layout
        self.n_horizon = n_horizon
        self.dt = dt
        self.penalty = penalty
        n = layout.n
        # theta / scale, then the slack t / SLACK_UNIT
        z = ca.SX.sym("z", n)
        slack = ca.SX.sym("slack")
        theta_hat = ca.SX.sym("theta_hat", n)
        weights = ca.SX.sym("w_to", n)
        x_c = ca.SX.sym("x_c", 2)
        box = ca.SX.sym("box", 4)  # x_min, y_min, x_max, y_max [m]
        obstacle = ca.SX.sym("obstacle", 4)  # px, py [m], yaw [rad], active (0/1)
        margin = ca.SX.sym("margin")
        theta = z * ca.DM(layout.scale)
        horizon_s = theta[layout.i_v0] * dt * n_horizon
        states, headings = state_trajectory(layout, x_c, theta, horizon_s, n_horizon)
        name = f"trajectory_{layout.skill.name}_{n_horizon}"
        self.plan = ca.Function(f"{name}_plan", [z, x_c], [states, headings], ["z", "x_c"], ["x", "alpha"])
        if solver == "compiled":
            self.plan = cache.compiled_function(self.plan, cache_dir)
        hard = _kept_inside(states[:, 1:], box, obstacle, margin)
        self.violation = ca.Function(f"{name}_violation", [z, x_c, box, obstacle, margin], [ca.fmax(-ca.mmin(hard), 0)])
        if solver == "compiled":
            self.violation = cache.compiled_function(self.violation, cache_dir)
        constraints = hard + slack * SLACK_UNIT
        penalty_parameter = ca.SX.sym("penalty")
        objective = ca.dot(weights, (z - theta_hat / ca.DM(layout.scale)) ** 2) + penalty_parameter * slack + slack**2
        p = ca.vertcat(theta_hat, weights, x_c, box, obstacle, margin, penalty_parameter)
        self.n_constraints = constraints.numel()
        variables = ca.vertcat(z, slack)
        nlp = {"x": variables, "p": p, "f": objective, "g": constraints}
        hessian = _objective_hessian(name, variables, p, weights, self.n_constraints)
        self.solver = _make_solver(name, nlp, solver, max_iter, cache_dir, hessian)

    def solve(
        self,
        theta_hat: np.ndarray,
        weights: np.ndarray,
        x_c: np.ndarray,
        box: np.ndarray,
        obstacle: np.ndarray,
        margin: float,
        guess: np.ndarray,
        lam_x0: Optional[np.ndarray] = None,
        lam_g0: Optional[np.ndarray] = None,
    ) -> SolveResult:
        """Optimise theta* near theta_hat; alpha_c is fixed to theta_hat's (the paper's alpha_c = alpha_c_hat).

        Args:
            theta_hat: estimated parameters (eq. 7).
            weights: diagonal of W_TO (on theta / scale).
            x_c: current state [m].
            box: (x_min, y_min, x_max, y_max) [m].
            obstacle: (px [m], py [m], yaw [rad], active 0/1).
            margin: back-off from every constraint [m], so the executed state is inside with room to spare.
            guess: warm start (previous solution shifted, or theta_hat).
            lam_x0: bound multipliers of the previous solve.
            lam_g0: constraint multipliers of the previous solve.

        Returns:
            The result; ``slack`` is the plan's largest violation of the margin [m] (0 when eq. 9 was feasible).
        """
        layout = self.layout
        lower, upper = layout.lower.copy(), layout.upper.copy()
        lower[layout.i_alpha] = upper[layout.i_alpha] = theta_hat[layout.i_alpha]
        guess = np.clip(guess, lower, upper)
        # The warm start made feasible: its slack is its own violation.
        slack = float(self.violation(guess / layout.scale, x_c, box, obstacle, margin))
        x0 = np.append(guess, slack)
        scale = np.append(layout.scale, SLACK_UNIT)
        p = np.concatenate([theta_hat, weights, x_c, box, obstacle, [margin, self.penalty]])
        lbg = np.zeros(self.n_constraints)
        ubg = np.full(self.n_constraints, np.inf)
        result = _solve(
            self.solver, scale, x0, np.append(lower, 0.0), np.append(upper, np.inf), p, lbg, ubg, lam_x0, lam_g0
        )
        result.slack = float(result.theta[-1]) if np.isfinite(result.theta[-1]) else math.inf
        result.theta = result.theta[:-1]
        return result

    def states(self, theta: np.ndarray, x_c: np.ndarray):
        """Planned states (2 x (n_horizon + 1)) and headings of U for ``theta`` from ``x_c``."""
        x, alpha = self.plan(theta / self.layout.scale, x_c)
        return np.asarray(x, dtype=float), np.asarray(alpha, dtype=float).ravel()
