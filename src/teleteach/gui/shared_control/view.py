"""The SHARED CONTROL tab (issue 9, Mower et al. RSS 2021): what the MPC plans, shown to the operator.

A 2D view of the task plane (QPainter) draws the boundary, the obstacle's straight edge, the executed trail, the arm's
own trail (/cartesian_pose on the plane: where the robot really is) and the planned horizon; text gives the identified
skill, the mode, the fitting error of each skill and the solve times. A small drawing of each pattern the controller
recognises, made from its own skill models, shows what to draw. A double click starts/stops recording the MPC's
output as a ``shared_control`` skill (like LOW-LEVEL's recording). All data arrive as task-plane values through the
worker's signals; this module has no ROS in it.
"""

import collections
import dataclasses
import math
import time
from typing import Callable, List, Optional, Sequence, Tuple

import casadi as ca
import numpy as np
from PyQt5.QtCore import QPointF, QRectF, Qt, pyqtSignal
from PyQt5.QtGui import QColor, QPainter, QPen, QPolygonF
from PyQt5.QtWidgets import QHBoxLayout, QLabel, QVBoxLayout, QWidget

from teleteach.core.gui_config import GuiConfig
from teleteach.gui.device import ClickClassifier
from teleteach.gui.widgets import restyle
from teleteach.shared_control.loop import DIRECT, FALLBACK, MODE_NAMES, SHARED, UNKNOWN
from teleteach.shared_control.models import SKILLS

MODE_COLOURS = {DIRECT: "#1565c0", SHARED: "#2e7d32", FALLBACK: "#d22828", UNKNOWN: "#6a1b9a"}


@dataclasses.dataclass
class SharedStatus:
    """One /shared_control/state message, in the values the tab shows.

    Attributes:
        mode: 0 DIRECT, 1 SHARED, 2 FALLBACK, 3 UNKNOWN (teleteach.shared_control.loop.MODE_NAMES).
        skill: identified skill ("" in direct control).
        skills: skill names, in the order of ``fitting_errors``.
        fitting_errors: epsilon_i per skill.
        estimation_time: wall time of all estimations [s].
        optimisation_time: wall time of the trajectory optimisation [s].
        state: executed state in the task plane [m].
        message: the node's words about the cycle.
    """

    mode: int
    skill: str
    skills: Tuple[str, ...]
    fitting_errors: Tuple[float, ...]
    estimation_time: float
    optimisation_time: float
    state: Tuple[float, float]
    message: str = ""


TICK_STEPS = (0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0)  # [m] candidate spacings of the axes' ticks
AXIS_TITLES = ("task x [m]  (the robot's right)", "task y [m]  (away from the robot)")


def ticks(low: float, high: float, most: int = 8) -> Tuple[float, ...]:
    """Round values [m] in [low, high], at the finest spacing of TICK_STEPS that gives at most ``most`` of them."""
    for step in TICK_STEPS:
        first, last = math.ceil(low / step - 1e-9), math.floor(high / step + 1e-9)
        if last - first + 1 <= most:
            return tuple(round(index * step, 6) for index in range(first, last + 1))
    return (low, high)


class PlaneView(QWidget):
    """The task plane, x to the right and y up, scaled to fit the boundary (or what is drawn when there is none).

    Axes in metres along the bottom and the left of the shown area, with titles saying which way the task's x and y
    point for the operator standing behind the robot.
    """

    MARGIN_PX = 64  # room for the tick labels and the axis titles beside them
    DEFAULT_EXTENT = ((-0.3, -0.2), (0.3, 0.2))

    def __init__(self, trail_length: int):
        super().__init__()
        self.setMinimumSize(480, 360)
        self.boundary = np.zeros((0, 2))
        self.obstacle: Optional[Tuple[float, float, float]] = None
        self.trail = collections.deque(maxlen=trail_length)
        self.arm_trail = collections.deque(maxlen=trail_length)
        self.plan = np.zeros((0, 2))
        self.label_boxes: List[QRectF] = []  # the y tick labels' and the y title's (pixels) as last drawn: apart

    def extent(self) -> Tuple[np.ndarray, np.ndarray]:
        """Lower-left and upper-right corner of the shown area [m]."""
        points = [self.boundary] if len(self.boundary) else [np.array(self.DEFAULT_EXTENT)]
        if not len(self.boundary):
            points += [np.array(self.trail).reshape(-1, 2), self.plan]
        points = np.vstack(points)
        low, high = points.min(axis=0), points.max(axis=0)
        pad = 0.05 * max(float(np.max(high - low)), 1e-3)
        return low - pad, high + pad

    def to_pixels(self, point: Sequence[float]) -> QPointF:
        """Task-plane point [m] -> widget pixel (same scale on both axes)."""
        low, high = self.extent()
        width, height = self.width() - 2 * self.MARGIN_PX, self.height() - 2 * self.MARGIN_PX
        scale = min(width / max(high[0] - low[0], 1e-9), height / max(high[1] - low[1], 1e-9))
        centre = (low + high) / 2
        return QPointF(
            self.width() / 2 + (point[0] - centre[0]) * scale, self.height() / 2 - (point[1] - centre[1]) * scale
        )

    def _polyline(self, painter: QPainter, points, colour: str, width: float, style=Qt.SolidLine) -> None:
        if len(points) < 2:
            return
        painter.setPen(QPen(QColor(colour), width, style))
        painter.drawPolyline(QPolygonF([self.to_pixels(point) for point in points]))

    def paintEvent(self, _event) -> None:  # noqa: N802 - Qt's name
        """Boundary, obstacle edge with hatching on its blocked side, trail, plan, current state, legend."""
        painter = QPainter(self)
        painter.setRenderHint(QPainter.Antialiasing)
        painter.fillRect(self.rect(), QColor("#fafafa"))
        if len(self.boundary):
            self._polyline(painter, np.vstack([self.boundary, self.boundary[:1]]), "#424242", 2.5)
        if self.obstacle is not None:
            self._draw_obstacle(painter)
        self._polyline(painter, list(self.arm_trail), "#2e7d32", 4.0)
        self._polyline(painter, list(self.trail), "#1565c0", 2.0)
        self._polyline(painter, self.plan, "#ef6c00", 3.0, Qt.DashLine)
        self._draw_axes(painter)
        if self.trail:
            painter.setPen(QPen(QColor("#0d47a1"), 1))
            painter.setBrush(QColor("#1565c0"))
            painter.drawEllipse(self.to_pixels(self.trail[-1]), 6, 6)
        painter.setBrush(Qt.NoBrush)
        for row, (text, colour) in enumerate(
            (
                ("boundary", "#424242"),
                ("obstacle edge", "#d22828"),
                ("executed", "#1565c0"),
                ("arm", "#2e7d32"),
                ("plan", "#ef6c00"),
            )
        ):
            painter.setPen(QPen(QColor(colour), 3))
            y = 14 + 16 * row
            painter.drawLine(8, y, 30, y)
            painter.setPen(QColor("#212121"))
            painter.drawText(36, y + 5, text)
        painter.end()

    def axes(self) -> Tuple[Tuple[float, ...], Tuple[float, ...]]:
        """The ticks [m] of the x axis and of the y axis for the area shown now."""
        low, high = self.extent()
        return ticks(low[0], high[0]), ticks(low[1], high[1])

    def _draw_axes(self, painter: QPainter) -> None:
        """Ticks with their values [m] along the bottom and the left of the shown area, and the axis titles."""
        low, _ = self.extent()
        x_ticks, y_ticks = self.axes()
        bottom, left = self.to_pixels(low).y(), self.to_pixels(low).x()
        painter.setPen(QPen(QColor("#616161"), 1))
        metrics = painter.fontMetrics()
        for value in x_ticks:
            x = self.to_pixels((value, low[1])).x()
            painter.drawLine(QPointF(x, bottom), QPointF(x, bottom + 5))
            text = f"{value:.2f}"
            painter.drawText(QPointF(x - metrics.horizontalAdvance(text) / 2, bottom + 6 + metrics.ascent()), text)
        self.label_boxes = []
        for value in y_ticks:
            y = self.to_pixels((low[0], value)).y()
            painter.drawLine(QPointF(left - 5, y), QPointF(left, y))
            text = f"{value:.2f}"
            width = metrics.horizontalAdvance(text)
            painter.drawText(QPointF(left - 7 - width, y + metrics.ascent() / 2), text)
            self.label_boxes.append(QRectF(left - 7 - width, y - metrics.ascent() / 2, width, metrics.height()))
        painter.setPen(QColor("#212121"))
        painter.drawText(
            QRectF(0, self.height() - metrics.height() - 2, self.width(), metrics.height()),
            Qt.AlignCenter,
            AXIS_TITLES[0],
        )
        widest = max((metrics.horizontalAdvance(f"{value:.2f}") for value in y_ticks), default=0)
        title_right = max(metrics.height() + 2, left - 11 - widest)  # left of the tick labels, on the widget
        self.label_boxes.append(QRectF(title_right - metrics.height(), 0, metrics.height(), self.height()))
        painter.save()
        painter.translate(title_right, self.height() / 2)
        painter.rotate(-90)
        painter.drawText(
            QRectF(-self.height() / 2, -metrics.height(), self.height(), metrics.height()),
            Qt.AlignCenter,
            AXIS_TITLES[1],
        )
        painter.restore()

    def _draw_obstacle(self, painter: QPainter) -> None:
        """The edge through (x, y); yaw points to the free side, the other side is hatched."""
        x, y, yaw = self.obstacle
        low, high = self.extent()
        length = 2.0 * float(np.linalg.norm(high - low))
        normal = np.array([math.cos(yaw), math.sin(yaw)])
        along = np.array([-normal[1], normal[0]])
        base = np.array([x, y])
        ends = [base - length * along, base + length * along]
        blocked = [ends[1], ends[0], ends[0] - length * normal, ends[1] - length * normal]
        painter.save()
        painter.setClipRect(QRectF(self.rect()))
        painter.setPen(Qt.NoPen)
        painter.setBrush(QColor(210, 40, 40, 50))
        painter.drawPolygon(QPolygonF([self.to_pixels(point) for point in blocked]))
        painter.restore()
        self._polyline(painter, ends, "#d22828", 2.5)


# rho of each pictured pattern (amplitude or radius [m], frequency [1/m], phase [m]): what the virtual device's keys 1
# and 2 draw on the task plane (teleteach.haptics.virtual.STROKES, twice the device's size)
PICTURED = {"wave": (0.02, 20.0, 0.0), "cycloid": (0.025, 20.0, 0.0)}
PICTURED_LENGTH = 0.15  # [m] of the underlying straight path drawn
PICTURE_WORDS = {"wave": "sway side to side", "cycloid": "loop as you go"}


def pattern_points(skill: str, rho: Sequence[float], length: float = PICTURED_LENGTH, count: int = 200) -> np.ndarray:
    """The ``count`` x 2 points [m] of a skill along a straight underlying path along x: x(s) = U + S_i U' (eq. 3)."""
    model = SKILLS[skill]
    points = []
    for s in np.linspace(0.0, length, count):
        offset = np.array(ca.DM(model.matrix(float(s), list(rho)))).reshape(2, 2)[:, 0]  # S_i U' with U' = (1, 0)
        points.append((s + offset[0], offset[1]))
    return np.array(points)


class PatternPictures(QWidget):
    """A drawing of each pattern the controller recognises, side by side, with its name: what the operator draws."""

    def __init__(self, patterns=PICTURED):
        super().__init__()
        self.paths = {name: pattern_points(name, rho) for name, rho in patterns.items() if name in SKILLS}
        self.setMinimumHeight(96)

    def paintEvent(self, _event) -> None:  # noqa: N802 - Qt's name
        """Each pattern in its own box, scaled alike, its name and how to move above it."""
        painter = QPainter(self)
        painter.setRenderHint(QPainter.Antialiasing)
        width = self.width() / max(len(self.paths), 1)
        metrics = painter.fontMetrics()
        extents = [path.max(axis=0) - path.min(axis=0) for path in self.paths.values()]
        span = np.max(extents, axis=0) if extents else np.ones(2)
        for column, (name, path) in enumerate(self.paths.items()):
            box = QRectF(column * width + 6, metrics.height() + 8, width - 12, self.height() - metrics.height() - 14)
            painter.setPen(QColor("#212121"))
            painter.drawText(
                QRectF(box.left(), 2, box.width(), metrics.height()),
                Qt.AlignCenter,
                f"{name}: {PICTURE_WORDS.get(name, '')}",
            )
            painter.fillRect(box, QColor("#f3f6fb"))
            scale = min(box.width() / span[0], box.height() / span[1])
            centre = (path.max(axis=0) + path.min(axis=0)) / 2
            points = [
                QPointF(box.center().x() + (x - centre[0]) * scale, box.center().y() - (y - centre[1]) * scale)
                for x, y in path
            ]
            painter.setPen(QPen(QColor("#1565c0"), 2.0))
            painter.drawPolyline(QPolygonF(points))
        painter.end()


class SharedControlTab(QWidget):
    """SHARED CONTROL: the plane view and the MPC's status; double click records the MPC's output as a skill."""

    recording_toggled = pyqtSignal()
    click_hint = pyqtSignal(str)  # two clicks too far apart for a double click: what the operator should know

    def __init__(self, config: GuiConfig, recorded_samples: Callable[[], int]):
        super().__init__()
        self.config = config
        self.active = False
        self.recording_since: Optional[float] = None
        self.recorded_samples = recorded_samples  # how many samples the recording holds
        self.status: Optional[SharedStatus] = None
        self.clicks = ClickClassifier(config.double_click_window)
        row = QHBoxLayout(self)
        self.view = PlaneView(config.shared_trail_length)
        row.addWidget(self.view, 3)
        panel = QVBoxLayout()
        self.skill_label = QLabel()
        self.mode_label = QLabel()
        self.errors_label = QLabel()
        self.times_label = QLabel()
        self.message_label = QLabel()
        self.message_label.setWordWrap(True)
        self.recording_label = QLabel()
        self.teaching_label = QLabel()  # on a wipe: the clutch and the stiffness being taught
        self.teaching_label.setWordWrap(True)
        for label in (self.skill_label, self.mode_label, self.errors_label, self.times_label):
            label.setStyleSheet("font-size: 14pt;")
            panel.addWidget(label)
        panel.addWidget(self.message_label)
        panel.addWidget(self.teaching_label)
        panel.addWidget(self.recording_label)
        panel.addWidget(QLabel("<b>Draw one of these</b> with the device, moving along steadily:"))
        self.patterns = PatternPictures()
        panel.addWidget(self.patterns)
        help_text = QLabel(
            "Move the device: the MPC recognises the motion pattern and keeps it inside the boundary. "
            "With the virtual device, key <b>1</b> draws a wave, <b>2</b> a cycloid (in its own window, "
            "'teleteach: virtual Sigma.7'; again: stop); its arrow keys move in steps, which draw no pattern.<br>"
            f"<b>double click</b> (within {config.double_click_window:.1f} s): start / stop recording a skill<br>"
            "<b>wiping a surface: close the gripper</b> (hold it): the device shapes the stiffness (x, y, z: along the "
            "surface, across it, into it) while the controller keeps the pattern; open it halfway to lead the pattern "
            "again<br>"
            "<b>open the gripper fully</b>: back to START"
        )
        help_text.setWordWrap(True)
        panel.addWidget(help_text)
        panel.addStretch(1)
        row.addLayout(panel, 2)
        self.show_status(None)

    def on_click(self, stamp: float) -> None:
        """A double click starts or stops the recording (single clicks do nothing here)."""
        if not self.active:
            return
        if self.clicks.click(stamp) == ClickClassifier.DOUBLE:
            self.recording_toggled.emit()
        elif self.clicks.missed_double is not None:
            self.click_hint.emit(self.clicks.missed_double_hint())

    def on_teaching(self, text: str) -> None:
        """What the wipe's teaching is doing (empty: no wipe, the no-contact plane)."""
        self.teaching_label.setText(text)
        restyle(self.teaching_label, "font-size: 13pt; color: #6a1b9a;" if text.startswith("CLUTCH") else "")

    def on_state(self, status: SharedStatus) -> None:
        """A /shared_control/state message: text and the executed trail."""
        self.view.trail.append(status.state)
        self.show_status(status)
        self.view.update()

    def on_arm(self, point: Sequence[float]) -> None:
        """Where the arm is (/cartesian_pose on the task plane) [m]: its trail, beside the plan it follows."""
        self.view.arm_trail.append(tuple(float(value) for value in point))
        self.view.update()

    def on_plan(self, points: np.ndarray) -> None:
        """The planned horizon in the task plane (n x 2) [m]."""
        self.view.plan = np.asarray(points, dtype=float).reshape(-1, 2)
        self.view.update()

    def on_boundary(self, points: np.ndarray) -> None:
        """The boundary polygon in the task plane (n x 2) [m]."""
        self.view.boundary = np.asarray(points, dtype=float).reshape(-1, 2)
        self.view.update()

    def on_obstacle(self, edge: Optional[Tuple[float, float, float]]) -> None:
        """The obstacle edge (x, y, yaw of the free side) in the task plane, or None."""
        self.view.obstacle = edge
        self.view.update()

    def show_status(self, status: Optional[SharedStatus]) -> None:
        """Refresh the text panel."""
        self.status = status
        if status is None:
            self.skill_label.setText("skill: -")
            self.message_label.setText(
                "waiting for /shared_control/state: the shared controller needs a few seconds to start;"
                " if none comes, is shared_control running?"
            )
            self.mode_label.setText("mode: -")
            self.errors_label.setText("fitting errors: - (no state yet)")
            self.times_label.setText("")
        else:
            mode = MODE_NAMES.get(status.mode, str(status.mode))
            self.skill_label.setText(f"skill: <b>{status.skill or '-'}</b>")
            self.mode_label.setText(f"mode: <b style='color: {MODE_COLOURS.get(status.mode, '#212121')}'>{mode}</b>")
            errors = [f"&nbsp;&nbsp;{name}: {error:.3g}" for name, error in zip(status.skills, status.fitting_errors)]
            if not errors:  # direct control for the first window: nothing was fitted yet
                errors = ["&nbsp;&nbsp;none yet (direct control while the first window fills)"]
            self.errors_label.setText("fitting errors [(m/s)<sup>2</sup>]:<br>" + "<br>".join(errors))
            self.times_label.setText(
                f"solve: estimation {1e3 * status.estimation_time:.2f} ms, "
                f"optimisation {1e3 * status.optimisation_time:.2f} ms"
            )
            self.message_label.setText(status.message)
        if self.recording_since is None:
            self.recording_label.setText("not recording")
            restyle(self.recording_label, "")
        else:
            elapsed = time.monotonic() - self.recording_since
            self.recording_label.setText(f"\u25cf RECORDING {elapsed:.1f} s, {self.recorded_samples()} samples")
            restyle(self.recording_label, "color: #d22828; font-size: 14pt; font-weight: bold;")
