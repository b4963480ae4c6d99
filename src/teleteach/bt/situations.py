"""A failure (or an unasked edit) described as features a policy can generalise over (issue 52).

The repair memory (:mod:`teleteach.bt.repairs`) compares a node's name and its reason's words: another product, gap
or integer is another failure. A policy needs what the answer may depend on instead, in numbers and categories:

- the node: its skill, the skill's kind, its type, where it stands (parent, index, neighbours, a decorator above);
- the failure: the reason parsed into categories and the values it measured, in SI units (:func:`parse_reason`;
  the patterns follow the messages the skills raise, e.g. ``... ended 1.4 cm from gap_1 (0.3 cm in height)``);
- the product in the task (mass, size) and the target gap (free width, clearance per side, shelf level, distance
  and bearing from the base, the angle it is faced at), from the scene (:mod:`teleteach.core.scene`);
- the library: which skills there are and how many of each kind.

This module is the one place that defines them; the ROS side only fills them (:func:`describe`). Every numeric
feature has a scale, a difference in it that matters: the policy measures distances in these scales, and a situation
farther than a few scales beyond what was demonstrated is one it does not know.
"""

import dataclasses
import hashlib
import math
import re
import typing

from teleteach.core.rotations import wrap_angle
from teleteach.core.scene import BasePose, Gap, Product

FeatureValue = typing.Union[float, str]

# Each failure category: the pattern of the skills' message, and its measured values (name, unit factor to SI).
_M, _CM, _MM, _S, _RAD, _DEG = 1.0, 0.01, 0.001, 1.0, 1.0, 1.0
_NUMBER = r"([-+]?\d+(?:\.\d+)?)"
FAILURES: typing.Tuple[typing.Tuple[str, "re.Pattern[str]", typing.Tuple[typing.Tuple[str, float], ...]], ...] = (
    ("grasp_failed", re.compile(rf"the grasp of \S+ \({_NUMBER} mm wide\) failed"), (("grasp_width_m", _MM),)),
    (
        "grasp_slipped",
        re.compile(rf"not in the gripper after grasping \(finger opening {_NUMBER} m, nearest product {_NUMBER} m"),
        (("finger_opening_m", _M), ("product_offset_m", _M)),
    ),
    ("product_missing", re.compile(r"is not on the table"), ()),
    ("gripper_occupied", re.compile(r"the gripper already holds"), ()),
    ("release_failed", re.compile(r"is still in the gripper after releasing it"), ()),
    (
        "placement_missed",
        re.compile(rf"ended {_NUMBER} cm from \S+ \({_NUMBER} cm in height\)"),
        (("placement_error_m", _CM), ("height_error_m", _CM)),
    ),
    ("product_tilted", re.compile(rf"is not upright \(tilted {_NUMBER} deg\)"), (("tilt_deg", _DEG),)),
    ("neighbour_pushed", re.compile(rf"neighbour \S+ moved {_NUMBER} cm"), (("neighbour_move_m", _CM),)),
    ("hand_empty", re.compile(r"no product in the gripper to|there is none in the hand|the hand holds none"), ()),
    ("not_in_hand", re.compile(rf"in the hand \(\S+ is {_NUMBER} cm from the hand's hold"), (("hold_offset_m", _CM),)),
    ("gap_empty", re.compile(r"^no product in \S+"), ()),
    ("no_taught_skill", re.compile(r"no taught skill places at"), ()),
    ("arm_blocked", re.compile(rf"the arm did not reach its goal: {_NUMBER} rad off"), (("joint_error_rad", _RAD),)),
    ("unreachable", re.compile(r"needs a joint flip|no arm posture reaches"), ()),
    (
        "base_not_reached",
        re.compile(rf"the base did not reach \(.*?\) within \d+ s: {_NUMBER} m, {_NUMBER} rad away"),
        (("base_offset_m", _M), ("base_turn_rad", _RAD)),
    ),
    ("base_refused", re.compile(r"move_base did not reach"), ()),
    ("timed_out", re.compile(rf"did not finish within {_NUMBER} s"), (("timeout_s", _S),)),
)
UNKNOWN_FAILURE = "other"  # a reason no pattern recognises: still a category, one the policy may not know

# Numeric features: name -> scale, a difference that matters (in the feature's unit).
MEASURED_SCALES = {
    "grasp_width_m": 0.005,
    "finger_opening_m": 0.005,
    "product_offset_m": 0.01,
    "placement_error_m": 0.005,
    "height_error_m": 0.005,
    "tilt_deg": 10.0,
    "neighbour_move_m": 0.005,
    "hold_offset_m": 0.01,
    "joint_error_rad": 0.05,
    "base_offset_m": 0.05,
    "base_turn_rad": 0.1,
    "timeout_s": 5.0,
}
PRODUCT_SCALES = {"mass_kg": 0.15, "width_m": 0.005, "depth_m": 0.005, "height_m": 0.02}
TARGET_SCALES = {
    "gap_width_m": 0.005,
    "clearance_m": 0.002,  # per side: (gap width - product width) / 2
    "level_m": 0.05,  # the gap's height above the floor (the shelf level)
    "distance_m": 0.05,  # from base_link to the gap, on the floor
    "bearing_rad": 0.2,  # of the gap seen from the base, against the base's heading
    "facing_rad": 0.2,  # between the base's heading and the direction into the shelf
}
CONTEXT_SCALES = {"index": 1.0, "siblings": 1.0, "depth": 1.0}
LIBRARY_KINDS = ("predefined", "condition", "stiffness", "shared_control", "dmp")
SCALES = {
    **{f"measured:{name}": scale for name, scale in MEASURED_SCALES.items()},
    **{f"product:{name}": scale for name, scale in PRODUCT_SCALES.items()},
    **{f"target:{name}": scale for name, scale in TARGET_SCALES.items()},
    **{f"node:{name}": scale for name, scale in CONTEXT_SCALES.items()},
    **{f"library:{kind}": 1.0 for kind in LIBRARY_KINDS},
}
CATEGORIES = (
    "node:skill",
    "node:kind",
    "node:type",
    "node:parent_type",
    "node:decorator",
    "node:previous",
    "node:next",
    "failure",
)


def feature_set() -> str:
    """A digest of the feature definitions: a policy saved under another set cannot be read with this one."""
    described = repr((sorted(SCALES.items()), CATEGORIES, [(name, pattern.pattern) for name, pattern, _ in FAILURES]))
    return hashlib.sha256(described.encode()).hexdigest()[:16]


class Failure(typing.NamedTuple):
    """A reason parsed: its first recognised category, every category it names, and the values it measured (SI)."""

    category: str
    problems: typing.Tuple[str, ...]
    measured: typing.Dict[str, float]


def parse_reason(reason: str) -> Failure:
    """The categories and measured values of a skill's failure message (several problems are joined by '; ')."""
    problems: typing.List[str] = []
    measured: typing.Dict[str, float] = {}
    for part in reason.split("; "):
        for category, pattern, values in FAILURES:
            match = pattern.search(part)
            if match is None:
                continue
            if category not in problems:
                problems.append(category)
            for (name, unit), text in zip(values, match.groups()):
                value = float(text) * unit
                measured[name] = max(measured.get(name, -math.inf), value)  # two neighbours pushed: the larger move
            break
    return Failure(problems[0] if problems else UNKNOWN_FAILURE, tuple(problems), measured)


@dataclasses.dataclass(frozen=True)
class NodeContext:
    """The failed (or edited) node and the tree's shape around it; names of neighbours are their skills."""

    name: str
    skill: str  # the leaf's skill ("" for a composite)
    kind: str  # the skill's library kind ("" for a composite)
    type: str  # skill | sequence | selector | ...
    parent: str
    parent_type: str
    in_execution: bool  # the parent is the composite /change_tree edits by default
    index: int  # among the parent's children
    siblings: int  # the parent's children, this one included
    depth: int  # below the root
    decorator: str  # the decorator right above the node's place ("" if none)
    previous: str  # the previous sibling's skill or type ("" if first)
    next: str  # the next sibling's skill or type ("" if last)


@dataclasses.dataclass(frozen=True)
class ProductFeatures:
    """The product the task is about: mass [kg], size across the fingers, into the shelf and tall [m]."""

    name: str
    mass_kg: float
    width_m: float
    depth_m: float
    height_m: float


@dataclasses.dataclass(frozen=True)
class TargetFeatures:
    """The gap the task is about, as the robot meets it (see TARGET_SCALES for the fields)."""

    name: str
    gap_width_m: float
    clearance_m: float
    level_m: float
    distance_m: float
    bearing_rad: float
    facing_rad: float


@dataclasses.dataclass(frozen=True)
class Situation:
    """Where the tree stands when it asks for help (or is edited unasked), as a policy sees it."""

    node: NodeContext
    reason: str
    failure: Failure
    product: typing.Optional[ProductFeatures]
    target: typing.Optional[TargetFeatures]
    library: typing.Tuple[typing.Tuple[str, str], ...]  # (name, kind) of each skill

    def features(self) -> typing.Dict[str, FeatureValue]:
        """Numbers under SCALES' names, categories as strings; what does not apply is left out."""
        node = self.node
        found: typing.Dict[str, FeatureValue] = {
            "node:skill": node.skill,
            "node:kind": node.kind,
            "node:type": node.type,
            "node:parent_type": node.parent_type,
            "node:decorator": node.decorator,
            "node:previous": node.previous,
            "node:next": node.next,
            "node:index": float(node.index),
            "node:siblings": float(node.siblings),
            "node:depth": float(node.depth),
            "failure": self.failure.category,
        }
        found.update({f"problem:{problem}": 1.0 for problem in self.failure.problems})
        found.update({f"measured:{name}": value for name, value in self.failure.measured.items()})
        for prefix, part in (("product", self.product), ("target", self.target)):
            if part is not None:
                values = dataclasses.asdict(part)
                found.update({f"{prefix}:{key}": value for key, value in values.items() if key != "name"})
        for kind in LIBRARY_KINDS:
            found[f"library:{kind}"] = float(sum(1 for _, skill_kind in self.library if skill_kind == kind))
        found.update({f"has:{name}": 1.0 for name, _ in self.library})
        return found

    def to_dict(self) -> typing.Dict[str, typing.Any]:
        """Plain data for yaml (the failure is parsed again from the reason when read)."""
        return {
            "node": dataclasses.asdict(self.node),
            "reason": self.reason,
            "product": None if self.product is None else dataclasses.asdict(self.product),
            "target": None if self.target is None else dataclasses.asdict(self.target),
            "library": [list(entry) for entry in self.library],
        }

    @classmethod
    def from_dict(cls, data: typing.Mapping[str, typing.Any]) -> "Situation":
        """Build from :meth:`to_dict`'s data; TypeError or ValueError (via the dataclasses) when it does not fit."""
        product, target = data["product"], data["target"]
        return cls(
            node=NodeContext(**data["node"]),
            reason=str(data["reason"]),
            failure=parse_reason(str(data["reason"])),
            product=None if product is None else ProductFeatures(**product),
            target=None if target is None else TargetFeatures(**target),
            library=tuple((str(name), str(kind)) for name, kind in data["library"]),
        )


Spec = typing.Dict[str, typing.Any]  # a node of a tree description (teleteach.bt.tree.describe, config/tree.yaml)
DECORATOR_TYPES = ("retry", "timeout", "inverter")


def node_context(root: Spec, name: str, execution: str, kinds: typing.Mapping[str, str]) -> NodeContext:
    """Where node ``name`` stands in the tree description ``root``; ``kinds`` maps skills to their library kind.

    Raises:
        KeyError: the tree has no node ``name``.
    """
    found = _find(root, name, parent=None, depth=0)
    if found is None:
        raise KeyError(f"the tree has no node '{name}'")
    node, parent, depth = found
    decorator = ""
    while parent is not None and parent[0]["type"] in DECORATOR_TYPES:  # a wrapped node stands where its wrapper does
        decorator = decorator or parent[0]["type"]
        node, parent, depth = parent[0], parent[1], depth - 1
    children = parent[0]["children"] if parent is not None else [node]
    index = next(number for number, child in enumerate(children) if child is node)
    spec = found[0]
    skill = spec.get("skill", spec["name"]) if spec["type"] == "skill" else ""
    return NodeContext(
        name=name,
        skill=skill,
        kind=kinds.get(skill, "") if skill else "",
        type=spec["type"],
        parent=parent[0]["name"] if parent is not None else "",
        parent_type=parent[0]["type"] if parent is not None else "",
        in_execution=parent is not None and parent[0]["name"] == execution,
        index=index,
        siblings=len(children),
        depth=depth,
        decorator=decorator,
        previous=_label(children[index - 1]) if index > 0 else "",
        next=_label(children[index + 1]) if index + 1 < len(children) else "",
    )


def _find(spec: Spec, name: str, parent, depth: int):
    """(node, (parent, its parent link), depth) of the node called ``name`` below ``spec``, or None."""
    if spec["name"] == name:
        return spec, parent, depth
    for child in spec.get("children", []):
        found = _find(child, name, (spec, parent), depth + 1)
        if found is not None:
            return found
    return None


def _label(spec: Spec) -> str:
    while spec["type"] in DECORATOR_TYPES:
        spec = spec["children"][0]
    return spec.get("skill", spec["name"]) if spec["type"] == "skill" else spec["type"]


def product_features(product: Product) -> ProductFeatures:
    """A scene product's features; its width is across the fingers (the scene's y edge, which a gap's width holds)."""
    depth, width, height = product.size
    return ProductFeatures(product.name, product.mass, width, depth, height)


def target_features(gap: Gap, product_width: float, base: BasePose) -> TargetFeatures:
    """A gap as the robot at ``base`` meets it with a product ``product_width`` [m] wide."""
    dx, dy = gap.position[0] - base.x, gap.position[1] - base.y
    return TargetFeatures(
        name=gap.name,
        gap_width_m=gap.width,
        clearance_m=(gap.width - product_width) / 2.0,
        level_m=gap.position[2],
        distance_m=math.hypot(dx, dy),
        bearing_rad=wrap_angle(math.atan2(dy, dx) - base.yaw),
        facing_rad=wrap_angle(gap.yaw - base.yaw),
    )


def describe(
    root: Spec,
    execution: str,
    node_name: str,
    reason: str,
    library: typing.Iterable[typing.Tuple[str, str]],
    product: typing.Optional[Product] = None,
    gap: typing.Optional[Gap] = None,
    base: typing.Optional[BasePose] = None,
) -> Situation:
    """The situation of a help request for ``node_name`` with ``reason``.

    Args:
        root: the tree's description (teleteach.bt.tree.describe of the live root).
        execution: the name of the composite /change_tree edits by default.
        node_name: the failed or edited node.
        reason: the failure's message ("" for an unasked edit).
        library: (name, kind) of every library skill.
        product: the product the task is about (None: unknown).
        gap: the gap it is for (None: unknown).
        base: where the base stands (None: unknown; the target is then unknown too).
    """
    library = tuple((name, kind) for name, kind in library)
    facts = product_features(product) if product is not None else None
    target = None
    if gap is not None and base is not None:
        target = target_features(gap, facts.width_m if facts is not None else 0.0, base)
    return Situation(
        node=node_context(root, node_name, execution, dict(library)),
        reason=reason,
        failure=parse_reason(reason),
        product=facts,
        target=target,
        library=library,
    )
