"""ChangeTree semantics: edit a live py_trees tree by unique node names (the /change_tree service, without ROS).

Operations (``teleteach/ChangeTree``): ``remove`` a node; ``add`` (append), ``prepend`` or ``insert`` (at ``index``)
a copy of a tree node or a new leaf of a library skill into ``parent`` (empty: the execution composite,
BehaviorExecution in the thesis tree). Copies get unique names (``PlaceItem_2``) that the result returns.
``convert`` turns a composite into another ``node_type`` (sequence, selector, parallel) keeping its children;
``wrap`` puts a decorator (``retry`` with ``parameter`` attempts, ``timeout`` after ``parameter`` seconds, or
``inverter``) or a new composite (``sequence | selector | parallel``, e.g. to build ``selector(ProductInHand,
PickItem)`` by wrapping PickItem, then prepending the condition into the selector) around a node; ``unwrap``
replaces a decorator, or a composite of one child, by its child. ``undo`` and ``redo`` revert and re-apply
the last edits of any kind: each edit is kept as plain data (what was inserted or removed where, which types a
composite had, what was put around what), saved with the tree, so an undo restores the same names, types and order
even after a restart.

Edits keep execution going: py_trees' sequence memory is the identity of the running child, so inserting or removing
siblings before or after it leaves it running and remembered; a wrapped or unwrapped node keeps running inside or
outside its decorator. Removing a running node (or a composite holding one) and converting a running composite are
refused; a pause does not change that, since a paused composite still holds its suspended child and a converted one
would start its children again. A leaf that failed and waits for the operator (``awaiting_help``) is not running:
removing it makes its parent continue with the node that takes its place; inserting a node right in front of it runs
that node first, then retries the failed one.

A bad request changes nothing and says exactly what was wrong. The caller serialises edits with ticks.
"""

import json
import re
import typing

import py_trees
from py_trees.common import Status

from teleteach.bt.behaviours import PauseCondition, SkillLeaf
from teleteach.bt.library import SkillLibrary
from teleteach.bt.tree import (
    COMPOSITE_DEFAULTS,
    COMPOSITES,
    DECORATORS,
    EditRecord,
    LeafFactory,
    Spec,
    TreeSpecError,
    create_decorator,
    create_root,
    decorator_parameters,
    describe,
    describe_shallow,
    node_type,
)

OPERATIONS = ("remove", "add", "prepend", "insert", "convert", "wrap", "unwrap", "undo", "redo", "repair")
WRAPPERS = (*DECORATORS, *COMPOSITES)  # what wrap can put around a node
# Composites made by convert and wrap keep the child they run: a condition or skill is a goal that takes ticks, so a
# selector re-asking its first child on every tick (py_trees' memory false) would cancel the skill it had chosen.
EDITED_COMPOSITE = {**COMPOSITE_DEFAULTS, "selector": {"memory": True}}
HISTORY_LIMIT = 100  # edits kept for undo, and undone edits kept for redo
_COPY_SUFFIX = re.compile(r"_\d+$")
_INVERSE = {"insert": "remove", "remove": "insert", "wrap": "unwrap", "unwrap": "wrap", "convert": "convert"}

History = typing.Dict[str, typing.List[EditRecord]]


class ChangeResult(typing.NamedTuple):
    """What /change_tree answers."""

    success: bool
    message: str
    new_node_name: str = ""


class TreeEditor:
    """Edits a tree in place, keeping a name index so that every lookup is O(1), and the history undo replays.

    Args:
        root: the root of the tree
        execution: name of the composite edited when a request names no parent
        library: skills that add/prepend/insert may name
        make_leaf: builds the leaf of a skill (the same factory the tree was built with)
        history: saved ``{"undo": [edit, ...], "redo": [...]}`` (oldest first), e.g. from the saved tree
    """

    def __init__(
        self,
        root: py_trees.behaviour.Behaviour,
        execution: str,
        library: SkillLibrary,
        make_leaf: LeafFactory,
        history: typing.Optional[History] = None,
    ):
        self.root = root
        self.library = library
        self.make_leaf = make_leaf
        self.nodes: typing.Dict[str, py_trees.behaviour.Behaviour] = {}
        for node in root.iterate():
            self.nodes[node.name] = node
        self.execution = self.nodes[execution]
        self._next_suffix: typing.Dict[str, int] = {}
        history = history or {}
        self.undo_edits: typing.List[EditRecord] = list(history.get("undo", []))[-HISTORY_LIMIT:]
        self.redo_edits: typing.List[EditRecord] = list(history.get("redo", []))[-HISTORY_LIMIT:]

    @property
    def history(self) -> History:
        """The edits undo and redo would replay (oldest first), as saved with the tree."""
        return {"undo": list(self.undo_edits), "redo": list(self.redo_edits)}

    def protected_reason(self, node: py_trees.behaviour.Behaviour) -> str:
        """Why ``node`` may not be removed, copied or wrapped, or "" if it may."""
        if node is self.root:
            return f"'{node.name}' is the root of the tree"
        if node is self.execution:
            return f"'{node.name}' is the composite that /change_tree edits by default"
        if isinstance(node, PauseCondition):
            return f"'{node.name}' is the condition that pauses the tree"
        return ""

    def change(
        self,
        node_name: str,
        operation: str,
        index: int = 0,
        parent: str = "",
        node_type: str = "",
        parameter: float = 0.0,
    ) -> ChangeResult:
        """Apply one /change_tree request; on any error nothing changes."""
        if operation not in OPERATIONS:
            return ChangeResult(False, f"unknown operation '{operation}'; expected one of {', '.join(OPERATIONS)}")
        if operation in ("undo", "redo"):
            return self._replay(operation)
        if operation == "repair":
            return ChangeResult(False, "there is no remembered repair to apply: the open help request suggests none")
        request = EditRequest(node_name, operation, index, parent, node_type, parameter)
        suffixes = dict(self._next_suffix)
        result, edit = self._request(request)
        if result.success:
            self._remember(edit)
        else:
            self._next_suffix = suffixes  # a refused request uses up no name: the next copy is still Idle_2
        return result

    def apply_requests(self, requests: typing.Sequence["EditRequest"]) -> ChangeResult:
        """Apply several requests as one edit (one undo reverts them all); if one fails, none stays applied."""
        applied: typing.List[EditRecord] = []
        messages: typing.List[str] = []
        suffixes = dict(self._next_suffix)
        for number, request in enumerate(requests, start=1):
            result, edit = self._request(request)
            if not result.success:
                for done in reversed(applied):
                    self._apply(inverse(done))
                self._next_suffix = suffixes
                return ChangeResult(
                    False, f"edit {number} of {len(requests)} ({request.describe()}) failed: {result.message}"
                )
            applied.append(edit)
            messages.append(result.message)
        if not applied:
            return ChangeResult(False, "no edits to apply")
        self._remember({"edit": "group", "edits": applied})
        return ChangeResult(True, "; ".join(messages))

    def _remember(self, edit: EditRecord) -> None:
        self.undo_edits = [*self.undo_edits, edit][-HISTORY_LIMIT:]
        self.redo_edits = []

    def _request(self, request: "EditRequest") -> typing.Tuple[ChangeResult, EditRecord]:
        """Carry out one request that is not undo, redo or repair: the result, and the edit that undo replays."""
        node_name, operation = request.node_name, request.operation
        if operation not in OPERATIONS or operation in ("undo", "redo", "repair"):
            return ChangeResult(False, f"'{operation}' cannot be part of a repair"), {}
        if not node_name:
            return ChangeResult(False, "empty node name"), {}
        if operation == "remove":
            edit: typing.Union[EditRecord, ChangeResult] = {
                "edit": "remove",
                "node": {"name": node_name},
                "parent": request.parent,
            }
        elif operation == "convert":
            edit = self._conversion(node_name, request.node_type)
        elif operation == "wrap":
            edit = self._wrapping(node_name, request.node_type, request.parameter)
        elif operation == "unwrap":
            edit = {"edit": "unwrap", "wrapper": {"name": node_name}}
        else:
            edit = self._addition(node_name, operation, request.index, request.parent)
        if isinstance(edit, ChangeResult):
            return edit, {}
        origin = f"a copy of '{node_name}'" if node_name in self.nodes else f"library skill '{node_name}'"
        result = self._apply(edit)
        if result.success and edit["edit"] == "insert":
            where = f"'{edit['parent']}' at index {edit['index']}"
            result = result._replace(message=f"{operation}: {origin} as '{result.new_node_name}' in {where}")
        return result, edit

    def _replay(self, operation: str) -> ChangeResult:
        """Undo (apply the inverse of) the last edit, or redo the last undone one."""
        edits, other = (self.undo_edits, self.redo_edits) if operation == "undo" else (self.redo_edits, self.undo_edits)
        if not edits:
            return ChangeResult(False, f"nothing to {operation}")
        edit = edits[-1]
        replayed = inverse(edit) if operation == "undo" else json.loads(json.dumps(edit))
        result = self._apply(replayed)
        if not result.success:
            return ChangeResult(False, f"cannot {operation} the last edit: {result.message}")
        edits.pop()
        other.append(edit)
        del other[:-HISTORY_LIMIT]
        return ChangeResult(True, f"{operation}: {result.message}", result.new_node_name)

    def _apply(self, edit: EditRecord) -> ChangeResult:
        """Carry out one edit (completing its record with what it found), or say why not and change nothing."""
        apply = {
            "group": self._group,
            "insert": self._insert,
            "remove": self._remove,
            "convert": self._convert,
            "wrap": self._wrap,
            "unwrap": self._unwrap,
        }.get(edit.get("edit"))
        if apply is None:
            return ChangeResult(False, f"unknown edit {json.dumps(edit)}")
        try:
            return apply(edit)
        except (KeyError, TypeError, ValueError, TreeSpecError) as error:  # a hand-edited or damaged saved history
            return ChangeResult(False, f"the edit {json.dumps(edit)} cannot be applied: {error!r}")

    # --------------------------------------------------------------------------------------------- requests
    def _addition(
        self, node_name: str, operation: str, index: int, parent: str
    ) -> typing.Union[EditRecord, ChangeResult]:
        source = self.nodes.get(node_name)
        if source is not None:
            reason = self.protected_reason(source)
            if reason:
                return ChangeResult(False, f"cannot copy {reason}")
            spec = self._renamed(describe(source))
        elif node_name in self.library:
            spec = self._renamed({"type": "skill", "name": node_name, "skill": node_name})
        else:
            return ChangeResult(False, f"'{node_name}' is neither a node of the tree nor a skill in the library")
        unavailable = self._unavailable_skill(spec)
        if unavailable:
            return ChangeResult(False, f"cannot {operation} '{node_name}': {unavailable}")
        position = {"add": None, "prepend": 0, "insert": index}[operation]  # None: the end, once known
        return {"edit": "insert", "parent": parent, "index": position, "node": spec}

    def _conversion(self, node_name: str, kind: str) -> typing.Union[EditRecord, ChangeResult]:
        if kind not in COMPOSITES:
            return ChangeResult(False, f"cannot convert to '{kind}'; expected node_type {' | '.join(COMPOSITES)}")
        node = self.nodes.get(node_name)
        if node is None:
            return ChangeResult(False, f"no node named '{node_name}' in the tree")
        if not isinstance(node, py_trees.composites.Composite):
            return ChangeResult(False, f"cannot convert '{node_name}': it is a {node_type(node)}, not a composite")
        after = {"type": kind, "name": node_name, **EDITED_COMPOSITE[kind]}
        return {"edit": "convert", "before": describe_shallow(node), "after": after}

    def _wrapping(self, node_name: str, kind: str, parameter: float) -> typing.Union[EditRecord, ChangeResult]:
        if kind not in WRAPPERS:
            return ChangeResult(False, f"cannot wrap in '{kind}'; expected node_type {' | '.join(WRAPPERS)}")
        node = self.nodes.get(node_name)
        if node is None:
            return ChangeResult(False, f"no node named '{node_name}' in the tree")
        if kind in COMPOSITES:
            settings = EDITED_COMPOSITE[kind]
        else:
            value = {"retry": {"attempts": parameter}, "timeout": {"seconds": parameter}}.get(kind, {})
            try:
                settings = decorator_parameters(kind, value, f"wrap '{node_name}'")
            except TreeSpecError as error:
                return ChangeResult(False, f"{error} (the request's parameter)")
        name = self._unique_name(f"{kind.capitalize()}{node_name}", set())
        return {"edit": "wrap", "node": node_name, "wrapper": {"type": kind, "name": name, **settings}}

    # ------------------------------------------------------------------------------------------------ edits
    def _group(self, edit: EditRecord) -> ChangeResult:
        """Several edits as one (an applied repair): all of them, or none."""
        applied, messages = [], []
        for part in edit["edits"]:
            result = self._apply(part)
            if not result.success:
                for done in reversed(applied):
                    self._apply(inverse(done))
                return result
            applied.append(part)
            messages.append(result.message)
        return ChangeResult(True, "; ".join(messages))

    def _editable(self, name: str, verb: str) -> typing.Union[py_trees.behaviour.Behaviour, ChangeResult]:
        """The node called ``name`` if ``verb`` may act on it, else the refusal saying why not."""
        node = self.nodes.get(name)
        if node is None:
            return ChangeResult(False, f"no node named '{name}' in the tree")
        reason = self.protected_reason(node)
        if reason:
            return ChangeResult(False, f"cannot {verb} {reason}")
        return node

    def _remove(self, edit: EditRecord) -> ChangeResult:
        node_name = edit["node"]["name"]
        node = self._editable(node_name, "remove")
        if isinstance(node, ChangeResult):
            return node
        parent = node.parent
        if edit.get("parent") and parent.name != edit["parent"]:
            return ChangeResult(False, f"'{node_name}' is a child of '{parent.name}', not of '{edit['parent']}'")
        for descendant in node.iterate():
            if self.protected_reason(descendant):
                return ChangeResult(
                    False, f"cannot remove '{node_name}': it holds '{descendant.name}', which must stay"
                )
            if _busy(descendant):
                what = "it is running" if descendant is node else f"it holds the running leaf '{descendant.name}'"
                return ChangeResult(False, f"cannot remove '{node_name}': {what}; removing it would abort its skill")
        index = parent.children.index(node)
        edit.update(parent=parent.name, index=index, node=describe(node))
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

    def _insert(self, edit: EditRecord) -> ChangeResult:
        parent_name, spec = edit["parent"], edit["node"]
        if parent_name:
            parent = self.nodes.get(parent_name)
            if parent is None:
                return ChangeResult(False, f"no composite named '{parent_name}' in the tree")
            if not isinstance(parent, py_trees.composites.Composite):
                return ChangeResult(False, f"'{parent_name}' is not a composite, nodes cannot be added to it")
        else:
            parent = self.execution
        size = len(parent.children)
        position = size if edit["index"] is None else edit["index"]
        if not isinstance(position, int) or not 0 <= position <= size:
            return ChangeResult(False, f"index {position} is out of range for '{parent.name}' (0..{size})")
        taken = [name for name in _names(spec) if name in self.nodes]
        if taken:
            return ChangeResult(False, f"cannot insert '{spec['name']}': the name '{taken[0]}' is in the tree")
        unavailable = self._unavailable_skill(spec)
        if unavailable:
            return ChangeResult(False, f"cannot insert '{spec['name']}': {unavailable}")
        new_node = create_root(spec, self.library, self.make_leaf)
        parent.insert_child(new_node, position)
        edit.update(parent=parent.name, index=position)
        for descendant in new_node.iterate():
            self.nodes[descendant.name] = descendant
        self._run_first_if_in_front_of_failed(parent, new_node, position)
        return ChangeResult(True, f"inserted '{new_node.name}' in '{parent.name}' at index {position}", new_node.name)

    def _convert(self, edit: EditRecord) -> ChangeResult:
        before, after = edit["before"], edit["after"]
        node = self.nodes.get(before["name"])
        if node is None or not isinstance(node, py_trees.composites.Composite):
            return ChangeResult(False, f"no composite named '{before['name']}' in the tree")
        if node is self.root:
            return ChangeResult(False, f"cannot convert '{node.name}': it is the root of the tree, the pause needs it")
        if describe_shallow(node) != before:
            return ChangeResult(False, f"'{node.name}' is a {node_type(node)}, not the {before['type']} it was")
        if after["type"] == before["type"]:
            return ChangeResult(False, f"'{node.name}' is a {before['type']} already")
        if node.status == Status.RUNNING:
            running = [leaf.name for leaf in node.iterate() if not leaf.children and leaf.status == Status.RUNNING]
            return ChangeResult(
                False,
                f"cannot convert '{node.name}' while it runs {', '.join(running) or 'a child'}, paused or not (a new"
                f" {after['type']} would start its children again): convert a composite that does not run, or wrap a"
                f" node that has not run yet in a {after['type']}",
            )
        converted = create_root({**after, "children": []}, self.library, self.make_leaf)
        children = list(node.children)
        node.children.clear()
        for child in children:
            child.parent = None
            converted.add_child(child)
        self._replace(node, converted)
        if node is self.execution:
            self.execution = converted
        return ChangeResult(True, f"converted '{node.name}' from a {before['type']} to a {after['type']}")

    def _wrap(self, edit: EditRecord) -> ChangeResult:
        wrapper_spec, node = edit["wrapper"], self._editable(edit["node"], "wrap")
        if isinstance(node, ChangeResult):
            return node
        kind, name = wrapper_spec["type"], wrapper_spec["name"]
        if name in self.nodes:
            return ChangeResult(False, f"cannot wrap '{node.name}': the name '{name}' is in the tree")
        parent = node.parent
        if kind in DECORATORS:
            settings = decorator_parameters(kind, wrapper_spec, f"wrap '{node.name}'")
            wrapper = create_decorator({**wrapper_spec, **settings}, _detached(node))
        else:
            settings = {}
            wrapper = create_root({**wrapper_spec, "children": []}, self.library, self.make_leaf)
            running = node.status == Status.RUNNING
            wrapper.add_child(_detached(node))
            if running:  # a new composite would start by stopping its children: it continues the running one
                wrapper.status, wrapper.current_child = Status.RUNNING, node
        self._replace(node, wrapper, parent)
        what = "".join(f", {key} {value}" for key, value in settings.items())
        return ChangeResult(True, f"wrapped '{node.name}' in the {kind} '{name}'{what}", name)

    def _unwrap(self, edit: EditRecord) -> ChangeResult:
        name = edit["wrapper"]["name"]
        wrapper = self._editable(name, "unwrap")
        if isinstance(wrapper, ChangeResult):
            return wrapper
        one_child = isinstance(wrapper, py_trees.composites.Composite) and len(wrapper.children) == 1
        if not (isinstance(wrapper, py_trees.decorators.Decorator) or one_child):
            what = f"a {node_type(wrapper)}" + (f" of {len(wrapper.children)} children" if wrapper.children else "")
            return ChangeResult(
                False, f"cannot unwrap '{name}': it is {what}, not a decorator or a composite of one child"
            )
        child = wrapper.children[0]
        edit.update(wrapper=describe_shallow(wrapper), node=child.name)
        parent = wrapper.parent
        wrapper.children.clear()
        self._replace(wrapper, _detached(child), parent)
        del self.nodes[name]
        return ChangeResult(True, f"unwrapped '{child.name}' from the {edit['wrapper']['type']} '{name}'")

    def _replace(
        self,
        old: py_trees.behaviour.Behaviour,
        new: py_trees.behaviour.Behaviour,
        parent: typing.Optional[py_trees.behaviour.Behaviour] = None,
    ) -> None:
        """Put ``new`` where ``old`` was (same index, and what its parent remembered), under ``old``'s name."""
        parent = parent or old.parent
        parent.children[parent.children.index(old)] = new
        new.parent = parent
        if getattr(parent, "current_child", None) is old:
            parent.current_child = new
        if isinstance(parent, py_trees.decorators.Decorator):
            parent.decorated = new
        if old.parent is parent:
            old.parent = None
        self.nodes[new.name] = new

    @staticmethod
    def _run_first_if_in_front_of_failed(
        parent: py_trees.composites.Composite, new_node: py_trees.behaviour.Behaviour, position: int
    ) -> None:
        """A node inserted in front of a leaf awaiting help (or a decorator around one) runs first, then the leaf."""
        if not (isinstance(parent, py_trees.composites.Sequence) and parent.memory):
            return
        following = parent.children[position + 1] if position + 1 < len(parent.children) else None
        if following is None or following is not parent.current_child:
            return
        if any(getattr(node, "awaiting_help", False) for node in following.iterate()):
            following.stop(Status.INVALID)
            parent.current_child = new_node

    def _unavailable_skill(self, spec: Spec) -> str:
        """Why a skill the description runs is unavailable (its file is missing or bad), or "" if all can run."""
        if spec["type"] == "skill":
            entry = self.library.get(spec["skill"])
            if entry is None:
                return f"skill '{spec['skill']}' is not in the library"
            return f"skill '{entry.name}' is unavailable: {entry.problem}" if not entry.available else ""
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


class EditRequest(typing.NamedTuple):
    """One /change_tree request (what an operator asked for, as a repair remembers it)."""

    node_name: str
    operation: str
    index: int = 0
    parent: str = ""
    node_type: str = ""
    parameter: float = 0.0

    def describe(self) -> str:
        """One line for the operator, e.g. "wrap PickItem in a retry (3)" or "insert PickItem2 at index 1"."""
        text = f"{self.operation} {self.node_name}"
        if self.operation in ("wrap", "convert"):
            article = "an" if self.node_type[:1] in "aeiou" else "a"
            text += f" {'in' if self.operation == 'wrap' else 'to'} {article} {self.node_type}"
            if self.node_type in ("retry", "timeout"):
                text += f" ({self.parameter:g})"
        if self.operation == "insert":
            text += f" at index {self.index}"
        if self.parent and self.operation != "remove":
            text += f" in {self.parent}"
        return text

    @classmethod
    def from_line(cls, line: str) -> typing.Optional["EditRequest"]:
        """The request :meth:`describe` wrote ``line`` for (a help request carries edits as lines); None if none."""
        found = _DESCRIBED.fullmatch(line.strip())
        if found is None:
            return None
        parameter, index = found["parameter"], found["index"]
        return cls(
            found["node_name"],
            found["operation"],
            index=int(index) if index else 0,
            parent=found["parent"] or "",
            node_type=found["node_type"] or "",
            parameter=float(parameter) if parameter else 0.0,
        )


# What EditRequest.describe writes: "wrap PickItem in a retry (3)", "insert LookToShelf at index 1 in SelectorPick"
_DESCRIBED = re.compile(
    r"(?P<operation>\w+) (?P<node_name>\S*)"
    r"(?: (?:in|to) an? (?P<node_type>\w+)(?: \((?P<parameter>[^)]+)\))?)?"
    r"(?: at index (?P<index>-?\d+))?"
    r"(?: in (?P<parent>\S+))?"
)


def inverse(edit: EditRecord) -> EditRecord:
    """The edit that undoes ``edit`` (a copy: the history keeps the original)."""
    if edit["edit"] == "group":
        return {"edit": "group", "edits": [inverse(part) for part in reversed(edit["edits"])]}
    undone = json.loads(json.dumps(edit))
    undone["edit"] = _INVERSE[edit["edit"]]
    if edit["edit"] == "convert":
        undone["before"], undone["after"] = undone["after"], undone["before"]
    return undone


def _names(spec: Spec) -> typing.List[str]:
    """Every node name of a description."""
    return [spec["name"], *(name for child in spec.get("children", []) for name in _names(child))]


def _detached(node: py_trees.behaviour.Behaviour) -> py_trees.behaviour.Behaviour:
    """``node`` without its parent link, ready to be given a new parent."""
    node.parent = None
    return node


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
