"""The RSS paper's controller on the surface: the operator's commands, directly or through the shared controller.

Direct control integrates the operator's commands h^r into the tool's in-plane targets; shared control runs the MPC
(teleteach.shared_control.loop.SharedControl: recognise the wave or the cycloid, keep it inside the boundary) over the
same commands, one 50 Hz cycle each. The boundary is the marked area shrunk by half the tool's contact patch, so that
the patch stays on the marked area. The scripted operators are not drawn from the identifier's model (issue 49): a
hand's underlying path (overlapping minimum-jerk reaches from right to left that drift across the board, Flash and
Henis 1991), its own speed changes, a pattern whose size and frequency the seed picks, and a hand's noise.
"""

import dataclasses
import math
from typing import Callable, List, Optional, Sequence, Tuple

import numpy as np
from scipy.ndimage import gaussian_filter1d

from teleteach.core.paths import config_file
from teleteach.core.wiping import WipingConfig
from teleteach.shared_control import wipe_measures
from teleteach.shared_control.constraints import Box, StraightEdge
from teleteach.shared_control.loop import MODE_NAMES, SharedControl, SharedControlConfig
from teleteach.shared_control.operators import commands_around_path, reaching_path, retime
from teleteach.shared_control.surface import wiping_box
from teleteach.wiping.ablation import wipe_figures
from teleteach.wiping.trial import SurfaceStiffness, run_wipe

REACHES = 4  # minimum-jerk reaches of the underlying path
AMPLITUDE = {"wave": (0.035, 0.05), "cycloid": (0.025, 0.035)}  # [m] range the seed draws the pattern's size from
FREQUENCY = (10.0, 15.0)  # [1/m] range of the pattern's spatial frequency
DRIFT = (0.01, 0.05)  # [m] how far the hand's path drifts across the board (toward one edge)
MEAN_SPEED = 0.05  # [m/s] along the underlying path
NOISE = 0.01  # [m/s] a hand's noise on each command axis
# A hand on a joystick does not repeat its pattern exactly (the paper's Fig. 9: direct-control patterns far poorer than
# the shared controller's): its size and timing wander slowly along the stroke. Smooth noise (a Gaussian filter of
# WANDER_TIME over white noise, scaled to unit standard deviation) of these standard deviations:
WANDER_TIME = 0.5  # [s] the wander's correlation time
AMPLITUDE_WANDER = 0.2  # [-] relative to the pattern's size
PHASE_WANDER = 0.1  # [periods] of the pattern's timing
# IV-D's moving obstacle: a straight edge across the board, parallel to u, that comes down from beyond the
# boundary's top to OBSTACLE_NEAR and goes back every OBSTACLE_PERIOD (free side below it), as the paper's experimenter
# moved a straight edge across the whiteboard. Given in the board's coordinates (tracked relative to the board).
OBSTACLE_PERIOD = 6.0  # [s]
OBSTACLE_FAR, OBSTACLE_NEAR = 0.10, 0.03  # [m] along v
# What a wipe under shared control reads: the scene (board, tool), the world's uncertainty, the wiping and the shared
# controller's settings (a bench's result names their digests).
CONFIG_FILES = tuple(
    config_file(name) for name in ("supermarket.yaml", "uncertainty.yaml", "wiping.yaml", "shared_control.yaml")
)
BOUNDARY_TOLERANCE = 0.002  # [m] the tool's centre beyond the boundary by more than this is a violation (the arm
#                             tracks its equilibrium within a few millimetres: issue 31's margin)


def _smooth_noise(rng: np.random.Generator, count: int, samples: float) -> np.ndarray:
    """Gaussian-filtered white noise (filter width ``samples``), scaled to zero mean and unit standard deviation."""
    smooth = gaussian_filter1d(rng.standard_normal(count), samples, mode="nearest")
    return (smooth - smooth.mean()) / smooth.std()


def human_wipe(seed: int, skill: str, box: Box, dt: float) -> Tuple[np.ndarray, np.ndarray]:
    """A scripted operator wiping from right to left across the box: (commands h^r (N x 2) [m/s], start (u, v) [m]).

    The underlying path crosses 85 % of the box's length in ``REACHES`` overlapping minimum-jerk reaches of uneven
    duration (the hand's own speed changes; the whole at a mean speed of ``MEAN_SPEED``, trimmed to where the hand
    moves) while drifting across the board by a seeded amount toward a seeded edge; the pattern's size and frequency
    are drawn per seed, and its size and timing wander along the stroke.
    """
    rng = np.random.default_rng([seed, 4949])
    length = 0.85 * (box.x_max - box.x_min)
    side = rng.choice([-1.0, 1.0])
    drift = side * rng.uniform(*DRIFT)
    along = -length * np.cumsum(rng.uniform(0.7, 1.3, REACHES))
    along *= length / abs(along[-1])
    across = drift * np.linspace(0.0, 1.0, REACHES + 1)[1:] ** 1.5
    durations = rng.uniform(0.7, 1.3, REACHES) * length / REACHES / MEAN_SPEED
    path = reaching_path(np.column_stack([along, across]), durations, 0.4, dt)
    path = retime(path, dt, dt, MEAN_SPEED)
    amplitude, frequency = rng.uniform(*AMPLITUDE[skill]), rng.uniform(*FREQUENCY)
    size = amplitude * (1.0 + AMPLITUDE_WANDER * _smooth_noise(rng, len(path), WANDER_TIME / dt))
    timing = PHASE_WANDER / frequency * _smooth_noise(rng, len(path), WANDER_TIME / dt)
    rho = (size, frequency, timing)
    commands = commands_around_path(path, dt, [(skill, rho), (skill, rho)], math.inf, NOISE, rng)
    start = np.array([box.x_max - 0.075 * (box.x_max - box.x_min), 0.0]) + path[0]
    return commands, start


def moving_edge(time: float) -> StraightEdge:
    """Where IV-D's edge is at ``time`` [s] into the wipe (its free side toward -v)."""
    v = OBSTACLE_FAR + (OBSTACLE_NEAR - OBSTACLE_FAR) * 0.5 * (1.0 - math.cos(2.0 * math.pi * time / OBSTACLE_PERIOD))
    return StraightEdge(0.0, v, -0.5 * math.pi)


def direct_targets(commands: np.ndarray, start: Sequence[float], dt: float) -> np.ndarray:
    """Direct control: the tool goes where the operator's commands take it, boundary or not."""
    return np.asarray(start, dtype=float) + np.cumsum(np.asarray(commands, dtype=float) * dt, axis=0)


def shared_targets(
    commands: np.ndarray,
    start: Sequence[float],
    box: Box,
    config: SharedControlConfig,
    obstacle: Optional[Callable[[float], StraightEdge]] = None,
):
    """Shared control: the MPC's executed state of each cycle over the commands; also each cycle's record.

    ``obstacle(t)``, when given, is the edge the controller senses at the cycle's time ``t`` [s].
    """
    controller = SharedControl(config, tuple(start), box)
    records = []
    for k, command in enumerate(np.asarray(commands, dtype=float)):
        if obstacle is not None:
            controller.set_obstacle(obstacle(k * config.dt))
        records.append(controller.step(command))
    return np.array([record.state for record in records]), records


def solve_times(records: List) -> np.ndarray:
    """CPU time [s] of each cycle's estimation and optimisation (the paper's Fig. 7 figure)."""
    return np.array([sum(record.cpu_times) for record in records])


@dataclasses.dataclass(frozen=True)
class AssistedWipeJob:
    """One operator's wipe, directly and under shared control, on the arm (for teleteach.run.trials.run_trials).

    Both modes press with the same stiffness on the same surface, with the same perception error (the seed's); the
    figures are the paper's (F_h, F_x after the first window, eqs 11-12) on the tool's path as the world moved it,
    and the world's: boundary violations of the tool's centre, contact, the area covered; with ``obstacle``, IV-D's
    moving edge is there (shared control senses it) and the violations of it are counted too.
    """

    group: str
    seed: int
    skill: str
    stiffness: SurfaceStiffness
    wiping: WipingConfig
    surface: str
    base_pose: str
    obstacle: bool = False

    def run(self, process: dict) -> dict:
        """Both wipes of this operator, judged from the world."""
        scene = process["scene"]
        surface, tool = scene.surface(self.surface), scene.wiping_tool
        box = wiping_box(surface, tool.size[:2])
        config = SharedControlConfig.from_yaml()
        commands, start = human_wipe(self.seed, self.skill, box, config.dt)
        shared, records = shared_targets(commands, start, box, config, moving_edge if self.obstacle else None)
        row = {"seed": self.seed, "skill": self.skill, "cycles": len(commands)}
        window = config.n_window
        times = config.dt * np.arange(len(commands))
        edges = [moving_edge(time) if self.obstacle else None for time in times]
        for mode, targets in (("direct", direct_targets(commands, start, config.dt)), ("shared", shared)):
            record, _ = run_wipe(
                scene,
                process["kinematics"],
                process["uncertainty"],
                self.wiping,
                surface,
                self.base_pose,
                self.seed,
                targets,
                self.stiffness,
            )
            figures = wipe_figures(record, commands, self.skill, self.wiping, tool.size[:2], surface.area, window)
            violations = wipe_measures.boundary_violations(record.positions, box, BOUNDARY_TOLERANCE)
            planned = wipe_measures.boundary_violations(targets, box)
            row[mode] = {
                **figures,
                "F_x_targets": wipe_measures.pattern_fits(
                    self.skill, times[window:], commands[window:], targets[window:]
                )["F_x"],
                "boundary_violations": violations["count"],
                "boundary_worst_m": violations["worst_m"],
                "target_violations": planned["count"],
                "obstacle_violations": wipe_measures.obstacle_violations(record.positions, edges, BOUNDARY_TOLERANCE)[
                    "count"
                ],
            }
        solves = solve_times(records)
        row["shared"]["solve_p50_ms"] = 1000 * float(np.median(solves))
        row["shared"]["solve_p99_ms"] = 1000 * float(np.quantile(solves, 0.99))
        row["shared"]["over_cycle"] = int(np.sum(solves > config.dt))
        row["shared"]["modes"] = {
            name: sum(MODE_NAMES[r.mode] == name for r in records) for name in MODE_NAMES.values()
        }
        row["shared"]["misidentified"] = sum(r.skill not in ("", self.skill) for r in records)
        return row
