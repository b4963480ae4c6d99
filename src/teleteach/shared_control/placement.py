"""Shared control in the placement: the RSS paper's assistance where the operator puts a product into a gap.

The paper's controller keeps what the operator asks for as far as the workspace's boundaries and the obstacles allow.
In a placement, the boundary is the opening of the target gap between its neighbours, and the neighbours (with the
shelf front they stand at) are the obstacles. Seen in the gap's frame (x into the shelf, y across, z up; origin where
the held product's centre belongs), what the held product may do is a box that depends on where it is:

- in front of the opening (the product's front face not past the neighbours' fronts): free;
- asked to go past the front within ``capture`` of the opening's corridor (across): guided into the corridor;
- asked to go past it from farther aside: held at the front, a wall the operator slides along until aligned;
- past the front: kept in the corridor, and not below the board.

The corridor is where the product's centre leaves ``margin`` to each neighbour: half the gap's free width, less the
product's half width across it, less the margin. Each rule is a box, so the assisted target is the operator's own
clipped to it, its exact projection (the paper's optimisation with no horizon, which a box needs none for); the
teleoperation's speed limit then moves the arm there. The gap, its neighbours and the held product's size and turn are
from perception (the held product is the perceived one nearest the hand); where the product sits in the hand is the
grasp's (centred between the fingers, ``held_below`` beyond the hand along its axis), as the skills assume: believing
perception's bias on a product in the hand (a few millimetres) steered it into a neighbour in development trials.
"""

import dataclasses
from typing import Optional, Tuple

import numpy as np
from scipy.spatial.transform import Rotation

from teleteach.core.frames import Transform
from teleteach.core.observed import ObservedScene
from teleteach.core.teleoperation import AssistanceParameters

HELD_WITHIN = 0.15  # [m] the perceived product nearest the hand, this close to it, is the one held
NEIGHBOUR_BAND = (0.25, 0.15, 0.1)  # [m] a product this close to the gap (depth, beyond its width across, height) is a
#                                      neighbour


@dataclasses.dataclass(frozen=True)
class Opening:
    """A gap's opening and the product in the hand, as the assistance uses them.

    Attributes:
        gap: its name.
        frame: the gap's frame in the base frame.
        width: [m] the gap's free width between its neighbours.
        fronts: [m] the depth (gap x) of the neighbours' fronts (0 without neighbours: the gap's own centre).
        in_hand: the held product's box in the hand's (TCP's) frame: where the grasp holds it, turned as perceived.
        size: [m] that box's size.
    """

    gap: str
    frame: Transform
    width: float
    fronts: float
    in_hand: Transform
    size: np.ndarray

    @classmethod
    def perceived(
        cls, scene: ObservedScene, gap: str, base: Transform, hand: np.ndarray, held_below: float
    ) -> Tuple[Optional["Opening"], str]:
        """The opening of ``gap`` from what perception reports, or (None, why not).

        Args:
            scene: the perceived scene (world frame).
            gap: the gap to place at.
            base: the base frame in world (TF world -> base_link).
            hand: the TCP's pose in the base frame (x y z qx qy qz qw).
            held_below: [m] the grasped product's centre beyond the TCP along the hand's z (the grasp's height above
                the product's centre, config/skills_motion.yaml).
        """
        if gap not in scene.gaps:
            return None, f"perception reports no {gap}"
        frame = scene.gaps[gap].frame  # world <- gap
        to_gap = frame.inverse()
        hand_world = base * Transform.from_pose(hand)
        nearest = min(
            scene.products.values(), key=lambda box: np.linalg.norm(box.position - hand_world.position), default=None
        )
        if nearest is None or np.linalg.norm(nearest.position - hand_world.position) > HELD_WITHIN:
            return None, "no perceived product in the hand"
        width = scene.gaps[gap].width
        band = np.array(NEIGHBOUR_BAND) + np.array([0.0, width / 2.0, 0.0])
        fronts = []
        for box in scene.products.values():
            centre = to_gap.apply_point(box.position)
            if box.name != nearest.name and np.all(np.abs(centre) <= band):
                fronts.append(
                    centre[0] - _half_extents(frame.rotation.inv() * Rotation.from_quat(box.quaternion), box.size)[0]
                )
        turn = hand_world.rotation.inv() * Rotation.from_quat(nearest.quaternion)
        in_hand = Transform(np.array([0.0, 0.0, held_below]), turn)
        return cls(gap, base.inverse() * frame, width, min(fronts, default=0.0), in_hand, np.asarray(nearest.size)), ""


def _half_extents(rotation: Rotation, size) -> np.ndarray:
    """A box turned by ``rotation`` (in the gap's axes): its half extents along them [m]."""
    return 0.5 * np.abs(rotation.as_matrix()) @ np.asarray(size, dtype=float)


def assist(
    opening: Opening, current: np.ndarray, target: np.ndarray, parameters: AssistanceParameters
) -> Tuple[np.ndarray, str]:
    """The hand's target (base frame [m]) the assistance lets through, from the hand's pose now, and what it did.

    ``current`` (x y z qx qy qz qw, base frame) decides the rule (in front of the opening or past it) and turns the
    held product with the hand; ``target`` is clipped to its box.
    """
    to_gap = opening.frame.inverse()
    hand_in_gap = to_gap * Transform.from_pose(current)
    product = hand_in_gap.rotation * opening.in_hand.rotation  # the held product's turn in the gap's axes
    offset = hand_in_gap.rotation.apply(opening.in_hand.position)  # its centre from the hand, gap frame
    half = _half_extents(product, opening.size)
    corridor = max(0.0, opening.width / 2.0 - half[1] - parameters.margin)
    front = opening.fronts - half[0] - parameters.front_margin
    now = hand_in_gap.position + offset  # the held product's centre, gap frame
    asked = to_gap.apply_point(target) + offset
    allowed = asked.copy()
    said = ""
    if now[0] > front:  # past the front: in the corridor, not below the board
        allowed[1] = np.clip(asked[1], -corridor, corridor)
        allowed[2] = max(asked[2], 0.0)
        said = f"kept in {opening.gap}'s opening" if not np.allclose(allowed, asked) else ""
    elif asked[0] > front:
        if abs(asked[1]) <= corridor + parameters.capture:
            allowed[1] = np.clip(asked[1], -corridor, corridor)
            said = f"guided into {opening.gap}'s opening" if allowed[1] != asked[1] else ""
        else:
            allowed[0] = front
            off = (abs(asked[1]) - corridor) * 100.0
            said = f"held at {opening.gap}'s front: {off:.1f} cm beside its opening"
    return opening.frame.apply_point(allowed - offset), said
