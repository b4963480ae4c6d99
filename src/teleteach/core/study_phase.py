"""The phases of a participant's session as teleteach/StudyState numbers them, and what that message says.

Words the study node, the GUI and the device node (the scripted operator's waits) share, so they
live below all of them, as the GUI's tabs do in active_tab.py.
"""

import dataclasses
import enum
from typing import Optional, Tuple

from teleteach.core.questionnaire import Item


class Phase(enum.IntEnum):
    """teleteach/StudyState's phases."""

    PREPARING = 0
    INSTRUCTIONS = 1
    RUNNING = 2
    DONE = 3
    QUESTIONNAIRE = 4
    FINISHED = 5


PHASE_NAMES = tuple(phase.name for phase in Phase)


def known_phase(number: int) -> Optional[Phase]:
    """The phase of a StudyState phase number; None for a number this version does not know."""
    return Phase(number) if 0 <= number < len(PHASE_NAMES) else None


def phase_name(number: int, default: str) -> str:
    """The name of a StudyState phase number; ``default`` for a number this version does not know."""
    phase = known_phase(number)
    return default if phase is None else phase.name


@dataclasses.dataclass(frozen=True)
class StudyView:
    """What study/state says (the fields of teleteach/StudyState; its items as questionnaire Items)."""

    phase: Phase
    study: str = ""
    participant: str = ""
    condition: str = ""
    condition_label: str = ""
    task: str = ""
    title: str = ""
    instructions: str = ""
    trial: int = 0
    trials: int = 0
    elapsed: float = 0.0
    timeout: float = 0.0
    status: str = ""
    success: bool = False
    items: Tuple[Item, ...] = ()
