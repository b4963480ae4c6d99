"""The LOW-LEVEL tab's place in the window: the ellipsoid the device shapes; a double click records.

Its topics (the stiffness stream, the scene and TF for a recording's gap) are still the worker's.
"""

from teleteach.core.active_tab import Tab
from teleteach.gui.adapter import TabParts
from teleteach.gui.low_level.view import LowLevelTab
from teleteach.gui.session import Action


def build(window) -> TabParts:
    """LOW-LEVEL in ``window``: the tab over the window's ellipsoid command, its recording the window's."""
    view = LowLevelTab(
        window.config,
        window.command,
        recorded_samples=lambda: len(window.recorder),
        last_click=lambda: window.worker.last_click,
        device_time=lambda: window.worker.device_time,
    )
    view.recording_toggled.connect(lambda: window.carry_out(window.session.toggle_stiffness_recording()))
    actions = {
        Action.ENTER_LOW_LEVEL: lambda: view.on_enter(window.worker.latest_sample()),
        Action.LEAVE_LOW_LEVEL: view.on_leave,
    }
    return TabParts(Tab.LOW_LEVEL.title, view, actions=actions)
