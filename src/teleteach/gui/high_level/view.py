"""The HIGH-LEVEL tab's widgets (thesis II-B, Fig. 5): they show the flow and collect choices; no ROS here."""

from typing import List, Optional, Sequence, Tuple

from PyQt5.QtCore import QEvent, QObject, Qt, pyqtSignal
from PyQt5.QtWidgets import (
    QDial,
    QFrame,
    QGridLayout,
    QGroupBox,
    QHBoxLayout,
    QLabel,
    QPushButton,
    QScrollArea,
    QSizePolicy,
    QSlider,
    QSplitter,
    QVBoxLayout,
    QWidget,
)

from teleteach.bt.editor import EditRequest
from teleteach.core.gui_config import GuiConfig
from teleteach.gui.device import DeviceSample
from teleteach.gui.high_level.styles import (
    ACTIVE_STEP_STYLE,
    BUTTON_STYLE,
    MAX_COLUMNS,
    REPAIR_STYLE,
    SELECTED_STYLE,
    STEP_STYLE,
    UNAVAILABLE_STYLE,
    button_size,
)
from teleteach.gui.high_level.tree_view import TreeView
from teleteach.gui.proposal import HelpRequestView
from teleteach.gui.selection import (
    COMPOSITE_TYPES,
    DEFAULT_PARENT,
    PAGES,
    REPAIR_CHOICE,
    LibrarySkill,
    SelectionFlow,
    Step,
    TreeSnapshot,
)
from teleteach.gui.widgets import big, restyle


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
        self.step1 = self._node_step()
        self.selected_label = big(QLabel("waiting for the behaviour tree..."), 13)
        self.selected_label.setStyleSheet("color: #1b5e20;")
        self.selected_label.setWordWrap(True)  # a proposal of several edits must not widen the window
        column.addWidget(self.selected_label)
        column.addWidget(self.step1, 1)  # the buttons get the room; the steps below keep their size
        self.step2, self.step3 = self._operation_step(), self._index_step()
        for box in (self.step2, self.step3):
            box.setSizePolicy(QSizePolicy.Preferred, QSizePolicy.Maximum)
        self.answer_label = big(QLabel(""), 12)
        self.answer_label.setWordWrap(True)
        column.addWidget(self.answer_label)
        gesture = QLabel(
            "Open the gripper fully to return to START.  Click with the handle pushed down: undo the last edit;"
            " pulled up: redo."
        )
        gesture.setWordWrap(True)
        column.addWidget(gesture)
        splitter.addWidget(left)
        splitter.addWidget(self._tree_column())
        splitter.setSizes([620, 380])
        QVBoxLayout(self).addWidget(splitter)
        self.refresh()

    def _node_step(self) -> QGroupBox:
        """Step 1: the buttons (scrolled, wrapped to the width) and the node slider."""
        box = QGroupBox("Step 1: select a node  (device X, click to confirm)")
        step1 = QVBoxLayout(box)
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
        return box

    def _operation_step(self) -> QGroupBox:
        """Step 2: the operation slider and the page's operations, its last one on top."""
        box = QGroupBox("Step 2: operation  (device Y, click; roll: page 2)")
        step2 = QHBoxLayout(box)
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
        return box

    def _index_step(self) -> QGroupBox:
        """Step 3: the dial (an index, or a decorator's value) and what it says."""
        box = QGroupBox("Step 3: insert index / wrap value  (roll, click)")
        step3 = QHBoxLayout(box)
        self.dial = QDial()
        self.dial.setNotchesVisible(True)  # a notch per position: the device's detents in roll
        self.dial.setPageStep(1)
        self.dial.setWrapping(False)
        self.dial.setMinimumSize(120, 120)
        step3.addWidget(self.dial)
        self.index_label = big(QLabel("index 0"), 12)
        self.index_label.setWordWrap(True)
        step3.addWidget(self.index_label, 1)
        return box

    def _tree_column(self) -> QWidget:
        """The live tree, its legend, and steps 2 and 3 below it."""
        right = QWidget()
        tree_column = QVBoxLayout(right)
        tree_column.addWidget(big(QLabel("Behaviour tree (live)"), 11))
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
        return right

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

    def set_help(self, help_request: HelpRequestView) -> None:
        """A help request's remembered repair (a first button applies it) and the robot's proposal (preselected)."""
        self.flow.repair_node = help_request.node_name if help_request.suggestion else ""
        self.repair_tooltip = "; ".join(help_request.suggestion)
        self.flow.set_offer(help_request.offer())
        self._rebuild()
        self.refresh()

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
        size = button_size([name for _, entries in groups for name in entries] + library)
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
        self.flow.set_choices(names, self.tree.child_count(DEFAULT_PARENT) + 1 if self.tree else 1, self._sizes())
        self.node_slider.setRange(0, max(0, len(names) - 1))
        self.dial.setRange(0, self.flow.insert_slots - 1)
        self.refresh()

    def _sizes(self) -> dict:
        """{composite: its number of children}, for inserting into it (the root and BehaviorExecution aside)."""
        if self.tree is None:
            return {}
        root = self.tree.root
        return {
            node.name: len(node.child_ids)
            for node in self.tree.nodes
            if node.type in COMPOSITE_TYPES and node is not root and node.name != DEFAULT_PARENT
        }

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
            (self.step1, (Step.NODE, Step.PROPOSAL)),
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
        self._show_operations()
        self._show_dial()
        self.selected_label.setText(self._step_text() if flow.choices else "waiting for the behaviour tree...")
        if flow.answer and flow.step is not Step.WAITING:
            colour = "#1e9632" if flow.answer.startswith("done") else "#d22828"
            restyle(self.answer_label, f"color: {colour};")
            self.answer_label.setText(flow.answer)

    def _show_operations(self) -> None:
        """Step 2: the page's operations on the slider, the one chosen in bold."""
        flow = self.flow
        operations = flow.operations
        self.operation_slider.setRange(0, len(operations) - 1)
        self.operation_slider.setValue(flow.operation_index)
        self.page_label.setText(f"page {flow.page + 1} of {len(PAGES)}")
        shown = list(reversed(operations))
        for position, label in enumerate(self.operation_labels):
            label.setVisible(position < len(shown))
            if position < len(shown):
                label.setText(shown[position])
                chosen = flow.step is not Step.NODE and shown[position] == flow.selected_operation
                restyle(label, "font-weight: bold; color: #e65100;" if chosen else "color: #555;")

    def _show_dial(self) -> None:
        """Step 3: the dial on the index to insert at, or on the decorator's value."""
        flow = self.flow
        if flow.step is Step.PARAMETER:
            values = flow.parameter_values
            self.dial.setRange(0, len(values) - 1)
            self.dial.setValue(flow.parameter_index)
            self.index_label.setText(f"{flow.selected_operation}: {flow.parameter:g}")
        else:
            self.dial.setRange(0, self.flow.insert_slots - 1)
            self.dial.setValue(flow.index)
            self.index_label.setText(f"insert at index {flow.index} of {flow.target or DEFAULT_PARENT}")

    def _step_text(self) -> str:
        """What the operator is doing now, in one line."""
        flow = self.flow
        node = flow.selected_node or "-"
        step_text = {
            Step.NODE: f"selected: {node}",
            Step.OPERATION: f"{node}: choose the operation ({flow.selected_operation})",
            Step.INDEX: f"{node}: insert at index {flow.index}",
            Step.PARAMETER: f"{node}: {flow.selected_operation} {flow.parameter:g}",
            Step.WAITING: "waiting for /change_tree...",
            Step.PROPOSAL: f"the robot proposes: {flow.offer.text if flow.offer else '-'}. Click: apply it;"
            " another button: choose yourself",
        }[flow.step]
        if flow.target and flow.step in (Step.NODE, Step.OPERATION):
            step_text += f"  (adding into {flow.target})"
        if flow.edit_gesture and flow.step is not Step.WAITING:
            step_text = (
                f"click to {flow.edit_gesture} the last edit (handle {'down' if flow.edit_gesture == 'undo' else 'up'})"
            )
        elif flow.edit_gesture_near and flow.step is not Step.WAITING:
            way = "down" if flow.edit_gesture_near == "undo" else "up"
            step_text += (
                f"  (handle {way} {100 * abs(flow.height):.1f} cm: {flow.edit_gesture_near} from "
                f"{100 * flow.config.edit_push:.1f} cm)"
            )
        return step_text
