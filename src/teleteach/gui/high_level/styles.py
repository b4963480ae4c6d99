"""How HIGH-LEVEL looks: the node buttons in their states, the three steps (the active one framed), the columns."""

from typing import Sequence

from PyQt5.QtCore import QSize
from PyQt5.QtWidgets import QPushButton

SELECTED_STYLE = "QPushButton { background: #ffd54f; border: 3px solid #e65100; font-weight: bold; padding: 6px; }"
BUTTON_STYLE = "QPushButton { padding: 6px; }"
UNAVAILABLE_STYLE = "QPushButton { padding: 6px; color: #9e9e9e; background: #eeeeee; }"
REPAIR_STYLE = "QPushButton { padding: 6px; color: white; background: #d22828; font-weight: bold; }"
_GROUP = "QGroupBox#step {{ border: {}; border-radius: 4px; margin-top: 1.3em; }} "
_TITLE = "QGroupBox#step::title {{ subcontrol-origin: margin; left: 8px; {} }}"
ACTIVE_STEP_STYLE = _GROUP.format("3px solid #2e7d32") + _TITLE.format("color: #1b5e20; font-weight: bold;")
STEP_STYLE = _GROUP.format("1px solid #bbb") + _TITLE.format("")
MAX_COLUMNS = 6  # buttons per row when the window is wide enough


def button_size(names: Sequence[str]) -> QSize:
    """The size a node button needs for the longest of ``names`` in the selected (bold, bordered) style."""
    probe = QPushButton()
    probe.setStyleSheet(SELECTED_STYLE)
    size = QSize(0, 0)
    for name in names:
        probe.setText(name)
        size = size.expandedTo(probe.sizeHint())
    probe.deleteLater()
    return size
