"""The stiffness ablation's question (bench/stiffness_ablation.py): profiles, and whether the world tells them apart.

A profile replaces the translational stiffness of a taught skill (in its target's frame: x along the insertion, y
across the gap) and keeps everything else: constant low (the skill's first sample, the operator's approach preset,
throughout), constant high (the controller's maximum on every axis), the taught profile, a sweep of the insertion
phase (thesis III-C's phase 3) over the stiffness along and across the gap, and (when asked) one over its vertical
stiffness: the axis that sets the product down on the shelf, where the peak contact force of a placement comes from.
"""

import dataclasses
from typing import Dict, List, Tuple

import numpy as np
from scipy.stats import binomtest

from teleteach.core import skill_file
from teleteach.run.outcome import PHASES

HIGH_STIFFNESS = 3000.0  # [N/m] the controller's max_stiffness (config/controllers.yaml)
INSERTION_START = PHASES["perpendicular"][2][0]  # [s] thesis III-C's phase 3 on the teaching trajectory
SWEEP = (150.0, 500.0, 1500.0, 3000.0)  # [N/m] insertion stiffness along and across, each
PROFILES = ("constant_low", "constant_high", "taught")
# Two cells differ when their success rates lie SUCCESS_APART apart, or one's median peak force is FORCE_APART times
# the other's, with non-overlapping intervals either way (issue 28's bar).
SUCCESS_APART = 0.2
FORCE_APART = 2.0
# A trial touched a neighbour when it moved one more than this [m] (a product left alone settles by a tenth of a mm).
CONTACT_MOVE = 0.0005
GOAL_SUCCESS = 0.9  # the best taught profile places at least this often ...
GOAL_FORCE_SHARE = 0.5  # ... with a median peak force of at most this share of constant high's


def stiffness_profiles(taught: skill_file.Skill, sweep=SWEEP, vertical=()) -> Dict[str, skill_file.Skill]:
    """The skills compared, by cell name: the taught trajectory with its stiffness replaced.

    Only the translational stiffness differs: times, poses and the rotational stiffness are the taught ones. The
    stiffness is in the skill's frame (gap_1's: x along the insertion, y across the gap, z up). Sweep cells are named
    ``sweep_<along>_<across>`` and keep the taught stiffness before INSERTION_START and its vertical stiffness after;
    vertical cells (``vertical_<z>``, one per value of ``vertical``) are the taught profile with z from INSERTION_START.
    """
    count = len(taught.time)
    stiffness = {
        "constant_low": np.repeat(taught.stiffness[:1], count, axis=0),
        "constant_high": np.tile(HIGH_STIFFNESS * np.eye(3), (count, 1, 1)),
        "taught": taught.stiffness,
    }
    insertion = taught.time - taught.time[0] >= INSERTION_START
    for along in sweep:
        for across in sweep:
            profile = taught.stiffness.copy()
            profile[insertion] = [np.diag([along, across, matrix[2, 2]]) for matrix in taught.stiffness[insertion]]
            stiffness[sweep_name(along, across)] = profile
    for value in vertical:
        profile = taught.stiffness.copy()
        profile[insertion, 2, 2] = value
        stiffness[vertical_name(value)] = profile
    return {
        name: dataclasses.replace(taught, name=f"{taught.name}_{name}", stiffness=matrices)
        for name, matrices in stiffness.items()
    }


def sweep_name(along: float, across: float) -> str:
    """The cell of the sweep with these insertion stiffnesses [N/m]."""
    return f"sweep_{along:.0f}_{across:.0f}"


def vertical_name(stiffness: float) -> str:
    """The cell of the vertical sweep with this insertion stiffness along z [N/m]."""
    return f"vertical_{stiffness:.0f}"


def insertion_stiffness(skill: skill_file.Skill) -> Tuple[float, float]:
    """Median stiffness along (x) and across (y) the gap [N/m] in the insertion phase of a skill in the gap's frame."""
    insertion = skill.time - skill.time[0] >= INSERTION_START
    return float(np.median(skill.stiffness[insertion, 0, 0])), float(np.median(skill.stiffness[insertion, 1, 1]))


def all_cells(results: dict) -> Dict[str, dict]:
    """Every cell's summary by name: the profiles, the sweep's cells, the vertical cells."""
    return {**results["profiles"], **results["sweep"]["cells"], **results["vertical"]["cells"]}


def goals(results: dict) -> List[str]:
    """Issue 28's two ablation goals, each judged from the figures: met / not met and why."""
    cells = all_cells(results)
    lines = []
    apart = []
    for first in cells:
        for second in cells:
            a, b = cells[first], cells[second]
            if first >= second:
                continue
            rate = abs(a["success_rate"] - b["success_rate"]) >= SUCCESS_APART and (
                a["success_interval"][0] > b["success_interval"][1]
                or b["success_interval"][0] > a["success_interval"][1]
            )
            low, high = sorted((a, b), key=lambda cell: cell["median_peak_force_n"])
            force = (
                high["median_peak_force_n"] >= FORCE_APART * low["median_peak_force_n"]
                and high["median_peak_force_interval"][0] > low["median_peak_force_interval"][1]
            )
            if rate or force:
                apart.append((first, second, "success" if rate else "peak force"))
    profile_pairs = [pair for pair in apart if pair[0] in PROFILES and pair[1] in PROFILES]
    shown = profile_pairs or apart
    lines.append(
        ("met" if apart else "not met")
        + f": the world tells profiles apart ({len(apart)} pairs differ by >= 20 points of success or 2x median peak "
        + "force with non-overlapping intervals"
        + (f"; e.g. {', '.join(f'{a} vs {b} ({what})' for a, b, what in shown[:3])})" if shown else ")")
    )
    high = results["profiles"]["constant_high"]["median_peak_force_n"]
    best = max(
        ((name, cell) for name, cell in cells.items() if name not in ("constant_low", "constant_high")),
        key=lambda item: (item[1]["success_rate"], -item[1]["median_peak_force_n"]),
    )
    taught = results["profiles"]["taught"]
    for name, cell in (("taught", taught), best):
        ok = cell["success_rate"] >= GOAL_SUCCESS and cell["median_peak_force_n"] <= GOAL_FORCE_SHARE * high
        lines.append(
            f"{'met' if ok else 'not met'}: {name} places at {100 * cell['success_rate']:.0f} % "
            f"[{100 * cell['success_interval'][0]:.0f}, {100 * cell['success_interval'][1]:.0f}] with median peak "
            f"force {cell['median_peak_force_n']:.1f} N = {100 * cell['median_peak_force_n'] / high:.0f} % of constant "
            f"high's {high:.1f} N (goal: >= 90 %, <= 50 %)"
        )
    return lines


def across_contrast(trials: Dict[str, List[dict]], sweep) -> List[dict]:
    """Compliant against stiff across the gap, paired trial by trial (the same seed: the same errors and grasp).

    For each stiffness along the gap, the sweep's softest and stiffest cells across it; and constant low against
    constant high. Only the trials where either cell moved a neighbour (CONTACT_MOVE) say anything: in the others the
    product never met the gap's sides. Per pair: those trials, how often the compliant cell moved the neighbour less,
    a two-sided sign test, and the median neighbour move and lateral offset of each.
    """
    softest, stiffest = min(sweep), max(sweep)
    # one stiffness swept: no compliant and stiff cell across, only the profiles
    pairs = [
        (sweep_name(along, softest), sweep_name(along, stiffest)) for along in sorted(set(sweep)) if softest < stiffest
    ]
    pairs.append(("constant_low", "constant_high"))
    contrasts = []
    for compliant, stiff in pairs:
        by_seed = {trial["seed"]: trial for trial in trials[stiff]}
        paired = [(trial, by_seed[trial["seed"]]) for trial in trials[compliant] if trial["seed"] in by_seed]
        touched = [
            (a, b) for a, b in paired if max(a["neighbour_max_move_m"], b["neighbour_max_move_m"]) > CONTACT_MOVE
        ]
        less = sum(a["neighbour_max_move_m"] < b["neighbour_max_move_m"] for a, b in touched)
        more = sum(a["neighbour_max_move_m"] > b["neighbour_max_move_m"] for a, b in touched)
        contrasts.append(
            {
                "compliant": compliant,
                "stiff": stiff,
                "trials": len(paired),
                "touched": len(touched),
                "compliant_moved_less": less,
                "sign_test_p": binomtest(less, less + more).pvalue if less + more else 1.0,
                "neighbour_move_m": _medians(touched, lambda trial: trial["neighbour_max_move_m"]),
                "lateral_offset_m": _medians(touched, lambda trial: abs(trial["lateral_m"])),
            }
        )
    return contrasts


def _medians(pairs, value) -> List[float]:
    """The median of ``value`` over the first and over the second trial of each pair (NaN without pairs)."""
    if not pairs:
        return [float("nan"), float("nan")]
    return [float(np.median([value(pair[side]) for pair in pairs])) for side in (0, 1)]
