"""Small helpers every tab's widgets use: a style set only when it changes, a big label."""

from PyQt5.QtGui import QFont
from PyQt5.QtWidgets import QLabel, QWidget


def restyle(widget: QWidget, style: str) -> None:
    """Set a style sheet only when it differs: Qt re-polishes a widget (and its children) on every setStyleSheet."""
    if widget.styleSheet() != style:
        widget.setStyleSheet(style)


def big(label: QLabel, points: int, bold: bool = True) -> QLabel:
    """``label`` in a ``points``-sized (bold) font."""
    font = QFont(label.font())
    font.setPointSize(points)
    font.setBold(bold)
    label.setFont(font)
    return label
