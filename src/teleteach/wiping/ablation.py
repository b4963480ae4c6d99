"""Does the taught stiffness decide a wipe's outcome? The cells, the scripted operator's pattern, one trial's figures.

Issue 49's comparison (Stiffness Copilot's framing: a policy should be as safe as a constant low stiffness and as
efficient as a constant high one): constant high, constant low, an isotropic profile of the taught ellipsoid's volume
(an operator who sizes the ellipsoid but does not shape it), and the anisotropic profile taught for wiping, compliant
along the normal and stiff along the surface. Every cell wipes the same trials: trial k has the same base error, the
same perception error of the surface and the same operator commands in every cell (a paired design).
"""

import dataclasses
import math
from typing import Dict, List

import numpy as np

from teleteach.core.wiping import WipingConfig, WipingError, contact_mask, covered_area, force_figures
from teleteach.run.trials import bootstrap_median_interval, wilson_interval
from teleteach.shared_control import wipe_measures
from teleteach.shared_control.operators import commands_around_path
from teleteach.wiping.trial import SurfaceStiffness, run_wipe

HIGH, LOW = 3000.0, 300.0  # [N/m] the impedance controller's maximum, and a tenth of it
TAUGHT = SurfaceStiffness(HIGH, HIGH, LOW)
CELLS: Dict[str, SurfaceStiffness] = {
    "constant_high": SurfaceStiffness(HIGH, HIGH, HIGH),
    "constant_low": SurfaceStiffness(LOW, LOW, LOW),
    "taught_isotropic": SurfaceStiffness(*[float(np.cbrt(np.prod(TAUGHT.eigenvalues())))] * 3),
    "taught_anisotropic": TAUGHT,
}
SURFACE = "counter_board"
BASE_POSE = "wipe_counter"

# The scripted operator: right to left along the surface's u (as in the paper's study), a wave or a cycloid around it.
START_U, END_U = 0.15, -0.15  # [m] the underlying path along u, at v = 0
SPEED = 0.05  # [m/s] along the underlying path
PATTERNS = {"wave": (0.05, 12.5, 0.0), "cycloid": (0.035, 12.5, 0.0)}  # rho: amplitude [m], frequency [1/m], phase
HAND_NOISE = 0.01  # [m/s] white noise on each command axis: a hand is not a plotter


def operator_pattern(seed: int, dt: float):
    """Trial seed's pattern: (skill, commands h^r (N x 2) [m/s], targets: the commands integrated from the start).

    Even seeds wave, odd seeds draw a cycloid; the hand's noise comes from the seed.
    """
    skill = "wave" if seed % 2 == 0 else "cycloid"
    count = int(round(abs(END_U - START_U) / SPEED / dt))
    path = np.column_stack([np.linspace(START_U, END_U, count), np.zeros(count)])
    rho = PATTERNS[skill]
    rng = np.random.default_rng([seed, 49])
    commands = commands_around_path(path, dt, [(skill, rho), (skill, rho)], math.inf, HAND_NOISE, rng)
    targets = path[0] + np.cumsum(commands * dt, axis=0)
    return skill, commands, targets


def coverage(record, config: WipingConfig, footprint, area) -> dict:
    """The part of the marked ``area`` the wipe's contact patch swept while in contact (core.wiping.covered_area)."""
    in_contact = contact_mask(record.normal_forces, config.contact_threshold)
    return covered_area(record.positions, record.yaws, in_contact, footprint, area, config.coverage_resolution)


def wipe_figures(
    record, commands: np.ndarray, skill: str, config: WipingConfig, footprint, area, skip: int = 0
) -> dict:
    """One wipe's figures, from the world: contact, force, tracking, the pattern's fit (F_h, F_x), area covered.

    The fit leaves out the first ``skip`` cycles (the paper leaves out the shared controller's first window).
    """
    in_contact = contact_mask(record.normal_forces, config.contact_threshold)
    figures = force_figures(record.normal_forces, in_contact)
    tracking = wipe_measures.tracking_error(record.targets, record.positions)
    fits = wipe_measures.pattern_fits(skill, record.times[skip:], commands[skip:], record.positions[skip:])
    covered = coverage(record, config, footprint, area)
    return {
        **figures,
        "tracking_rms_m": tracking["rms_m"],
        "tracking_max_m": tracking["max_m"],
        **fits,
        "covered_fraction": covered["covered_fraction"],
        "covered_area_m2": covered["covered_area_m2"],
    }


@dataclasses.dataclass(frozen=True)
class WipeJob:
    """One trial of one cell, for teleteach.run.trials.run_trials (the process loads scene, kinematics, uncertainty)."""

    group: str
    seed: int
    stiffness: SurfaceStiffness
    config: WipingConfig

    def run(self, process: dict) -> dict:
        """The wipe, judged from the world; a surface out of reach is a failed trial that says so."""
        scene = process["scene"]
        surface = scene.surface(SURFACE)
        skill, commands, targets = operator_pattern(self.seed, self.config.dt)
        row = {"seed": self.seed, "skill": skill}
        try:
            record, _ = run_wipe(
                scene,
                process["kinematics"],
                process["uncertainty"],
                self.config,
                surface,
                BASE_POSE,
                self.seed,
                targets,
                self.stiffness,
            )
        except WipingError as error:
            return {**row, "error": str(error)}
        tool = scene.wiping_tool
        figures = wipe_figures(record, commands, skill, self.config, tool.size[:2], surface.area)
        return {**row, **figures, "surface_error": record.seen_error.tolist()}


def jobs(seeds: List[int], config: WipingConfig) -> List[WipeJob]:
    """Every cell's trial for each seed."""
    return [WipeJob(name, seed, stiffness, config) for seed in seeds for name, stiffness in CELLS.items()]


def summarise_cell(trials: List[dict], contact_goal: float) -> dict:
    """A cell's figures: how many wipes kept contact (Wilson interval), medians with bootstrap intervals."""
    done = [trial for trial in trials if "error" not in trial]
    kept = sum(trial["contact_fraction"] >= contact_goal for trial in done)
    summary = {"trials": len(trials), "failed": len(trials) - len(done), "kept_contact": kept}
    summary["kept_contact_interval"] = list(wilson_interval(kept, len(trials)))
    for key in ("contact_fraction", "force_mean_n", "force_spread_n", "peak_force_n", "tracking_rms_m", "F_x"):
        values = [trial[key] for trial in done]
        summary[f"median_{key}"] = float(np.median(values))
        summary[f"median_{key}_interval"] = list(bootstrap_median_interval(values))
    summary["min_contact_fraction"] = min(trial["contact_fraction"] for trial in done)
    return summary


def goals(cells: Dict[str, dict], contact_goal: float) -> List[dict]:
    """Issue 49's goal, each part with what was measured and whether it is met."""
    taught, high, low = cells["taught_anisotropic"], cells["constant_high"], cells["constant_low"]
    spread = taught["median_force_spread_n"] / high["median_force_spread_n"]
    taught_fx = taught["median_F_x"] / high["median_F_x"]
    low_fx = low["median_F_x"] / high["median_F_x"]
    return [
        {
            "goal": f"taught keeps contact >= {contact_goal:.0%} of the wipe in every trial",
            "measured": f"{taught['kept_contact']} of {taught['trials']} (least {taught['min_contact_fraction']:.1%})",
            "met": taught["kept_contact"] == taught["trials"],
        },
        {
            "goal": "taught contact-force spread <= 50 % of constant high's (medians)",
            "measured": f"{spread:.0%}",
            "met": spread <= 0.5,
        },
        {
            "goal": "taught F_x within 1.5x of constant high's, constant low's >= 2x (medians)",
            "measured": f"taught {taught_fx:.2f}x, low {low_fx:.2f}x",
            "met": taught_fx <= 1.5 and low_fx >= 2.0,
        },
    ]
