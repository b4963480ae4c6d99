"""What a thesis run achieved, computed from plain data (no ROS): tree edits, stiffness phases, product placement.

The checks mirror the thesis' results: III-B removes PlaceItem, III-E inserts the demonstrated skill at the dialled
index, the recorded stiffness shows III-C's three phases (approach compliant with equal low X/Y stiffness, Y
stiffened for alignment, X stiffened for insertion), and the product ends in the gap without pushing its neighbours.
"""

import dataclasses
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from teleteach.skill_file import Skill

# Phases of the demonstration trajectories [s from the start of the recording]: approach, alignment, insertion
PHASES = {
    "perpendicular": ((0.0, 3.0), (3.0, 5.0), (5.0, 11.0)),  # config/trajectories/perpendicular.yaml
    "angled_45": ((0.0, 3.0), (3.0, 7.0), (7.0, 12.0)),  # config/trajectories/angled_45.yaml
}


@dataclasses.dataclass
class StiffnessPhases:
    """Principal stiffness along base X and Y [N/m] per phase of a recorded perpendicular placement."""

    approach_x: float
    approach_y: float
    alignment_y: float
    insertion_x: float

    @property
    def alignment_ratio(self) -> float:
        """Y stiffness during alignment over Y stiffness during approach."""
        return self.alignment_y / self.approach_y

    @property
    def insertion_ratio(self) -> float:
        """X stiffness during insertion over X stiffness during approach."""
        return self.insertion_x / self.approach_x

    def check(self, min_ratio: float = 3.0, stiffer_insertion: bool = True) -> List[str]:
        """Problems with the three phases (empty: III-C's pattern is there; III-D's without ``stiffer_insertion``)."""
        problems = []
        if abs(self.approach_x - self.approach_y) > 0.1 * max(self.approach_x, self.approach_y):
            problems.append(f"approach X/Y stiffness not equal ({self.approach_x:.0f} vs {self.approach_y:.0f} N/m)")
        if self.alignment_ratio < min_ratio:
            problems.append(f"Y stiffness in alignment only {self.alignment_ratio:.1f}x the approach's")
        if stiffer_insertion and self.insertion_ratio < min_ratio:
            problems.append(f"X stiffness in insertion only {self.insertion_ratio:.1f}x the approach's")
        return problems


def stiffness_phases(skill: Skill, trajectory: str = "perpendicular") -> StiffnessPhases:
    """Median stiffness in the approach, peak Y in alignment and peak X in insertion, from the diagonal of K."""
    times = skill.time - skill.time[0]
    kx, ky = skill.stiffness[:, 0, 0], skill.stiffness[:, 1, 1]
    approach_window, alignment_window, insertion_window = PHASES[trajectory]

    def window(bounds: Tuple[float, float]) -> np.ndarray:
        inside = (times >= bounds[0]) & (times < bounds[1])
        if not inside.any():
            raise ValueError(f"the recording ({times[-1]:.1f} s) has no samples in {bounds[0]:g}-{bounds[1]:g} s")
        return inside

    approach = window(approach_window)
    return StiffnessPhases(
        approach_x=float(np.median(kx[approach])),
        approach_y=float(np.median(ky[approach])),
        alignment_y=float(ky[window(alignment_window)].max()),
        insertion_x=float(kx[window(insertion_window)].max()),
    )


def alignment_axis_yaw(skill: Skill, trajectory: str = "perpendicular") -> float:
    """Direction [deg, (-90, 90]] of the stiffest horizontal axis of K at the end of the alignment phase (III-D)."""
    times = skill.time - skill.time[0]
    index = max(int(np.searchsorted(times, PHASES[trajectory][1][1])) - 1, 0)
    values, vectors = np.linalg.eigh(skill.stiffness[index][:2, :2])
    major = vectors[:, int(np.argmax(values))]
    yaw = float(np.degrees(np.arctan2(major[1], major[0])))
    return yaw - 180.0 if yaw > 90.0 else yaw + 180.0 if yaw <= -90.0 else yaw


@dataclasses.dataclass
class Placement:
    """Where the placed product ended relative to the gap, and how far every other shelf product moved [m]."""

    product: str
    horizontal_error: float
    vertical_error: float
    neighbour_moves: Dict[str, float]

    def check(self, tolerance: float = 0.02, neighbour_limit: float = 0.01) -> List[str]:
        """Problems with the placement (empty: on the shelf in the gap, neighbours in place)."""
        problems = []
        if self.horizontal_error > tolerance or self.vertical_error > tolerance:
            problems.append(
                f"{self.product} is {100 * self.horizontal_error:.1f} cm beside and {100 * self.vertical_error:.1f} cm "
                f"above/below the gap's target (limit {100 * tolerance:.0f} cm)"
            )
        for name, moved in sorted(self.neighbour_moves.items()):
            if moved > neighbour_limit:
                problems.append(f"neighbour {name} moved {100 * moved:.1f} cm (limit {100 * neighbour_limit:.0f} cm)")
        return problems

    @property
    def displaced(self) -> List[str]:
        """Neighbours moved by more than 1 cm."""
        return sorted(name for name, moved in self.neighbour_moves.items() if moved > 0.01)


def placement(
    product: str,
    gap_position: Sequence[float],
    initial: Dict[str, np.ndarray],
    final: Dict[str, np.ndarray],
    shelf_prefix: str = "product_shelf",
) -> Placement:
    """Compare product positions (world [m]) at the start and the end of a run."""
    if product not in final:
        raise ValueError(f"no final position of {product}")
    offset = np.asarray(final[product], dtype=float) - np.asarray(gap_position, dtype=float)
    moves = {
        name: float(np.linalg.norm(np.asarray(final[name]) - np.asarray(start)))
        for name, start in initial.items()
        if name.startswith(shelf_prefix) and name in final
    }
    return Placement(product, float(np.hypot(offset[0], offset[1])), float(abs(offset[2])), moves)


def sequence_changes(sequences: Sequence[Tuple[str, ...]]) -> List[Tuple[str, ...]]:
    """The distinct consecutive values of a composite's children over time (each edit once)."""
    changes: List[Tuple[str, ...]] = []
    for children in sequences:
        if not changes or changes[-1] != tuple(children):
            changes.append(tuple(children))
    return changes


def describe_edit(before: Sequence[str], after: Sequence[str]) -> str:
    """One line: which leaves left or joined a sequence, and where."""
    removed = [name for name in before if name not in after]
    added = [(after.index(name), name) for name in after if name not in before]
    parts = [f"removed {name}" for name in removed] + [f"inserted {name} at index {index}" for index, name in added]
    return ", ".join(parts) if parts else "reordered"


def expected_sequences(initial: Sequence[str], removed: Optional[str], inserted: Optional[str], index: Optional[int]):
    """The children after III-B (``removed`` gone) and after III-E (``inserted`` at ``index``); None: no such edit."""
    after_removal = [name for name in initial if name != removed]
    after_insertion = list(after_removal)
    if inserted is not None and index is not None:
        after_insertion.insert(index, inserted)
    return tuple(after_removal), tuple(after_insertion)
