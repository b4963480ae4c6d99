"""The tabs of the teaching GUI (thesis Fig. 3): START, HIGH-LEVEL (with the live tree view) and LOW-LEVEL.

Tabs only display and collect the operator's choices; talking to ROS is the main window's job. Each tab acts on
device signals only while it is the active one (thesis A.2.1).
"""

import dataclasses
import math
import time
from typing import Callable, List, Optional, Sequence, Tuple

from PyQt5.QtCore import QEvent, QObject, QSize, Qt, QTimer, pyqtSignal
from PyQt5.QtGui import QBrush, QColor, QFont
from PyQt5.QtWidgets import (
    QDial,
    QFrame,
    QGridLayout,
    QGroupBox,
    QHBoxLayout,
    QHeaderView,
    QLabel,
    QPushButton,
    QScrollArea,
    QSizePolicy,
    QSlider,
    QSplitter,
    QTreeWidget,
    QTreeWidgetItem,
    QVBoxLayout,
    QWidget,
)

from teleteach.bt.editor import EditRequest
from teleteach.core.gui_config import GuiConfig
from teleteach.core.teleoperation import Clutch
from teleteach.gui.device import ClickClassifier, DeviceSample
from teleteach.gui.ellipsoid import MODES, EllipsoidCommand
from teleteach.gui.gl_view import ANGLE_NAMES, AXIS_NAMES, EllipsoidView
from teleteach.gui.selection import (
    COMPOSITE_TYPES,
    DEFAULT_PARENT,
    PAGES,
    REPAIR_CHOICE,
    STATUS_NAMES,
    LibrarySkill,
    SelectionFlow,
    Step,
    TreeSnapshot,
)
from teleteach.msg import Behaviour

STATUS_COLOURS = {
    Behaviour.RUNNING: QColor(40, 90, 220),
    Behaviour.SUCCESS: QColor(30, 150, 50),
    Behaviour.FAILURE: QColor(210, 40, 40),
}
NOT_VISITED = QColor(150, 150, 150)
PAUSE_CONDITION = "PauseCondition"  # its FAILURE is "not paused" (the tree runs), its SUCCESS "paused": no error
PAUSE_STATES = {
    Behaviour.SUCCESS: ("paused", QColor(230, 81, 0)),
    Behaviour.FAILURE: ("not paused", QColor(30, 150, 50)),
}
COMPOSITE_KINDS = {Behaviour.SEQUENCE: "sequence", Behaviour.SELECTOR: "selector", Behaviour.PARALLEL: "parallel"}
SELECTED_STYLE = "QPushButton { background: #ffd54f; border: 3px solid #e65100; font-weight: bold; padding: 6px; }"
BUTTON_STYLE = "QPushButton { padding: 6px; }"
UNAVAILABLE_STYLE = "QPushButton { padding: 6px; color: #9e9e9e; background: #eeeeee; }"
REPAIR_STYLE = "QPushButton { padding: 6px; color: white; background: #d22828; font-weight: bold; }"
_GROUP = "QGroupBox#step {{ border: {}; border-radius: 4px; margin-top: 1.3em; }} "
_TITLE = "QGroupBox#step::title {{ subcontrol-origin: margin; left: 8px; {} }}"
ACTIVE_STEP_STYLE = _GROUP.format("3px solid #2e7d32") + _TITLE.format("color: #1b5e20; font-weight: bold;")
STEP_STYLE = _GROUP.format("1px solid #bbb") + _TITLE.format("")
MAX_COLUMNS = 6  # buttons per row when the window is wide enough


def restyle(widget: QWidget, style: str) -> None:
    """Set a style sheet only when it differs: Qt re-polishes a widget (and its children) on every setStyleSheet."""
    if widget.styleSheet() != style:
        widget.setStyleSheet(style)


def _button_size(names: Sequence[str]) -> QSize:
    """The size a node button needs for the longest of ``names`` in the selected (bold, bordered) style."""
    probe = QPushButton()
    probe.setStyleSheet(SELECTED_STYLE)
    size = QSize(0, 0)
    for name in names:
        probe.setText(name)
        size = size.expandedTo(probe.sizeHint())
    probe.deleteLater()
    return size


def _big(label: QLabel, points: int, bold: bool = True) -> QLabel:
    font = QFont(label.font())
    font.setPointSize(points)
    font.setBold(bold)
    label.setFont(font)
    return label


@dataclasses.dataclass(frozen=True)
class AuthorityView:
    """Who leads the skill the robot replays (skills/authority), and the operator's clutch on its correction."""

    skill: str
    confidence: float  # [0, 1]
    operator_weight: float  # the share of the operator's correction that moves the arm
    correction: float  # [m] what the correction moves the equilibrium by now
    clutch: Clutch
    reason: str


def authority_text(view: AuthorityView) -> str:
    """START's line while a skill replays: who leads, how much a correction counts, what it moves."""
    leader = "the robot leads" if view.confidence >= 0.5 else "you lead"
    clutch = "correcting" if view.clutch is Clutch.ENGAGED else "hold the gripper closed to correct it"
    text = (
        f"replaying {view.skill}: {leader} (confidence {100 * view.confidence:.0f} %). Your correction counts "
        f"{100 * view.operator_weight:.0f} %, it moves the arm {1000 * view.correction:.0f} mm; {clutch}."
    )
    return f"{text} {view.reason}" if view.reason else text


class StartTab(QWidget):
    """Choose the teaching mode with the device, a click opens it; start a tree that waits for the operator.

    Device X left of the neutral zone selects HIGH-LEVEL, right of it LOW-LEVEL (as in the thesis); device Y up beyond
    half its range selects SHARED CONTROL above them, down beyond half its range TELEOP below them. In the neutral zone
    (``start_neutral_zone`` around the centre) nothing is selected, so a resting, centred handle opens nothing; the
    centre panel there shows what the tree does, and a click in it starts a tree that waits for its start
    (``start_requested``).
    """

    SHARED_CONTROL_Y = 0.5  # fraction of device_range above which device Y selects SHARED CONTROL (below -: TELEOP)
    NEUTRAL = -1  # ``selected`` in the neutral zone
    WAITING_STYLE = "background: #ffe0b2; border: {border}; color: #bf360c; font-size: 14pt; font-weight: bold;"
    STATE_STYLE = "background: #f5f5f5; border: {border}; color: #424242; font-size: 12pt;"

    mode_chosen = pyqtSignal(int)
    start_requested = pyqtSignal()
    AUTHORITY_SHOWN_FOR = 1000  # [ms] a replay's line stays this long after its last report

    def __init__(self, config: GuiConfig):
        super().__init__()
        self.config = config
        self.active = False
        self.selected = self.NEUTRAL
        self.tree_waiting = False
        self.tree_message = "no behaviour tree yet"
        layout = QVBoxLayout(self)
        layout.addStretch(1)
        title = _big(QLabel("Teleoperated teaching"), 20)
        title.setAlignment(Qt.AlignCenter)
        layout.addWidget(title)
        hint = QLabel(
            "Move the device left/right to choose a teaching mode (up for SHARED CONTROL, down for TELEOP), "
            "click (close the gripper) to open it."
        )
        hint.setAlignment(Qt.AlignCenter)
        layout.addWidget(hint)
        self.authority = QLabel()
        self.authority.setAlignment(Qt.AlignCenter)
        self.authority.setWordWrap(True)
        self.authority.setStyleSheet("background: #e1f5fe; color: #01579b; font-size: 13pt; padding: 6px;")
        self.authority.hide()
        self._authority_timer = QTimer(self)
        self._authority_timer.setSingleShot(True)
        self._authority_timer.timeout.connect(self.authority.hide)
        layout.addWidget(self.authority)
        row = QHBoxLayout()
        self.buttons: List[QPushButton] = []
        for index, (text, colour, height) in enumerate(
            (
                ("HIGH-LEVEL teaching\nchange the behaviour tree", "#c8e6c9", 240),
                ("LOW-LEVEL teaching\ndemonstrate stiffness", "#ffcdd2", 240),
                ("SHARED CONTROL\nthe MPC keeps your motion pattern; record it as a skill", "#bbdefb", 110),
                ("TELEOP\nmove the arm with the device (hold the gripper closed)", "#fff3c4", 110),
            )
        ):
            button = QPushButton(text)
            button.setMinimumHeight(height)
            button.setProperty("colour", colour)
            button.clicked.connect(lambda _checked, tab=index + 1: self.mode_chosen.emit(tab))
            self.buttons.append(button)
        self.centre = QLabel()
        self.centre.setAlignment(Qt.AlignCenter)
        self.centre.setWordWrap(True)
        self.centre.setFixedWidth(220)
        self.centre.setMinimumHeight(240)
        layout.addWidget(self.buttons[2])
        row.addWidget(self.buttons[0], 1)
        row.addWidget(self.centre)
        row.addWidget(self.buttons[1], 1)
        layout.addLayout(row)
        layout.addWidget(self.buttons[3])
        gesture = QLabel("In any mode, open the gripper fully to come back here.")
        gesture.setAlignment(Qt.AlignCenter)
        layout.addWidget(gesture)
        layout.addStretch(2)
        self._show()

    def show_authority(self, view: AuthorityView) -> None:
        """A skill replays: who leads it and what the operator's correction does (hidden once the reports stop)."""
        self.authority.setText(authority_text(view))
        self.authority.show()
        self._authority_timer.start(self.AUTHORITY_SHOWN_FOR)

    def show_tree(self, waiting: bool, message: str) -> None:
        """What the behaviour tree does (teleteach/TreeExecution): a tree waiting for its start is shown loudly."""
        self.tree_waiting, self.tree_message = waiting, message
        self._show()

    def _show(self) -> None:
        for index, button in enumerate(self.buttons):
            border = "5px solid #e65100" if index == self.selected else "1px solid #888"
            button.setStyleSheet(
                f"QPushButton {{ background: {button.property('colour')}; border: {border}; font-size: 16pt; }}"
            )
        border = "5px solid #e65100" if self.selected == self.NEUTRAL else "1px dashed #888"
        if self.tree_waiting:
            self.centre.setText("The robot waits for you.\n\nHandle in the centre, click: start its task.")
            self.centre.setStyleSheet(self.WAITING_STYLE.format(border=border))
        else:
            self.centre.setText(f"centre: no mode\n\nrobot: {self.tree_message}")
            self.centre.setStyleSheet(self.STATE_STYLE.format(border=border))

    def on_device(self, sample: DeviceSample) -> None:
        """Device X (and Y) choose the button; the neutral zone chooses none."""
        if self.active:
            if sample.y > self.SHARED_CONTROL_Y * self.config.device_range:
                selected = 2
            elif sample.y < -self.SHARED_CONTROL_Y * self.config.device_range:
                selected = 3
            elif abs(sample.x) < self.config.start_neutral_zone:
                selected = self.NEUTRAL
            else:
                selected = 0 if sample.x < 0.0 else 1
            if selected != self.selected:
                self.selected = selected
                self._show()

    def on_click(self, _stamp: float = 0.0) -> None:
        """Open the chosen mode; in the neutral zone, ask to start the tree."""
        if not self.active:
            return
        if self.selected == self.NEUTRAL:
            self.start_requested.emit()
        else:
            self.mode_chosen.emit(self.selected + 1)


class TreeView(QTreeWidget):
    """The live tree with node states in colour (running blue, success green, failure red, not visited grey)."""

    def __init__(self):
        super().__init__()
        self.setHeaderLabels(["Behaviour", "Skill", "State"])
        for column in range(3):  # every name whole: the columns take what their longest entry needs
            self.header().setSectionResizeMode(column, QHeaderView.ResizeToContents)
        self.header().setStretchLastSection(False)
        self._signature: Optional[tuple] = None

    def show_tree(self, tree: TreeSnapshot) -> None:
        """Rebuild when anything shown changed."""
        signature = tuple((depth, node.name, node.class_name, node.status) for depth, node in tree.depth_first())
        if signature == self._signature:
            return
        self._signature = signature
        self.clear()
        items = {}
        for _, node in tree.depth_first():
            parent = items.get(node.parent_id)
            state = STATUS_NAMES.get(node.status, "not visited") if node.status != Behaviour.INVALID else "not visited"
            colour = STATUS_COLOURS.get(node.status, NOT_VISITED)
            if node.class_name == PAUSE_CONDITION and node.status in PAUSE_STATES:
                state, colour = PAUSE_STATES[node.status]
            kind = COMPOSITE_KINDS.get(node.type, node.class_name)  # not py_trees' class (EditableSequence)
            item = QTreeWidgetItem([node.name, kind, state])
            brush = QBrush(colour)
            for column in range(3):
                item.setForeground(column, brush)
            if parent is None:
                self.addTopLevelItem(item)
            else:
                parent.addChild(item)
            items[node.own_id] = item
        self.expandAll()


class HighLevelTab(QWidget):
    """Buttons for the tree's nodes and the library's skills, and the three steps (thesis II-B, Fig. 5)."""

    request_ready = pyqtSignal(object)  # EditRequest
    selection_confirmed = pyqtSignal(str, str)  # step, choice (SelectionFlow.confirmation)

    def __init__(self, config: GuiConfig):
        super().__init__()
        self.config = config
        self.active = False
        self.flow = SelectionFlow(config)
        self.tree: Optional[TreeSnapshot] = None
        self.library: List[LibrarySkill] = []
        self.repair_tooltip = ""
        self._layout_signature: Optional[tuple] = None
        self.buttons: List[QPushButton] = []
        self._groups: List[Tuple[QGridLayout, List[QPushButton]]] = []
        self._columns = 0

        splitter = QSplitter(Qt.Horizontal)
        left = QWidget()
        column = QVBoxLayout(left)
        self.step1 = QGroupBox("Step 1: select a node  (device X, click to confirm)")
        step1 = QVBoxLayout(self.step1)
        buttons = QWidget()
        self.button_area = QVBoxLayout(buttons)
        self.button_area.setContentsMargins(0, 0, 0, 0)
        self.button_scroll = QScrollArea()  # a long banner or a big tree: scroll, never squeeze the buttons
        self.button_scroll.setWidgetResizable(True)
        self.button_scroll.setHorizontalScrollBarPolicy(Qt.ScrollBarAlwaysOff)  # the groups wrap to its width
        self.button_scroll.setFrameShape(QFrame.NoFrame)
        self.button_scroll.setWidget(buttons)
        self.button_scroll.viewport().installEventFilter(self)  # a resized window or splitter: wrap again
        step1.addWidget(self.button_scroll)
        self.node_slider = QSlider(Qt.Horizontal)
        self.node_slider.setTickPosition(QSlider.TicksBelow)  # one tick per button: where the device's detents are
        self.node_slider.setTickInterval(1)
        self.node_slider.setEnabled(False)
        step1.addWidget(self.node_slider)
        self.selected_label = _big(QLabel("waiting for the behaviour tree..."), 13)
        self.selected_label.setStyleSheet("color: #1b5e20;")
        column.addWidget(self.selected_label)
        column.addWidget(self.step1, 1)  # the buttons get the room; the steps below keep their size

        self.step2 = QGroupBox("Step 2: operation  (device Y, click; roll: page 2)")
        step2 = QHBoxLayout(self.step2)
        self.operation_slider = QSlider(Qt.Vertical)
        self.operation_slider.setTickPosition(QSlider.TicksRight)  # one tick per operation: the device's detents
        self.operation_slider.setTickInterval(1)
        self.operation_slider.setMinimumHeight(120)
        step2.addWidget(self.operation_slider)
        labels = QVBoxLayout()
        self.page_label = QLabel()
        labels.addWidget(self.page_label)
        self.operation_labels = [QLabel() for _ in range(max(len(page) for page in PAGES))]
        for label in self.operation_labels:  # top to bottom: the page's last operation first
            labels.addWidget(label)
        step2.addLayout(labels)
        self.step3 = QGroupBox("Step 3: insert index / wrap value  (roll, click)")
        step3 = QHBoxLayout(self.step3)
        self.dial = QDial()
        self.dial.setNotchesVisible(True)  # a notch per position: the device's detents in roll
        self.dial.setPageStep(1)
        self.dial.setWrapping(False)
        self.dial.setMinimumSize(120, 120)
        step3.addWidget(self.dial)
        self.index_label = _big(QLabel("index 0"), 12)
        self.index_label.setWordWrap(True)
        step3.addWidget(self.index_label, 1)
        for box in (self.step2, self.step3):
            box.setSizePolicy(QSizePolicy.Preferred, QSizePolicy.Maximum)

        self.answer_label = _big(QLabel(""), 12)
        self.answer_label.setWordWrap(True)
        column.addWidget(self.answer_label)
        gesture = QLabel(
            "Open the gripper fully to return to START.  Click with the handle pushed down: undo the last edit;"
            " pulled up: redo."
        )
        gesture.setWordWrap(True)
        column.addWidget(gesture)
        splitter.addWidget(left)

        right = QWidget()
        tree_column = QVBoxLayout(right)
        tree_column.addWidget(_big(QLabel("Behaviour tree (live)"), 11))
        self.tree_view = TreeView()
        tree_column.addWidget(self.tree_view)
        legend = QLabel(
            '<span style="color:#285adc">running</span> &nbsp; <span style="color:#1e9632">success</span> &nbsp; '
            '<span style="color:#d22828">failure</span> &nbsp; <span style="color:#969696">not visited</span>'
        )
        tree_column.addWidget(legend)
        # steps 2 and 3 below the tree: the buttons of step 1 get the whole height of the left column, so the
        # thesis' tree, its library and the skills taught show in whole rows at the default window size
        tree_column.addWidget(self.step2)
        tree_column.addWidget(self.step3)
        splitter.addWidget(right)
        splitter.setSizes([620, 380])
        QVBoxLayout(self).addWidget(splitter)
        self.refresh()

    # data ---------------------------------------------------------------------------------------
    def choices(self) -> Tuple[List[Tuple[str, List[str]]], List[str]]:
        """Button groups: (composite name, its children) in tick order, then the library's skills.

        Every node is a button (a decorator or a composite an operator made can be wrapped, unwrapped, converted)
        except the root and the execution composite, whose children are the thesis' buttons.
        """
        groups: List[Tuple[str, List[str]]] = []
        if self.flow.repair_node:
            groups.append(("Remembered repair", [REPAIR_CHOICE]))
        if self.tree is not None:
            for _, node in self.tree.depth_first():
                children = [child.name for child in self.tree.children(node) if child.name != DEFAULT_PARENT]
                if children:
                    groups.append((node.name, children))
        return groups, [skill.name for skill in self.library]

    def on_tree(self, tree: TreeSnapshot) -> None:
        """A new tree snapshot (always accepted; the view stays current even when the tab is hidden)."""
        self.tree = tree
        self.tree_view.show_tree(tree)
        self._rebuild()

    def set_repair(self, node_name: str, suggestion: Sequence[str]) -> None:
        """A help request suggests a remembered repair (a first button applies it), or no longer does."""
        self.flow.repair_node = node_name if suggestion else ""
        self.repair_tooltip = "; ".join(suggestion)
        self._rebuild()

    def on_library(self, library: Sequence[LibrarySkill]) -> None:
        """The skill library changed (a demonstrated skill appears here, thesis III-E; a broken one is greyed)."""
        self.library = list(library)
        self._rebuild()

    def _rebuild(self) -> None:
        groups, library = self.choices()
        problems = {skill.name: skill.problem for skill in self.library if not skill.available}
        signature = (tuple((name, tuple(leaves)) for name, leaves in groups), tuple(library), tuple(problems.items()))
        if signature == self._layout_signature:
            return
        self._layout_signature = signature
        while self.button_area.count():
            old = self.button_area.takeAt(0).widget()
            if old is None:
                continue  # the stretch below the groups
            old.hide()  # gone from the screen now, not when the event loop gets round to deleting it
            old.deleteLater()
        self.buttons = []
        self.unavailable = set()
        self._groups = []
        names: List[str] = []
        size = _button_size([name for _, entries in groups for name in entries] + library)
        for title, entries in [*groups, ("Skill library", library)]:
            if not entries:
                continue
            box = QGroupBox(title)
            grid = QGridLayout(box)
            grid.setSpacing(3)
            self._groups.append((grid, []))
            for name in entries:
                button = QPushButton(name)
                button.setMinimumSize(size)  # aligned columns, labels readable however long the banner grows
                button.setFocusPolicy(Qt.NoFocus)
                if name == REPAIR_CHOICE:
                    button.setToolTip(self.repair_tooltip)
                if title == "Skill library" and name in problems:
                    button.setEnabled(False)  # greyed: /change_tree refuses it (its file is missing or bad)
                    button.setToolTip(f"unavailable: {problems[name]}")
                    self.unavailable.add(len(self.buttons))
                self._groups[-1][1].append(button)
                self.buttons.append(button)
                names.append(name)
            self.button_area.addWidget(box)
        self.button_area.addStretch(1)  # the groups keep their height; the room left stays below them
        self._columns = 0
        self._wrap()
        sizes = {}
        if self.tree is not None:
            root = self.tree.root
            sizes = {
                node.name: len(node.child_ids)
                for node in self.tree.nodes
                if node.type in COMPOSITE_TYPES and node is not root and node.name != DEFAULT_PARENT
            }
        self.flow.set_choices(names, self.tree.child_count(DEFAULT_PARENT) + 1 if self.tree else 1, sizes)
        self.node_slider.setRange(0, max(0, len(names) - 1))
        self.dial.setRange(0, self.flow.insert_slots - 1)
        self.refresh()

    def _wrap(self) -> None:
        """Lay each group's buttons in as many columns (at most six) as fit the visible width: none is cut off."""
        if not self._groups:
            return
        first = self._groups[0][0]
        box = first.parentWidget()
        margins = first.contentsMargins().left() + first.contentsMargins().right()
        margins += box.contentsMargins().left() + box.contentsMargins().right()
        room = self.button_scroll.viewport().width() - margins
        step = self.buttons[0].minimumWidth() + first.spacing()
        columns = max(1, min(MAX_COLUMNS, (room + first.spacing()) // step))
        if columns == self._columns:
            return
        self._columns = columns
        for grid, buttons in self._groups:
            for button in buttons:
                grid.removeWidget(button)
            for position, button in enumerate(buttons):
                grid.addWidget(button, position // columns, position % columns)

    def eventFilter(self, watched: QObject, event: QEvent) -> bool:  # noqa: N802 (Qt API)
        """Wrap the buttons again when their visible width changes (window or splitter resized)."""
        if event.type() == QEvent.Resize and watched is self.button_scroll.viewport():
            self._wrap()
        return False

    # device -------------------------------------------------------------------------------------
    def on_device(self, sample: DeviceSample) -> None:
        """Move the control of the current step."""
        if self.active:
            self.flow.device(sample)
            self.refresh()

    def on_click(self, _stamp: float = 0.0) -> None:
        """Confirm the current step; the last one sends the request."""
        if not self.active:
            return
        confirmation = self.flow.confirmation()
        request: Optional[EditRequest] = self.flow.click()
        if confirmation is not None:
            self.selection_confirmed.emit(*confirmation)
        if request is not None:
            what = " ".join(part for part in (request.operation, request.node_type, request.node_name) if part)
            self.answer_label.setText(f"sending: {what} ...")
            self.request_ready.emit(request)
        self.refresh()

    def on_answer(self, success: bool, message: str) -> None:
        """The answer of /change_tree (or why there was none)."""
        self.flow.answered(success, message)
        self.refresh()

    def reset(self) -> None:
        """Back to step 1."""
        self.flow.reset()
        self.refresh()

    def refresh(self) -> None:
        """Show the flow's state; controls of other steps are greyed out."""
        flow = self.flow
        for box, steps in (
            (self.step1, (Step.NODE,)),
            (self.step2, (Step.OPERATION,)),
            (self.step3, (Step.INDEX, Step.PARAMETER)),
        ):
            box.setObjectName("step")  # the style applies to the step boxes, not to the button groups inside
            box.setEnabled(flow.step in steps)
            restyle(box, ACTIVE_STEP_STYLE if flow.step in steps else STEP_STYLE)
        if 0 <= flow.node_index < len(self.buttons):
            self.button_scroll.ensureWidgetVisible(self.buttons[flow.node_index])
        for index, button in enumerate(self.buttons):
            style = UNAVAILABLE_STYLE if index in self.unavailable else BUTTON_STYLE
            if button.text() == REPAIR_CHOICE:
                style = REPAIR_STYLE
            restyle(button, SELECTED_STYLE if index == flow.node_index else style)
        self.node_slider.setValue(flow.node_index)
        operations = flow.operations
        self.operation_slider.setRange(0, len(operations) - 1)
        self.operation_slider.setValue(flow.operation_index)
        self.page_label.setText(f"page {flow.page + 1} of {len(PAGES)}")
        shown = list(reversed(operations))
        for position, label in enumerate(self.operation_labels):
            label.setVisible(position < len(shown))
            if position < len(shown):
                label.setText(shown[position])
                chosen = shown[position] == flow.selected_operation
                restyle(label, "font-weight: bold; color: #e65100;" if chosen else "color: #555;")
        if flow.step is Step.PARAMETER:
            values = flow.parameter_values
            self.dial.setRange(0, len(values) - 1)
            self.dial.setValue(flow.parameter_index)
            self.index_label.setText(f"{flow.selected_operation}: {flow.parameter:g}")
        else:
            self.dial.setRange(0, self.flow.insert_slots - 1)
            self.dial.setValue(flow.index)
            self.index_label.setText(f"insert at index {flow.index} of {flow.target or DEFAULT_PARENT}")
        node = flow.selected_node or "-"
        step_text = {
            Step.NODE: f"selected: {node}",
            Step.OPERATION: f"{node}: choose the operation ({flow.selected_operation})",
            Step.INDEX: f"{node}: insert at index {flow.index}",
            Step.PARAMETER: f"{node}: {flow.selected_operation} {flow.parameter:g}",
            Step.WAITING: "waiting for /change_tree...",
        }[flow.step]
        if flow.target and flow.step in (Step.NODE, Step.OPERATION):
            step_text += f"  (adding into {flow.target})"
        if flow.edit_gesture and flow.step is not Step.WAITING:
            step_text = (
                f"click to {flow.edit_gesture} the last edit (handle {'down' if flow.edit_gesture == 'undo' else 'up'})"
            )
        self.selected_label.setText(step_text if flow.choices else "waiting for the behaviour tree...")
        if flow.answer and flow.step is not Step.WAITING:
            colour = "#1e9632" if flow.answer.startswith("done") else "#d22828"
            restyle(self.answer_label, f"color: {colour};")
            self.answer_label.setText(flow.answer)


class LowLevelTab(QWidget):
    """The ellipsoid views, the commanded values, the mode and the recording state (thesis II-C, Fig. 4)."""

    recording_toggled = pyqtSignal()

    def __init__(
        self,
        config: GuiConfig,
        command: EllipsoidCommand,
        recorded_samples: Callable[[], int],
        last_click: Callable[[], float],
        device_time: Callable[[], float],
    ):
        """A LOW-LEVEL tab over ``command``.

        ``recorded_samples``: how many samples the recording holds; ``last_click`` and ``device_time``: when the
        last click arrived and the time now, both on the device's clock (a double click is told from two clicks).
        """
        super().__init__()
        self.config = config
        self.command = command
        self._active = False
        self.recording_since: Optional[float] = None
        self.recorded_samples = recorded_samples
        self.clicks = ClickClassifier(config.double_click_window)
        self.last_click = last_click
        self.device_time = device_time
        self._drawn_version = -1

        layout = QHBoxLayout(self)
        self.view = EllipsoidView(command)
        layout.addWidget(self.view, 3)  # no alignment flag: a QOpenGLWidget with one gets size 0x0 and never paints
        panel = QVBoxLayout()
        self.mode_label = _big(QLabel(), 14)
        self.mode_label.setTextFormat(Qt.RichText)
        panel.addWidget(self.mode_label)
        self.axis_labels = []
        for _ in range(3):
            label = _big(QLabel(), 12, bold=False)
            label.setWordWrap(True)
            panel.addWidget(label)
            self.axis_labels.append(label)
        self.device_lost_label = _big(QLabel("DEVICE LOST\nholding the last stiffness until it is back"), 13)
        self.device_lost_label.setStyleSheet("background: #d22828; color: white; padding: 6px;")
        self.device_lost_label.setWordWrap(True)
        self.device_lost_label.hide()
        panel.addWidget(self.device_lost_label)
        self.recording_label = _big(QLabel(), 14)
        panel.addWidget(self.recording_label)
        self.controller_label = QLabel("controller: -")
        self.controller_label.setWordWrap(True)
        panel.addWidget(self.controller_label)
        gestures = QLabel(
            "<b>Device gestures</b><br>"
            "move: semi-axis lengths (X, Y, Z)<br>"
            "rotate: roll / pitch / yaw of the axes<br>"
            "<b>click</b>: next mode ALL \u2192 X \u2192 Y \u2192 Z<br>"
            f"<b>double click</b> (within {config.double_click_window:.1f} s): start / stop recording<br>"
            "<b>open the gripper fully</b>: stop, save, back to START"
        )
        gestures.setWordWrap(True)
        gestures.setStyleSheet("background: #eef; padding: 6px; border: 1px solid #99b;")
        panel.addWidget(gestures)
        panel.addStretch(1)
        panel_widget = QWidget()
        panel_widget.setLayout(panel)
        panel_widget.setMinimumWidth(270)
        panel_widget.setMaximumWidth(330)
        layout.addWidget(panel_widget, 1)

        self._repaint = QTimer(self)  # runs while the tab is active: the other tabs' time costs nothing here
        self._repaint.timeout.connect(self._tick)
        self._repaint.setInterval(max(1, int(round(1000.0 / config.repaint_rate))))
        self._refresh_labels()

    @property
    def active(self) -> bool:
        """Whether this is the tab shown (set by the window)."""
        return self._active

    @active.setter
    def active(self, active: bool) -> None:
        self._active = active
        if active:
            self._repaint.start()
        else:
            self._repaint.stop()

    def on_click(self, stamp: float) -> None:
        """Clicks are classified: single -> next mode (after the double-click window), double -> recording."""
        if not self.active:
            return
        kind = self.clicks.click(stamp)
        if kind == ClickClassifier.DOUBLE:
            self.recording_toggled.emit()
        elif kind == ClickClassifier.SINGLE:
            self.command.next_mode()

    def show_device_lost(self, lost: bool) -> None:
        """Say that the device is gone (the ellipsoid, and the stiffness sent, stay as they were) or back."""
        self.device_lost_label.setVisible(lost)

    def on_enter(self, handle: Optional[DeviceSample]) -> None:
        """Keep the ellipsoid as it is until the handle meets it (no jump to wherever the handle is).

        ``handle``: the device's latest sample (None before the first).
        """
        self.command.hold(handle)

    def on_leave(self) -> None:
        """Drop a pending click."""
        self.clicks.reset()

    def _tick(self) -> None:
        """Capped repaint: mode changes from pending clicks, then redraw only what changed."""
        if not self.active:
            return
        if self.clicks.poll(self.device_time(), self.last_click()) == ClickClassifier.SINGLE:
            self.command.next_mode()
        version = self.command.state()[3]
        if version != self._drawn_version:
            self._drawn_version = version
            self.view.update()
        self._refresh_labels()

    def _refresh_labels(self) -> None:
        lengths, angles, mode, _ = self.command.state()
        gain = self.config.stiffness_per_pixel
        self.mode_label.setText(
            "mode: "
            + " ".join(
                f'<span style="color:#e65100"><u>{name}</u></span>'
                if name == mode
                else f'<span style="color:#999">{name}</span>'
                for name in MODES
            )
        )
        handle_stiffness, handle_angles = self.command.waiting()
        for axis, label in enumerate(self.axis_labels):
            live = mode in ("ALL", AXIS_NAMES[axis])
            restyle(label, "" if live else "color: #999;")
            text = (
                f"{AXIS_NAMES[axis]}: {lengths[axis] * gain:6.0f} N/m, "
                f"{ANGLE_NAMES[axis]} {angles[axis] * 57.29578:5.1f}\N{DEGREE SIGN}"
            )
            stiffness, angle = handle_stiffness[axis], handle_angles[axis]
            now = [f"{stiffness:.0f} N/m"] if math.isfinite(stiffness) else []
            now += [f"{angle * 57.29578:.0f}\N{DEGREE SIGN}"] if math.isfinite(angle) else []
            if now:
                text += f"<br><span style='color:#bf360c'>held: waits for the handle (now {', '.join(now)})</span>"
            label.setText(text)
        if self.recording_since is None:
            restyle(self.recording_label, "color: #555;")
            self.recording_label.setText("not recording")
        else:
            elapsed = time.monotonic() - self.recording_since
            restyle(self.recording_label, "color: #d22828;")
            self.recording_label.setText(f"\u25cf REC {elapsed:.1f} s\n{self.recorded_samples()} samples")
