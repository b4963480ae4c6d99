"""The HIGH-LEVEL tab's place in the window: a confirmed edit goes to /change_tree, each confirmed step is published.

Its topics (the tree, the skill library, help requests) are still the worker's.
"""

from teleteach.bt.editor import EditRequest
from teleteach.core.active_tab import Tab
from teleteach.gui.adapter import TabParts
from teleteach.gui.high_level.view import HighLevelTab
from teleteach.gui.session import Action
from teleteach.srv import ChangeTree, ChangeTreeRequest


def build(window) -> TabParts:
    """HIGH-LEVEL in ``window``."""
    view = HighLevelTab(window.config)
    view.request_ready.connect(lambda request: send_change(window, request))
    view.selection_confirmed.connect(lambda step, choice: window.topics.send_selection(Tab.HIGH_LEVEL, step, choice))
    return TabParts(Tab.HIGH_LEVEL.title, view, actions={Action.RESET_HIGH_LEVEL: view.reset})


def send_change(window, request: EditRequest) -> None:
    """/change_tree(request), off the GUI thread; the answer comes back to the window (key ``change_tree``)."""
    window.services.call("change_tree", "change_tree", ChangeTree, ChangeTreeRequest(**request._asdict()))
