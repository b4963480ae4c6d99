"""A study file (``config/studies/<name>.yaml``), read and validated.

The format is documented for users in ``config/studies/example.yaml``.

Every problem is one line naming the file, the line and the field (``example.yaml:14: conditions.guided.parameters:
unknown parameter 'teaching_gui/guidence' ...``), because a study file is written by hand and a study must not start
on a mistake: a condition sets only real parameters of real nodes (:mod:`teleteach.study.parameters`), and every
task has a goal judged from the world (:mod:`teleteach.study.goals`).
"""

import dataclasses
import hashlib
import math
import pathlib
import re
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple

import yaml

from teleteach.core.questionnaire import NASA_TLX, Item
from teleteach.core.scene import SceneError, load_scene
from teleteach.haptics.scenario import ScenarioError, load_scenario
from teleteach.study.goals import AXES, Goal, PlacementGoal, StiffnessGoal, TreeGoal
from teleteach.study.parameters import check_launch_argument, check_parameter

NAME = re.compile(r"^[A-Za-z0-9_-]+$")
CONDITION_ORDERS = ("latin_square", "random", "fixed")
TASK_ORDERS = ("fixed", "latin_square", "random")
START_MODES = ("HIGH_LEVEL", "LOW_LEVEL", "SHARED_CONTROL")
PAUSE_TREE = ("instructions", "always", "never")
INTENDED_STEPS = ("mode", "node", "operation", "index")
_TOP = ("name", "description", "participants", "conditions", "tasks", "trials_per_task", "order", "questionnaire")
_TOP += ("system", "scripted")
_CONDITION = ("label", "description", "parameters")
_TASK = ("title", "instructions", "goal", "intended", "timeout", "trials", "pause_tree", "system", "script")
_GOAL = ("tree", "stiffness", "placement")
_TREE = ("absent", "present", "children")
_STIFFNESS = (*AXES, "hold")
_PLACEMENT = ("product", "gap", "hold")
_ORDER = ("conditions", "tasks", "seed")
_QUESTIONNAIRE = ("nasa_tlx", "items")
_ITEM = ("name", "title", "question", "low", "high", "points")
_SCRIPTED = ("parameters", "speed", "reading_time", "aim")
DEFAULT_TIMEOUT = 180.0  # [s] a task's time limit when its file gives none


class StudyError(ValueError):
    """A study file that cannot be run; the message is one line naming the file, the line and the field."""


@dataclasses.dataclass(frozen=True)
class Condition:
    """A named set of node parameters (``<node>/<parameter>``: value)."""

    name: str
    parameters: Mapping[str, Any]
    label: str = ""  # what the participant may read about it ("" = nothing)
    description: str = ""


@dataclasses.dataclass(frozen=True)
class Task:
    """What the participant does in a trial, and the goal the world must show."""

    name: str
    title: str
    instructions: str
    goal: Goal
    timeout: float  # [s]
    trials: int
    intended: Mapping[str, str] = dataclasses.field(default_factory=dict)  # step -> the right choice
    pause_tree: str = "instructions"  # the tree waits while the instructions show | for the whole trial | never
    system: Mapping[str, Any] = dataclasses.field(default_factory=dict)  # full.launch arguments of this task
    script: Optional[pathlib.Path] = None  # the scripted participant's keyframes


@dataclasses.dataclass(frozen=True)
class Order:
    """How conditions and tasks are ordered for each participant."""

    conditions: str = "latin_square"
    tasks: str = "fixed"
    seed: int = 0


@dataclasses.dataclass(frozen=True)
class Scripted:
    """The scripted participant: extra node parameters, and the seeded spread of its pace."""

    parameters: Mapping[str, Any] = dataclasses.field(default_factory=dict)
    speed: Tuple[float, float] = (1.0, 1.0)  # time scale of the task scripts, drawn per participant
    reading_time: Tuple[float, float] = (1.0, 1.0)  # [s] before the start gesture, drawn per trial
    aim: float = 0.0  # [m] the hand aims off the task script's positions by up to this in x and y, drawn per trial


@dataclasses.dataclass(frozen=True)
class Study:
    """A validated study."""

    name: str
    source: pathlib.Path
    conditions: Tuple[Condition, ...]
    tasks: Tuple[Task, ...]
    questionnaire: Tuple[Item, ...]
    order: Order = dataclasses.field(default_factory=Order)
    participants: Tuple[str, ...] = ()
    system: Mapping[str, Any] = dataclasses.field(default_factory=dict)
    scripted: Scripted = dataclasses.field(default_factory=Scripted)
    description: str = ""
    digest: str = ""  # sha256 of the file's text

    def condition(self, name: str) -> Condition:
        """The condition called ``name``."""
        return next(condition for condition in self.conditions if condition.name == name)

    def task(self, name: str) -> Task:
        """The task called ``name``."""
        return next(task for task in self.tasks if task.name == name)


class _Fields:
    """The parsed yaml with the line of every key and item, for messages ``file:line: path: problem``."""

    def __init__(self, text: str, source: str):
        self.source = source
        try:
            root = yaml.compose(text, Loader=yaml.SafeLoader)
            self.data = yaml.safe_load(text)
        except yaml.YAMLError as error:
            mark = getattr(error, "problem_mark", None)
            line = f":{mark.line + 1}" if mark is not None else ""
            problem = getattr(error, "problem", None) or str(error).splitlines()[0]
            raise StudyError(f"{source}{line}: not valid YAML: {problem}") from None
        self.lines: Dict[Tuple[Any, ...], int] = {}
        if root is not None:
            self._walk(root, ())

    def _walk(self, node: yaml.Node, path: Tuple[Any, ...]) -> None:
        self.lines.setdefault(path, node.start_mark.line + 1)
        if isinstance(node, yaml.MappingNode):
            for key, value in node.value:
                self.lines[(*path, key.value)] = key.start_mark.line + 1
                self._walk(value, (*path, key.value))
        elif isinstance(node, yaml.SequenceNode):
            for index, item in enumerate(node.value):
                self._walk(item, (*path, index))

    def error(self, path: Sequence[Any], problem: str) -> StudyError:
        """The one-line error for the field at ``path``."""
        path = tuple(path)
        line = next((self.lines[path[:size]] for size in range(len(path), -1, -1) if path[:size] in self.lines), 1)
        field = "".join(f"[{part}]" if isinstance(part, int) else f".{part}" for part in path).lstrip(".")
        return StudyError(f"{self.source}:{line}: {field + ': ' if field else ''}{problem}")


def load_study(path) -> Study:
    """Read and validate a study file.

    Raises:
        StudyError: the file is missing or breaks the format (one line: file, line, field, problem).
    """
    path = pathlib.Path(path).expanduser().resolve()
    try:
        text = path.read_text()
    except OSError as error:
        raise StudyError(f"{path}: cannot read the study file ({error.strerror})") from None
    return parse_study(text, path)


def parse_study(text: str, path: pathlib.Path) -> Study:
    """Validate study yaml ``text`` of the file ``path`` (scripts are found relative to it)."""
    fields = _Fields(text, str(path))
    data = fields.data
    if not isinstance(data, dict):
        raise fields.error((), "a study file is a mapping with conditions and tasks")
    _known(fields, (), data, _TOP)
    name = data.get("name", path.stem)
    if not (isinstance(name, str) and NAME.match(name)):
        raise fields.error(("name",), f"must be letters, digits, '_' or '-' (a folder name), got {name!r}")
    participants = _names(fields, ("participants",), data.get("participants", []), "participant ids")
    system = _system(fields, ("system",), data.get("system", {}))
    trials_per_task = _integer(fields, ("trials_per_task",), data.get("trials_per_task", 1), 1)
    conditions = _conditions(fields, data)
    tasks = tuple(_tasks(fields, data, path.parent, trials_per_task))
    return Study(
        name=name,
        source=path,
        conditions=conditions,
        tasks=tasks,
        questionnaire=_questionnaire(fields, data.get("questionnaire", {})),
        order=_order(fields, data.get("order", {})),
        participants=participants,
        system=system,
        scripted=_scripted(fields, data.get("scripted", {})),
        description=_text(fields, ("description",), data.get("description", "")),
        digest=hashlib.sha256(text.encode("utf-8")).hexdigest(),
    )


def _known(fields: _Fields, path, data: Mapping[str, Any], allowed: Sequence[str]) -> None:
    for key in data:
        if key not in allowed:
            raise fields.error((*path, key), f"unknown field (allowed: {', '.join(allowed)})")


def _mapping(fields: _Fields, path, value: Any, what: str) -> Dict[str, Any]:
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise fields.error(path, f"must be a mapping of {what}, got {value!r}")
    return value


def _text(fields: _Fields, path, value: Any) -> str:
    if not isinstance(value, str):
        raise fields.error(path, f"must be text, got {value!r}")
    return value.strip()


def _number(fields: _Fields, path, value: Any, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise fields.error(path, f"must be a finite number, got {value!r}")
    if positive and value <= 0:
        raise fields.error(path, f"must be positive, got {value}")
    return float(value)


def _integer(fields: _Fields, path, value: Any, lowest: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < lowest:
        raise fields.error(path, f"must be a whole number >= {lowest}, got {value!r}")
    return value


def _names(fields: _Fields, path, value: Any, what: str) -> Tuple[str, ...]:
    if not isinstance(value, list):
        raise fields.error(path, f"must be a list of {what}, got {value!r}")
    for index, item in enumerate(value):
        if not (isinstance(item, str) and NAME.match(item)):
            raise fields.error((*path, index), f"must be letters, digits, '_' or '-', got {item!r}")
    if len(set(value)) != len(value):
        raise fields.error(path, f"lists a name twice: {value}")
    return tuple(value)


def _range(fields: _Fields, path, value: Any, positive: bool = False) -> Tuple[float, float]:
    if not (isinstance(value, list) and len(value) == 2):
        raise fields.error(path, f"must be [low, high], got {value!r}")
    low, high = (_number(fields, (*path, index), item, positive) for index, item in enumerate(value))
    if low > high:
        raise fields.error(path, f"low {low:g} is above high {high:g}")
    return low, high


def _system(fields: _Fields, path, value: Any) -> Dict[str, Any]:
    system = _mapping(fields, path, value, "full.launch arguments")
    for name, argument in system.items():
        problem = check_launch_argument(name, argument)
        if problem:
            raise fields.error((*path, name), problem)
    return dict(system)


def _parameters(fields: _Fields, path, value: Any) -> Dict[str, Any]:
    parameters = _mapping(fields, path, value, "node parameters (<node>/<parameter>: value)")
    for name, setting in parameters.items():
        problem = check_parameter(str(name), setting)
        if problem:
            raise fields.error((*path, name), problem)
    return dict(parameters)


def _conditions(fields: _Fields, data: Mapping[str, Any]) -> Tuple[Condition, ...]:
    raw = _mapping(fields, ("conditions",), data.get("conditions"), "conditions")
    if not raw:
        raise fields.error(("conditions",), "a study needs at least one condition")
    conditions = []
    for name, spec in raw.items():
        path = ("conditions", name)
        if not (isinstance(name, str) and NAME.match(name)):
            raise fields.error(path, "a condition's name must be letters, digits, '_' or '-'")
        spec = _mapping(fields, path, spec, "label, description and parameters")
        _known(fields, path, spec, _CONDITION)
        conditions.append(
            Condition(
                name=name,
                parameters=_parameters(fields, (*path, "parameters"), spec.get("parameters", {})),
                label=_text(fields, (*path, "label"), spec.get("label", "")),
                description=_text(fields, (*path, "description"), spec.get("description", "")),
            )
        )
    return tuple(conditions)


def _tasks(fields: _Fields, data: Mapping[str, Any], folder: pathlib.Path, trials_per_task: int) -> List[Task]:
    raw = _mapping(fields, ("tasks",), data.get("tasks"), "tasks")
    if not raw:
        raise fields.error(("tasks",), "a study needs at least one task")
    tasks = []
    for name, spec in raw.items():
        path = ("tasks", name)
        if not (isinstance(name, str) and NAME.match(name)):
            raise fields.error(path, "a task's name must be letters, digits, '_' or '-'")
        spec = _mapping(fields, path, spec, "task fields")
        _known(fields, path, spec, _TASK)
        if "goal" not in spec:
            raise fields.error(path, f"no goal: a task needs a goal judged from the world ({', '.join(_GOAL)})")
        intended = _mapping(fields, (*path, "intended"), spec.get("intended", {}), "selection steps")
        _known(fields, (*path, "intended"), intended, INTENDED_STEPS)
        if "mode" in intended and intended["mode"] not in START_MODES:
            raise fields.error((*path, "intended", "mode"), f"must be one of {', '.join(START_MODES)}")
        tasks.append(
            Task(
                name=name,
                title=_text(fields, (*path, "title"), spec.get("title", name.replace("_", " "))),
                instructions=_text(fields, (*path, "instructions"), spec.get("instructions", "")),
                goal=_goal(fields, (*path, "goal"), spec["goal"], spec.get("system", {})),
                timeout=_number(fields, (*path, "timeout"), spec.get("timeout", DEFAULT_TIMEOUT), positive=True),
                trials=_integer(fields, (*path, "trials"), spec.get("trials", trials_per_task), 1),
                intended={step: str(choice) for step, choice in intended.items()},
                pause_tree=_choice(fields, (*path, "pause_tree"), spec.get("pause_tree", "instructions"), PAUSE_TREE),
                system=_system(fields, (*path, "system"), spec.get("system", {})),
                script=_script(fields, (*path, "script"), spec.get("script"), folder),
            )
        )
    return tasks


def _choice(fields: _Fields, path, value: Any, choices: Sequence[str]) -> str:
    if value not in choices:
        raise fields.error(path, f"must be one of {', '.join(choices)}, got {value!r}")
    return value


def _flag(fields: _Fields, path, value: Any) -> bool:
    if not isinstance(value, bool):
        raise fields.error(path, f"must be true or false, got {value!r}")
    return value


def _script(fields: _Fields, path, value: Any, folder: pathlib.Path) -> Optional[pathlib.Path]:
    if value is None:
        return None
    script = (folder / _text(fields, path, value)).resolve()
    try:
        load_scenario(script)
    except ScenarioError as error:
        raise fields.error(path, f"not a playable scenario: {error}") from None
    return script


def _goal(fields: _Fields, path, value: Any, system: Mapping[str, Any]) -> Goal:
    spec = _mapping(fields, path, value, "goal kinds")
    _known(fields, path, spec, _GOAL)
    if not spec:
        raise fields.error(path, f"empty: a task needs a goal judged from the world ({', '.join(_GOAL)})")
    tree = stiffness = placement = None
    if "tree" in spec:
        tree_path = (*path, "tree")
        raw = _mapping(fields, tree_path, spec["tree"], "absent, present, children")
        _known(fields, tree_path, raw, _TREE)
        children = _mapping(fields, (*tree_path, "children"), raw.get("children", {}), "composite: [children]")
        tree = TreeGoal(
            absent=_names(fields, (*tree_path, "absent"), raw.get("absent", []), "node names"),
            present=_names(fields, (*tree_path, "present"), raw.get("present", []), "node names"),
            children={
                parent: _names(fields, (*tree_path, "children", parent), names, "node names")
                for parent, names in children.items()
            },
        )
        if not (tree.absent or tree.present or tree.children):
            raise fields.error(tree_path, "names nothing to judge (give absent, present or children)")
    if "stiffness" in spec:
        stiffness_path = (*path, "stiffness")
        raw = _mapping(fields, stiffness_path, spec["stiffness"], "axis bounds [N/m] and hold [s]")
        _known(fields, stiffness_path, raw, _STIFFNESS)
        bounds = tuple(
            _range(fields, (*stiffness_path, axis), raw[axis], positive=True) if axis in raw else None for axis in AXES
        )
        if all(bound is None for bound in bounds):
            raise fields.error(stiffness_path, "bounds no axis (give x, y or z as [low, high] in N/m)")
        stiffness = StiffnessGoal(bounds, _number(fields, (*stiffness_path, "hold"), raw.get("hold", 1.0), True))
    if "placement" in spec:
        placement = _placement(fields, (*path, "placement"), spec["placement"], system)
    return Goal(tree=tree, stiffness=stiffness, placement=placement)


def _placement(fields: _Fields, path, value: Any, system: Mapping[str, Any]) -> PlacementGoal:
    raw = _mapping(fields, path, value, "product, gap, hold")
    _known(fields, path, raw, _PLACEMENT)
    for key in ("product", "gap"):
        if key not in raw:
            raise fields.error(path, f"missing field '{key}'")
    product, gap = (_text(fields, (*path, key), raw[key]) for key in ("product", "gap"))
    try:
        scene = load_scene()
        scene.gap(gap)
        scene.product(product)
    except (SceneError, KeyError) as error:
        raise fields.error(path, str(error).strip("'\"")) from None
    if product in (system.get("absent_products") or []):
        raise fields.error((*path, "product"), f"{product} is left out of the scene by absent_products")
    return PlacementGoal(product, gap, _number(fields, (*path, "hold"), raw.get("hold", 1.0), positive=True))


def _order(fields: _Fields, value: Any) -> Order:
    raw = _mapping(fields, ("order",), value, "conditions, tasks, seed")
    _known(fields, ("order",), raw, _ORDER)
    conditions = raw.get("conditions", "latin_square")
    if conditions not in CONDITION_ORDERS:
        raise fields.error(("order", "conditions"), f"must be one of {', '.join(CONDITION_ORDERS)}")
    tasks = raw.get("tasks", "fixed")
    if tasks not in TASK_ORDERS:
        raise fields.error(("order", "tasks"), f"must be one of {', '.join(TASK_ORDERS)}")
    return Order(conditions, tasks, _integer(fields, ("order", "seed"), raw.get("seed", 0), 0))


def _questionnaire(fields: _Fields, value: Any) -> Tuple[Item, ...]:
    path = ("questionnaire",)
    raw = _mapping(fields, path, value, "nasa_tlx and items")
    _known(fields, path, raw, _QUESTIONNAIRE)
    items = list(NASA_TLX) if _flag(fields, (*path, "nasa_tlx"), raw.get("nasa_tlx", True)) else []
    extra = raw.get("items", [])
    if not isinstance(extra, list):
        raise fields.error((*path, "items"), f"must be a list of items, got {extra!r}")
    for index, spec in enumerate(extra):
        item_path = (*path, "items", index)
        spec = _mapping(fields, item_path, spec, "item fields")
        _known(fields, item_path, spec, _ITEM)
        for key in ("name", "question"):
            if key not in spec:
                raise fields.error(item_path, f"missing field '{key}'")
        name = spec["name"]
        if not (isinstance(name, str) and NAME.match(name)) or name in [item.name for item in items]:
            raise fields.error((*item_path, "name"), f"must be a new name of letters, digits, '_' or '-', got {name!r}")
        points = _integer(fields, (*item_path, "points"), spec.get("points", 7), 2)
        items.append(
            Item(
                name=name,
                title=_text(fields, (*item_path, "title"), spec.get("title", name.replace("_", " ").capitalize())),
                question=_text(fields, (*item_path, "question"), spec["question"]),
                low=_text(fields, (*item_path, "low"), spec.get("low", "Strongly disagree")),
                high=_text(fields, (*item_path, "high"), spec.get("high", "Strongly agree")),
                points=points,
                minimum=1.0,
                maximum=float(points),
            )
        )
    return tuple(items)


def _scripted(fields: _Fields, value: Any) -> Scripted:
    path = ("scripted",)
    raw = _mapping(fields, path, value, "parameters, speed, reading_time")
    _known(fields, path, raw, _SCRIPTED)
    return Scripted(
        parameters=_parameters(fields, (*path, "parameters"), raw.get("parameters", {})),
        speed=_range(fields, (*path, "speed"), raw.get("speed", [1.0, 1.0]), positive=True),
        reading_time=_range(fields, (*path, "reading_time"), raw.get("reading_time", [1.0, 1.0]), positive=True),
        aim=_aim(fields, (*path, "aim"), raw.get("aim", 0.0)),
    )


def _aim(fields: _Fields, path, value: Any) -> float:
    aim = _number(fields, path, value)
    if not 0.0 <= aim <= 0.02:
        raise fields.error(path, f"must be between 0 and 0.02 m, got {aim}")
    return aim
