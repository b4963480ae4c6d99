"""The questionnaire after each condition: NASA-TLX (raw) and the study's own Likert items.

NASA-TLX (Hart & Staveland 1988; NASA Task Load Index, paper-and-pencil version) rates six subscales on a 0-100 scale
in steps of 5; the raw TLX (Hart 2006) is their unweighted mean, without the 15 pairwise comparisons. Performance is
the one subscale whose low end is good ("Perfect" .. "Failure"): raw TLX averages the ratings as given, so a high
score always means a high workload.

A word the study (which asks and scores) and the GUI (which shows the items) share, so it lives below both.
"""

import dataclasses
import math
from typing import Dict, Mapping, Sequence, Tuple


class AnswerError(ValueError):
    """Answers that cannot be stored; the message says exactly what is wrong."""


@dataclasses.dataclass(frozen=True)
class Item:
    """One question with a scale of ``points`` positions from ``minimum`` to ``maximum``.

    Attributes:
        name: the item's key in the data (``mental_demand``, a Likert item's own name).
        title: the heading shown (``Mental Demand``).
        question: the question shown.
        low, high: labels of the scale's ends.
        points: positions on the scale (21 for a TLX subscale: 0, 5, .., 100).
        minimum, maximum: the values of the first and the last position.
    """

    name: str
    title: str
    question: str
    low: str
    high: str
    points: int
    minimum: float
    maximum: float

    def value(self, position: int) -> float:
        """The answer at ``position`` (0 .. points - 1) of the scale."""
        position = min(max(int(position), 0), self.points - 1)
        return self.minimum + position * (self.maximum - self.minimum) / (self.points - 1)

    def position(self, value: float) -> int:
        """The scale position whose value is ``value`` (nearest)."""
        step = (self.maximum - self.minimum) / (self.points - 1)
        return min(max(round((value - self.minimum) / step), 0), self.points - 1)

    def accepts(self, value: float) -> bool:
        """Whether ``value`` is one of the scale's values."""
        return math.isfinite(value) and abs(self.value(self.position(value)) - value) < 1e-6


def tlx_item(name: str, title: str, question: str, low: str = "Very Low", high: str = "Very High") -> Item:
    """A NASA-TLX subscale: 0 .. 100 in steps of 5."""
    return Item(name, title, question, low, high, 21, 0.0, 100.0)


NASA_TLX: Tuple[Item, ...] = (
    tlx_item("mental_demand", "Mental Demand", "How mentally demanding was the task?"),
    tlx_item("physical_demand", "Physical Demand", "How physically demanding was the task?"),
    tlx_item("temporal_demand", "Temporal Demand", "How hurried or rushed was the pace of the task?"),
    tlx_item(
        "performance",
        "Performance",
        "How successful were you in accomplishing what you were asked to do?",
        low="Perfect",
        high="Failure",
    ),
    tlx_item("effort", "Effort", "How hard did you have to work to accomplish your level of performance?"),
    tlx_item("frustration", "Frustration", "How insecure, discouraged, irritated, stressed, and annoyed were you?"),
)
TLX_NAMES = tuple(item.name for item in NASA_TLX)


def raw_tlx(answers: Mapping[str, float]) -> float:
    """The raw TLX: the mean of the six subscales (0..100).

    Raises:
        AnswerError: a subscale is missing.
    """
    missing = [name for name in TLX_NAMES if name not in answers]
    if missing:
        raise AnswerError(f"raw TLX needs all six subscales; missing {', '.join(missing)}")
    return sum(float(answers[name]) for name in TLX_NAMES) / len(TLX_NAMES)


def check_answers(items: Sequence[Item], names: Sequence[str], values: Sequence[float]) -> Dict[str, float]:
    """The answers by item name, when they answer exactly ``items`` in order, each with a value of its scale.

    Raises:
        AnswerError: an item is missing, unknown or out of order, or a value is not on its item's scale.
    """
    expected = [item.name for item in items]
    if list(names) != expected:
        raise AnswerError(f"answers must name the items {', '.join(expected)} in this order, got {', '.join(names)}")
    if len(values) != len(items):
        raise AnswerError(f"{len(items)} items but {len(values)} values")
    for item, value in zip(items, values):
        if not item.accepts(float(value)):
            raise AnswerError(
                f"{item.name}: {value} is not on its scale ({item.points} positions from {item.minimum:g} to "
                f"{item.maximum:g})"
            )
    return {item.name: float(value) for item, value in zip(items, values)}
