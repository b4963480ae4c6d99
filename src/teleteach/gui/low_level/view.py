"""The LOW-LEVEL tab (thesis II-C, Fig. 4): the ellipsoid views, the commanded values, the mode, the recording.

It only displays; it acts on device signals only while it is the active tab.
"""

import math
import time
from typing import Callable, Optional

from PyQt5.QtCore import Qt, QTimer, pyqtSignal
from PyQt5.QtWidgets import (
    QHBoxLayout,
    QLabel,
    QVBoxLayout,
    QWidget,
)

from teleteach.core.gui_config import GuiConfig
from teleteach.gui.device import ClickClassifier, DeviceSample
from teleteach.gui.ellipsoid import MODES, EllipsoidCommand
from teleteach.gui.gl_view import ANGLE_NAMES, AXIS_NAMES, EllipsoidView
from teleteach.gui.widgets import big, restyle


class LowLevelTab(QWidget):
    """The ellipsoid views, the commanded values, the mode and the recording state (thesis II-C, Fig. 4)."""

    recording_toggled = pyqtSignal()
    click_hint = pyqtSignal(str)  # two clicks too far apart for a double click: what the operator should know

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
        layout.addWidget(self._panel(config), 1)

        self._repaint = QTimer(self)  # runs while the tab is active: the other tabs' time costs nothing here
        self._repaint.timeout.connect(self._tick)
        self._repaint.setInterval(max(1, int(round(1000.0 / config.repaint_rate))))
        self._refresh_labels()

    def _panel(self, config: GuiConfig) -> QWidget:
        """The mode, the values per axis, the device's and the recording's state, the controller, the gestures."""
        panel = QVBoxLayout()
        self.mode_label = big(QLabel(), 14)
        self.mode_label.setTextFormat(Qt.RichText)
        panel.addWidget(self.mode_label)
        self.axis_labels = []
        for _ in range(3):
            label = big(QLabel(), 12, bold=False)
            label.setWordWrap(True)
            panel.addWidget(label)
            self.axis_labels.append(label)
        self.device_lost_label = big(QLabel("DEVICE LOST\nholding the last stiffness until it is back"), 13)
        self.device_lost_label.setStyleSheet("background: #d22828; color: white; padding: 6px;")
        self.device_lost_label.setWordWrap(True)
        self.device_lost_label.hide()
        panel.addWidget(self.device_lost_label)
        self.recording_label = big(QLabel(), 14)
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
        return panel_widget

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
        if self.clicks.missed_double is not None:
            self.click_hint.emit(self.clicks.missed_double_hint())
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
