"""The shared-control MPC loop (Fig. 2): direct control for the first window, then estimate, identify, optimise.

Each 50 Hz cycle takes one operator command h^r (velocity in the task plane [m/s]) and returns the executed state
and a ``SharedControlRecord`` with the fields of teleteach/SharedControlState. The loop never raises on bad input
and never outputs a state outside the boundary or on the obstacle's side: when an optimisation fails or its plan
is infeasible it falls back (previous plan, hold, nearest free point) and says so in the record.
"""

import collections
import dataclasses
import enum
import itertools
import math
import time
from typing import Deque, Dict, List, Optional, Sequence, Tuple

import numpy as np
import yaml

from teleteach.core.parameters import from_mapping
from teleteach.core.paths import config_file
from teleteach.core.rotations import wrap_angle
from teleteach.shared_control import constraints
from teleteach.shared_control.constraints import Box, StraightEdge
from teleteach.shared_control.models import SKILLS, ClothoidPath, ParameterLayout, control_function, skill_names
from teleteach.shared_control.problems import SkillEstimation, SolveResult, TrajectoryOptimisation


class Mode(enum.IntEnum):
    """Who drove a cycle; the values of teleteach/SharedControlState's mode constants."""

    DIRECT = 0  # the operator alone, while the first window fills
    SHARED = 1  # the plan of the recognised skill (blended with the operator's step by its authority)
    FALLBACK = 2  # an optimisation failed or its plan was infeasible: the previous plan, hold or the nearest free point
    UNKNOWN = 3  # no skill explains the commands: the operator's step, kept inside the constraints


DIRECT, SHARED, FALLBACK, UNKNOWN = Mode
MODE_NAMES = {mode: mode.name for mode in Mode}

# A box so large that it never binds: the default when no boundary is given [m].
UNBOUNDED = Box(-1e3, -1e3, 1e3, 1e3)


@dataclasses.dataclass
class SharedControlConfig:
    """Parameters of the shared controller (units in brackets).

    Attributes:
        dt: cycle period [s] (50 Hz).
        window_time: t_w, duration of the estimation window [s].
        horizon_time: duration of the trajectory-optimisation horizon [s].
        skills: skill names, keys of ``models.SKILLS``.
        n_segments: Clothoid segments of the underlying trajectory.
        estimation_curvature_bound: |phi0| bound in estimation [1/m] (tight bounds keep skills apart).
        estimation_curvature_rate_bound: |phi1| bound in estimation [1/m^2].
        optimisation_curvature_bound: |phi0| bound in trajectory optimisation [1/m] (room to bend around obstacles).
        optimisation_curvature_rate_bound: |phi1| bound in trajectory optimisation [1/m^2].
        speed_bounds: (min, max) of v0 [m/s].
        heading_continuity: allowed change of alpha_c per cycle [rad]. 0 is the paper's equality alpha_c =
            alpha_c_prev: a heading error then grows through the extrapolated curvature (measured: ~1 rad of drift
            in 14 s of noisy input). pi or more: every skill fits the heading its window asks for (warm-started from
            its previous estimate; a fresh seed starts at the followed skill's), which a person's path needs: it
            turns faster than the estimation's Clothoid may bend (docs/reference.md, *Operators nobody tuned to*).
        speed_scale: typical operator speed [m/s] (scales the fitting residuals).
        max_command_speed: commands faster than this are clipped [m/s] (an executed step is no faster than the
            fastest command of the window: ``SharedControl._paced``).
        idle_speed: when the RMS command speed over a full window is below this, the operator is idle: the window
            restarts (direct control for t_w again), so estimation starts afresh when they move again; commands
            slower than this before the first move are left out of the window [m/s].
        regularisation_weights: W_R on (curvature, heading, speed, skill) of theta / scale [-].
        curvature_weight: always-on penalty on phi / scale in estimation [-].
        optimisation_weights: W_TO on (curvature, heading, speed, skill) of theta / scale [-].
        margin: back-off from every constraint inside the optimisation [m].
        recovery_speed: a state outside the free region (an obstacle moved onto it, a boundary that excludes it)
            moves to the nearest free state at most this fast: the equilibrium never jumps [m/s].
        constraint_penalty: cost of each millimetre by which the plan violates the margin (exact penalty on the
            trajectory optimisation's slack), against W_TO's cost on theta / scale [1/mm].
        solver: "compiled" (cached shared libraries), "fast" (casadi virtual machine) or "ipopt" (plain baseline).
        skip_feasible_optimisation: take theta* = theta_hat without solving eq. 9 when theta_hat's plan already
            keeps the margin (it is then the exact minimiser); False solves eq. 9 every cycle.
        max_iterations_estimation: iteration cap of each skill estimation [-].
        max_iterations_optimisation: iteration cap of the trajectory optimisation [-].
        cache_dir: folder of compiled code (None: ``cache.cache_dir()``).
        switch_confidence: confidence (normalised margin of the fitting errors, ``identification_confidence``) a
            new best skill needs before it counts towards a switch [-].
        switch_hold: the new best skill must keep that confidence this long before the identification switches
            (hysteresis: noise around a crossing of the fitting errors does not flick the skill back and forth) [s].
        blend_authority: True: the executed step blends the plan and the operator's direct step by ``authority``
            (a pattern no skill explains stays the operator's, kept inside the constraints); False: the paper's
            behaviour, the plan always (``SharedControlConfig.paper()``).
        authority_confidence: confidence at and above which the margin between skills gives the plan full
            authority (below, authority falls in proportion) [-].
        authority_residual: (full, none): relative fitting error e_1 / mean |h|^2 of the identified skill below
            which the plan has full authority and above which the operator has it (linear between) [-].
        recency_half_life: age at which a command of the window counts half as much as the newest one in the fit
            (``problems.recency_weights``): after the operator changes pattern the new one outweighs the old sooner,
            while the whole window still damps noise (0: the paper's uniform window) [s].
        reseed_period: every this long, each skill's warm-started estimate is compared with a fresh grid seed and
            restarted from it when the seed fits better: after the operator changes pattern, the estimate of the
            new pattern's skill can sit in a local minimum fitted to the old one (0: never) [s].
        unknown_memory: how far back the identification looks for a pattern outside every skill (``_outside``) [s].
        unknown_switches: this many changes of the leading skill (the best fit, by ``switch_confidence``) within
            ``unknown_memory`` name the pattern UNKNOWN, the skill held, until the lead has stayed put that long: a
            pattern that is neither skill is fitted best by each in turn (0: never) [-].
        unknown_turn: the followed skill's underlying path turning more than this within ``unknown_memory`` names
            the pattern UNKNOWN: it loops on the spot, where every skill's pattern goes along a path (0: never) [rad].
    """

    dt: float
    window_time: float
    horizon_time: float
    skills: Tuple[str, ...]
    n_segments: int
    estimation_curvature_bound: float
    estimation_curvature_rate_bound: float
    optimisation_curvature_bound: float
    optimisation_curvature_rate_bound: float
    speed_bounds: Tuple[float, float]
    heading_continuity: float
    speed_scale: float
    max_command_speed: float
    idle_speed: float
    regularisation_weights: Tuple[float, float, float, float]
    curvature_weight: float
    optimisation_weights: Tuple[float, float, float, float]
    margin: float
    recovery_speed: float
    constraint_penalty: float
    solver: str
    skip_feasible_optimisation: bool
    max_iterations_estimation: int
    max_iterations_optimisation: int
    switch_confidence: float
    switch_hold: float
    reseed_period: float
    recency_half_life: float
    blend_authority: bool
    authority_confidence: float
    authority_residual: Tuple[float, float]
    unknown_memory: float
    unknown_switches: int
    unknown_turn: float
    cache_dir: Optional[str] = None

    @classmethod
    def paper(cls, **changes) -> "SharedControlConfig":
        """The RSS paper's controller: a 1 s window and the plan always in control (no blend, no UNKNOWN)."""
        paper = {"window_time": 1.0, "blend_authority": False, "recency_half_life": 0.0}
        return cls.from_yaml(**{**paper, **changes})

    @classmethod
    def from_yaml(cls, **changes) -> "SharedControlConfig":
        """The node's configuration of config/shared_control.yaml (the one place of the values), with ``changes``."""
        parameters = yaml.safe_load(config_file("shared_control.yaml").read_text())
        return dataclasses.replace(cls.from_parameters(parameters), **changes)

    @classmethod
    def from_parameters(cls, parameters: Dict[str, object]) -> "SharedControlConfig":
        """From the node's parameters (config/shared_control.yaml, with ``rate`` [Hz] instead of ``dt``).

        Each field must be there, so the yaml is the one place of the values; a missing one is a ValueError naming it.
        """
        if "rate" not in parameters:
            raise ValueError("config/shared_control.yaml: missing rate")
        fields = {field.name for field in dataclasses.fields(cls)}
        values = {name: value for name, value in parameters.items() if name in fields}  # the node reads the others
        values["dt"] = 1.0 / float(parameters["rate"])
        return from_mapping(cls, values, "config/shared_control.yaml", optional=("cache_dir",))

    @property
    def n_window(self) -> int:
        """Commands in the estimation window."""
        return max(int(round(self.window_time / self.dt)), 2)

    @property
    def n_horizon(self) -> int:
        """Points of the horizon after the current state."""
        return max(int(round(self.horizon_time / self.dt)), 1)


@dataclasses.dataclass
class SharedControlRecord:
    """One cycle, with the fields of teleteach/SharedControlState (plus the plan, for displays).

    Attributes:
        mode: DIRECT, SHARED, FALLBACK or UNKNOWN (no skill explains the commands: the operator's step, kept
            inside the constraints).
        skill: identified skill this cycle ("" in direct control).
        skills: all skills, in the order of fitting_errors.
        fitting_errors: epsilon_i of each skill (eq. 8) [(m/s)^2] (inf when its estimation failed).
        parameters: theta* of the identified skill.
        estimation_time: wall time of all skill estimations this cycle [s].
        optimisation_time: wall time of the trajectory optimisation [s].
        command: h^r used this cycle (x, y) [m/s].
        state: executed x (x, y) [m].
        message: what happened, in words.
        iterations: (estimation iterations summed over skills, optimisation iterations).
        cpu_times: CPU time of (all estimations, optimisation) [s] (load-independent, as the paper reports).
        plan: planned states (2 x (n_horizon + 1)) [m] as the robot follows them (a state in the margin stopped at
            the constraint, as an executed step is), empty in direct control.
        velocity: velocity of the executed state (x, y) [m/s]: the plan's at that state, else the direct step's
            (the impedance controller's x_dot_r, so the arm follows a moving reference without lag).
        confidence: ``identification_confidence`` of this cycle's fitting errors [-] (0 in direct control).
        authority: weight of the plan in the executed step (1: the plan, 0: the operator's direct step) [-].
        cycle: cycles since the controller was enabled (set by the node's ``CycleSchedule``).
        late_cycles: of these, cycles whose state was ready after the cycle's period (set by the node).
    """

    mode: int
    skill: str
    skills: List[str]
    fitting_errors: List[float]
    parameters: List[float]
    estimation_time: float
    optimisation_time: float
    command: Tuple[float, float]
    state: Tuple[float, float]
    message: str
    iterations: Tuple[int, int] = (0, 0)
    cpu_times: Tuple[float, float] = (0.0, 0.0)
    plan: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((2, 0)))
    velocity: Tuple[float, float] = (0.0, 0.0)
    confidence: float = 0.0
    authority: float = 0.0
    cycle: int = 0
    late_cycles: int = 0


def identification_confidence(errors: Sequence[float]) -> float:
    """Normalised margin (e_2 - e_1) / e_2 between the best and second-best fitting errors, in [0, 1].

    1: only one skill explains the commands; 0: two explain them equally well (or none could be fitted).
    """
    finite = np.sort(np.asarray([e for e in errors if math.isfinite(e)], dtype=float))
    if finite.size == 0:
        return 0.0
    if finite.size == 1 or finite[1] <= 0.0:
        return 1.0 if finite.size == 1 else 0.0
    return float((finite[1] - finite[0]) / finite[1])


def plan_velocity(plan: np.ndarray, dt: float, index: int) -> np.ndarray:
    """Velocity of a plan (2 x n states dt apart) at its ``index``-th state [m/s] (central difference inside)."""
    return np.gradient(plan, dt, axis=1)[:, index]


def _fit_error(result: SolveResult) -> float:
    """How badly an estimate explains the window: its cost, infinite when the estimation failed."""
    return result.cost if result.theta is not None and np.isfinite(result.cost) else math.inf


def _weights(layout: ParameterLayout, groups: Sequence[float]) -> np.ndarray:
    curvature, heading, speed, skill = groups
    weights = np.full(layout.n, float(skill))
    weights[: layout.i_alpha] = curvature
    weights[layout.i_alpha] = heading
    weights[layout.i_v0] = speed
    return weights


@dataclasses.dataclass
class CycleReport:
    """What one cycle has found so far: the facts its record carries, whether it ends shared, direct or in fallback."""

    command: np.ndarray
    notes: List[str]
    skills: List[str] = dataclasses.field(default_factory=list)
    errors: List[float] = dataclasses.field(default_factory=list)
    skill: str = ""
    parameters: List[float] = dataclasses.field(default_factory=list)
    estimation_time: float = 0.0
    optimisation_time: float = 0.0
    iterations: Tuple[int, int] = (0, 0)
    confidence: float = 0.0


class SharedControl:
    """Skill-based shared control MPC (the paper's Fig. 2), one ``step`` per cycle.

    Args:
        config: parameters.
        initial_state: x at start [m].
        box: boundary (None: unbounded).
    """

    def __init__(self, config: SharedControlConfig, initial_state: Sequence[float] = (0.0, 0.0), box: Box = None):
        self.config = config
        cfg = self.config
        self.skills = skill_names(cfg.skills)
        if not self.skills:
            raise ValueError("at least one skill is needed")
        path = ClothoidPath(cfg.n_segments)
        self.estimation_layouts: Dict[str, ParameterLayout] = {}
        self.optimisation_layouts: Dict[str, ParameterLayout] = {}
        self.estimations: Dict[str, SkillEstimation] = {}
        self.optimisations: Dict[str, TrajectoryOptimisation] = {}
        for name in self.skills:
            self._add_problems(name, path)
        self._controls: Dict[str, object] = {}  # u(s, theta) per skill, built when first asked (keep)
        self.box = UNBOUNDED
        self.obstacle: Optional[StraightEdge] = None
        if box is not None:
            self.set_boundary(box)
        self.reset(initial_state)

    def _add_problems(self, name: str, path: ClothoidPath) -> None:
        """Build the skill's estimation and optimisation problems, on layouts sharing scales, once at start."""
        cfg = self.config
        se = ParameterLayout(
            SKILLS[name],
            path,
            cfg.estimation_curvature_bound,
            cfg.estimation_curvature_rate_bound,
            cfg.speed_bounds,
        )
        to = ParameterLayout(
            SKILLS[name],
            path,
            cfg.optimisation_curvature_bound,
            cfg.optimisation_curvature_rate_bound,
            cfg.speed_bounds,
        )
        # Both layouts share scales, so theta / scale means the same in both problems.
        to.scale = se.scale
        self.estimation_layouts[name] = se
        self.optimisation_layouts[name] = to
        self.estimations[name] = SkillEstimation(
            se,
            cfg.n_window,
            cfg.dt,
            cfg.speed_scale,
            cfg.solver,
            cfg.max_iterations_estimation,
            cfg.cache_dir,
            cfg.recency_half_life,
        )
        self.optimisations[name] = TrajectoryOptimisation(
            to,
            cfg.n_horizon,
            cfg.dt,
            cfg.solver,
            cfg.max_iterations_optimisation,
            cfg.constraint_penalty,
            cfg.cache_dir,
        )

    # Environment -----------------------------------------------------------------------------------------------

    def set_boundary(self, box: Optional[Box]) -> None:
        """Use ``box`` as the boundary (None removes it)."""
        if box is not None and not isinstance(box, Box):
            raise TypeError(f"box must be a Box, got {type(box).__name__}")
        self.box = box or UNBOUNDED

    def set_obstacle(self, obstacle: Optional[StraightEdge]) -> None:
        """Use ``obstacle`` as the straight edge to stay clear of (None removes it)."""
        if obstacle is not None and not isinstance(obstacle, StraightEdge):
            raise TypeError(f"obstacle must be a StraightEdge, got {type(obstacle).__name__}")
        self.obstacle = obstacle

    # Loop ------------------------------------------------------------------------------------------------------

    def reset(self, initial_state: Sequence[float]) -> None:
        """Start again in direct control at ``initial_state`` [m]."""
        state = np.asarray(initial_state, dtype=float).reshape(2)
        if not np.all(np.isfinite(state)):
            raise ValueError(f"initial state must be finite, got {state}")
        self.state = state
        self.window = collections.deque(maxlen=self.config.n_window)
        self.estimates: Dict[str, Optional[np.ndarray]] = {name: None for name in self.skills}
        self.alpha_c: Optional[float] = None
        self.skill: Optional[str] = None
        self.theta_star: Optional[np.ndarray] = None
        self.lam = (None, None)
        self.plan = np.zeros((2, 0))
        self.plan_index = 0
        self._cpu = [0.0, 0.0]
        self._estimation_cycles = 0
        self._kept: Optional[Tuple[str, np.ndarray]] = None  # the pattern keep() goes on with, while it is called
        self._forget_identification()

    def _forget_identification(self) -> None:
        self.identified: Optional[str] = None
        self._candidate: Optional[str] = None
        self._candidate_cycles = 0
        self._leader: Optional[str] = None
        self._lead_changes: Deque[int] = collections.deque()  # estimation cycles at which the leading skill changed
        self._headings: Deque[float] = collections.deque()  # alpha_c of the recent cycles, unwrapped [rad]
        self._was_outside = False  # the last cycle's pattern was outside every skill

    def measure(self, state: Sequence[float]) -> None:
        """Take the robot's measured state [m] as x_c of the next cycle (ignored, not raised, when not finite)."""
        state = np.asarray(state, dtype=float).reshape(2)
        if np.all(np.isfinite(state)):
            self.state = state

    def step(self, command: Sequence[float]) -> SharedControlRecord:
        """One cycle: take the operator command h^r [m/s], return the record of the executed state."""
        cfg = self.config
        self._cpu = [0.0, 0.0]
        self._kept = None  # the operator commands again (keep sets it back after its own step)
        command, notes = self._sanitise(command)
        self.window.append(command)
        if len(self.window) < cfg.n_window:
            self._trim_idle_start()
        if len(self.window) == cfg.n_window and self._idle():
            self.window.clear()
            self.window.append(command)
            self._forget()
            self._forget_identification()
            self.plan, self.plan_index = np.zeros((2, 0)), 0
            notes.append("operator idle: estimation restarts")
        if constraints.violation(self.state, self.box, self.obstacle) > 0.0:
            return self._recover(CycleReport(command, notes))
        if len(self.window) < cfg.n_window:
            return self._direct(command, notes)
        try:
            return self._shared(command, notes)
        except Exception as error:  # the loop must keep the robot safe whatever a solver does
            self._forget()
            return self._fallback(CycleReport(command, [*notes, f"shared control error: {error}"]))

    def coast(self, command: Sequence[float]) -> SharedControlRecord:
        """A cycle without solving, for a loop that has fallen behind (the node's catch-up).

        The command joins the window, the state follows the previous plan (stopped at the constraints, as a solved
        step is; direct control while the window fills), and the estimates move on with it: the executed state keeps
        its speed and the window stays on the time grid however long a solve took. The estimates are kept, so the
        next solve goes on from them.
        """
        command, notes = self._sanitise(command)
        self.window.append(command)
        if constraints.violation(self.state, self.box, self.obstacle) > 0.0:
            return self._recover(CycleReport(command, notes))
        if len(self.window) < self.config.n_window:
            return self._direct(command, notes)
        report = CycleReport(command, notes, list(self.skills), skill=self.skill or "")
        if self.skill is None or self.plan_index + 1 >= self.plan.shape[1]:
            notes.append("late cycle: no plan to follow, holding")
            return self._record(FALLBACK, report, "; ".join(notes))
        self.plan_index += 1
        candidate = self.plan[:, self.plan_index]
        velocity = plan_velocity(self.plan, self.config.dt, self.plan_index)
        if constraints.violation(candidate, self.box, self.obstacle, self.config.margin) > 0.0:
            safe = self._safe_state(candidate)
            candidate = self.state if safe is None else safe
            velocity = (candidate - self.state) / self.config.dt
            notes.append("step stopped at the constraint")
        candidate, velocity, paced = self._paced(candidate, velocity)
        if paced:
            notes.append(paced)
        self.state = candidate
        self._advance({name: self._coasted(name) for name in self.skills}, self.theta_star)
        message = "; ".join([*notes, f"late cycle: following the previous plan ({self.skill})"])
        return self._record(SHARED, report, message, self.plan, velocity, 1.0)

    def keep(self) -> SharedControlRecord:
        """One cycle on the recognised pattern alone: the operator's hand is busy elsewhere (a wipe's clutch).

        The first cycle takes the identified skill's estimate (its pattern, phase, heading and speed) and straightens
        its underlying path; each cycle then commands what that estimate's operator would, v0 u(0, theta) (eqs 2,
        4), and moves it on by a cycle. So the plan goes on with the operator's pattern along the heading they had,
        constraints and all, without feeding its own predictions back into the estimation (extrapolating a bending
        path's curvature turned the pattern around within a second). Nothing identified: the command is zero
        (direct control holds). The next :meth:`step` gives the pattern back to the operator. The record says which.
        """
        kept = self._kept if self._kept is not None else self._pattern_to_keep()
        command = np.zeros(2)
        if kept is not None:
            skill, theta = kept
            layout = self.estimation_layouts[skill]
            if skill not in self._controls:
                self._controls[skill] = control_function(layout)
            speed = float(theta[layout.i_v0])
            command = speed * np.asarray(self._controls[skill](0.0, theta), dtype=float).ravel()
        record = self.step(command)
        if kept is not None:
            ds = speed * self.config.dt
            self._kept = (skill, layout.shift(theta, ds, speed * self.config.horizon_time))
            record.message = f"clutch: keeping the {skill}; {record.message}"
        else:
            record.message = f"clutch: no pattern recognised to keep; {record.message}"
        return record

    def _pattern_to_keep(self) -> Optional[Tuple[str, np.ndarray]]:
        """The identified skill and its estimate on a straight underlying path (curvatures zero), or None."""
        estimate = self.estimates.get(self.skill) if self.skill is not None else None
        if estimate is None or not np.all(np.isfinite(estimate)):
            return None
        theta = np.array(estimate, dtype=float)
        theta[: self.estimation_layouts[self.skill].i_alpha] = 0.0
        return self.skill, theta

    def _coasted(self, name: str) -> SolveResult:
        """The estimate of ``name`` as it stands, as if estimated again (it is shifted to the next s_c by _advance)."""
        theta = self.estimates[name]
        return SolveResult(theta, 0.0, theta is not None, "Coasted", 0, 0.0, None, None)

    def _trim_idle_start(self) -> None:
        """Drop the rest before the operator's first move, so the first estimate sees motion only.

        A window that starts with rest fits a skill to zeros; its heading is then arbitrary and can point against
        the operator (issue 15: 21 of 50 start timings went the wrong way).
        """
        while self.window and np.linalg.norm(self.window[0]) < self.config.idle_speed:
            self.window.popleft()

    def _idle(self) -> bool:
        return float(np.sqrt(np.mean(self._window_speeds() ** 2))) < self.config.idle_speed

    def _window_speeds(self) -> np.ndarray:
        """Speed of each command in the window [m/s]."""
        return np.linalg.norm(np.array(self.window).reshape(-1, 2), axis=1)

    def _sanitise(self, command) -> Tuple[np.ndarray, List[str]]:
        notes = []
        try:
            value = np.asarray(command, dtype=float).ravel()[:2]
            if value.shape != (2,):
                raise ValueError
        except (TypeError, ValueError):
            return np.zeros(2), [f"rejected malformed command {command!r}: used zero velocity"]
        if not np.all(np.isfinite(value)):
            return np.zeros(2), [f"rejected non-finite command {value.tolist()}: used zero velocity"]
        speed = float(np.linalg.norm(value))
        if speed > self.config.max_command_speed:
            value = value * (self.config.max_command_speed / speed)
            notes.append(f"command speed {speed:.3g} m/s clipped to {self.config.max_command_speed:.3g} m/s")
        return value, notes

    def _direct(self, command, notes) -> SharedControlRecord:
        """Direct control while the window fills: x += h^r dt, kept inside the constraints."""
        target = self.state + command * self.config.dt
        mode = DIRECT
        message = f"direct control ({len(self.window)}/{self.config.n_window} commands in the window)"
        if constraints.violation(target, self.box, self.obstacle) > 0:
            safe = self._safe_state(target)
            if safe is None:
                mode, message = FALLBACK, "no free state exists (obstacle covers the boundary): holding"
                safe = self.state
            else:
                message += "; stopped at the constraint"
            target = safe
        velocity = (target - self.state) / self.config.dt if mode == DIRECT else np.zeros(2)
        self.state = target
        return self._record(mode, CycleReport(command, notes), "; ".join([*notes, message]), velocity=velocity)

    def _shared(self, command, notes) -> SharedControlRecord:
        """A cycle with a full window: estimate each skill, identify the operator's, plan it, blend with the command."""
        commands = np.array(self.window)
        self._estimation_cycles += 1
        results, errors, report = self._estimate_skills(command, notes, commands)
        best = int(np.argmin(errors))
        if not np.isfinite(errors[best]):
            self._forget()
            notes.append("skill estimation failed for every skill")
            return self._fallback(report)
        confidence = identification_confidence(errors)
        if self._switch_pending(self.skills[best], confidence):
            best, confidence = self._reseed_identified(commands, results, errors, report)
        skill, outside = self._chosen_skill(self.skills[best], confidence, errors)
        result = self._optimise(skill, results[skill].theta)
        report.skill, report.parameters, report.confidence = skill, result.theta.tolist(), confidence
        report.optimisation_time, report.iterations = result.time, (report.iterations[0], result.iterations)
        plan = None
        if np.all(np.isfinite(result.theta)):
            plan, _ = self.optimisations[skill].states(result.theta, self.state)
        if plan is None or not np.all(np.isfinite(plan)):
            notes.append(f"trajectory optimisation {result.status} after {result.iterations} iterations: no plan")
            self.skill = None
            return self._fallback(report)
        message = self._plan_message(skill, result)
        step = self._step_in_margin(plan)
        if step is None:
            notes.append("no free state exists within the margin")
            self.skill = None
            return self._fallback(report)
        planned, planned_velocity, stopped = step
        if stopped:
            message += "; step stopped at the constraint"
        self.skill, self.theta_star, self.lam = skill, result.theta, (result.lam_x, result.lam_g)
        authority = 0.0 if outside else self._authority(errors[self.skills.index(skill)], confidence, commands)
        state, velocity = self._blend(planned, planned_velocity, command, authority)
        state, velocity, paced = self._paced(state, velocity)
        if paced:
            message += f"; {paced}"
        # The stored plan passes through the executed state, so a fallback continues from where the robot is.
        self.plan, self.plan_index = plan + (state - plan[:, 1])[:, None], 1
        self.state = state
        self._advance(results, result.theta)
        mode = SHARED if authority > 0.0 else UNKNOWN
        if outside:
            message += f"; {outside}: unknown pattern, operator's step"
        elif authority < 1.0:
            message += f"; authority {authority:.2f}" if authority > 0.0 else "; unknown pattern: operator's step"
        return self._record(mode, report, "; ".join([*notes, message]), plan, velocity, authority)

    def _estimate_skills(
        self, command, notes, commands: np.ndarray
    ) -> Tuple[Dict[str, SolveResult], List[float], CycleReport]:
        """Each skill's estimate on the window and its fit error, in the cycle's report, to identify the operator's."""
        errors, results = [], {}
        estimation_time, estimation_iterations = 0.0, 0
        for name in self.skills:
            result = self._estimate(name, commands)
            results[name] = result
            estimation_time += result.time
            self._cpu[0] += result.cpu_time
            estimation_iterations += max(result.iterations, 0)
            errors.append(_fit_error(result))
        report = CycleReport(command, notes, list(self.skills), errors, estimation_time=estimation_time)
        report.iterations = (estimation_iterations, 0)
        return results, errors, report

    def _reseed_identified(self, commands: np.ndarray, results, errors: List[float], report: CycleReport):
        """The best skill's index and the confidence after the identified skill is estimated again from a fresh seed.

        Before the identification leaves a skill, that skill's estimate gets a fresh seed: a local minimum of its warm
        start after the operator's pattern changed must not switch the skill back and forth.
        """
        current, previous = self.skills.index(self.identified), results[self.identified]
        result = results[self.identified] = self._reseeded(self.identified, commands, previous)
        report.estimation_time += result.time - previous.time
        self._cpu[0] += result.cpu_time - previous.cpu_time
        errors[current] = _fit_error(result)
        report.errors = list(errors)
        return int(np.argmin(errors)), identification_confidence(errors)

    def _optimise(self, skill: str, theta_hat: np.ndarray) -> SolveResult:
        """The skill's plan from the estimate, warm-started from the last plan's solution while the skill stays."""
        cfg = self.config
        layout = self.optimisation_layouts[skill]
        if skill == self.skill and self.theta_star is not None:
            guess, (lam_x, lam_g) = self.theta_star, self.lam
            guess = guess.copy()
            guess[layout.i_alpha] = theta_hat[layout.i_alpha]
        else:
            guess, lam_x, lam_g = theta_hat, None, None
        obstacle = self.obstacle.as_array() if self.obstacle is not None else constraints.INACTIVE_OBSTACLE
        optimisation = self.optimisations[skill]
        result = self._estimate_if_feasible(optimisation, theta_hat) if cfg.skip_feasible_optimisation else None
        if result is None:
            result = optimisation.solve(
                theta_hat,
                _weights(layout, cfg.optimisation_weights),
                self.state,
                self.box.as_array(),
                obstacle,
                cfg.margin,
                guess,
                lam_x,
                lam_g,
            )
        self._cpu[1] = result.cpu_time
        return result

    def _step_in_margin(self, plan: np.ndarray) -> Optional[Tuple[np.ndarray, np.ndarray, bool]]:
        """The plan's first step and its velocity, and whether it was stopped at the margin (None: no free state).

        A step entering the margin (only possible with slack) becomes the nearest point that keeps it, so every
        executed state keeps the margin the arm needs to lag without crossing.
        """
        cfg = self.config
        planned, planned_velocity = plan[:, 1], plan_velocity(plan, cfg.dt, 1)
        if constraints.violation(planned, self.box, self.obstacle, cfg.margin) > 0.0:
            safe = self._safe_state(planned)
            if safe is None:
                return None
            return safe, (safe - self.state) / cfg.dt, True
        return planned, planned_velocity, False

    def _plan_message(self, skill: str, result: SolveResult) -> str:
        """The cycle's line for the operator: the skill, and whether its plan is a last iterate or cuts the margin."""
        message, margin = f"shared control: {skill}", self.config.margin
        if not result.success:
            message += f" (optimisation {result.status} after {result.iterations} iterations: its last iterate)"
        if result.slack > 0.0:
            message += f"; no plan keeps the {1e3 * margin:.0f} mm margin: {1e3 * result.slack:.1f} mm into it"
        return message

    def _paced(self, target, velocity) -> Tuple[np.ndarray, np.ndarray, str]:
        """The step towards ``target`` no faster than the operator's fastest command in the window, and why if cut.

        A plan keeps the operator's pattern, not a pace of its own: a last iterate at the iteration cap can ask for
        far more (1.81 m/s measured at the boundary, where the operator moved at 0.1 m/s). The step is shortened
        along its line, so it stays in the free region (convex: box and half-plane) when its ends are.
        """
        dt = self.config.dt
        pace = float(np.max(self._window_speeds(), initial=0.0))
        step = float(np.linalg.norm(target - self.state))
        if step <= pace * dt:
            return np.array(target, dtype=float), np.array(velocity, dtype=float), ""
        target = self.state + (target - self.state) * (pace * dt / step)
        return target, (target - self.state) / dt, f"step of {step / dt:.2f} m/s paced to the operator's {pace:.2f} m/s"

    def _authority(self, error: float, confidence: float, commands: np.ndarray) -> float:
        """Weight of the plan: high when one skill explains the commands well and clearly better than the others."""
        cfg = self.config
        if not cfg.blend_authority:
            return 1.0
        energy = float(np.mean(np.sum(commands**2, axis=1)))
        residual = error / energy if energy > 0.0 else math.inf
        full, none = cfg.authority_residual
        fit = float(np.clip((none - residual) / (none - full), 0.0, 1.0))
        margin = (
            float(np.clip(confidence / cfg.authority_confidence, 0.0, 1.0)) if cfg.authority_confidence > 0 else 1.0
        )
        return fit * margin

    def _blend(self, planned, planned_velocity, command, authority: float) -> Tuple[np.ndarray, np.ndarray]:
        """Executed state and velocity: authority x the plan's next state + the rest x the operator's direct step.

        A blend that enters the margin moves to the nearest point that keeps it (as the plan's step does).
        """
        dt = self.config.dt
        if authority >= 1.0:
            return np.array(planned, dtype=float), np.asarray(planned_velocity, dtype=float)
        state = authority * planned + (1.0 - authority) * (self.state + command * dt)
        velocity = authority * planned_velocity + (1.0 - authority) * command
        if constraints.violation(state, self.box, self.obstacle, self.config.margin) > 0.0:
            safe = self._safe_state(state)
            state = np.array(planned, dtype=float) if safe is None else safe
            velocity = (state - self.state) / dt
        return state, velocity

    def _chosen_skill(self, best: str, confidence: float, errors) -> Tuple[str, str]:
        """The skill to plan this cycle, and why the pattern is outside every skill ("" if it is not).

        A pattern outside every skill switches no skill: the one identified is held.
        """
        outside = self._outside(best, confidence)
        if outside and self.identified:
            return self.identified, outside
        return self._identify(best, confidence, errors), outside

    def _outside(self, best: str, confidence: float) -> str:
        """Why the pattern is outside every skill ("" when it is not), from the identification's recent history.

        Each skill's fit explains one window; a pattern no skill has is still fitted best by one of them, so the
        window alone names a skill. Over successive windows it shows: a figure-eight or a zig-zag is fitted best by
        each skill in turn (``unknown_switches`` changes of the lead within ``unknown_memory``), a circle or a spiral
        drawn on the spot by a skill whose underlying path goes round (turning more than ``unknown_turn``). Both look
        back ``unknown_memory``, so the pattern stays UNKNOWN until neither has been seen for that long.
        """
        cfg = self.config
        if cfg.unknown_switches <= 0 and cfg.unknown_turn <= 0:
            return ""  # the rule is off (the default): no history kept on the 50 Hz path
        cycle, memory = self._estimation_cycles, int(round(cfg.unknown_memory / cfg.dt))
        if best != self._leader and (self._leader is None or confidence >= cfg.switch_confidence):
            if self._leader is not None:
                self._lead_changes.append(cycle)
            self._leader = best
        while self._lead_changes and self._lead_changes[0] <= cycle - memory:
            self._lead_changes.popleft()
        if self.alpha_c is not None:
            last = self._headings[-1] if self._headings else self.alpha_c
            self._headings.append(last + wrap_angle(self.alpha_c - last))
        while len(self._headings) > memory:
            self._headings.popleft()
        reason = ""
        if cfg.unknown_switches > 0 and len(self._lead_changes) >= cfg.unknown_switches:
            reason = f"{len(self._lead_changes)} changes of the best-fitting skill in {cfg.unknown_memory:.3g} s"
        elif cfg.unknown_turn > 0 and self._headings and np.ptp(self._headings) > cfg.unknown_turn:
            reason = f"underlying path turned {np.ptp(self._headings):.1f} rad in {cfg.unknown_memory:.3g} s"
        if reason and not self._was_outside:  # from here the skill is held: the one leading now
            self.identified, self._candidate, self._candidate_cycles = self._leader, None, 0
        self._was_outside = bool(reason)
        return reason

    def _switch_pending(self, best: str, confidence: float) -> bool:
        """True when ``best`` would count towards leaving the identified skill this cycle."""
        current = self.identified
        return current is not None and best != current and confidence >= self.config.switch_confidence

    def _identify(self, best: str, confidence: float, errors: Sequence[float]) -> str:
        """The skill to follow: ``best`` once it has kept ``switch_confidence`` for ``switch_hold`` (hysteresis)."""
        cfg = self.config
        current = self.identified
        if current is None or not math.isfinite(errors[self.skills.index(current)]):
            self.identified, self._candidate, self._candidate_cycles = best, None, 0
            return best
        if best == current or confidence < cfg.switch_confidence:
            self._candidate, self._candidate_cycles = None, 0
            return current
        self._candidate_cycles = self._candidate_cycles + 1 if best == self._candidate else 1
        self._candidate = best
        if self._candidate_cycles * cfg.dt >= cfg.switch_hold - 1e-9:
            self.identified, self._candidate, self._candidate_cycles = best, None, 0
        return self.identified

    def _estimate_if_feasible(self, optimisation: TrajectoryOptimisation, theta_hat) -> Optional[SolveResult]:
        """theta* = theta_hat when its plan already keeps the margin: then it is the exact minimiser of eq. 10."""
        start, cpu_start = time.perf_counter(), time.thread_time()
        plan, _ = optimisation.states(theta_hat, self.state)
        if constraints.violation(plan[:, 1:], self.box, self.obstacle, self.config.margin) > 0.0:
            return None
        elapsed, cpu = time.perf_counter() - start, time.thread_time() - cpu_start
        return SolveResult(theta_hat.copy(), 0.0, True, "Estimate_Feasible", 0, elapsed, None, None, cpu)

    def _estimate(self, name: str, commands: np.ndarray) -> SolveResult:
        cfg = self.config
        layout = self.estimation_layouts[name]
        estimation = self.estimations[name]
        previous = self.estimates[name]
        if previous is None:
            return self._fresh_estimate(name, commands, self.alpha_c)
        weights = _weights(layout, cfg.regularisation_weights)
        curvature = self._curvature_weights(layout)
        result = estimation.solve(
            commands, previous, previous, weights, self.alpha_c, curvature, cfg.heading_continuity
        )
        if self._reseed_due(name):
            result = self._reseeded(name, commands, result)
        return result

    def _reseeded(self, name: str, commands: np.ndarray, result: SolveResult) -> SolveResult:
        """``result``, or the estimate restarted from a fresh grid seed when that fits the window better."""
        if result.theta is None:
            return result
        cfg = self.config
        layout, estimation = self.estimation_layouts[name], self.estimations[name]
        seed = self._seed(name, commands, self.alpha_c)
        if estimation.fitting_error(seed, commands) >= estimation.fitting_error(result.theta, commands):
            return result
        curvature = self._curvature_weights(layout)
        weights = _weights(layout, cfg.regularisation_weights)
        reseeded = estimation.solve(commands, seed, seed, weights, self.alpha_c, curvature, cfg.heading_continuity)
        if reseeded.theta is not None and np.isfinite(reseeded.cost) and reseeded.cost < result.cost:
            reseeded.time += result.time
            reseeded.cpu_time += result.cpu_time
            return reseeded
        return result

    def _reseed_due(self, name: str) -> bool:
        """True once per reseed_period for each skill, the skills in turn (one grid search per cycle at most)."""
        period = int(round(self.config.reseed_period / self.config.dt))
        if period <= 0:
            return False
        return (self._estimation_cycles + self.skills.index(name) * period // len(self.skills)) % period == 0

    def window_fits(self, commands: np.ndarray) -> Dict[str, float]:
        """Each skill's fitting error on one window, fitted from a fresh grid seed with nothing from earlier cycles.

        What the window alone says, without continuity or hysteresis: ``bench/shared_control_identifiability.py``
        measures with it how often the best-fitting skill is the operator's.
        """
        commands = np.asarray(commands, dtype=float)
        fits = {}
        for name in self.skills:
            result = self._fresh_estimate(name, commands, None)
            fits[name] = self.estimations[name].fitting_error(result.theta, commands)
        return fits

    def _fresh_estimate(self, name: str, commands: np.ndarray, heading: Optional[float]) -> SolveResult:
        """A skill's estimation from the grid seed (``_seed``), pulled towards no earlier estimate."""
        layout = self.estimation_layouts[name]
        guess = self._seed(name, commands, heading)
        curvature = self._curvature_weights(layout)
        return self.estimations[name].solve(commands, guess, None, np.zeros(layout.n), None, curvature)

    def _curvature_weights(self, layout: ParameterLayout) -> np.ndarray:
        """The estimation's always-on penalty on the Clothoid's curvature entries (phi), zero elsewhere."""
        weights = np.zeros(layout.n)
        weights[: layout.i_alpha] = self.config.curvature_weight
        return weights

    def _seed(self, name: str, commands: np.ndarray, heading: Optional[float]) -> np.ndarray:
        """First guess of an estimation: the best fit over a grid of heading, speed, amplitude, frequency and phase.

        The mean command alone is a biased heading and speed when the window holds a fraction of a large, fast loop
        (measured: a 4.5 cm cycloid at 1.5 Hz seeded 3 rad off, and heading continuity kept it there); a single
        guessed amplitude left small, fast loops in a local minimum where the wrong skill fitted better. After the
        first estimate the heading is alpha_c's (``heading``; None: a grid of headings).
        """
        layout = self.estimation_layouts[name]
        skill = layout.skill
        mean = commands.mean(axis=0)
        if heading is not None:
            headings = np.array([heading])
        else:
            mean_heading = math.atan2(mean[1], mean[0]) if np.linalg.norm(mean) > 1e-9 else 0.0
            headings = mean_heading + np.linspace(0.0, 2 * math.pi, 8, endpoint=False)
        speed = float(np.clip(np.linalg.norm(mean), *self.config.speed_bounds))
        low, high = skill.rho_lower[skill.frequency_index], skill.rho_upper[skill.frequency_index]
        amplitudes = np.geomspace(skill.rho_lower[skill.amplitude_index], skill.rho_upper[skill.amplitude_index], 4)
        grid = np.array(
            list(
                itertools.product(
                    headings, speed * np.array([0.5, 1.0, 2.0]), amplitudes, np.geomspace(low, high, 8), range(4)
                )
            )
        )
        candidates = np.tile(layout.guess(0.0, speed), (len(grid), 1))
        candidates[:, layout.i_alpha] = grid[:, 0]
        candidates[:, layout.i_v0] = grid[:, 1]
        candidates[:, layout.i_rho + skill.amplitude_index] = grid[:, 2]
        candidates[:, layout.i_rho + skill.frequency_index] = grid[:, 3]
        candidates[:, layout.i_rho + skill.phase_index] = grid[:, 4] / 4 / grid[:, 3]
        candidates = np.clip(candidates, layout.lower, layout.upper)
        errors = self.estimations[name].fitting_errors(candidates, commands)
        return candidates[int(np.argmin(errors))]

    def _advance(self, results: Dict[str, SolveResult], theta_star: np.ndarray) -> None:
        """Move every estimate to the next cycle's s_c (each with its own v0), and alpha_c with the followed skill's.

        alpha_c is the operator's heading, from the followed skill's own estimate: the plan's heading bends away
        from a boundary the operator pushes into, and feeding that back (the paper's alpha_c = alpha*_prev) turned
        the estimation away from the operator's commands (issue 31: a wave identified as a cycloid at the boundary).
        """
        cfg = self.config
        for name, result in results.items():
            layout = self.estimation_layouts[name]
            if result.theta is None or not np.all(np.isfinite(result.theta)):
                self.estimates[name] = None
                continue
            theta = np.clip(result.theta, layout.lower, layout.upper)
            ds = theta[layout.i_v0] * cfg.dt
            self.estimates[name] = layout.shift(theta, ds, theta[layout.i_v0] * cfg.horizon_time)
        layout = self.optimisation_layouts[self.skill]
        ds = theta_star[layout.i_v0] * cfg.dt
        self.theta_star = layout.shift(theta_star, ds, theta_star[layout.i_v0] * cfg.horizon_time)
        estimate = self.estimates[self.skill]
        self.alpha_c = None if estimate is None else float(estimate[self.estimation_layouts[self.skill].i_alpha])

    def _forget(self) -> None:
        """After a failure, restart the estimation as on the first iteration (regularisation and alpha_c relaxed)."""
        self.estimates = {name: None for name in self.skills}
        self.alpha_c = None
        self.skill = None
        self.theta_star = None
        self.lam = (None, None)

    def _fallback(self, report: CycleReport) -> SharedControlRecord:
        """Safe output from a free state: the previous plan's next state, else hold."""
        report.skills = list(self.skills)
        notes = report.notes
        for name in self.skills:
            self.estimates[name] = None
        self.alpha_c = None
        if self.plan_index + 1 < self.plan.shape[1]:
            candidate = self.plan[:, self.plan_index + 1]
            if constraints.violation(candidate, self.box, self.obstacle) == 0.0:
                self.plan_index += 1
                notes.append("fallback: following the previous plan")
                velocity = plan_velocity(self.plan, self.config.dt, self.plan_index)
                self.state, velocity, paced = self._paced(candidate, velocity)
                if paced:
                    notes.append(paced)
                return self._record(FALLBACK, report, "; ".join(notes), self.plan, velocity)
        self.plan = np.zeros((2, 0))
        notes.append("fallback: holding the current state")
        return self._record(FALLBACK, report, "; ".join(notes))

    def _recover(self, report: CycleReport) -> SharedControlRecord:
        """Recovery of a state that is not free (an obstacle moved onto it, a boundary excludes it).

        No plan meanwhile; the state moves to the nearest free state at most ``recovery_speed``, never a jump.
        """
        self._forget()
        self.plan, self.plan_index = np.zeros((2, 0)), 0
        report.skills = list(self.skills)
        safe = self._safe_state(self.state)
        if safe is None:
            report.notes.append("no free state exists (the obstacle covers the boundary): holding")
            return self._record(FALLBACK, report, "; ".join(report.notes))
        offset = safe - self.state
        distance = float(np.linalg.norm(offset))
        speed = self.config.recovery_speed
        step = min(distance, speed * self.config.dt)
        self.state = self.state + offset * (step / distance)
        report.notes.append(
            f"state {1e3 * distance:.1f} mm from the free region (obstacle on it or boundary around it): moving there "
            f"at {speed:.3g} m/s"
        )
        return self._record(
            FALLBACK, report, "; ".join(report.notes), velocity=offset * (step / distance) / self.config.dt
        )

    def _as_followed(self, plan) -> np.ndarray:
        """The plan as the robot follows it: each state stopped at the constraint, as an executed step is.

        A plan enters the margin when no plan keeps it or the optimisation stopped at its iteration cap.
        """
        return constraints.stopped_at_constraints(plan, self.box, self.obstacle, self.config.margin)

    def _safe_state(self, point) -> Optional[np.ndarray]:
        return constraints.nearest_free_point(point, self.box, self.obstacle, self.config.margin)

    def _record(
        self, mode, report: CycleReport, message: str, plan=None, velocity=(0.0, 0.0), authority=0.0
    ) -> SharedControlRecord:
        """The cycle's record: the report's facts, the executed state and what was planned and sent."""
        return SharedControlRecord(
            mode=mode,
            skill=report.skill,
            skills=list(report.skills),
            fitting_errors=[float(e) for e in report.errors],
            parameters=[float(p) for p in report.parameters],
            estimation_time=float(report.estimation_time),
            optimisation_time=float(report.optimisation_time),
            command=(float(report.command[0]), float(report.command[1])),
            state=(float(self.state[0]), float(self.state[1])),
            message=message,
            iterations=(int(report.iterations[0]), int(report.iterations[1])),
            cpu_times=(float(self._cpu[0]), float(self._cpu[1])),
            plan=np.zeros((2, 0)) if plan is None else self._as_followed(plan),
            velocity=(float(velocity[0]), float(velocity[1])),
            confidence=float(report.confidence),
            authority=float(authority),
        )
