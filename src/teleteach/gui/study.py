"""A user study's screens in the teaching GUI, as a state machine without Qt (tested in test/unit/test_gui_study.py).

The study node publishes where the session stands (study/state); this machine turns it, the device and the clicks
into what the participant sees and what goes back to the study node (study/input):

- PREPARING, INSTRUCTIONS, DONE, QUESTIONNAIRE, FINISHED show the study's page instead of the tabs: the device and
  its clicks act on the page only (a click must not open a teaching mode while the participant reads);
- INSTRUCTIONS: the start gesture is a click with the handle at the centre (within ``study_start_radius`` on every
  axis), so that every trial starts from the same hand position; a click elsewhere says where the handle is;
- RUNNING: the tabs, with a banner saying the task, the time and what the world shows;
- QUESTIONNAIRE: one item at a time; device X moves its slider (the scale's positions in equal bins of the device's
  range), a click takes the answer and shows the next item; after the last one a summary, where a click sends the
  answers; a click with the handle pushed down (below ``-edit_push``, as undo in HIGH-LEVEL) goes back one item.
"""

import dataclasses
import enum
from typing import List, Optional, Tuple

from teleteach.core.gui_config import GuiConfig
from teleteach.core.questionnaire import Item
from teleteach.core.study_phase import Phase, StudyView, known_phase
from teleteach.gui.device import DeviceSample, scale_to_index


@dataclasses.dataclass(frozen=True)
class Submission:
    """What goes to study/input: ``start``, or ``questionnaire`` with the answers."""

    kind: str
    names: Tuple[str, ...] = ()
    values: Tuple[float, ...] = ()


class Page(enum.Enum):
    """What the window shows."""

    TABS = "tabs"  # no study, or a trial running: the teaching tabs
    STUDY = "study"  # the study's page (instructions, end of a trial, questionnaire, thank you)


class StudyScreen:
    """The study's screens: the status in, the device and clicks on the page, submissions out."""

    def __init__(self, config: GuiConfig):
        self.config = config
        self.status: Optional[StudyView] = None
        self.sample = DeviceSample(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        self.item_index = 0
        self.answers: List[Optional[int]] = []  # confirmed scale position of each item
        self.position = 0  # the slider's position under the device now
        self.sending = False
        self.sent = False
        self.message = ""
        self._items_key: Tuple[str, ...] = ()

    # inputs -------------------------------------------------------------------------------------------------
    def on_status(self, status: StudyView) -> None:
        """A new study/state."""
        previous = self.status
        self.status = status
        if previous is None or previous.phase != status.phase or previous.trial != status.trial:
            self.message, self.sending, self.sent = "", False, False
        key = tuple(item.name for item in status.items)
        fresh = previous is None or previous.phase != Phase.QUESTIONNAIRE or key != self._items_key
        if status.phase == Phase.QUESTIONNAIRE and fresh:
            self._items_key = key
            self.item_index = 0
            self.answers = [None] * len(status.items)
            self._follow_device()

    def on_device(self, sample: DeviceSample) -> None:
        """A device sample (only while the study's page is shown)."""
        self.sample = sample
        if self.phase == Phase.INSTRUCTIONS and self.centred and self.message.startswith("Bring"):
            self.message = ""  # the handle is where it should be now
        self._follow_device()

    def on_click(self) -> Optional[Submission]:
        """A click on the study's page; returns what to send to study/input, if anything."""
        phase = self.phase
        if phase == Phase.INSTRUCTIONS and not self.sending:
            if not self.centred:
                self.message = "Bring the handle to the centre (the dot into the ring), then click."
                return None
            self.sending, self.message = True, "starting..."
            return Submission("start")
        if phase != Phase.QUESTIONNAIRE or self.sending or self.sent:
            return None
        if self.sample.z < -self.config.edit_push:  # back one item
            self.item_index = max(0, self.item_index - 1)
            self._follow_device()
            return None
        items = self.status.items
        if self.item_index < len(items):
            self.answers[self.item_index] = self.position
            self.item_index += 1
            self._follow_device()
            return None
        self.sending, self.message = True, "sending your answers..."
        return Submission(
            "questionnaire",
            tuple(item.name for item in items),
            tuple(item.value(position) for item, position in zip(items, self.answers)),
        )

    def answered(self, success: bool, message: str) -> None:
        """study/input's answer (or why there was none)."""
        self.sending = False
        if success:
            self.sent = self.phase == Phase.QUESTIONNAIRE
            self.message = "Thank you." if self.sent else ""
        else:
            self.message = f"not taken: {message}"

    # what to show -------------------------------------------------------------------------------------------
    @property
    def phase(self) -> Optional[Phase]:
        """The study's phase (None without a study)."""
        return self.status.phase if self.status else None

    @property
    def page(self) -> Page:
        """The study's page, or the tabs (no study, or a trial running)."""
        return Page.STUDY if self.phase is not None and self.phase != Phase.RUNNING else Page.TABS

    @property
    def centred(self) -> bool:
        """Whether the handle is at the centre (the start gesture's place)."""
        radius = self.config.study_start_radius
        return all(abs(value) <= radius for value in (self.sample.x, self.sample.y, self.sample.z))

    @property
    def item(self) -> Optional[Item]:
        """The item asked now (None on the summary)."""
        items = self.status.items if self.status else ()
        return items[self.item_index] if self.item_index < len(items) else None

    @property
    def reviewing(self) -> bool:
        """Every item answered: the summary waits for the click that sends them."""
        return self.phase == Phase.QUESTIONNAIRE and self.item is None

    def summary(self) -> List[Tuple[str, float]]:
        """(title, answer) of every answered item."""
        items = self.status.items if self.status else ()
        answered = [(item, position) for item, position in zip(items, self.answers) if position is not None]
        return [(item.title, item.value(position)) for item, position in answered]

    def banner(self) -> str:
        """RUNNING: the task and the time; on a second line what the world shows."""
        status = self.status
        if status is None or status.phase != Phase.RUNNING:
            return ""
        minutes, seconds = divmod(int(status.elapsed), 60)
        limit_minutes, limit_seconds = divmod(int(status.timeout), 60)
        text = f"Trial {status.trial} of {status.trials}: {status.title}   "
        text += f"{minutes}:{seconds:02d} of {limit_minutes}:{limit_seconds:02d}"
        return text + (f"\n{status.status}" if status.status else "")

    def _follow_device(self) -> None:
        item = self.item
        if item is not None:
            self.position = scale_to_index(self.sample.x, self.config.device_range, item.points)


ITEM_FIELDS = (
    "item_names",
    "item_titles",
    "item_questions",
    "item_low",
    "item_high",
    "item_points",
    "item_minimum",
    "item_maximum",
)
"""teleteach/StudyState's arrays, one per field of a questionnaire's Item, in the Item's order."""


def study_view(message) -> StudyView:
    """The GUI's view of a teleteach/StudyState message: the view's fields by their names, the items from arrays."""
    phase = known_phase(message.phase)
    items = tuple(Item(*fields) for fields in zip(*(getattr(message, name) for name in ITEM_FIELDS)))
    named = {
        field.name: getattr(message, field.name)
        for field in dataclasses.fields(StudyView)
        if field.name not in ("phase", "items")
    }
    # a newer study's phase: wait as when preparing
    return StudyView(phase=phase if phase is not None else Phase.PREPARING, items=items, **named)
