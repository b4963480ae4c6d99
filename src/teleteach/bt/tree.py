"""Trees as yaml: parse and validate a tree description, build the py_trees tree, and write a live tree back.

The format (``config/tree.yaml`` holds the thesis tree)::

    execution: BehaviorExecution      # composite that /change_tree edits when no parent is named
    root:
      type: selector                  # selector (alias fallback) | sequence | parallel | pause | skill
      name: Root
      memory: false                   # selector, sequence: resume the running child (true) or re-check (false)
      children:
        - {type: pause, name: PauseCondition}
        - type: sequence
          name: BehaviorExecution
          memory: true
          children:
            - LookToShelf                         # a skill leaf: name = library skill
            - {name: PlaceItem_2, skill: PlaceItem}  # a leaf named apart from its skill
            - {name: MoveBase45, skill: MoveBase2, parameters: {base_pose: place_45deg}}  # the goal's parameters

A parallel has ``policy: success_on_all | success_on_one`` and ``synchronise: true | false``. A decorator has exactly
one child: ``retry`` (``attempts``: how many times its child may fail before it fails, >= 1), ``timeout``
(``seconds`` > 0 of wall time before it stops its child and fails) or ``inverter``. A predefined skill
leaf may carry ``parameters``, a mapping of names sent as its goal's parameters (what the skill acts on: product,
base_pose, gap; see config/skills_motion.yaml). Names are unique in the tree. Saved trees are written by
:func:`dump_yaml` in the same format, fast enough for 1000-leaf trees; they may end with ``history``, the edits that
/change_tree's undo and redo replay (see teleteach.bt.editor).
"""

import json
import math
import pathlib
import typing

import py_trees
import yaml

from teleteach.bt.behaviours import EditableSequence, PausableSelector, PauseCondition, SkillLeaf
from teleteach.bt.library import SkillEntry, SkillLibrary

COMPOSITES = ("selector", "sequence", "parallel")
DECORATORS = ("retry", "timeout", "inverter")
TYPES = (*COMPOSITES, *DECORATORS, "pause", "skill")
EDIT_KINDS = ("insert", "remove", "convert", "wrap", "unwrap", "group")
COMPOSITE_DEFAULTS = {  # what a composite written without these fields (or converted to this type) gets
    "selector": {"memory": False},
    "sequence": {"memory": True},
    "parallel": {"policy": "success_on_all", "synchronise": False},
}
PARALLEL_POLICIES = ("success_on_all", "success_on_one")

Spec = typing.Dict[str, typing.Any]  # a tree node as a tree file writes it: type, name, its children or skill
EditRecord = typing.Dict[str, typing.Any]  # an applied edit as the history keeps it: {"edit": kind, ...}
LeafFactory = typing.Callable[[str, SkillEntry], SkillLeaf]

_Loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


class TreeSpecError(ValueError):
    """A tree description is malformed; the message names the node and what is wrong."""


class TreeSpec(typing.NamedTuple):
    """A validated tree description."""

    root: Spec
    execution: str
    history: typing.Optional[typing.Dict[str, typing.List[EditRecord]]] = None  # {"undo": [edit, ...], "redo": [...]}


def parse_tree(data: typing.Any, library: SkillLibrary, source: str = "tree") -> TreeSpec:
    """Validate plain data (from yaml) into a :class:`TreeSpec`; raise :class:`TreeSpecError` naming the problem."""
    if not isinstance(data, dict) or "root" not in data:
        raise TreeSpecError(f"{source}: expected a mapping with 'root' (and 'execution')")
    unknown = set(data) - {"root", "execution", "history"}
    if unknown:
        raise TreeSpecError(f"{source}: unknown top-level fields {sorted(unknown)}")
    names: typing.Dict[str, str] = {}
    root = _parse_node(data["root"], library, names, f"{source}: root")
    if root["type"] not in COMPOSITES:
        raise TreeSpecError(f"{source}: the root must be a composite, got {root['type']!r}")
    execution = data.get("execution", "")
    if not isinstance(execution, str) or names.get(execution) not in COMPOSITES:
        raise TreeSpecError(f"{source}: execution {execution!r} must name a composite of the tree")
    return TreeSpec(root=root, execution=execution, history=_parse_history(data.get("history"), source))


def _parse_history(data: typing.Any, source: str) -> typing.Optional[typing.Dict[str, typing.List[EditRecord]]]:
    """The saved undo/redo edits: checked for shape here, for meaning when an undo or redo applies one."""
    if data is None:
        return None
    if not isinstance(data, dict) or set(data) - {"undo", "redo"}:
        raise TreeSpecError(f"{source}: history must be a mapping with 'undo' and 'redo' lists of edits")
    history: typing.Dict[str, typing.List[EditRecord]] = {}
    for key in ("undo", "redo"):
        edits = data.get(key) or []
        if not isinstance(edits, list) or not all(
            isinstance(edit, dict) and edit.get("edit") in EDIT_KINDS for edit in edits
        ):
            raise TreeSpecError(f"{source}: history/{key} must be a list of edits of kind {', '.join(EDIT_KINDS)}")
        history[key] = edits
    return history


# The fields each node type takes besides its type and name.
NODE_FIELDS = {
    "selector": {"memory", "children"},
    "sequence": {"memory", "children"},
    "parallel": {"policy", "synchronise", "children"},
    "retry": {"attempts", "children"},
    "timeout": {"seconds", "children"},
    "inverter": {"children"},
    "pause": set(),
    "skill": {"skill", "parameters"},
}


def _parse_node(data: typing.Any, library: SkillLibrary, names: typing.Dict[str, str], where: str) -> Spec:
    """One node of a tree file and its subtree as a spec, each mistake named with its path in the tree."""
    if isinstance(data, str):
        data = {"type": "skill", "name": data}
    if not isinstance(data, dict):
        raise TreeSpecError(f"{where}: a node is a skill name or a mapping, got {data!r}")
    node_type = data.get("type", "skill")
    node_type = "selector" if node_type == "fallback" else node_type
    name = data.get("name")
    if not isinstance(name, str) or not name:
        raise TreeSpecError(f"{where}: node without a name: {data!r}")
    where = f"{where}/{name}"
    if node_type not in TYPES:
        raise TreeSpecError(f"{where}: unknown type {node_type!r}; expected one of {', '.join(TYPES)} or fallback")
    if name in names:
        raise TreeSpecError(f"{where}: the name {name!r} is used twice; names in a tree are unique")
    names[name] = node_type
    unknown = set(data) - {"type", "name"} - NODE_FIELDS[node_type]
    if unknown:
        raise TreeSpecError(f"{where}: unknown fields {sorted(unknown)} for a {node_type}")
    spec: Spec = {"type": node_type, "name": name}
    if node_type == "skill":
        return _skill_spec(spec, data, library, where)
    if node_type == "pause":
        return spec
    if node_type == "parallel":
        policy = data.get("policy", COMPOSITE_DEFAULTS["parallel"]["policy"])
        if policy not in PARALLEL_POLICIES:
            raise TreeSpecError(f"{where}: unknown policy {policy!r}; expected one of {', '.join(PARALLEL_POLICIES)}")
        spec["policy"] = policy
        spec["synchronise"] = _flag(data, "synchronise", COMPOSITE_DEFAULTS["parallel"]["synchronise"], where)
    elif node_type in DECORATORS:
        spec.update(decorator_parameters(node_type, data, where))
    else:
        spec["memory"] = _flag(data, "memory", COMPOSITE_DEFAULTS[node_type]["memory"], where)
    children = data.get("children", [])
    if not isinstance(children, list):
        raise TreeSpecError(f"{where}: children must be a list")
    if node_type in DECORATORS and len(children) != 1:
        raise TreeSpecError(f"{where}: a {node_type} decorates exactly one child, got {len(children)}")
    spec["children"] = [_parse_node(child, library, names, where) for child in children]
    return spec


def _skill_spec(spec: Spec, data: Spec, library: SkillLibrary, where: str) -> Spec:
    """A skill leaf's spec: its skill, which the library must hold, and parameters only a predefined skill takes."""
    skill = data.get("skill", spec["name"])
    if skill not in library:
        raise TreeSpecError(f"{where}: skill {skill!r} is not in the skill library")
    spec["skill"] = skill
    parameters = data.get("parameters", {})
    if not isinstance(parameters, dict) or not all(
        isinstance(key, str) and isinstance(value, str) for key, value in parameters.items()
    ):
        raise TreeSpecError(f"{where}: parameters must map names to names, e.g. {{base_pose: start}}")
    if parameters and library.get(skill).demonstrated:
        raise TreeSpecError(f"{where}: parameters are for predefined skills; {skill!r} is a demonstrated skill")
    if parameters:
        spec["parameters"] = dict(parameters)
    return spec


def decorator_parameters(node_type: str, data: Spec, where: str) -> Spec:
    """The checked parameter of a decorator (``attempts`` of a retry, ``seconds`` of a timeout)."""
    if node_type == "retry":
        attempts = data.get("attempts")
        if isinstance(attempts, float) and attempts.is_integer():
            attempts = int(attempts)
        if isinstance(attempts, bool) or not isinstance(attempts, int) or attempts < 1:
            raise TreeSpecError(f"{where}: a retry needs attempts, a whole number >= 1, got {attempts!r}")
        return {"attempts": attempts}
    if node_type == "timeout":
        seconds = data.get("seconds")
        if isinstance(seconds, bool) or not isinstance(seconds, (int, float)) or not 0 < seconds < math.inf:
            raise TreeSpecError(f"{where}: a timeout needs seconds, a finite number > 0, got {seconds!r}")
        return {"seconds": float(seconds)}
    return {}


def _flag(data: Spec, key: str, default: bool, where: str) -> bool:
    value = data.get(key, default)
    if not isinstance(value, bool):
        raise TreeSpecError(f"{where}: {key} must be true or false, got {value!r}")
    return value


def load_tree(path: typing.Union[str, pathlib.Path], library: SkillLibrary) -> TreeSpec:
    """Read and validate a tree yaml file."""
    path = pathlib.Path(path)
    try:
        data = yaml.load(path.read_text(), Loader=_Loader)
    except (OSError, yaml.YAMLError) as error:
        raise TreeSpecError(f"cannot read tree {path}: {error}") from None
    return parse_tree(data, library, source=str(path))


def create_root(spec: Spec, library: SkillLibrary, make_leaf: LeafFactory) -> py_trees.behaviour.Behaviour:
    """Build the py_trees tree of a validated node description; leaves come from ``make_leaf(name, skill)``."""
    node_type = spec["type"]
    if node_type == "skill":
        entry = library.get(spec["skill"])
        if entry is None:
            raise TreeSpecError(f"{spec['name']}: skill {spec['skill']!r} is not in the skill library")
        leaf = make_leaf(spec["name"], entry)
        leaf.parameters = dict(spec.get("parameters", {}))
        return leaf
    if node_type == "pause":
        return PauseCondition(spec["name"])
    children = [create_root(child, library, make_leaf) for child in spec["children"]]
    if node_type in DECORATORS:
        return create_decorator(spec, children[0])
    if node_type == "selector":
        return PausableSelector(spec["name"], memory=spec["memory"], children=children)
    if node_type == "sequence":
        return EditableSequence(spec["name"], memory=spec["memory"], children=children)
    policy_class = {
        "success_on_all": py_trees.common.ParallelPolicy.SuccessOnAll,
        "success_on_one": py_trees.common.ParallelPolicy.SuccessOnOne,
    }[spec["policy"]]
    policy = policy_class(synchronise=spec["synchronise"]) if spec["policy"] == "success_on_all" else policy_class()
    return py_trees.composites.Parallel(spec["name"], policy=policy, children=children)


def create_decorator(spec: Spec, child: py_trees.behaviour.Behaviour) -> py_trees.decorators.Decorator:
    """The py_trees decorator of a (shallow) decorator description, around ``child``."""
    if spec["type"] == "retry":
        return py_trees.decorators.Retry(spec["name"], child, num_failures=spec["attempts"])
    if spec["type"] == "timeout":
        return py_trees.decorators.Timeout(spec["name"], child, duration=spec["seconds"])
    return py_trees.decorators.Inverter(spec["name"], child)


def node_type(node: py_trees.behaviour.Behaviour) -> str:
    """The yaml type of a live node."""
    if isinstance(node, py_trees.decorators.Retry):
        return "retry"
    if isinstance(node, py_trees.decorators.Timeout):
        return "timeout"
    if isinstance(node, py_trees.decorators.Inverter):
        return "inverter"
    if isinstance(node, py_trees.composites.Selector):
        return "selector"
    if isinstance(node, py_trees.composites.Sequence):
        return "sequence"
    if isinstance(node, py_trees.composites.Parallel):
        return "parallel"
    if isinstance(node, PauseCondition):
        return "pause"
    if isinstance(node, SkillLeaf):
        return "skill"
    raise TreeSpecError(f"{node.name}: {type(node).__name__} has no yaml form")


def describe_shallow(node: py_trees.behaviour.Behaviour) -> Spec:
    """The yaml description of one live node, without its children."""
    kind = node_type(node)
    spec: Spec = {"type": kind, "name": node.name}
    if kind == "skill":
        spec["skill"] = node.skill
        if node.parameters:
            spec["parameters"] = dict(node.parameters)
    elif kind == "parallel":
        policy = node.policy
        spec["policy"] = (
            "success_on_one" if isinstance(policy, py_trees.common.ParallelPolicy.SuccessOnOne) else "success_on_all"
        )
        spec["synchronise"] = bool(policy.synchronise)
    elif kind == "retry":
        spec["attempts"] = node.num_failures
    elif kind == "timeout":
        spec["seconds"] = node.duration
    elif kind in COMPOSITES:
        spec["memory"] = bool(node.memory)
    return spec


def describe(node: py_trees.behaviour.Behaviour) -> Spec:
    """The yaml description of a live (sub)tree: what :func:`create_root` would build it from."""
    spec = describe_shallow(node)
    if spec["type"] in COMPOSITES or spec["type"] in DECORATORS:
        spec["children"] = [describe(child) for child in node.children]
    return spec


def dump_yaml(tree: TreeSpec, header: str = "") -> str:
    """Write a tree description as block yaml with flow-style leaves (strings JSON-quoted, which yaml reads)."""
    lines = _header(tree.execution, header)
    stack: typing.List[typing.Tuple[Spec, str, bool]] = [(tree.root, "  ", False)]
    while stack:
        spec, indent, item = stack.pop()
        children = _dump_node(spec, indent, lines, item)
        stack.extend((child, children, True) for child in reversed(spec.get("children", [])))
    return _with_history(lines, tree.history)


def dump_live_yaml(
    root: py_trees.behaviour.Behaviour,
    execution: str,
    header: str = "",
    history: typing.Optional[typing.Dict[str, typing.List[EditRecord]]] = None,
) -> str:
    """:func:`dump_yaml` of a live tree in linear time, without building its description (leaf lines are cached)."""
    lines = _header(execution, header)
    stack: typing.List[typing.Tuple[py_trees.behaviour.Behaviour, str, bool]] = [(root, "  ", False)]
    while stack:
        node, indent, item = stack.pop()
        text = node.__dict__.get("_yaml_line")
        if text is None and isinstance(node, SkillLeaf):
            text = node._yaml_line = _flow_leaf(node.name, node.skill, node.parameters)
        if text is not None:
            lines.append(f"{indent}- {text}" if item else f"{indent}{text}")
            continue
        spec = describe_shallow(node)
        if spec["type"] in COMPOSITES or spec["type"] in DECORATORS:
            spec["children"] = node.children
        children = _dump_node(spec, indent, lines, item)
        stack.extend((child, children, True) for child in reversed(node.children))
    return _with_history(lines, history)


def _with_history(lines: typing.List[str], history: typing.Optional[typing.Dict[str, typing.List[EditRecord]]]) -> str:
    """The tree's lines, then its edit history (one JSON edit per line, which yaml reads)."""
    if history and (history.get("undo") or history.get("redo")):
        lines.append("history:")
        for key in ("undo", "redo"):
            edits = history.get(key, [])
            lines.append(f"  {key}:" if edits else f"  {key}: []")
            lines.extend(f"    - {json.dumps(edit)}" for edit in edits)
    return "\n".join(lines) + "\n"


def _header(execution: str, header: str) -> typing.List[str]:
    lines = [f"# {line}" for line in header.splitlines()]
    lines.append(f"execution: {json.dumps(execution)}")
    lines.append("root:")
    return lines


def _flow_leaf(name: str, skill: str, parameters: typing.Optional[typing.Dict[str, str]] = None) -> str:
    text = f"type: skill, name: {json.dumps(name)}, skill: {json.dumps(skill)}"
    if parameters:
        text += ", parameters: " + json.dumps(parameters)
    return f"{{{text}}}"


def _dump_node(spec: Spec, indent: str, lines: typing.List[str], item: bool) -> str:
    """Write one node's own lines; return the indent of its children's items."""
    first = f"{indent}- " if item else indent
    rest = f"{indent}  " if item else indent
    name = json.dumps(spec["name"])
    if spec["type"] == "skill":
        lines.append(f"{first}{_flow_leaf(spec['name'], spec['skill'], spec.get('parameters'))}")
        return rest
    if spec["type"] == "pause":
        lines.append(f"{first}{{type: pause, name: {name}}}")
        return rest
    lines.append(f"{first}type: {spec['type']}")
    lines.append(f"{rest}name: {name}")
    if spec["type"] == "parallel":
        lines.append(f"{rest}policy: {spec['policy']}")
        lines.append(f"{rest}synchronise: {str(spec['synchronise']).lower()}")
    elif spec["type"] == "retry":
        lines.append(f"{rest}attempts: {spec['attempts']}")
    elif spec["type"] == "timeout":
        lines.append(f"{rest}seconds: {json.dumps(spec['seconds'])}")
    elif spec["type"] in COMPOSITES:
        lines.append(f"{rest}memory: {str(spec['memory']).lower()}")
    lines.append(f"{rest}children:" if spec["children"] else f"{rest}children: []")
    return rest + "  "
