"""Where a product ended on the shelf, judged from the world: gap, distance, upright or not, neighbours pushed.

One judgement for everyone who asks "was it placed?": the placing skills (PlaceItem, DropItem, ReplaySkill) on the
robot's live view of the scene, and run_thesis on the scene recorded in the bag. Plain data in, no ROS.
"""

import dataclasses
from typing import Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np
from scipy.spatial.transform import Rotation

from teleteach.core.scene import Gap, GapLookup

HEIGHT_TOLERANCE = 0.02  # [m] a product centre farther than this above/below its gap's target is not on the board
UPRIGHT_TILT = 10.0  # [deg] largest tilt of a product's vertical axis that still counts as standing upright
NEIGHBOUR_LIMIT = 0.01  # [m] a neighbour moved farther than this was pushed (thesis III-C: "without moving others")
CARRIED = 0.05  # [m] a product that moved farther than this was carried, not pushed


@dataclasses.dataclass(frozen=True)
class Placement:
    """A product's final pose relative to the gaps of the scene.

    ``gap`` is the gap it stands in (None when in none); ``nearest_gap`` the gap whose target is closest, and
    ``distance_m`` / ``height_error_m`` the horizontal / vertical distance from that target [m]; ``tilt_deg`` the
    angle between its vertical axis and the world's; ``neighbour_moves`` how far each product standing near that gap
    at the start moved [m].
    """

    product: str
    gap: Optional[str]
    nearest_gap: str
    distance_m: float
    height_error_m: float
    tilt_deg: float
    neighbour_moves: Dict[str, float]

    @property
    def upright(self) -> bool:
        """Whether the product stands upright."""
        return self.tilt_deg <= UPRIGHT_TILT

    @property
    def neighbours_max_move_m(self) -> float:
        """The largest move of a neighbour [m] (0 when it has none)."""
        return max(self.neighbour_moves.values(), default=0.0)

    @property
    def displaced(self) -> List[str]:
        """Neighbours pushed by more than NEIGHBOUR_LIMIT."""
        return sorted(name for name, moved in self.neighbour_moves.items() if moved > NEIGHBOUR_LIMIT)

    def problems(self, expected_gap: Optional[str] = None) -> List[str]:
        """What is wrong with this placement (empty: upright in a gap, in ``expected_gap`` if given, nothing pushed)."""
        wanted = expected_gap or self.nearest_gap
        problems = []
        if self.gap != wanted:
            problems.append(
                f"{self.product} ended {100.0 * self.distance_m:.1f} cm from {self.nearest_gap} "
                f"({100.0 * self.height_error_m:.1f} cm in height)"
                + ("" if self.nearest_gap == wanted else f", not in {wanted}")
            )
        if not self.upright:
            problems.append(f"{self.product} is not upright (tilted {self.tilt_deg:.0f} deg)")
        for name in self.displaced:
            problems.append(f"{self.product}'s neighbour {name} moved {100.0 * self.neighbour_moves[name]:.1f} cm")
        return problems


def tilt(quaternion: Sequence[float]) -> float:
    """Angle [deg] between a body's z axis, given its (x, y, z, w) orientation, and the world's vertical."""
    axis = Rotation.from_quat(np.asarray(quaternion, dtype=float)).apply([0.0, 0.0, 1.0])
    return float(np.degrees(np.arccos(np.clip(axis[2], -1.0, 1.0))))


def neighbours(gap: Gap, initial: Mapping[str, np.ndarray], product: str) -> List[str]:
    """Products other than ``product`` that stood within two gap widths of the gap's target at the start."""
    target = np.asarray(gap.position, dtype=float)
    return sorted(
        name
        for name, position in initial.items()
        if name != product and np.linalg.norm(np.asarray(position, dtype=float) - target) <= 2.0 * gap.width
    )


def judge(
    scene: GapLookup,
    product: str,
    pose: Tuple[Sequence[float], Sequence[float]],
    initial: Mapping[str, np.ndarray],
    final: Mapping[str, np.ndarray],
    expected_gap: Optional[str] = None,
) -> Placement:
    """Judge where ``product`` ended.

    Args:
        scene: the gaps (the scene file's, or the perceived ones: teleteach.perception.ObservedScene).
        product: the product's name.
        pose: its final centre [m] and (x, y, z, w) quaternion in world.
        initial: every product's centre [m] before the placement (for the neighbours' moves).
        final: every product's centre [m] after it.
        expected_gap: the gap it was meant for (default: the nearest one); the distances are measured from it.

    Raises:
        SceneError: ``expected_gap`` is not a gap of the scene.
    """
    position = np.asarray(pose[0], dtype=float)
    nearest = scene.gap(expected_gap) if expected_gap else scene.nearest_gap(position)
    horizontal, vertical = nearest.distance(position)
    inside = horizontal <= nearest.tolerance and vertical <= HEIGHT_TOLERANCE
    moves = {
        name: float(np.linalg.norm(np.asarray(final[name], dtype=float) - np.asarray(initial[name], dtype=float)))
        for name in neighbours(nearest, initial, product)
        if name in final
    }
    return Placement(
        product=product,
        gap=nearest.name if inside else None,
        nearest_gap=nearest.name,
        distance_m=horizontal,
        height_error_m=vertical,
        tilt_deg=tilt(pose[1]),
        neighbour_moves=moves,
    )


def placed_products(
    scene: GapLookup, initial: Mapping[str, np.ndarray], final: Mapping[str, Tuple[np.ndarray, np.ndarray]]
) -> List[Placement]:
    """The products that were carried (moved more than CARRIED) and ended at a gap's board height near a gap.

    Those are the products somebody placed, or tried to: the ones that stayed, or were only pushed, are left out.
    """
    positions = {name: pose[0] for name, pose in final.items()}
    placements = []
    for name, pose in sorted(final.items()):
        start = initial.get(name)
        if start is None or np.linalg.norm(np.asarray(pose[0]) - np.asarray(start)) <= CARRIED:
            continue
        placement = judge(scene, name, pose, initial, positions)
        if (
            placement.height_error_m <= HEIGHT_TOLERANCE
            and placement.distance_m <= 2.0 * scene.gap(placement.nearest_gap).width
        ):
            placements.append(placement)
    return placements
