"""ChangeTree semantics: edit a live py_trees tree by unique node names (the /change_tree service, without ROS).

Operations (``teleteach/ChangeTree``): ``remove`` a node; ``add`` (append), ``prepend`` or ``insert`` (at ``index``)
a copy of a tree node or a new leaf of a library skill into ``parent`` (empty: the execution composite,
BehaviorExecution in the thesis tree). Copies get unique names (``PlaceItem_2``) that the result returns.

Edits keep execution going: py_trees' sequence memory is the identity of the running child, so inserting or removing
siblings before or after it leaves it running and remembered. Removing a running node (or a composite holding one)
is refused. A leaf that failed and waits for the operator (``awaiting_help``) is not running: removing it makes its
parent continue with the node that takes its place; inserting a node right in front of it runs that node first,
then retries the failed one.

A bad request changes nothing and says exactly what was wrong. The caller serialises edits with ticks.
"""

import re
import typing

import py_trees
from py_trees.common import Status

from teleteach.bt.behaviours import PauseCondition, SkillLeaf
from teleteach.bt.library import SkillLibrary
from teleteach.bt.tree import LeafFactory, Spec, create_root, describe

OPERATIONS = ("remove", "add", "prepend", "insert")
_COPY_SUFFIX = re.compile(r"_\d+$")


class ChangeResult(typing.NamedTuple):
    """What /change_tree answers."""

    success: bool
    message: str
    new_node_name: str = ""


class TreeEditor:
    """Edits a tree in place, keeping a name index so that every lookup is O(1).

    Args:
        root: the root of the tree
        execution: name of the composite edited when a request names no parent
        library: skills that add/prepend/insert may name
        make_leaf: builds the leaf of a skill (the same factory the tree was built with)
    """

    def __init__(
        self, root: py_trees.behaviour.Behaviour, execution: str, library: SkillLibrary, make_leaf: LeafFactory
    ):
        self.root = root
        self.library = library
        self.make_leaf = make_leaf
        self.nodes: typing.Dict[str, py_trees.behaviour.Behaviour] = {}
        for node in root.iterate():
            self.nodes[node.name] = node
        self.execution = self.nodes[execution]
        self._next_suffix: typing.Dict[str, int] = {}

    def protected_reason(self, node: py_trees.behaviour.Behaviour) -> str:
        """Why ``node`` may not be removed or copied, or "" if it may."""
        if node is self.root:
            return f"'{node.name}' is the root of the tree"
        if node is self.execution:
            return f"'{node.name}' is the composite that /change_tree edits by default"
        if isinstance(node, PauseCondition):
            return f"'{node.name}' is the condition that pauses the tree"
        return ""

    def change(self, node_name: str, operation: str, index: int = 0, parent: str = "") -> ChangeResult:
        """Apply one /change_tree request; on any error nothing changes."""
        if operation not in OPERATIONS:
            return ChangeResult(False, f"unknown operation '{operation}'; expected one of {', '.join(OPERATIONS)}")
        if not node_name:
            return ChangeResult(False, "empty node name")
        if operation == "remove":
            return self._remove(node_name, parent)
        return self._add(node_name, operation, index, parent)

    def _remove(self, node_name: str, parent_name: str) -> ChangeResult:
        node = self.nodes.get(node_name)
        if node is None:
            return ChangeResult(False, f"no node named '{node_name}' in the tree")
        reason = self.protected_reason(node)
        if reason:
            return ChangeResult(False, f"cannot remove {reason}")
        parent = node.parent
        if parent_name and parent.name != parent_name:
            return ChangeResult(False, f"'{node_name}' is a child of '{parent.name}', not of '{parent_name}'")
        for descendant in node.iterate():
            if self.protected_reason(descendant):
                return ChangeResult(
                    False, f"cannot remove '{node_name}': it holds '{descendant.name}', which must stay"
                )
            if _busy(descendant):
                what = "it is running" if descendant is node else f"it holds the running leaf '{descendant.name}'"
                return ChangeResult(False, f"cannot remove '{node_name}': {what}; removing it would abort its skill")
        index = parent.children.index(node)
        was_current = parent.current_child is node
        parent.remove_child(node)  # stops the node if needed: only a leaf awaiting help here, no goal is out
        if was_current and parent.status == Status.RUNNING:
            self._move_memory_after_removal(parent, index)
        for descendant in node.iterate():
            del self.nodes[descendant.name]
        return ChangeResult(True, f"removed '{node_name}' from '{parent.name}' (it was at index {index})")

    @staticmethod
    def _move_memory_after_removal(parent: py_trees.composites.Composite, index: int) -> None:
        """The removed node was what ``parent`` remembered: continue with the node now at its index."""
        if isinstance(parent, py_trees.composites.Sequence) and parent.memory:
            parent.current_child = parent.children[index] if index < len(parent.children) else None
        elif isinstance(parent, py_trees.composites.Selector):
            parent.stop(Status.INVALID)  # re-decide from the highest priority on the next tick

    def _add(self, node_name: str, operation: str, index: int, parent_name: str) -> ChangeResult:
        if parent_name:
            parent = self.nodes.get(parent_name)
            if parent is None:
                return ChangeResult(False, f"no composite named '{parent_name}' in the tree")
            if not isinstance(parent, py_trees.composites.Composite):
                return ChangeResult(False, f"'{parent_name}' is not a composite, nodes cannot be added to it")
        else:
            parent = self.execution
        size = len(parent.children)
        if operation == "insert" and not 0 <= index <= size:
            return ChangeResult(False, f"index {index} is out of range for '{parent.name}' (0..{size})")
        position = {"add": size, "prepend": 0, "insert": index}[operation]
        source = self.nodes.get(node_name)
        if source is not None:
            reason = self.protected_reason(source)
            if reason:
                return ChangeResult(False, f"cannot copy {reason}")
            spec = self._renamed(describe(source))
            origin = f"a copy of '{node_name}'"
        elif node_name in self.library:
            spec = self._renamed({"type": "skill", "name": node_name, "skill": node_name})
            origin = f"library skill '{node_name}'"
        else:
            return ChangeResult(False, f"'{node_name}' is neither a node of the tree nor a skill in the library")
        unavailable = self._unavailable_skill(spec)
        if unavailable:
            return ChangeResult(False, f"cannot {operation} '{node_name}': {unavailable}")
        new_node = create_root(spec, self.library, self.make_leaf)
        parent.insert_child(new_node, position)
        for descendant in new_node.iterate():
            self.nodes[descendant.name] = descendant
        self._run_first_if_in_front_of_failed(parent, new_node, position)
        return ChangeResult(
            True, f"{operation}: {origin} as '{new_node.name}' in '{parent.name}' at index {position}", new_node.name
        )

    @staticmethod
    def _run_first_if_in_front_of_failed(
        parent: py_trees.composites.Composite, new_node: py_trees.behaviour.Behaviour, position: int
    ) -> None:
        """A node inserted right in front of a leaf awaiting help runs first; the failed leaf is retried after it."""
        if not (isinstance(parent, py_trees.composites.Sequence) and parent.memory):
            return
        following = parent.children[position + 1] if position + 1 < len(parent.children) else None
        if following is not None and following is parent.current_child and getattr(following, "awaiting_help", False):
            following.stop(Status.INVALID)
            parent.current_child = new_node

    def _unavailable_skill(self, spec: Spec) -> str:
        """Why a skill the description runs is unavailable (its file is missing or bad), or "" if all can run."""
        if spec["type"] == "skill":
            entry = self.library.get(spec["skill"])
            return f"skill '{entry.name}' is unavailable: {entry.problem}" if entry and not entry.available else ""
        for child in spec.get("children", []):
            reason = self._unavailable_skill(child)
            if reason:
                return reason
        return ""

    def _renamed(self, spec: Spec) -> Spec:
        """Give every node of a description a name unused in the tree (and in the description itself)."""
        taken: typing.Set[str] = set()

        def rename(node: Spec) -> Spec:
            renamed = dict(node)
            base = node["skill"] if node["type"] == "skill" else _COPY_SUFFIX.sub("", node["name"]) or node["name"]
            renamed["name"] = self._unique_name(base, taken)
            taken.add(renamed["name"])
            if "children" in node:
                renamed["children"] = [rename(child) for child in node["children"]]
            return renamed

        return rename(spec)

    def _unique_name(self, base: str, taken: typing.Set[str]) -> str:
        if base not in self.nodes and base not in taken:
            return base
        suffix = self._next_suffix.get(base, 2)
        while f"{base}_{suffix}" in self.nodes or f"{base}_{suffix}" in taken:
            suffix += 1
        self._next_suffix[base] = suffix + 1
        return f"{base}_{suffix}"


def _busy(node: py_trees.behaviour.Behaviour) -> bool:
    """A leaf whose skill is out (running and not merely waiting for the operator)."""
    if node.children or node.status != Status.RUNNING:
        return False
    return not (isinstance(node, SkillLeaf) and node.awaiting_help)


def snapshot(root: py_trees.behaviour.Behaviour) -> typing.Tuple:
    """Everything an edit could change: structure, names, types, statuses, messages, composite memories."""

    def record(node: py_trees.behaviour.Behaviour) -> typing.Tuple:
        current = getattr(node, "current_child", None)
        return (
            type(node).__name__,
            node.name,
            getattr(node, "skill", ""),
            node.status,
            node.feedback_message,
            current.name if current is not None else None,
            tuple(record(child) for child in node.children),
        )

    return record(root)
