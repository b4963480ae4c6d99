"""Preparing a recorded demonstration for learning: checks, time alignment, resampling and smoothing on the manifold.

The thesis (Appendix C.2) recorded stiffness at the GUI's low rate and poses at the controller's rate and found that
the abrupt steps between consecutive GUI samples spoiled the DMP fit. Here:

1. every stream is checked (enough samples, finite, strictly increasing times, SPD stiffness, unit quaternions);
2. the stiffness samples the GUI really published are recovered from a zero-order-hold staircase (a value repeated
   at the pose rate is one GUI sample; a value held for longer than the GUI period also gets a knot where the hold
   ends, so that a pause is not turned into a slow ramp);
3. all streams are cut to the time window they share and resampled on one uniform grid: stiffness piecewise along
   geodesics between the GUI samples (linear interpolation on the manifold), positions linearly, orientations by
   slerp;
4. the stiffness is smoothed in the tangent space at its Karcher mean M: Exp_M(G_s * Log_M(X(t))) with a Gaussian
   G_s of standard deviation ``smoothing`` [s]. The result is SPD by construction.
"""

import dataclasses
from typing import Dict, Optional, Tuple

import numpy as np
from scipy.ndimage import gaussian_filter1d
from scipy.spatial.transform import Rotation, Slerp

from teleteach.learning import spd

MIN_SAMPLES = 5
"""Fewest samples of any stream that a demonstration may have."""


class LearningError(ValueError):
    """The demonstration cannot be learned; the message names the stream, the sample and the problem."""


@dataclasses.dataclass
class Demonstration:
    """A demonstration on a uniform time grid starting at 0, ready for the DMPs.

    Attributes:
        time: (n,) uniform grid [s], time[0] == 0.
        stiffness: (n, m, m) resampled and smoothed stiffness [N/m].
        poses: name -> (n, 7) resampled poses (x, y, z, qx, qy, qz, qw).
        sample_time: (k,) times of the stiffness samples as recorded (the GUI samples), same clock as ``time``.
        samples: (k, m, m) those samples.
        start_time: the original time of grid point 0 (stamp of the recording) [s].
    """

    time: np.ndarray
    stiffness: np.ndarray
    poses: Dict[str, np.ndarray]
    sample_time: np.ndarray
    samples: np.ndarray
    start_time: float = 0.0

    @property
    def duration(self) -> float:
        """Length of the grid [s]."""
        return float(self.time[-1])


def check_times(times, what: str, minimum: int = MIN_SAMPLES) -> np.ndarray:
    """Return ``times`` as an array or raise :class:`LearningError` (too few, not finite, not increasing)."""
    times = np.asarray(times, dtype=float)
    if times.ndim != 1 or times.size < minimum:
        raise LearningError(f"{what} has too few samples: {times.size} (need at least {minimum})")
    bad = np.flatnonzero(~np.isfinite(times))
    if bad.size:
        raise LearningError(f"{what} time is not finite at sample {bad[0]}")
    bad = np.flatnonzero(np.diff(times) <= 0)
    if bad.size:
        index = bad[0] + 1
        raise LearningError(
            f"{what} times are not strictly increasing (non-monotonic) at sample {index}: "
            f"{times[index]:.6f} s after {times[index - 1]:.6f} s"
        )
    return times


def check_stiffness(matrices, what: str = "stiffness") -> np.ndarray:
    """Return SPD matrices (n, m, m) or raise :class:`LearningError` naming the first non-SPD sample."""
    matrices = np.asarray(matrices, dtype=float)
    if matrices.ndim != 3 or matrices.shape[1] != matrices.shape[2] or matrices.shape[1] not in (2, 3):
        raise LearningError(f"{what} must be a stack of 2x2 or 3x3 matrices, got shape {matrices.shape}")
    try:
        return spd.check_spd(matrices, what)
    except spd.SPDError as error:
        raise LearningError(f"non-SPD sample: {error}") from None


def check_poses(poses, what: str) -> np.ndarray:
    """Return poses (n, 7) or raise :class:`LearningError` (shape, non-finite, non-unit quaternion)."""
    poses = np.asarray(poses, dtype=float)
    if poses.ndim != 2 or poses.shape[1] != 7:
        raise LearningError(f"{what} must have shape (n, 7) (x, y, z, qx, qy, qz, qw), got {poses.shape}")
    bad = np.flatnonzero(~np.isfinite(poses).all(axis=1))
    if bad.size:
        raise LearningError(f"{what} is not finite at sample {bad[0]}")
    norms = np.linalg.norm(poses[:, 3:], axis=1)
    bad = np.flatnonzero(np.abs(norms - 1.0) > 1e-3)
    if bad.size:
        raise LearningError(f"{what} quaternion is not unit length at sample {bad[0]} (norm {norms[bad[0]]:.4f})")
    return poses


def gui_samples(times, matrices, relative_tolerance: float = 1e-9) -> Tuple[np.ndarray, np.ndarray]:
    """The samples the GUI published, recovered from a zero-order-hold staircase recorded at a higher rate.

    A run of equal consecutive matrices is one sample at the run's first time. The GUI period P is the median run
    length; a run longer than 1.5 P was a pause, so it also gets a knot P before the next change (and the last run
    one at the last time), where the recorded value was still the same.
    """
    times = np.asarray(times, dtype=float)
    matrices = np.asarray(matrices, dtype=float)
    scale = np.abs(matrices).max()
    changed = np.abs(np.diff(matrices, axis=0)).max(axis=(1, 2)) > relative_tolerance * scale
    starts = np.concatenate([[0], np.flatnonzero(changed) + 1])
    if starts.size == times.size:
        return times, matrices
    start_times = times[starts]
    run_ends = np.append(start_times[1:], times[-1])
    lengths = np.diff(start_times)
    period = float(np.median(lengths)) if lengths.size else 0.0
    knot_times, knots = [], []
    for run, (start, end) in enumerate(zip(start_times, run_ends)):
        knot_times.append(start)
        knots.append(matrices[starts[run]])
        last = run == starts.size - 1
        hold_end = end if last else end - period
        if hold_end > start + 0.5 * period and hold_end > start:
            knot_times.append(hold_end)
            knots.append(matrices[starts[run]])
    return np.array(knot_times), np.array(knots)


def resample_geodesic(knot_times, knots, times) -> np.ndarray:
    """SPD matrices at ``times`` along the geodesics between consecutive knots (held beyond the ends)."""
    knot_times = np.asarray(knot_times, dtype=float)
    knots = np.asarray(knots, dtype=float)
    times = np.asarray(times, dtype=float)
    if knots.shape[0] == 1:
        return np.repeat(knots, times.size, axis=0)
    index = np.clip(np.searchsorted(knot_times, times, side="right") - 1, 0, knot_times.size - 2)
    fraction = np.clip((times - knot_times[index]) / (knot_times[index + 1] - knot_times[index]), 0.0, 1.0)
    frames = spd.Frame(knots[index])
    return frames.exp(fraction[:, None, None] * frames.log(knots[index + 1]))


def smooth_at_mean(matrices, dt: float, width: float) -> np.ndarray:
    """Gaussian smoothing (standard deviation ``width`` [s]) of Log_M(X(t)) at the Karcher mean M, mapped back."""
    matrices = np.asarray(matrices, dtype=float)
    if width <= 0:
        return matrices
    mean = spd.karcher_mean(matrices)
    frame = spd.Frame(mean)
    tangent = spd.mandel(frame.log(matrices))
    smoothed = gaussian_filter1d(tangent, sigma=width / dt, axis=0, mode="nearest", truncate=4.0)
    return frame.exp(spd.unmandel(smoothed))


def resample_poses(times, poses, grid) -> np.ndarray:
    """Poses at ``grid``: positions linearly, orientations by slerp (held beyond the ends)."""
    times = np.asarray(times, dtype=float)
    clamped = np.clip(grid, times[0], times[-1])
    positions = np.column_stack([np.interp(clamped, times, poses[:, axis]) for axis in range(3)])
    orientations = Slerp(times, Rotation.from_quat(poses[:, 3:]))(clamped).as_quat()
    return np.hstack([positions, orientations])


def _checked_pose_streams(poses: Dict[str, Tuple[np.ndarray, np.ndarray]]) -> Dict[str, Tuple[np.ndarray, np.ndarray]]:
    """Each pose stream's times and poses as checked arrays, one pose per time, so they can be resampled."""
    streams = {}
    for name, (times, values) in poses.items():
        times = check_times(times, name)
        values = check_poses(values, name)
        if values.shape[0] != times.size:
            raise LearningError(f"{name} has {values.shape[0]} samples but {times.size} times")
        streams[name] = (times, values)
    return streams


def _shared_window(stiffness_times: np.ndarray, streams, shortest: float) -> Tuple[float, float]:
    """The time every stream covers (start, end) [s]: only there is the demonstration known; at least ``shortest``."""
    start = max([stiffness_times[0], *(times[0] for times, _ in streams.values())])
    end = min([stiffness_times[-1], *(times[-1] for times, _ in streams.values())])
    if end - start < shortest:
        raise LearningError(
            f"the streams share only {max(end - start, 0.0):.3f} s of time (need {shortest:.3f} s): "
            "stiffness and poses were not recorded together"
        )
    return start, end


def prepare(
    stiffness_times,
    stiffness,
    poses: Dict[str, Tuple[np.ndarray, np.ndarray]],
    rate: float,
    smoothing: float,
    min_duration: Optional[float] = None,
    recover_gui_samples: bool = True,
) -> Demonstration:
    """Check, align, resample and smooth a recording.

    Args:
        stiffness_times: (n,) times of the stiffness samples [s].
        stiffness: (n, m, m) SPD stiffness samples [N/m], m = 2 or 3.
        poses: name -> (times (k,), poses (k, 7)), each stream on its own clock (same time base as stiffness).
        rate: rate of the uniform grid [Hz].
        smoothing: standard deviation of the Gaussian smoothing on the manifold [s] (0: none).
        min_duration: shortest acceptable shared window [s] (default: 4 grid steps).
        recover_gui_samples: False fits the staircase as recorded (the thesis' way; for comparison only).
    """
    if not (np.isfinite(rate) and rate > 0):
        raise LearningError(f"resampling rate must be finite and > 0, got {rate}")
    if not (np.isfinite(smoothing) and smoothing >= 0):
        raise LearningError(f"smoothing width must be finite and >= 0, got {smoothing}")
    stiffness_times = check_times(stiffness_times, "stiffness")
    stiffness = check_stiffness(stiffness)
    if stiffness.shape[0] != stiffness_times.size:
        raise LearningError(f"stiffness has {stiffness.shape[0]} samples but {stiffness_times.size} times")
    streams = _checked_pose_streams(poses)
    step = 1.0 / rate
    start, end = _shared_window(stiffness_times, streams, 4 * step if min_duration is None else min_duration)
    # the grid's own times from 0: start + k step - start loses the uniform step to rounding at epoch-sized stamps
    offsets = np.arange(int(np.floor((end - start) / step + 1e-9)) + 1) * step
    grid = start + offsets
    sample_times, samples = gui_samples(stiffness_times, stiffness)
    knot_times, knots = (sample_times, samples) if recover_gui_samples else (stiffness_times, stiffness)
    resampled = resample_geodesic(knot_times, knots, grid)
    smoothed = smooth_at_mean(resampled, step, smoothing)
    inside = (sample_times >= start - 1e-9) & (sample_times <= grid[-1] + 1e-9)
    return Demonstration(
        time=offsets,
        stiffness=smoothed,
        poses={name: resample_poses(times, values, grid) for name, (times, values) in streams.items()},
        sample_time=sample_times[inside] - start,
        samples=samples[inside],
        start_time=float(start),
    )
