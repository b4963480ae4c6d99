"""The study's page of the teaching GUI: instructions, the end of a trial, the questionnaire, thank you.

It only draws what :class:`teleteach.gui.study.StudyScreen` says; the window routes the device and clicks to that
machine while the page is shown.
"""

from typing import Optional

from PyQt5.QtCore import QPointF, Qt
from PyQt5.QtGui import QColor, QFont, QPainter, QPen
from PyQt5.QtWidgets import QHBoxLayout, QLabel, QSizePolicy, QVBoxLayout, QWidget

from teleteach.core.study_phase import Phase
from teleteach.gui.study import StudyScreen

TITLE_STYLE = "color: #1a237e;"
DONE_STYLE = "color: #1b5e20;"
NOT_DONE_STYLE = "color: #b71c1c;"


def _font(label: QLabel, points: int, bold: bool = False) -> QLabel:
    font = QFont(label.font())
    font.setPointSize(points)
    font.setBold(bold)
    label.setFont(font)
    return label


def _paragraph(points: int, bold: bool = False, style: str = "") -> QLabel:
    """A label of text that wraps, in ``points``, with ``style``."""
    label = _font(QLabel(), points, bold)
    label.setWordWrap(True)
    label.setStyleSheet(style)
    return label


class CentreTarget(QWidget):
    """A ring (the start gesture's radius) and a dot where the handle is (device X right, Y up)."""

    def __init__(self, radius: float, reach: float):
        super().__init__()
        self.radius = radius
        self.reach = reach  # [m] shown from the centre to the widget's edge
        self.point = (0.0, 0.0)
        self.inside = False
        self.setMinimumSize(220, 220)
        self.setSizePolicy(QSizePolicy.Fixed, QSizePolicy.Fixed)

    def show_point(self, x: float, y: float, inside: bool) -> None:
        """Where the handle is [m], and whether it is at the centre."""
        if (x, y, inside) != (*self.point, self.inside):
            self.point, self.inside = (x, y), inside
            self.update()

    def paintEvent(self, _event) -> None:  # noqa: N802 - Qt's name
        """Draw the ring and the dot."""
        painter = QPainter(self)
        painter.setRenderHint(QPainter.Antialiasing)
        half = min(self.width(), self.height()) / 2.0
        centre = QPointF(self.width() / 2.0, self.height() / 2.0)
        scale = (half - 10.0) / self.reach
        painter.setPen(QPen(QColor("#9e9e9e"), 1, Qt.DashLine))
        painter.drawEllipse(centre, half - 10.0, half - 10.0)
        ring = QColor("#2e7d32") if self.inside else QColor("#e65100")
        painter.setPen(QPen(ring, 3))
        painter.drawEllipse(centre, self.radius * scale, self.radius * scale)
        x = max(-self.reach, min(self.reach, self.point[0])) * scale
        y = max(-self.reach, min(self.reach, self.point[1])) * scale
        painter.setPen(Qt.NoPen)
        painter.setBrush(ring)
        painter.drawEllipse(QPointF(centre.x() + x, centre.y() - y), 9.0, 9.0)
        painter.end()


class ScaleView(QWidget):
    """A questionnaire's scale as on the paper form.

    A line with a tick per position (the middle one taller), the position under the device marked, each position's
    value under it when there are few (a Likert item).
    """

    def __init__(self):
        super().__init__()
        self.points = 21
        self.position = 10
        self.values = [str(value) for value in range(21)]
        self.setMinimumHeight(90)

    def show_scale(self, points: int, position: int, values) -> None:
        """``points`` positions, ``position`` marked, ``values`` their labels."""
        if (points, position, list(values)) != (self.points, self.position, self.values):
            self.points, self.position, self.values = points, position, list(values)
            self.update()

    def paintEvent(self, _event) -> None:  # noqa: N802 - Qt's name
        """Draw the line, the ticks and the mark."""
        painter = QPainter(self)
        painter.setRenderHint(QPainter.Antialiasing)
        left, right, y = 20.0, self.width() - 20.0, 40.0
        step = (right - left) / max(1, self.points - 1)
        painter.setPen(QPen(QColor("#37474f"), 3))
        painter.drawLine(QPointF(left, y), QPointF(right, y))
        middle = (self.points - 1) / 2.0
        for index in range(self.points):
            x = left + index * step
            tall = 22.0 if index in (0, self.points - 1) or index == middle else 12.0
            painter.drawLine(QPointF(x, y - tall), QPointF(x, y))
            if self.points <= 11:
                painter.drawText(QPointF(x - 6.0, y + 26.0), self.values[index])
        x = left + self.position * step
        painter.setPen(Qt.NoPen)
        painter.setBrush(QColor("#e65100"))
        painter.drawEllipse(QPointF(x, y), 12.0, 12.0)
        painter.end()


class StudyPage(QWidget):
    """One page for every study screen; :meth:`show_screen` fills it from the study's state machine."""

    def __init__(self, radius: float, reach: float):
        super().__init__()
        column = QVBoxLayout(self)
        column.setContentsMargins(60, 40, 60, 40)
        self.header = _font(QLabel(), 12)
        self.header.setStyleSheet("color: #555;")
        column.addWidget(self.header)
        self.title = _paragraph(24, bold=True, style=TITLE_STYLE)
        column.addWidget(self.title)
        self.body = _paragraph(15)
        self.body.setTextFormat(Qt.RichText)
        column.addWidget(self.body)
        column.addSpacing(20)

        self.target = CentreTarget(radius, reach)
        target_row = QHBoxLayout()
        target_row.addStretch(1)
        target_row.addWidget(self.target)
        target_row.addStretch(1)
        column.addLayout(target_row)

        self.question = _paragraph(18, bold=True)
        column.addWidget(self.question)
        self.scale = ScaleView()  # moved by the device only
        column.addWidget(self.scale)
        ends = QHBoxLayout()
        self.low = _font(QLabel(), 13)
        self.value = _font(QLabel(), 16, bold=True)
        self.value.setAlignment(Qt.AlignCenter)
        self.high = _font(QLabel(), 13)
        self.high.setAlignment(Qt.AlignRight)
        for label in (self.low, self.value, self.high):
            ends.addWidget(label, 1)
        column.addLayout(ends)
        column.addStretch(1)
        self.message = _paragraph(14, bold=True, style="color: #b71c1c;")
        column.addWidget(self.message)
        self.hint = _paragraph(13, style="background: #eef; padding: 8px; border: 1px solid #99b;")
        column.addWidget(self.hint)
        self._slider_shown: Optional[bool] = None
        self._screens = {
            Phase.INSTRUCTIONS: self._instructions,
            Phase.DONE: self._done,
            Phase.QUESTIONNAIRE: self._questionnaire,
            Phase.FINISHED: self._finished,
        }

    def _questionnaire_widgets(self, shown: bool) -> None:
        if shown == self._slider_shown:
            return
        self._slider_shown = shown
        for widget in (self.question, self.scale, self.low, self.value, self.high):
            widget.setVisible(shown)

    def show_screen(self, screen: StudyScreen) -> None:
        """Fill the page from ``screen``."""
        status = screen.status
        if status is None:
            return
        phase = status.phase
        header = f"Study {status.study} \u00b7 participant {status.participant}"
        if status.trials and phase in (Phase.PREPARING, Phase.INSTRUCTIONS, Phase.DONE):
            header += f" \u00b7 trial {max(status.trial, 1)} of {status.trials}"
        if status.condition_label:
            header += f" \u00b7 {status.condition_label}"
        self.header.setText(header)
        self.message.setText(screen.message)
        self.target.setVisible(phase == Phase.INSTRUCTIONS)
        self._questionnaire_widgets(phase == Phase.QUESTIONNAIRE and not screen.reviewing and not screen.sent)
        self.title.setStyleSheet(TITLE_STYLE)
        self._screens.get(phase, self._preparing)(screen)

    def _preparing(self, screen: StudyScreen) -> None:
        self.title.setText("Please wait")
        self.body.setText("The robot and the next task are being prepared.")
        self.hint.setText("Rest your hand; nothing you do with the device counts now.")

    def _instructions(self, screen: StudyScreen) -> None:
        status = screen.status
        self.title.setText(status.title)
        self.body.setText(status.instructions.replace("\n", "<br>"))
        sample = screen.sample
        self.target.show_point(sample.x, sample.y, screen.centred)
        where = "at the centre: click to start" if screen.centred else "bring the handle to the centre"
        self.hint.setText(
            f"<b>To start</b>: bring the handle to the centre (the dot into the ring), then click (close the gripper "
            f"quickly and let go). Handle: {where}. You have {status.timeout:g} s from the start."
        )

    def _done(self, screen: StudyScreen) -> None:
        status = screen.status
        if status.success:
            self.title.setText(f"Done in {status.elapsed:.1f} s")
            self.title.setStyleSheet(DONE_STYLE)
        else:
            self.title.setText("Time is up")
            self.title.setStyleSheet(NOT_DONE_STYLE)
        self.body.setText(status.status)
        self.hint.setText("Rest your hand; the next step follows.")

    def _questionnaire(self, screen: StudyScreen) -> None:
        status = screen.status
        count = len(status.items)
        if screen.sent:
            self.title.setText("Thank you")
            self.body.setText("Your answers are stored.")
            self.hint.setText("Rest your hand; the next step follows.")
            return
        if screen.reviewing:
            self.title.setText("Your answers")
            rows = "".join(f"<tr><td>{title}</td><td><b>{value:g}</b></td></tr>" for title, value in screen.summary())
            self.body.setText(f"<table cellspacing='6'>{rows}</table>")
            self.hint.setText("<b>Click</b> to send these answers. Handle pushed down + click: back to the last item.")
            return
        item = screen.item
        self.title.setText(f"{item.title}  ({screen.item_index + 1} of {count})")
        self.body.setText("About the trials you just did (since the last questionnaire):")
        self.question.setText(item.question)
        self.scale.show_scale(item.points, screen.position, [f"{item.value(index):g}" for index in range(item.points)])
        self.low.setText(item.low)
        self.high.setText(item.high)
        self.value.setText(f"{item.value(screen.position):g}")
        self.hint.setText(
            "Move the handle <b>left or right</b> to set your answer, <b>click</b> to take it and go on. "
            "Handle pushed down + click: back one item."
        )

    def _finished(self, screen: StudyScreen) -> None:
        self.title.setText("Thank you")
        self.body.setText("The session is complete.")
        self.hint.setText("You may let go of the device.")
