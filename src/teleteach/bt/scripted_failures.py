"""Failure situations in the supermarket and a scripted operator who repairs them by a rule (issue 52, item 4).

A situation is drawn from a seed: the thesis tree (config/tree.yaml), its PlaceItem sometimes already wrapped in a
retry by an earlier repair; the library (config/skills.yaml), with or without a taught placing skill (PlaceTaught and
the skill it replays); a product of config/supermarket.yaml with another mass and width; a gap of the scene met from a
base pose in front of it, off by the base's error; and a skill failing for a reason it detects, worded as the skills
word it (teleteach.skills.predefined and motion).

The scripted operator's rule (:func:`scripted_repair`) is what the policy is not told; its answer depends on the
failure's category, the measured values, the product, the gap's clearance, the library and the tree's shape:

- a placement that failed (missed, pushed a neighbour, tilted) under a retry already: replace PlaceItem by PlaceTaught
  when the library has it, else remove it (skip the placement);
- a placement with less than 4 mm clearance per side: replace it by PlaceTaught if the library has it, else retry 3;
- a placement that missed by more than 2.5 cm: drive again first (insert MoveBase in front of it);
- any other placement failure: retry 2;
- a grasp that failed on a product wider than 65 mm, or that slipped on one heavier than 0.7 kg: remove the pick;
  another failed or slipped grasp: retry 2; a product not on the table: remove the pick;
- a base that did not reach its pose: retry 2.

:func:`novel_situation` draws failures no demonstration can cover (an arm blocked, a product far heavier than any):
the policy should ask there.
"""

import dataclasses
import math
import typing

import numpy as np

from teleteach.bt.editor import EditRequest
from teleteach.bt.library import SkillLibrary
from teleteach.bt.situations import Situation, describe
from teleteach.bt.tree import Spec, load_tree
from teleteach.bt.tree_policy import generalise
from teleteach.core.paths import config_file
from teleteach.core.scene import BasePose, Gap, Scene, load_scene

PICKS = {"PickItem": "product_pick_1", "PickItem2": "product_pick_2"}
DRIVES = ("MoveBase", "MoveBase2")
PLACE = "PlaceItem"
TAUGHT = (("PlaceTaught", "predefined"), ("DemonstratedPlace_1", "dmp"))
WIDTHS = (0.040, 0.075)  # [m] products across the fingers (the scene's are 50 mm)
MASSES = (0.2, 1.2)  # [kg]
NOVEL_MASS = (2.5, 4.0)  # [kg] far beyond MASSES
TIGHT = 0.004  # [m] clearance per side below which the operator does not trust PlaceItem
FAR_MISS = 0.025  # [m] a miss larger than this: the base stood off
WIDE = 0.065  # [m] a product wider than this does not fit the fingers' grasp
HEAVY = 0.7  # [kg] a heavier product that slipped is given up
BASE_ERROR = (0.03, 0.05)  # [m], [rad] of the base at its pose (uniform within +-)
FACING = 0.9  # [m] a base pose within this of a gap faces it


class World(typing.NamedTuple):
    """What situations are drawn from: the scene, the tree's description and the library without taught skills."""

    scene: Scene
    tree: Spec
    execution: str
    library: typing.Tuple[typing.Tuple[str, str], ...]

    @classmethod
    def load(cls) -> "World":
        """config/supermarket.yaml, config/tree.yaml, config/skills.yaml."""
        library = SkillLibrary.load(config_file("skills.yaml"))
        tree = load_tree(config_file("tree.yaml"), library)
        return cls(load_scene(), tree.root, tree.execution, tuple((entry.name, entry.kind) for entry in library))


def scripted_repair(situation: Situation) -> typing.Tuple[EditRequest, ...]:
    """The scripted operator's edits for a situation (the module docstring's rule)."""
    node, failure, measured = situation.node, situation.failure.category, situation.failure.measured
    taught = any(name == TAUGHT[0][0] for name, _ in situation.library)
    if node.skill == PLACE:
        clearance = situation.target.clearance_m
        if node.decorator == "retry":
            return _replace(situation, TAUGHT[0][0]) if taught else _remove(situation)
        if clearance < TIGHT:
            return _replace(situation, TAUGHT[0][0]) if taught else _retry(situation, 3)
        if measured.get("placement_error_m", 0.0) > FAR_MISS:
            return (EditRequest("MoveBase", "insert", node.index, node.parent),)
        return _retry(situation, 2)
    if failure == "product_missing":
        return _remove(situation)
    if failure == "grasp_failed" and situation.product.width_m > WIDE:
        return _remove(situation)
    if failure == "grasp_slipped" and situation.product.mass_kg > HEAVY:
        return _remove(situation)
    return _retry(situation, 2)


def _retry(situation: Situation, attempts: int) -> typing.Tuple[EditRequest, ...]:
    return (EditRequest(situation.node.name, "wrap", node_type="retry", parameter=float(attempts)),)


def _remove(situation: Situation) -> typing.Tuple[EditRequest, ...]:
    return (EditRequest(situation.node.name, "remove"),)


def _replace(situation: Situation, skill: str) -> typing.Tuple[EditRequest, ...]:
    node = situation.node
    return EditRequest(skill, "insert", node.index, node.parent), EditRequest(node.name, "remove")


def draw_situation(world: World, gaps: typing.Sequence[str], rng: np.random.Generator) -> Situation:
    """One failure at a random node: a pick, a drive to one of ``gaps`` or a placement into one of them."""
    where = rng.choice(["pick", "drive", "place", "place"])
    taught = bool(rng.random() < 0.6)
    library = world.library + (TAUGHT if taught else ())
    if where == "pick":
        node = str(rng.choice(sorted(PICKS)))
        product = _varied(world.scene.product(PICKS[node]), rng)
        category = rng.choice(["grasp_failed", "grasp_slipped", "product_missing"])
        reason = _pick_reason(category, product, rng)
        return describe(world.tree, world.execution, node, reason, library, product)
    gap = world.scene.gap(str(rng.choice(list(gaps))))
    base = _base_in_front(world.scene, gap, rng)
    product = _varied(world.scene.product(PICKS["PickItem"]), rng)
    if where == "drive":
        node = str(rng.choice(DRIVES))
        offset, turn = rng.uniform(0.05, 0.4), rng.uniform(0.0, 0.3)
        reason = (
            f"the base did not reach ({base.x:.2f}, {base.y:.2f}, {base.yaw:.2f}) within {rng.integers(20, 40)} s: "
            f"{offset:.3f} m, {turn:.3f} rad away"
        )
        return describe(world.tree, world.execution, node, reason, library, product, gap, base)
    tree = _wrapped(world.tree, PLACE) if rng.random() < 0.25 else world.tree
    reason = _place_reason(
        str(rng.choice(["placement_missed", "neighbour_pushed", "product_tilted"])), product, gap, rng
    )
    return describe(tree, world.execution, PLACE, reason, library, product, gap, base)


def novel_situation(world: World, gaps: typing.Sequence[str], rng: np.random.Generator) -> Situation:
    """A failure unlike every drawn one: the arm blocked on its way, or a slipped grasp of a far heavier product."""
    library = world.library + TAUGHT
    if rng.random() < 0.5:
        gap = world.scene.gap(str(rng.choice(list(gaps))))
        reason = (
            f"the arm did not reach its goal: {rng.uniform(0.05, 0.5):.3f} rad off 1.0 s after the trajectory's end "
            "(blocked?)"
        )
        product = _varied(world.scene.product(PICKS["PickItem"]), rng)
        base = _base_in_front(world.scene, gap, rng)
        return describe(world.tree, world.execution, PLACE, reason, library, product, gap, base)
    node = str(rng.choice(sorted(PICKS)))
    product = dataclasses.replace(_varied(world.scene.product(PICKS[node]), rng), mass=rng.uniform(*NOVEL_MASS))
    return describe(world.tree, world.execution, node, _pick_reason("grasp_slipped", product, rng), library, product)


def _varied(product, rng: np.random.Generator):
    """The product with another mass and width (depth and height as the scene has them)."""
    depth, _, height = product.size
    return dataclasses.replace(product, mass=rng.uniform(*MASSES), size=(depth, rng.uniform(*WIDTHS), height))


def _pick_reason(category: str, product, rng: np.random.Generator) -> str:
    if category == "grasp_failed":
        width = 1000.0 * product.size[1]
        return f"the grasp of {product.name} ({width:.0f} mm wide) failed: the fingers closed on nothing"
    if category == "grasp_slipped":
        return (
            f"{product.name} is not in the gripper after grasping (finger opening {rng.uniform(0.0, 0.01):.3f} m, "
            f"nearest product {rng.uniform(0.03, 0.2):.3f} m from the fingers)"
        )
    return f"{product.name} is not on the table"


def _place_reason(category: str, product, gap: Gap, rng: np.random.Generator) -> str:
    """PlaceItem's message (teleteach.core.placement.Placement.problems) for one problem."""
    if category == "placement_missed":
        return (
            f"{product.name} ended {rng.uniform(1.0, 4.5):.1f} cm from {gap.name} "
            f"({rng.uniform(0.0, 1.5):.1f} cm in height)"
        )
    if category == "neighbour_pushed":
        return f"{product.name}'s neighbour product_shelf_{rng.integers(1, 14)} moved {rng.uniform(1.1, 3.0):.1f} cm"
    return f"{product.name} is not upright (tilted {rng.uniform(12.0, 60.0):.0f} deg)"


def _base_in_front(scene: Scene, gap: Gap, rng: np.random.Generator) -> BasePose:
    """A base pose of the scene that faces ``gap`` (within FACING), off by the base's error."""
    facing = [
        pose
        for pose in scene.base_poses.values()
        if math.hypot(gap.position[0] - pose.x, gap.position[1] - pose.y) < FACING
    ]
    pose = facing[rng.integers(len(facing))]
    position, yaw = BASE_ERROR
    return BasePose(
        pose.x + rng.uniform(-position, position),
        pose.y + rng.uniform(-position, position),
        pose.yaw + rng.uniform(-yaw, yaw),
    )


def _wrapped(spec: Spec, name: str) -> Spec:
    """The tree with node ``name`` inside a retry (an earlier repair)."""
    if spec["name"] == name:
        return {"type": "retry", "name": f"Retry_{name}", "attempts": 2, "children": [spec]}
    if "children" not in spec:
        return spec
    return {**spec, "children": [_wrapped(child, name) for child in spec["children"]]}


def demonstrations(
    world: World, gaps: typing.Sequence[str], per_repair: int, rng: np.random.Generator, draws: int = 1000
) -> typing.List[typing.Tuple[Situation, typing.Tuple[EditRequest, ...]]]:
    """Situations the operator answered, at most ``per_repair`` of each kind of repair (an operator gives a handful).

    A kind of repair is a failure's category and the repair that answered it: "retry" after a slipped grasp and
    "retry" after a missed placement are two.

    The operator meets ``draws`` failures and answers each; the first ``per_repair`` of each kind are kept.
    """
    found: typing.List[typing.Tuple[Situation, typing.Tuple[EditRequest, ...]]] = []
    counts: typing.Dict[typing.Tuple[str, typing.Tuple[EditRequest, ...]], int] = {}
    for _ in range(draws):
        situation = draw_situation(world, gaps, rng)
        edits = scripted_repair(situation)
        kind = (situation.failure.category, generalise(edits, situation.node))
        if counts.get(kind, 0) < per_repair:
            counts[kind] = counts.get(kind, 0) + 1
            found.append((situation, edits))
    return found
