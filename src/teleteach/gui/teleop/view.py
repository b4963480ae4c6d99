"""The TELEOP tab: the operator moves the arm with the device (teleteach.core.teleoperation).

It shows what the operator needs while the arm follows the hand: whether the clutch holds, why the arm does not
follow (the limits, a lost device, the arm not free yet), where the equilibrium is and where the arm is, in the
robot's base frame, and the path being taught. The worker moves the arm; a double click asks the window to start or
stop recording the path (thesis III-C: the trajectory "generated remotely with the same haptic device").
"""

import dataclasses
from typing import Optional, Tuple

import numpy as np
from PyQt5.QtCore import Qt, pyqtSignal
from PyQt5.QtWidgets import QGridLayout, QGroupBox, QLabel, QVBoxLayout, QWidget

from teleteach.core.gui_config import GuiConfig
from teleteach.core.rotations import quaternion_to_rpy
from teleteach.core.teleoperation import Clutch
from teleteach.gui.device import ClickClassifier
from teleteach.gui.widgets import big

CLUTCH_STYLES = {
    Clutch.RELEASED: ("clutch released: the arm holds its pose", "background: #eceff1; color: #37474f;"),
    Clutch.CLOSING: ("clutch closing: keep the gripper closed...", "background: #fff8e1; color: #8d6e00;"),
    Clutch.ENGAGED: ("CLUTCH ENGAGED: the arm follows your hand", "background: #2e7d32; color: white;"),
}
NOT_DRIVING_STYLE = "background: #eceff1; color: #9e9e9e;"
AXES = ("x [m]", "y [m]", "z [m]", "roll [deg]", "pitch [deg]", "yaw [deg]")


@dataclasses.dataclass(frozen=True)
class TeleopView:
    """What the worker tells the tab each time it changes (and a few times a second)."""

    driving: bool  # the session holds the arm and the device drives its equilibrium
    clutch: Clutch
    reason: str  # why the arm holds or is limited; "" when it follows freely
    equilibrium: Optional[np.ndarray]  # x y z qx qy qz qw, base frame
    measured: Optional[np.ndarray]  # the arm's /cartesian_pose, the same frame
    stiffness: Tuple[float, float, float]  # [N/m] the principal stiffnesses commanded (LOW-LEVEL's ellipsoid)
    assistance: str  # shared control in the placement: where it helps, or why it does not


def _pose_values(pose: Optional[np.ndarray]):
    """x, y, z [m] and roll, pitch, yaw [deg] of a pose, or six dashes."""
    if pose is None:
        return ["-"] * 6
    angles = np.degrees(quaternion_to_rpy(pose[3:]))
    return [f"{value:+.3f}" for value in pose[:3]] + [f"{value:+.1f}" for value in angles]


def _limits(teleop) -> QLabel:
    """The teleoperation's limits in one line."""
    low, high = teleop.workspace_low, teleop.workspace_high
    limits = QLabel(
        f"limits: {teleop.max_speed:g} m/s, {teleop.max_angular_speed:g} rad/s; workspace x [{low[0]:g}, "
        f"{high[0]:g}] m, y [{low[1]:g}, {high[1]:g}] m, z [{low[2]:g}, {high[2]:g}] m; a handle that jumps more "
        f"than {teleop.max_device_jump * 100:g} cm releases the clutch"
    )
    limits.setWordWrap(True)
    return limits


class TeleopTab(QWidget):
    """Hold the gripper closed to move the arm, open it to let go; a double click records the path.

    See teleteach.core.teleoperation for the clutch and the mapping.
    """

    recording_toggled = pyqtSignal()
    click_hint = pyqtSignal(str)  # two clicks too far apart for a double click: what the operator should know

    def __init__(self, config: GuiConfig):
        super().__init__()
        self.active = False
        self.clicks = ClickClassifier(config.double_click_window)
        teleop = config.teleop
        layout = QVBoxLayout(self)
        layout.addWidget(big(QLabel("TELEOP: move the arm with the device"), 18))
        hint = QLabel(
            f"Close the gripper and keep it closed ({teleop.clutch_hold:g} s, longer than a click) to move the arm: it "
            f"follows the handle (x{teleop.scale:g}), at the stiffness set in LOW-LEVEL. Open the gripper to let go, "
            "move the handle back and close it again to go further. Open it fully: back to START. Double click: start "
            "or stop recording the path the arm takes (its pauses left out); then teach its stiffness in LOW-LEVEL."
        )
        hint.setWordWrap(True)
        layout.addWidget(hint)
        self.clutch_label = big(QLabel(), 20)
        self.clutch_label.setAlignment(Qt.AlignCenter)
        self.clutch_label.setMinimumHeight(90)
        layout.addWidget(self.clutch_label)
        self.reason_label = QLabel()
        self.reason_label.setWordWrap(True)
        self.reason_label.setStyleSheet("color: #bf360c; font-size: 13pt;")
        layout.addWidget(self.reason_label)
        layout.addWidget(self._poses(config.base_frame))
        layout.addWidget(_limits(teleop))
        self.path_label = QLabel("path: double click to record the path the arm takes")
        self.path_label.setWordWrap(True)
        self.path_label.setStyleSheet("font-size: 13pt; padding: 4px;")
        layout.addWidget(self.path_label)
        self.stiffness_label = QLabel()
        layout.addWidget(self.stiffness_label)
        self.assistance_label = QLabel()
        layout.addWidget(self.assistance_label)
        self.controller_label = QLabel("controller: -")
        layout.addWidget(self.controller_label)
        self.device_lost = QLabel("DEVICE LOST: the arm holds its pose")
        self.device_lost.setStyleSheet("background: #d22828; color: white; font-weight: bold; padding: 6px;")
        self.device_lost.hide()
        layout.addWidget(self.device_lost)
        layout.addStretch(1)
        self.view: Optional[TeleopView] = None
        self.on_state(TeleopView(False, Clutch.RELEASED, "waiting for the arm to be free", None, None, (0.0,) * 3, ""))

    def _poses(self, frame: str) -> QGroupBox:
        """The equilibrium commanded and the arm measured, x y z roll pitch yaw: a cell each in ``self.cells``."""
        poses = QGroupBox(f"the hand in {frame}")
        grid = QGridLayout(poses)
        self.cells = {}
        for column, axis in enumerate(AXES):
            grid.addWidget(QLabel(axis), 0, column + 1, alignment=Qt.AlignRight)
        for row, name in enumerate(("equilibrium (commanded)", "arm (measured)"), start=1):
            grid.addWidget(QLabel(name), row, 0)
            for column in range(len(AXES)):
                cell = QLabel("-")
                cell.setAlignment(Qt.AlignRight)
                cell.setStyleSheet("font-family: monospace; font-size: 12pt;")
                grid.addWidget(cell, row, column + 1)
                self.cells[row, column] = cell
        return poses

    def on_click(self, stamp: float) -> None:
        """A double click starts or stops the path's recording; a single click does nothing.

        (The clutch is a longer close of the gripper, never a click.)
        """
        if not self.active:
            return
        if self.clicks.click(stamp) == ClickClassifier.DOUBLE:
            self.recording_toggled.emit()
        elif self.clicks.missed_double is not None:
            self.click_hint.emit(self.clicks.missed_double_hint())

    def show_path(self, text: str, recording: bool) -> None:
        """What the path is: being recorded (loud) or what was kept."""
        self.path_label.setText(text)
        self.path_label.setStyleSheet(
            "font-size: 13pt; padding: 4px;"
            + (" background: #d22828; color: white; font-weight: bold;" if recording else "")
        )

    def show_device_lost(self, lost: bool) -> None:
        """The device's loss, loud: the arm holds meanwhile."""
        self.device_lost.setVisible(lost)

    def on_state(self, view: TeleopView) -> None:
        """Show the clutch, the reason and both poses."""
        self.view = view
        text, style = CLUTCH_STYLES[view.clutch]
        if not view.driving:
            text, style = "the arm is not yours yet", NOT_DRIVING_STYLE
        if self.clutch_label.text() != text:
            self.clutch_label.setText(text)
            self.clutch_label.setStyleSheet(style + " border-radius: 6px; padding: 8px;")
        self.reason_label.setText(view.reason)
        values = ", ".join(f"{value:.0f}" for value in view.stiffness)
        self.stiffness_label.setText(f"stiffness: {values} N/m along the ellipsoid's axes (set in LOW-LEVEL)")
        self.assistance_label.setText(view.assistance)
        for row, pose in ((1, view.equilibrium), (2, view.measured)):
            for column, value in enumerate(_pose_values(pose)):
                self.cells[row, column].setText(value)
