"""A task's goal, judged from the world: the tree, the commanded stiffness, where a product stands.

Three kinds, any of which a task may combine (all must hold at once):

- ``tree``: nodes absent from or present in the tree, or a composite's children in order, judged on the tree the
  behaviour tree node publishes (``/behaviour_tree/log/tree``);
- ``stiffness``: the principal stiffnesses on ``/eigenvalues`` within per-axis bounds [N/m], held for ``hold`` s;
- ``placement``: a product upright in a gap with no neighbour pushed (:func:`teleteach.core.placement.judge` on the
  world as it is, ``/teleteach/true_scene``, not as the robot perceives it), held for ``hold`` s.

Plain data in, no ROS: the study's ROS layer feeds the judge what it hears, with the time it heard it.
"""

import dataclasses
import math
from typing import Dict, Mapping, Optional, Sequence, Tuple

import numpy as np

from teleteach.core.placement import judge
from teleteach.core.scene import Scene

AXES = ("x", "y", "z")


@dataclasses.dataclass(frozen=True)
class TreeView:
    """The tree as a goal sees it: every behaviour's name, and each composite's children in tick order."""

    names: Tuple[str, ...]
    children: Mapping[str, Tuple[str, ...]]


@dataclasses.dataclass(frozen=True)
class TreeGoal:
    """Nodes that must be gone, nodes that must be there, composites whose children must be exactly these."""

    absent: Tuple[str, ...] = ()
    present: Tuple[str, ...] = ()
    children: Mapping[str, Tuple[str, ...]] = dataclasses.field(default_factory=dict)

    def check(self, tree: Optional[TreeView]) -> Tuple[bool, str]:
        """Whether ``tree`` meets the goal, and what it shows (the first thing still missing, or that all is done)."""
        if tree is None:
            return False, "no tree heard yet"
        names = set(tree.names)
        for name in self.absent:
            if name in names:
                return False, f"{name} is still in the tree"
        for name in self.present:
            if name not in names:
                return False, f"{name} is not in the tree yet"
        for parent, expected in self.children.items():
            actual = tuple(tree.children.get(parent, ()))
            if actual != tuple(expected):
                shown = ", ".join(actual) if parent in tree.children else "not in the tree"
                return False, f"{parent}: {shown}"
        done = [f"{name} removed" for name in self.absent] + [f"{name} in the tree" for name in self.present]
        done += [f"{parent} as asked" for parent in self.children]
        return True, "; ".join(done)


@dataclasses.dataclass(frozen=True)
class StiffnessGoal:
    """Each bounded axis' principal stiffness [N/m] within [low, high], for ``hold`` s without a break."""

    bounds: Tuple[Optional[Tuple[float, float]], ...]  # x, y, z; None: any value
    hold: float = 1.0  # [s]

    def check(self, eigenvalues: Optional[Sequence[float]]) -> Tuple[bool, str]:
        """Whether the stiffness is within the bounds now, and each bounded axis' value against its bounds."""
        if eigenvalues is None:
            return False, "no stiffness commanded yet"
        within, parts = True, []
        for axis, value, bound in zip(AXES, eigenvalues, self.bounds):
            if bound is None:
                continue
            low, high = bound
            ok = low <= value <= high
            within = within and ok
            verdict = "ok" if ok else ("too low" if value < low else "too high")
            parts.append(f"{axis.upper()} {value:.0f} N/m ({low:g}-{high:g}: {verdict})")
        return within, ", ".join(parts)


@dataclasses.dataclass(frozen=True)
class PlacementGoal:
    """``product`` upright in ``gap``, no neighbour pushed, for ``hold`` s."""

    product: str
    gap: str
    hold: float = 1.0  # [s]

    def check(
        self,
        scene: Scene,
        initial: Mapping[str, np.ndarray],
        final: Mapping[str, Tuple[np.ndarray, np.ndarray]],
    ) -> Tuple[bool, str]:
        """Whether the product stands as asked now (teleteach.core.placement.judge), and where it is."""
        if self.product not in final or not initial:
            return False, f"{self.product} not seen in the scene yet"
        positions = {name: pose[0] for name, pose in final.items()}
        placement = judge(scene, self.product, final[self.product], initial, positions, self.gap)
        problems = placement.problems(self.gap)
        if problems:
            return False, "; ".join(problems)
        return True, f"{self.product} upright in {self.gap}"


@dataclasses.dataclass(frozen=True)
class Goal:
    """A task's goal: one or more kinds, all of which must hold at once."""

    tree: Optional[TreeGoal] = None
    stiffness: Optional[StiffnessGoal] = None
    placement: Optional[PlacementGoal] = None

    @property
    def kinds(self) -> Tuple[str, ...]:
        """The kinds this goal judges (tree, stiffness, placement)."""
        return tuple(name for name in ("tree", "stiffness", "placement") if getattr(self, name) is not None)


@dataclasses.dataclass(frozen=True)
class Judgement:
    """Whether the goal is met now, and what the world shows (the participant's live status)."""

    met: bool
    status: str


class Held:
    """Since when a condition has held without a break."""

    def __init__(self) -> None:
        self.since: Optional[float] = None

    def update(self, time: float, holds: bool) -> None:
        """The condition at ``time`` [s]."""
        if not holds:
            self.since = None
        elif self.since is None:
            self.since = time

    def held(self, now: float) -> float:
        """[s] it has held until ``now`` (0 when it does not hold)."""
        return 0.0 if self.since is None else max(0.0, now - self.since)


class GoalJudge:
    """Judges a goal from what the world shows, fed sample by sample (times in seconds of one clock)."""

    def __init__(self, goal: Goal, scene: Optional[Scene] = None):
        if goal.placement is not None and scene is None:
            raise ValueError("a placement goal needs the scene")
        self.goal = goal
        self.scene = scene
        self._tree: Tuple[bool, str] = (False, "no tree heard yet")
        self._stiffness: Tuple[bool, str] = (False, "no stiffness commanded yet")
        self._placement: Tuple[bool, str] = (False, "no scene heard yet")
        self._stiffness_held = Held()
        self._placement_held = Held()
        self._initial: Dict[str, np.ndarray] = {}

    def tree(self, tree: TreeView) -> None:
        """A new tree."""
        if self.goal.tree is not None:
            self._tree = self.goal.tree.check(tree)

    def stiffness(self, time: float, eigenvalues: Sequence[float]) -> None:
        """A stiffness command (every one: a short excursion out of the bounds restarts the hold)."""
        if self.goal.stiffness is None or not all(math.isfinite(value) for value in eigenvalues):
            return
        self._stiffness = self.goal.stiffness.check(eigenvalues)
        self._stiffness_held.update(time, self._stiffness[0])

    def scene_products(self, time: float, poses: Mapping[str, Tuple[np.ndarray, np.ndarray]]) -> None:
        """The products' poses; the first ones heard are where they stood at the start."""
        if not poses:
            return
        if not self._initial:
            self._initial = {name: pose[0] for name, pose in poses.items()}
        if self.goal.placement is not None:
            self._placement = self.goal.placement.check(self.scene, self._initial, poses)
            self._placement_held.update(time, self._placement[0])

    def judgement(self, now: float) -> Judgement:
        """Whether every kind of the goal holds now (stiffness and placement for their hold time)."""
        parts, met = [], True
        if self.goal.tree is not None:
            met = met and self._tree[0]
            parts.append(self._tree[1])
        for kind, held, state in (
            ("stiffness", self._stiffness_held, self._stiffness),
            ("placement", self._placement_held, self._placement),
        ):
            spec = getattr(self.goal, kind)
            if spec is None:
                continue
            seconds = held.held(now)
            ok = state[0] and seconds >= spec.hold
            met = met and ok
            parts.append(state[1] + (f"; held {min(seconds, spec.hold):.1f} of {spec.hold:g} s" if state[0] else ""))
        return Judgement(met, "; ".join(parts))
