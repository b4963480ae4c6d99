"""The phases of a participant's session as teleteach/StudyState numbers them.

A word the study node, the GUI and the device node (the scripted operator's waits) share, so it
lives below all of them, as the GUI's tabs do in active_tab.py.
"""

import enum


class Phase(enum.IntEnum):
    """teleteach/StudyState's phases."""

    PREPARING = 0
    INSTRUCTIONS = 1
    RUNNING = 2
    DONE = 3
    QUESTIONNAIRE = 4
    FINISHED = 5


PHASE_NAMES = tuple(phase.name for phase in Phase)


def phase_name(number: int, default: str) -> str:
    """The name of a StudyState phase number; ``default`` for a number this version does not know."""
    return Phase(number).name if 0 <= number < len(PHASE_NAMES) else default
