"""The START tab (thesis Fig. 3): choose a teaching mode with the device, start a waiting tree.

It also shows who leads a replayed skill. It only displays and collects the operator's choices; it acts on device
signals only while it is the active tab (thesis A.2.1).
"""

import dataclasses
from typing import List

from PyQt5.QtCore import Qt, QTimer, pyqtSignal
from PyQt5.QtWidgets import (
    QHBoxLayout,
    QLabel,
    QPushButton,
    QVBoxLayout,
    QWidget,
)

from teleteach.core.gui_config import GuiConfig
from teleteach.core.teleoperation import Clutch
from teleteach.gui.device import DeviceSample
from teleteach.gui.widgets import big

MODE_BUTTONS = (  # text, colour, height [px] of START's buttons, in the order of their tabs
    ("HIGH-LEVEL teaching\nchange the behaviour tree", "#c8e6c9", 240),
    ("LOW-LEVEL teaching\ndemonstrate stiffness", "#ffcdd2", 240),
    ("SHARED CONTROL\nthe MPC keeps your motion pattern; record it as a skill", "#bbdefb", 110),
    ("TELEOP\nmove the arm with the device (hold the gripper closed)", "#fff3c4", 110),
)


VIRTUAL_DEVICE_KEYS = (
    "Virtual device: type into its small window \u201cteleteach: virtual Sigma.7\u201d (click it first). Arrows: x, y; "
    "PgUp/PgDn: z; Q/A W/S E/D: roll, pitch, yaw; Space: click; Enter: double click; hold O: gripper fully open "
    "(back to START); hold C: gripper closed (TELEOP's clutch)."
)


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


def _note(style: str) -> QLabel:
    """A centred line that wraps, hidden until it has something to say."""
    label = QLabel()
    label.setAlignment(Qt.AlignCenter)
    label.setWordWrap(True)
    label.setStyleSheet(style)
    label.hide()
    return label


class StartTab(QWidget):
    """Choose the teaching mode with the device, a click opens it; start a tree that waits for the operator.

    Device X left of the neutral zone selects HIGH-LEVEL, right of it LOW-LEVEL (as in the thesis); device Y up beyond
    half its range selects SHARED CONTROL above them, down beyond half its range TELEOP below them. In the neutral zone
    (``start_neutral_zone`` around the centre) nothing is selected, so a resting, centred handle opens nothing; the
    centre panel there shows what the tree does, and a click in it starts a tree that waits for its start, or runs a
    tree that is done again (``start_requested``).
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
        self.tree_done = False
        self.tree_message = "no behaviour tree yet"
        self.cue = ""  # in the neutral zone: how far SHARED CONTROL or TELEOP still is, once the handle is on its way
        layout = QVBoxLayout(self)
        layout.addStretch(1)
        title = big(QLabel("Teleoperated teaching"), 20)
        title.setAlignment(Qt.AlignCenter)
        layout.addWidget(title)
        hint = QLabel(
            "Move the device left/right to choose a teaching mode (up for SHARED CONTROL, down for TELEOP), "
            "click (close the gripper) to open it."
        )
        hint.setAlignment(Qt.AlignCenter)
        layout.addWidget(hint)
        self.authority = _note("background: #e1f5fe; color: #01579b; font-size: 13pt; padding: 6px;")
        self._authority_timer = QTimer(self)
        self._authority_timer.setSingleShot(True)
        self._authority_timer.timeout.connect(self.authority.hide)
        layout.addWidget(self.authority)
        row = QHBoxLayout()
        self.buttons: List[QPushButton] = self._mode_buttons()
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
        self.keys = _note("background: #fff8e1; color: #5d4037; font-size: 12pt; padding: 6px;")
        layout.addWidget(self.keys)
        layout.addStretch(2)
        self._show()

    def _mode_buttons(self) -> List[QPushButton]:
        """HIGH-LEVEL, LOW-LEVEL, SHARED CONTROL, TELEOP: a click on one opens its tab."""
        buttons = []
        for index, (text, colour, height) in enumerate(MODE_BUTTONS):
            button = QPushButton(text)
            button.setMinimumHeight(height)
            button.setProperty("colour", colour)
            button.clicked.connect(lambda _checked, tab=index + 1: self.mode_chosen.emit(tab))
            buttons.append(button)
        return buttons

    def show_device(self, backend: str) -> None:
        """Which device drives the GUI: for the virtual one, where its keys go and what they do."""
        self.keys.setVisible(backend == "virtual")
        self.keys.setText(VIRTUAL_DEVICE_KEYS)

    def show_authority(self, view: AuthorityView) -> None:
        """A skill replays: who leads it and what the operator's correction does (hidden once the reports stop)."""
        self.authority.setText(authority_text(view))
        self.authority.show()
        self._authority_timer.start(self.AUTHORITY_SHOWN_FOR)

    def show_tree(self, waiting: bool, message: str, done: bool = False) -> None:
        """What the tree does (teleteach/TreeExecution): loudly when it waits; once done, how to run it again."""
        self.tree_waiting, self.tree_message, self.tree_done = waiting, message, done
        self._show()

    def _show(self) -> None:
        for index, button in enumerate(self.buttons):
            border = "5px solid #e65100" if index == self.selected else "1px solid #888"
            button.setStyleSheet(
                f"QPushButton {{ background: {button.property('colour')}; border: {border}; font-size: 16pt; }}"
            )
        border = "5px solid #e65100" if self.selected == self.NEUTRAL else "1px dashed #888"
        cue = f"\n\n{self.cue}" if self.cue else ""
        if self.tree_waiting:
            self.centre.setText(f"The robot waits for you.\n\nHandle in the centre, click: start its task.{cue}")
            self.centre.setStyleSheet(self.WAITING_STYLE.format(border=border))
        elif self.tree_done:
            self.centre.setText(f"The robot's task is done.\n\nHandle in the centre, click: run it again.{cue}")
            self.centre.setStyleSheet(self.STATE_STYLE.format(border=border))
        else:
            self.centre.setText(f"centre: no mode{cue}\n\nrobot: {self.tree_message}")
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
            cue = self._cue(sample.y) if selected == self.NEUTRAL else ""
            if selected != self.selected or cue != self.cue:
                self.selected, self.cue = selected, cue
                self._show()

    def _cue(self, y: float) -> str:
        """Beyond half the way up (down) to SHARED CONTROL (TELEOP): how far it still is ("" nearer the centre)."""
        threshold = self.SHARED_CONTROL_Y * self.config.device_range
        if abs(y) < 0.5 * threshold:
            return ""
        mode, way = ("SHARED CONTROL", "up") if y > 0.0 else ("TELEOP", "down")
        return f"handle {way} {100 * abs(y):.1f} cm: {mode} from {100 * threshold:.1f} cm"

    def on_click(self, _stamp: float = 0.0) -> None:
        """Open the chosen mode; in the neutral zone, ask to start the tree."""
        if not self.active:
            return
        if self.selected == self.NEUTRAL:
            self.start_requested.emit()
        else:
            self.mode_chosen.emit(self.selected + 1)
