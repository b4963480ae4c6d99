"""HIGH-LEVEL teaching (thesis II-B, Appendix A.1): the tree as the GUI sees it and the three-step selection.

Step 1 selects a node (horizontal slider, device X), step 2 an operation (vertical slider, device Y), step 3 for
insert an index (dial, device rotation about X); each click confirms one step, the last one yields a request.

Beyond the thesis, without changing its gestures: in step 2, rolling the handle beyond ``page_turn`` shows a second
page of operations (unwrap, wrap in a decorator or composite, convert a composite), whose retry and timeout take
their value from the step-3 dial; a click with the handle pushed down (device Z below ``-edit_push``) undoes
the last edit, pulled up redoes it, from any step; and the robot's proposal (teleteach.gui.proposal) comes
preselected: its node and operation are shown chosen and a click confirms it, until the handle moves to another
button, which selects as in step 1 (the operator corrects the robot with the same gestures as ever).
"""

import dataclasses
import enum
from typing import Dict, List, NamedTuple, Optional, Sequence, Tuple

from teleteach.bt.editor import EditRequest
from teleteach.core.gui_config import GuiConfig
from teleteach.gui.device import DeviceSample, scale_to_index
from teleteach.gui.proposal import REPAIR_CHOICE, Offer
from teleteach.msg import Behaviour

# Bottom to top on the vertical slider: moving the device towards -Y goes towards "remove" (thesis Fig. 5, phase C).
OPERATIONS = ("remove", "insert", "prepend", "add")
# The second page, bottom to top: "operation node_type" as /change_tree takes them.
MORE_OPERATIONS = (
    "unwrap",
    "wrap retry",
    "wrap timeout",
    "wrap inverter",
    "wrap selector",
    "wrap sequence",
    "convert sequence",
    "convert selector",
    "convert parallel",
    "target",  # add, prepend and insert put nodes into the selected composite (again on it: back to the default)
)
PAGES = (OPERATIONS, MORE_OPERATIONS)
DEFAULT_PARENT = "BehaviorExecution"
COMPOSITE_TYPES = (2, 3, 4)  # teleteach/Behaviour SEQUENCE, SELECTOR, PARALLEL: what add, prepend and insert can fill

STATUS_NAMES = {
    Behaviour.INVALID: "invalid",
    Behaviour.RUNNING: "running",
    Behaviour.SUCCESS: "success",
    Behaviour.FAILURE: "failure",
}


EDIT_CUE = 0.5  # a handle pushed (pulled) beyond this share of edit_push is told how far undo (redo) still is


class LibrarySkill(NamedTuple):
    """A skill of the library as the HIGH-LEVEL tab shows it (the fields of teleteach/SkillLibrary)."""

    name: str
    kind: str
    data_file: str
    problem: str = ""  # why it cannot run (its file is missing or bad): its button is greyed out

    @property
    def available(self) -> bool:
        """Whether the skill can be added to the tree."""
        return not self.problem


@dataclasses.dataclass(frozen=True)
class TreeNode:
    """One behaviour of the live tree (the fields of teleteach/Behaviour the GUI needs)."""

    name: str
    class_name: str
    own_id: str
    parent_id: str
    child_ids: Tuple[str, ...]
    type: int
    status: int
    is_active: bool = False


@dataclasses.dataclass
class TreeSnapshot:
    """The tree in depth-first order plus lookups; built from /behaviour_tree/log/tree."""

    nodes: List[TreeNode]

    def __post_init__(self):
        self.by_id: Dict[str, TreeNode] = {node.own_id: node for node in self.nodes}

    @property
    def root(self) -> Optional[TreeNode]:
        """The node without a (known) parent."""
        for node in self.nodes:
            if node.parent_id not in self.by_id:
                return node
        return None

    def children(self, node: TreeNode) -> List[TreeNode]:
        """Children in tick order."""
        return [self.by_id[child] for child in node.child_ids if child in self.by_id]

    def depth_first(self) -> List[Tuple[int, TreeNode]]:
        """(depth, node) pairs from the root, children in tick order."""
        result: List[Tuple[int, TreeNode]] = []
        root = self.root
        stack = [(0, root)] if root else []
        while stack:
            depth, node = stack.pop()
            result.append((depth, node))
            stack.extend((depth + 1, child) for child in reversed(self.children(node)))
        return result

    def find(self, name: str) -> Optional[TreeNode]:
        """The node with this (unique) name."""
        return next((node for node in self.nodes if node.name == name), None)

    def child_count(self, parent_name: str) -> int:
        """Number of children of the composite ``parent_name`` (0 when absent)."""
        parent = self.find(parent_name)
        return len(self.children(parent)) if parent else 0


class Step(enum.Enum):
    """Where the operator is in the three-step flow."""

    NODE = 1
    OPERATION = 2
    INDEX = 3
    WAITING = 4
    PARAMETER = 5  # step 3 for a retry's attempts or a timeout's seconds
    PROPOSAL = 6  # the robot's proposal preselected: a click confirms it, the handle on another button leaves it


class SelectionFlow:
    """The three-step state machine of the HIGH-LEVEL tab; knows nothing about widgets or ROS.

    ``choices`` are the button names the horizontal slider walks over (tree leaves, then library skills).
    """

    def __init__(self, config: GuiConfig):
        self.config = config
        self.choices: List[str] = []
        self.default_slots = 1
        self.composite_sizes: Dict[str, int] = {}  # composite (or decorator) name -> number of children
        self.target = ""  # the composite add, prepend and insert put nodes into ("": DEFAULT_PARENT)
        self.step = Step.NODE
        self.node_index = 0
        self.page = 0
        self.operation_index = 0
        self.index = 0
        self.parameter_index = 0
        self.height = 0.0  # device Z of the latest sample: a click with the handle pushed or pulled undoes / redoes
        self._sample: Optional[DeviceSample] = None  # the latest device sample: a step that begins starts from it
        self.repair_node = ""  # the failed node whose help request suggests a remembered repair ("" if none)
        self.offer: Optional[Offer] = None  # the robot's proposal to preselect, until it is sent or withdrawn
        self._offer_button: Optional[int] = None  # the button under the handle when the preselection was first felt
        self._sent_offer: Optional[Offer] = None  # the offer the operator confirmed last
        self.answer = ""

    def set_choices(
        self, choices: Sequence[str], insert_slots: int, composite_sizes: Optional[Dict[str, int]] = None
    ) -> None:
        """New buttons (tree or library changed); keeps the selected name when it still exists.

        ``insert_slots`` is the dial's range for DEFAULT_PARENT; ``composite_sizes`` the other composites' child
        counts (a composite that is gone stops being the target).
        """
        selected = self.selected_node
        self.choices = list(choices)
        self.default_slots = max(1, insert_slots)
        self.composite_sizes = dict(composite_sizes or {})
        if self.target not in self.composite_sizes:
            self.target = ""
        if selected in self.choices:
            self.node_index = self.choices.index(selected)
        else:
            self.node_index = min(self.node_index, max(0, len(self.choices) - 1))
            if self.step in (Step.OPERATION, Step.INDEX, Step.PARAMETER):
                self.step = Step.NODE
        self.index = min(self.index, self.insert_slots - 1)
        self._offer_button = None  # the buttons moved: the handle's place is felt again
        if self.step is Step.PROPOSAL:
            self._preselect()

    def set_offer(self, offer: Optional[Offer]) -> None:
        """The robot's proposal of the open help request (None: none, or withdrawn); a new one is preselected."""
        if offer is None:
            self._sent_offer = None  # a later failure may bring the same proposal again: a new offer
        elif offer == self._sent_offer:
            return  # the help request still carries the proposal the operator confirmed
        if offer == self.offer:
            return  # the same proposal again: a preselection the operator left stays left
        self.offer = offer
        if offer is not None and self.step in (Step.NODE, Step.PROPOSAL):
            self._preselect()
        elif offer is None and self.step is Step.PROPOSAL:
            self.step = Step.NODE

    def _preselect(self) -> None:
        """Show the offer chosen: its node under the node slider, its operation (and page) under the other."""
        shown = self.offer.shown
        self.step, self._offer_button = Step.PROPOSAL, None
        buttons = [index for index, name in enumerate(self.choices) if name == shown.node_name]
        if buttons:  # a skill added from the library is its button there, the last one of that name
            self.node_index = buttons[-1] if shown.operation in ("add", "prepend", "insert") else buttons[0]
        operation = " ".join(part for part in (shown.operation, shown.node_type) if part)
        for page, operations in enumerate(PAGES):
            if operation in operations:
                self.page, self.operation_index = page, operations.index(operation)
        if shown.operation == "insert":
            self.index = min(shown.index, self.insert_slots - 1)

    @property
    def insert_slots(self) -> int:
        """Positions the index dial offers: the target's children + 1."""
        return self.composite_sizes[self.target] + 1 if self.target else self.default_slots

    @property
    def parent(self) -> str:
        """The composite add, prepend and insert put nodes into, as the request names it."""
        return self.target

    @property
    def selected_node(self) -> Optional[str]:
        """The name under the horizontal slider."""
        return self.choices[self.node_index] if self.choices else None

    @property
    def operations(self) -> Tuple[str, ...]:
        """The operations of the page the vertical slider walks over."""
        return PAGES[self.page]

    @property
    def selected_operation(self) -> str:
        """The operation under the vertical slider ("remove", ..., "wrap retry")."""
        return self.operations[min(self.operation_index, len(self.operations) - 1)]

    @property
    def parameter_values(self) -> Tuple[float, ...]:
        """What the step-3 dial offers for the selected wrap: attempts of a retry, seconds of a timeout."""
        wrapper = self.selected_operation.partition(" ")[2]
        return tuple(self.config.retry_attempts if wrapper == "retry" else self.config.timeout_seconds)

    @property
    def parameter(self) -> float:
        """The value under the dial in the parameter step."""
        values = self.parameter_values
        return values[min(self.parameter_index, len(values) - 1)]

    def reset(self) -> None:
        """Back to step 1, adding into DEFAULT_PARENT again (entering the tab, returning to START).

        An offer still open comes preselected again: the operator who looked elsewhere first finds it as it came.
        """
        self.step = Step.NODE
        self.page = 0
        self.target = ""
        if self.offer is not None:
            self._preselect()

    def device(self, sample: DeviceSample) -> None:
        """Move the control of the current step only; the others stay where they are (greyed out)."""
        self._sample = sample
        self.height = sample.z
        if self.step is Step.PROPOSAL and self.choices:
            button = scale_to_index(sample.x, self.config.device_range, len(self.choices))
            if self._offer_button is None:
                self._offer_button = button  # where the handle was when the preselection was first felt
            if button == self._offer_button:
                return
            self.step, self.page = Step.NODE, 0  # the handle went to another button: the operator selects
        if self.step is Step.NODE and self.choices:
            self.node_index = scale_to_index(sample.x, self.config.device_range, len(self.choices))
        elif self.step is Step.OPERATION:
            self.page = 1 if sample.roll > self.config.page_turn else 0
            self.operation_index = scale_to_index(sample.y, self.config.device_range, len(self.operations))
        elif self.step is Step.INDEX:
            self.index = scale_to_index(sample.roll, self.config.device_angle_range, self.insert_slots)
        elif self.step is Step.PARAMETER:
            values = self.parameter_values
            self.parameter_index = scale_to_index(sample.roll, self.config.device_angle_range, len(values))

    @property
    def edit_gesture_near(self) -> str:
        """The edit the handle is on its way to (beyond half ``edit_push``), before a click would send it, or ""."""
        if self.edit_gesture or abs(self.height) < EDIT_CUE * self.config.edit_push:
            return ""
        return "undo" if self.height < 0.0 else "redo"

    @property
    def edit_gesture(self) -> str:
        """The edit a click would send now: undo (handle pushed down), redo (pulled up), or "" (neither)."""
        if self.height < -self.config.edit_push:
            return "undo"
        if self.height > self.config.edit_push:
            return "redo"
        return ""

    def confirmation(self) -> Optional[Tuple[str, str]]:
        """What a click now confirms, as (step, choice); None when it confirms nothing.

        ("node", "PlaceItem"), ("operation", "remove"), ("index", "3"), ("parameter", "2"), ("undo", ""), ("redo", ""),
        ("repair", the failed node), ("proposal", the robot's request in words).
        """
        if self.step is Step.WAITING:
            return None
        if self.edit_gesture:
            return self.edit_gesture, ""
        if self.step is Step.PROPOSAL:
            return "proposal", self.offer.request.describe()
        if self.step is Step.NODE:
            if self.repair_node and self.selected_node == REPAIR_CHOICE:
                return "repair", self.repair_node
            return ("node", self.selected_node) if self.choices else None
        if self.step is Step.OPERATION:
            return "operation", self.selected_operation
        if self.step is Step.INDEX:
            return "index", str(self.index)
        return "parameter", f"{self.parameter:g}"

    def click(self) -> Optional[EditRequest]:
        """Confirm the current step; returns the request once the flow is complete.

        A step that begins takes its control from where the handle is now (samples come only when the handle moves),
        so what it shows before the handle moves is what a click confirms: step 2 showed the operation left from the
        last edit, and a click with the handle still then confirmed the one under it.
        """
        before = self.step
        request = self._confirm()
        begun = self.step is not before and self.step in (Step.OPERATION, Step.INDEX, Step.PARAMETER)
        if begun and self._sample is not None:
            self.device(self._sample)
        return request

    def _confirm(self) -> Optional[EditRequest]:
        """The click's transition: the next step, or the request of the last one."""
        if self.step is not Step.WAITING and self.edit_gesture:
            self.step = Step.WAITING
            return EditRequest("", self.edit_gesture)
        if self.step is Step.PROPOSAL:
            request, self._sent_offer = self.offer.request, self.offer
            self.step, self.offer = Step.WAITING, None  # sent: the same offer is not preselected again
            return request
        if self.step is Step.NODE:
            if self.repair_node and self.selected_node == REPAIR_CHOICE:
                self.step = Step.WAITING
                return EditRequest(self.repair_node, "repair")
            if self.choices:
                self.step = Step.OPERATION
            return None
        if self.step is Step.OPERATION:
            operation, _, node_type = self.selected_operation.partition(" ")
            if operation == "insert":
                self.step = Step.INDEX
                return None
            if node_type in ("retry", "timeout"):
                self.step = Step.PARAMETER
                return None
            if operation == "target":
                self._retarget(self.selected_node)
                return None
            self.step = Step.WAITING
            parent = self.target if operation in ("add", "prepend") else ""
            return EditRequest(self.selected_node, operation, parent=parent, node_type=node_type)
        if self.step is Step.INDEX:
            self.step = Step.WAITING
            return EditRequest(self.selected_node, "insert", self.index, parent=self.target)
        if self.step is Step.PARAMETER:
            self.step = Step.WAITING
            node_type = self.selected_operation.partition(" ")[2]
            return EditRequest(self.selected_node, "wrap", node_type=node_type, parameter=float(self.parameter))
        return None

    def _retarget(self, name: Optional[str]) -> None:
        """Make ``name`` the composite that add, prepend and insert fill (the current target again: the default)."""
        self.step, self.page = Step.NODE, 0
        if name not in self.composite_sizes:
            self.answer = f"refused: {name} is not a composite: add, prepend and insert cannot put nodes into it"
            return
        self.target = "" if name == self.target else name
        self.index = 0
        self.answer = f"done: add, prepend and insert now put nodes into {self.target or DEFAULT_PARENT}"

    def answered(self, success: bool, message: str) -> None:
        """The service answered (or failed): show it and start over."""
        self.answer = ("done: " if success else "refused: ") + message
        self.step = Step.NODE
        self.page = 0
