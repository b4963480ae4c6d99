"""The live behaviour tree as rqt_py_trees showed it: node states in colour."""

from typing import Optional

from PyQt5.QtGui import QBrush, QColor
from PyQt5.QtWidgets import (
    QHeaderView,
    QTreeWidget,
    QTreeWidgetItem,
)

from teleteach.gui.selection import (
    STATUS_NAMES,
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
