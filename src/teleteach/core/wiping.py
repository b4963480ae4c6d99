"""A wipe (issue 49) on the floor every other part stands on: its settings and what the world says it did.

The settings are config/wiping.yaml's (the force to press with, how to approach and retract, what counts as contact
and as a wipe done). The measures are plain numpy on recorded arrays, in the surface's own 2-D frame (u along the
surface, v across it [m], a yaw about its normal [rad], one sample per cycle): contact, force and the area the tool's
contact patch swept. So the skill server judging a wipe, the shared controller, the in-process trials, the benches and
the tests read one file and compute them the same way; the measures that need the shared controller's geometry or
models (violations of its boundary and obstacle, the pattern's fit) are teleteach.shared_control.wipe_measures.
"""

import dataclasses
import math
import pathlib
from typing import Dict, Optional, Sequence, Tuple

import numpy as np
import yaml
from scipy.spatial.transform import Rotation

from teleteach.core.frames import Transform
from teleteach.core.parameters import from_mapping
from teleteach.core.paths import config_file
from teleteach.core.rotations import wrap_angle
from teleteach.core.scene import WipingTool

DEFAULT_WIPING_FILE = config_file("wiping.yaml")
TOOL_DOWN = Rotation.from_euler("x", math.pi)  # the TCP's z into the surface, its x along u
ARM_REACH = 0.8  # [m] from panda_link0, a little inside the Panda's 0.855 m: farther the arm cannot press


# Most patch placements covered_area sweeps: 1 km of travel at a 1 mm step. More means a contact mask or positions
# gone wrong (a jump of the tool counted as a wipe), not a wipe.
MAX_PLACEMENTS = 1_000_000
# Cells tested against patch placements at once (memory of one rasterising chunk: a few arrays of this many floats).
CHUNK_CELLS = 2_000_000
# Slack on the patch's edges [m]: a cell centre exactly on an edge (an aligned patch) counts as covered.
EDGE_SLACK = 1e-9


class WipingError(ValueError):
    """A wipe cannot be done as asked (bad settings, a surface the arm cannot reach); nothing was wiped."""


@dataclasses.dataclass(frozen=True)
class WipingConfig:
    """The wiping task's settings (config/wiping.yaml: units and reasons there)."""

    rate: float
    contact_force: float
    max_depth: float
    contact_threshold: float
    approach_height: float
    approach_time: float
    settle_time: float
    retract_time: float
    input_loss_time: float
    coverage_resolution: float
    min_contact: float
    min_coverage: float

    def __post_init__(self):
        values = dataclasses.asdict(self)
        if not all(math.isfinite(value) and value > 0.0 for value in values.values()):
            raise WipingError(f"every wiping setting must be finite and > 0: {values}")
        if self.min_contact > 1.0 or self.min_coverage > 1.0:
            raise WipingError(f"min_contact and min_coverage are fractions in (0, 1]: {values}")

    @property
    def dt(self) -> float:
        """The pattern's cycle [s]."""
        return 1.0 / self.rate


def load_wiping_config(path: Optional[str] = None) -> WipingConfig:
    """The wiping settings (default: config/wiping.yaml)."""
    path = pathlib.Path(path or DEFAULT_WIPING_FILE)
    return from_mapping(WipingConfig, yaml.safe_load(path.read_text()), str(path), WipingError)


def off_surface(surface_in_base: Transform, tool: WipingTool, settings: WipingConfig, point) -> np.ndarray:
    """The TCP's position that holds the tool's face ``approach_height`` off the surface over ``point`` (u, v) [m].

    Measured from the face, not from a pressing equilibrium: a compliant normal presses centimetres deep.
    """
    return surface_in_base.apply_point([point[0], point[1], tool.reach + settings.approach_height])


def as_samples(name: str, values, columns: Optional[int] = None) -> np.ndarray:
    """``values`` as a non-empty finite float array of N samples (N, or N x columns), else ValueError."""
    try:
        array = np.asarray(values, dtype=float)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{name} must be numbers, got {values!r:.80}") from error
    wanted = "N" if columns is None else f"N x {columns}"
    if array.ndim != (1 if columns is None else 2) or (columns is not None and array.shape[1] != columns):
        raise ValueError(f"{name} must be an {wanted} array, got shape {array.shape}")
    if array.shape[0] == 0:
        raise ValueError(f"{name} has no samples")
    if not np.all(np.isfinite(array)):
        first = int(np.argwhere(~np.isfinite(array))[0][0])
        raise ValueError(f"{name} must be finite, got a non-finite value at sample {first}")
    return array


def as_mask(name: str, values, count: int) -> np.ndarray:
    """``values`` as a boolean array of ``count`` samples, else ValueError (a float mask is a mistake, not a cast)."""
    array = np.asarray(values)
    if array.dtype != bool:
        raise ValueError(f"{name} must be booleans (contact_mask's output), got dtype {array.dtype}")
    if array.shape != (count,):
        raise ValueError(f"{name} must have one entry per sample ({count}), got shape {array.shape}")
    return array


def _positive(name: str, value) -> float:
    """``value`` as a finite float > 0, else ValueError."""
    try:
        number = float(value)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{name} must be a number, got {value!r:.80}") from error
    if not (math.isfinite(number) and number > 0):
        raise ValueError(f"{name} must be finite and > 0, got {value}")
    return number


def as_rectangle(name: str, values) -> np.ndarray:
    """``values`` as (min_1, min_2, max_1, max_2) [m], finite with each min < max (anything with ``as_array()`` too)."""
    bounds = as_samples(name, values.as_array() if hasattr(values, "as_array") else values)
    if bounds.size != 4 or bounds[0] >= bounds[2] or bounds[1] >= bounds[3]:
        raise ValueError(f"{name} must be (u_min, v_min, u_max, v_max) with each min < max, got {tuple(bounds)}")
    return bounds


def contact_mask(normal_forces: Sequence[float], threshold: float) -> np.ndarray:
    """Which samples touch the surface: a normal force [N] at or above ``threshold`` [N].

    The threshold sits above the force sensor's noise, so a tool hovering over the surface is not in contact.

    Args:
        normal_forces: N normal forces [N], positive when the surface pushes the tool away.
        threshold: smallest force of a contact [N], > 0.

    Returns:
        N booleans, True in contact.
    """
    forces = as_samples("normal_forces", normal_forces)
    return forces >= _positive("threshold", threshold)


def force_figures(normal_forces: Sequence[float], in_contact: Sequence[bool]) -> Dict[str, float]:
    """How steadily the tool pressed: the fraction of samples in contact and the force while in contact.

    A stiff normal direction on a surface perceived a few millimetres off turns each millimetre into force (a wide
    spread, a high peak) or lifts off (a low contact fraction); this is what the stiffness ablation compares. At the
    controller's fixed rate the fraction of samples is the fraction of time.

    Args:
        normal_forces: N normal forces [N].
        in_contact: N booleans, from ``contact_mask``.

    Returns:
        ``contact_fraction`` in [0, 1]; ``force_mean_n`` and ``force_spread_n`` [N], the mean and the (population)
        standard deviation over the samples in contact, NaN without any; ``peak_force_n`` [N], over all samples.
    """
    forces = as_samples("normal_forces", normal_forces)
    touching = forces[as_mask("in_contact", in_contact, forces.size)]
    return {
        "contact_fraction": touching.size / forces.size,
        "force_mean_n": float(np.mean(touching)) if touching.size else math.nan,
        "force_spread_n": float(np.std(touching)) if touching.size else math.nan,
        "peak_force_n": float(np.max(forces)),
    }


def _placements(
    positions: np.ndarray, yaws: np.ndarray, in_contact: np.ndarray, step: float, reach: float
) -> Tuple[np.ndarray, np.ndarray]:
    """Centres (M x 2) and yaws (M) of the patch placements that sweep the in-contact samples.

    Each in-contact sample, and between two consecutive ones enough interpolated placements that no point of the
    patch moves more than ``step`` [m] from one placement to the next. ``reach`` [m] is the patch's half diagonal:
    turning by d yaw moves its corners by reach |d yaw|.
    """
    starts = np.flatnonzero(in_contact[:-1] & in_contact[1:])
    delta = positions[starts + 1] - positions[starts]
    turn = wrap_angle(yaws[starts + 1] - yaws[starts])
    travel = np.hypot(delta[:, 0], delta[:, 1]) + np.abs(turn) * reach  # farthest any point of the patch moves
    pieces = np.maximum(np.ceil(travel / step), 1).astype(int)
    extra = pieces - 1  # placements strictly between the two samples
    if int(in_contact.sum()) + int(extra.sum()) > MAX_PLACEMENTS:
        raise ValueError(
            f"the in-contact samples are up to {travel.max(initial=0.0):.3g} m apart: sweeping them would take more "
            f"than {MAX_PLACEMENTS} patch placements; is the contact mask right?"
        )
    segment = np.repeat(np.arange(starts.size), extra)
    index = np.arange(segment.size) - np.repeat(np.cumsum(extra) - extra, extra) + 1  # 1 .. pieces - 1 per segment
    fraction = index / pieces[segment]
    centres = positions[starts[segment]] + fraction[:, None] * delta[segment]
    angles = yaws[starts[segment]] + fraction * turn[segment]
    return np.vstack([positions[in_contact], centres]), np.concatenate([yaws[in_contact], angles])


def covered_area(
    positions: Sequence[Sequence[float]],
    yaws: Sequence[float],
    in_contact: Sequence[bool],
    footprint: Tuple[float, float],
    area: Tuple[float, float, float, float],
    resolution: float = 0.002,
) -> Dict[str, object]:
    """The part of the marked area the tool's contact patch wiped: the RSS task's goal, "sweep a given area".

    The patch is a ``footprint`` rectangle centred at each in-contact sample's position, its length along u turned
    by the sample's yaw about the normal. The marked area is cut into a grid of cells about ``resolution`` on a side
    (exactly the area: the cell size is the extent over a whole number of cells), and a cell is covered when its
    centre lies on a patch. Between two consecutive in-contact samples the patch sweeps: positions are interpolated
    linearly and yaws the shorter way round, at enough intermediate placements that no point of the patch moves
    more than half a cell from one placement to the next. So samples far apart leave no holes, and the swept shape
    differs from the continuous sweep by less than a cell at its border. A sample out of contact breaks the sweep.
    Patches reaching outside the marked area count only their part inside it.

    Args:
        positions: N x 2 tool positions (u, v) [m].
        yaws: N patch yaws [rad] about the normal, 0 with the patch's length along u.
        in_contact: N booleans, from ``contact_mask``.
        footprint: (length along u, width along v) of the contact patch [m], each at least one cell.
        area: the marked rectangle (u_min, v_min, u_max, v_max) [m].
        resolution: the grid's cell size [m].

    Returns:
        ``covered_area_m2`` [m^2]; ``covered_fraction`` of the marked area in [0, 1]; ``grid``, booleans of shape
        (cells along u, cells along v), True where covered (for a plot and for ``coverage_of``); ``cell_size_m``,
        the cells' (du, dv) [m].
    """
    positions, yaws, in_contact, patch = _patch_samples(positions, yaws, in_contact, footprint)
    resolution = _positive("resolution", resolution)
    area = as_rectangle("area", area)
    n_u, n_v, du, dv = _grid_cells(area, resolution)
    if min(patch) < max(du, dv):
        raise ValueError(f"footprint {footprint} is smaller than a grid cell ({du:.3g} x {dv:.3g} m): use a finer grid")
    reach = math.hypot(*patch) / 2
    centres, angles = _placements(positions, yaws, in_contact, min(du, dv) / 2, reach)
    near = _near_area(centres, area, reach, (du, dv))
    grid = np.zeros((n_u, n_v), dtype=bool)
    _paint_patches(grid, centres[near], angles[near], patch, area[:2], (du, dv), reach)
    return {
        "covered_area_m2": float(grid.sum()) * du * dv,
        "covered_fraction": float(grid.mean()),
        "grid": grid,
        "cell_size_m": (du, dv),
    }


def _patch_samples(positions, yaws, in_contact, footprint) -> Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``covered_area``'s samples and footprint as arrays, rejected with a reason when their shapes disagree."""
    positions = as_samples("positions", positions, 2)
    yaws = as_samples("yaws", yaws)
    if yaws.size != positions.shape[0]:
        raise ValueError(f"need one yaw per position, got {yaws.size} yaws for {positions.shape[0]} positions")
    in_contact = as_mask("in_contact", in_contact, yaws.size)
    patch = as_samples("footprint", footprint)
    if patch.size != 2 or np.any(patch <= 0):
        raise ValueError(f"footprint must be (length_u, width_v) with both > 0, got {tuple(patch)}")
    return positions, yaws, in_contact, patch


def _grid_cells(area: Tuple[float, float, float, float], resolution: float) -> Tuple[int, int, float, float]:
    """Cells along u and v and their size (du, dv) [m]: a whole number of cells about ``resolution`` fills the area."""
    u_min, v_min, u_max, v_max = area
    n_u = max(1, round((u_max - u_min) / resolution))
    n_v = max(1, round((v_max - v_min) / resolution))
    return n_u, n_v, (u_max - u_min) / n_u, (v_max - v_min) / n_v


def _near_area(
    centres: np.ndarray, area: Tuple[float, float, float, float], reach: float, cell: Tuple[float, float]
) -> np.ndarray:
    """Mask of the placements whose patch can reach the area (this also keeps far centres from overflowing an index)."""
    u_min, v_min, u_max, v_max = area
    du, dv = cell
    return (
        (centres[:, 0] > u_min - reach - du)
        & (centres[:, 0] < u_max + reach + du)
        & (centres[:, 1] > v_min - reach - dv)
        & (centres[:, 1] < v_max + reach + dv)
    )


def _paint_patches(
    grid: np.ndarray,
    centres: np.ndarray,
    angles: np.ndarray,
    patch: np.ndarray,
    origin: Tuple[float, float],
    cell: Tuple[float, float],
    reach: float,
) -> None:
    """Mark in ``grid`` every cell whose centre lies on a placed patch, in chunks so memory stays bounded."""
    length, width = patch
    u_min, v_min = origin
    du, dv = cell
    n_u, n_v = grid.shape
    # Cell offsets, around the cell holding a patch's centre, whose centres can lie on the patch.
    offsets_u, offsets_v = np.meshgrid(
        np.arange(-math.ceil(reach / du) - 1, math.ceil(reach / du) + 2),
        np.arange(-math.ceil(reach / dv) - 1, math.ceil(reach / dv) + 2),
        indexing="ij",
    )
    offsets_u, offsets_v = offsets_u.ravel(), offsets_v.ravel()
    home_u = np.floor((centres[:, 0] - u_min) / du).astype(int)
    home_v = np.floor((centres[:, 1] - v_min) / dv).astype(int)
    chunk = max(1, CHUNK_CELLS // offsets_u.size)
    for first in range(0, centres.shape[0], chunk):
        rows = slice(first, first + chunk)
        cell_u = home_u[rows, None] + offsets_u
        cell_v = home_v[rows, None] + offsets_v
        # A cell centre relative to the patch's centre, then in the patch's frame (R(yaw)^T times it).
        rel_u = u_min + (cell_u + 0.5) * du - centres[rows, 0, None]
        rel_v = v_min + (cell_v + 0.5) * dv - centres[rows, 1, None]
        cos, sin = np.cos(angles[rows, None]), np.sin(angles[rows, None])
        along, across = cos * rel_u + sin * rel_v, cos * rel_v - sin * rel_u
        hit = (
            (np.abs(along) <= length / 2 + EDGE_SLACK)
            & (np.abs(across) <= width / 2 + EDGE_SLACK)
            & (cell_u >= 0)
            & (cell_u < n_u)
            & (cell_v >= 0)
            & (cell_v < n_v)
        )
        grid[cell_u[hit], cell_v[hit]] = True


def coverage_of(grid: np.ndarray, reference_grid: np.ndarray) -> float:
    """The fraction of the reference's covered cells that ``grid`` covers too (a learned skill against its demo).

    Issue 49's goal: a learned wiping skill replayed at another surface pose covers >= 90 % of what its
    demonstration covered. Cells covered outside the reference neither help nor hurt.

    Args:
        grid: the ``grid`` of ``covered_area`` for the wipe judged.
        reference_grid: the ``grid`` of the reference wipe, on the same marked area and resolution.

    Returns:
        A fraction in [0, 1].
    """
    grid, reference_grid = np.asarray(grid), np.asarray(reference_grid)
    for name, array in (("grid", grid), ("reference_grid", reference_grid)):
        if array.dtype != bool or array.ndim != 2:
            raise ValueError(f"{name} must be a 2-D boolean grid (covered_area's), got {array.dtype} {array.shape}")
    if grid.shape != reference_grid.shape:
        raise ValueError(f"grids of different shapes: {grid.shape} and reference {reference_grid.shape}")
    reference_cells = int(reference_grid.sum())
    if reference_cells == 0:
        raise ValueError("the reference covers nothing: no coverage to compare with")
    return int(np.sum(grid & reference_grid)) / reference_cells
