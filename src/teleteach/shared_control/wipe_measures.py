"""Measures of a wipe that need the shared controller's geometry and models: violations and the pattern's fit.

In the surface's own 2-D frame as teleteach.core.wiping's measures (contact, force, the area swept), which these build
on. The boundary's and the obstacle's geometry is ``shared_control.constraints``' and the fits of eqs 11-12 are
``shared_control.metrics``': neither is written again.
"""

import math
from typing import Dict, Optional, Sequence, Tuple, Union

import numpy as np

from teleteach.core.wiping import as_rectangle, as_samples
from teleteach.shared_control.constraints import Box, StraightEdge, violations
from teleteach.shared_control.metrics import command_fit, position_fit
from teleteach.shared_control.models import SKILLS


def _tolerance(value) -> float:
    """A violation tolerance [m]: finite and >= 0."""
    try:
        number = float(value)
    except (TypeError, ValueError) as error:
        raise ValueError(f"tolerance must be a number, got {value!r:.80}") from error
    if not (math.isfinite(number) and number >= 0):
        raise ValueError(f"tolerance must be finite and >= 0, got {value}")
    return number


def _rectangle(name: str, values) -> Box:
    """``values`` as a ``Box``: a Box, or four finite bounds (min_1, min_2, max_1, max_2) with min < max [m]."""
    return values if isinstance(values, Box) else Box(*as_rectangle(name, values))


def boundary_violations(
    positions: Sequence[Sequence[float]],
    box: Union[Box, Tuple[float, float, float, float]],
    tolerance: float = 0.0,
) -> Dict[str, float]:
    """How often and how far the tool left the boundary (the marked area's edges, eq. 9b's box).

    Shared control keeps the planned states inside; the executed ones can still leave it (the arm lags, or there is
    no shared control): ``tolerance`` [m] separates tracking error from a violation.

    Args:
        positions: N x 2 tool positions (u, v) [m].
        box: the boundary, a ``Box`` or (u_min, v_min, u_max, v_max) [m].
        tolerance: excursion [m] not counted as a violation, >= 0.

    Returns:
        ``count``, the number of samples outside the box by more than ``tolerance``, and ``worst_m`` [m], the
        largest excursion of any sample (0 when none leaves the box).
    """
    positions = as_samples("positions", positions, 2)
    excursions = violations(positions.T, _rectangle("box", box), None)
    return {"count": int(np.sum(excursions > _tolerance(tolerance))), "worst_m": float(np.max(excursions))}


def obstacle_violations(
    positions: Sequence[Sequence[float]],
    edges: Sequence[Optional[StraightEdge]],
    tolerance: float = 0.0,
) -> Dict[str, float]:
    """How often and how deep the tool went past a straight-edge obstacle that may move (IV-C, IV-D).

    Args:
        positions: N x 2 tool positions (u, v) [m].
        edges: the obstacle at each sample (its pose then), or None where there was none.
        tolerance: penetration [m] not counted as a violation, >= 0.

    Returns:
        ``count``, the number of samples on the obstacle's side by more than ``tolerance``, and ``worst_m`` [m], the
        deepest penetration (0 when none).
    """
    positions = as_samples("positions", positions, 2)
    edges = list(edges)
    if len(edges) != positions.shape[0]:
        raise ValueError(f"need one edge (or None) per position, got {len(edges)} for {positions.shape[0]}")
    wrong = [type(edge).__name__ for edge in edges if edge is not None and not isinstance(edge, StraightEdge)]
    if wrong:
        raise ValueError(f"edges must be StraightEdge or None, got {wrong[0]}")
    samples_of = {}  # a still obstacle is one edge: its samples at once
    for index, edge in enumerate(edges):
        if edge is not None:
            samples_of.setdefault(edge, []).append(index)
    penetration = np.zeros(positions.shape[0])
    for edge, rows in samples_of.items():
        penetration[rows] = np.maximum(-edge.distance(positions[rows].T), 0.0)
    return {"count": int(np.sum(penetration > _tolerance(tolerance))), "worst_m": float(np.max(penetration))}


def pattern_fits(
    skill: str, times: Sequence[float], commands: Sequence[Sequence[float]], positions: Sequence[Sequence[float]]
) -> Dict[str, float]:
    """The user study's measures (eqs 11-12): how well the operator's commands and the tool's path fit a skill.

    Args:
        skill: the skill fitted, a key of ``SKILLS`` ("wave", "cycloid").
        times: N sample times [s], increasing (not assumed evenly spaced).
        commands: N x 2 operator commands h^r [m/s] in the surface's frame.
        positions: N x 2 tool positions x^r [m] in the surface's frame.

    Returns:
        ``F_h`` [(m/s)^2 / s] and ``F_x`` [m^2 / s]: smaller is a closer fit.
    """
    if skill not in SKILLS:
        raise ValueError(f"unknown skill {skill!r}: one of {sorted(SKILLS)}")
    times = as_samples("times", times)
    if times.size < 3 or np.any(np.diff(times) <= 0):
        raise ValueError(f"times must be at least 3 increasing samples, got {times.size} samples")
    for name, values in (("commands", commands), ("positions", positions)):
        if as_samples(name, values, 2).shape[0] != times.size:
            raise ValueError(f"need one of {name} per time ({times.size}), got {np.shape(values)[0]}")
    return {
        "F_h": command_fit(skill, times, np.asarray(commands, dtype=float)).value,
        "F_x": position_fit(skill, times, np.asarray(positions, dtype=float)).value,
    }


def tracking_error(targets: Sequence[Sequence[float]], positions: Sequence[Sequence[float]]) -> Dict[str, float]:
    """How far the tool was from where the pattern asked it to be (the equilibrium's in-plane point).

    A soft tool drags behind the pattern on a rough surface: this is the lag that compliance along the surface costs.

    Args:
        targets: N x 2 in-plane equilibrium points (u, v) [m].
        positions: N x 2 tool positions (u, v) [m] at the same samples.

    Returns:
        ``rms_m`` and ``max_m`` [m], the root mean square and the largest distance.
    """
    targets = as_samples("targets", targets, 2)
    positions = as_samples("positions", positions, 2)
    if targets.shape != positions.shape:
        raise ValueError(f"need one position per target, got {positions.shape[0]} for {targets.shape[0]}")
    distances = np.hypot(*(targets - positions).T)
    return {"rms_m": float(np.sqrt(np.mean(distances**2))), "max_m": float(np.max(distances))}
