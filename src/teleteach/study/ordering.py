"""The order of a participant's session: counterbalanced conditions, ordered tasks, repeated trials, questionnaires.

Conditions come in blocks: every trial of one condition, then its questionnaire, then the next condition. Within a
block each task's trials follow each other (so learning shows over a task's trials). The order of the conditions is
a row of a balanced Latin square (Williams design: every condition precedes every other one equally often; with an
odd number of conditions the square has twice as many rows, each row and its mirror), chosen by the participant's
number; or seeded random per participant; or the file's order. Tasks likewise within each block.
"""

import dataclasses
import random
import re
from typing import List, Sequence, Tuple

from teleteach.study.schema import Study

TRIAL = "trial"
QUESTIONNAIRE = "questionnaire"


class ParticipantError(ValueError):
    """A participant id the study cannot place in its counterbalancing."""


@dataclasses.dataclass(frozen=True)
class Step:
    """One step of a session: a trial of a task under a condition, or a condition's questionnaire.

    ``position`` counts steps from 1; ``repetition`` counts a task's trials under a condition from 1 (0 for a
    questionnaire); ``trial`` counts the session's trials from 1 (0 for a questionnaire).
    """

    kind: str
    position: int
    condition: str
    task: str = ""
    repetition: int = 0
    trial: int = 0

    @property
    def key(self) -> str:
        """A stable name for the step's files (``03_guided_remove_place_item_1``, ``05_guided_questionnaire``)."""
        if self.kind == QUESTIONNAIRE:
            return f"{self.position:02d}_{self.condition}_questionnaire"
        return f"{self.position:02d}_{self.condition}_{self.task}_{self.repetition}"

    def to_dict(self) -> dict:
        """For plan.json."""
        return dataclasses.asdict(self)


def balanced_latin_square(count: int) -> List[Tuple[int, ...]]:
    """Rows of a Williams design over ``count`` treatments: each precedes each other one equally often.

    The first row is 0, 1, n-1, 2, n-2, ...; row r adds r to it (mod n). An odd n needs the mirrored rows as well.
    """
    if count < 1:
        raise ValueError("a Latin square needs at least one treatment")
    first, low, high = [0], 1, count - 1
    while len(first) < count:
        first.append(low)
        low += 1
        if len(first) < count:
            first.append(high)
            high -= 1
    rows = [tuple((value + shift) % count for value in first) for shift in range(count)]
    if count % 2:
        rows += [tuple(reversed(row)) for row in rows]
    return rows


def participant_number(study: Study, participant: str) -> int:
    """The participant's number (1-based): the position in the study's ``participants``, else the digits of the id.

    Raises:
        ParticipantError: the id is not listed (when the study lists ids) or has no number in it.
    """
    if study.participants:
        if participant not in study.participants:
            raise ParticipantError(
                f"participant {participant!r} is not in the study's participants ({', '.join(study.participants)})"
            )
        return study.participants.index(participant) + 1
    digits = re.findall(r"\d+", participant)
    if not digits or int(digits[-1]) < 1:
        raise ParticipantError(
            f"participant id {participant!r} has no number >= 1 (e.g. P07) to place it in the counterbalancing; "
            "or list the ids under participants in the study file"
        )
    return int(digits[-1])


def _ordered(names: Sequence[str], how: str, number: int, seed_text: str, shift: int = 0) -> List[str]:
    if how == "fixed":
        return list(names)
    if how == "random":
        order = list(names)
        random.Random(seed_text).shuffle(order)
        return order
    rows = balanced_latin_square(len(names))
    return [names[index] for index in rows[(number - 1 + shift) % len(rows)]]


def session_plan(study: Study, participant: str) -> List[Step]:
    """Every step of ``participant``'s session, in order.

    Raises:
        ParticipantError: see :func:`participant_number`.
    """
    number = participant_number(study, participant)
    seed = study.order.seed
    conditions = _ordered(
        [condition.name for condition in study.conditions],
        study.order.conditions,
        number,
        f"{seed}/{participant}/conditions",
    )
    steps: List[Step] = []
    trial = 0
    for block, condition in enumerate(conditions):
        tasks = _ordered(
            [task.name for task in study.tasks], study.order.tasks, number, f"{seed}/{participant}/{condition}", block
        )
        for task_name in tasks:
            for repetition in range(1, study.task(task_name).trials + 1):
                trial += 1
                steps.append(Step(TRIAL, len(steps) + 1, condition, task_name, repetition, trial))
        if study.questionnaire:
            steps.append(Step(QUESTIONNAIRE, len(steps) + 1, condition))
    return steps
