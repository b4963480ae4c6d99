"""The TELEOP tab's place in the window: the device drives the arm through the clutch; a double click records a path.

Its topics (the teleoperation's /equilibrium_pose, the scene and TF for the placement's assistance) are still the
worker's.
"""

from teleteach.core.active_tab import Tab
from teleteach.gui.adapter import TabParts
from teleteach.gui.session import Action
from teleteach.gui.teleop.view import TeleopTab


def build(window) -> TabParts:
    """TELEOP in ``window``."""
    view = TeleopTab(window.config)
    view.recording_toggled.connect(lambda: window.carry_out(window.session.toggle_path_recording()))
    actions = {
        Action.TELEOP_ON: lambda: window.worker.drive_arm(True),
        Action.TELEOP_OFF: lambda: window.worker.drive_arm(False),
    }
    return TabParts(Tab.TELEOP.title, view, actions=actions)
