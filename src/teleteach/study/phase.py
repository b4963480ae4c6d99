"""The phases of a participant's session as teleteach/StudyState numbers them.

One definition for the study node, the GUI and the scripted device's waits (a light module: the device node imports
it).
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
