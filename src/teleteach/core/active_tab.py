"""The GUI's tabs as /teleteach/active_tab names them.

A word the GUI, the recording report and the thesis runner share, so it lives below all of them.
"""

import enum


class Tab(enum.IntEnum):
    """The GUI's tabs, as published on /teleteach/active_tab (thesis A.2.1)."""

    START = 0
    HIGH_LEVEL = 1
    LOW_LEVEL = 2
    SHARED_CONTROL = 3
    TELEOP = 4  # the device moves the arm (teleteach.core.teleoperation)

    @property
    def title(self) -> str:
        """The tab's title as the operator reads it (START, HIGH-LEVEL, LOW-LEVEL, SHARED CONTROL, TELEOP)."""
        return self.name.replace("_LEVEL", "-LEVEL").replace("_", " ")
