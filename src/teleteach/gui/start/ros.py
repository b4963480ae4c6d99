"""The START tab's place in the window: a click in the centre starts a waiting tree, elsewhere it opens a mode.

Its topics (the tree's execution, a replayed skill's authority) are still the worker's.
"""

from teleteach.core.active_tab import Tab
from teleteach.gui.adapter import TabParts
from teleteach.gui.start.view import StartTab


def build(window) -> TabParts:
    """START in ``window``."""
    view = StartTab(window.config)
    view.start_requested.connect(lambda: window.carry_out(window.session.start_requested()))
    view.mode_chosen.connect(window.tabs.setCurrentIndex)
    view.mode_chosen.connect(lambda tab: window.publish_selection(Tab.START, "mode", Tab(tab).name))
    return TabParts(Tab.START.title, view)
