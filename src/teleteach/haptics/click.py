"""The emulated button click of the thesis: a quick close-and-back of the finger-operated gripper.

Both sides of the gesture live here: :class:`ClickDetector` recognises it in a stream of gripper angles (used by
every backend without a native button), and :func:`flick_gripper_angle` produces it (used by the scenario and
virtual backends to script a click), so the two always agree.
"""

import dataclasses
import enum
import math
from typing import Iterable, Tuple


@dataclasses.dataclass(frozen=True)
class ClickParameters:
    """Thresholds of the click gesture.

    Attributes:
        close_threshold: [rad] the gripper counts as closed below this angle.
        release_threshold: [rad] the gripper counts as back open above this angle (> close_threshold: hysteresis).
        max_duration: [s] longest time from closing to release that still counts as a click.
        pulse_duration: [s] how long the button state stays True after a click.
    """

    close_threshold: float
    release_threshold: float
    max_duration: float
    pulse_duration: float

    def __post_init__(self):
        values = dataclasses.astuple(self)
        if not all(math.isfinite(value) for value in values):
            raise ValueError(f"click parameters must be finite numbers, got {self}")
        if not 0.0 <= self.close_threshold < self.release_threshold:
            raise ValueError(
                f"click thresholds need 0 <= close_threshold < release_threshold, "
                f"got close {self.close_threshold} rad, release {self.release_threshold} rad"
            )
        if self.max_duration <= 0.0 or self.pulse_duration <= 0.0:
            raise ValueError(
                f"click durations must be positive, got max_duration {self.max_duration} s, "
                f"pulse_duration {self.pulse_duration} s"
            )

    @classmethod
    def from_yaml(cls, **changes: float) -> "ClickParameters":
        """config/device.yaml's ``click`` section, the one place of its values, with ``changes``."""
        from teleteach.core.paths import config_values

        values = config_values("device.yaml", "click")
        return cls(**{**values, **changes})


class _Phase(enum.Enum):
    DISARMED = 0  # waiting for the gripper to be open (at start, after a reset, after a slow close)
    OPEN = 1  # armed: a close may start a click
    CLOSED = 2  # closed since `closed_since`, waiting for the release


class ClickDetector:
    """Turns gripper angles into the emulated button state.

    The gripper drops below ``close_threshold`` and comes back above ``release_threshold`` within
    ``max_duration`` -> one click: the button state goes True (one rising edge) for ``pulse_duration``.
    A slower close-and-back is a grip, not a click. The two thresholds give hysteresis, so noise around
    either threshold neither starts nor ends a gesture twice.

    Every click gets its own rising edge: one that completes while the button is pressed, or before a release of
    ``pulse_duration`` after it, waits for that release; and a waiting click is pressed only once a released state
    was returned, so a loop that stalled through a whole release still reports one (a double click stays two).
    """

    def __init__(self, parameters: ClickParameters):
        self.parameters = parameters
        self.clicks = 0
        self.reset()

    def reset(self) -> None:
        """Forgets the gesture in progress (after a gap in the data); the next click needs an open gripper first."""
        self._phase = _Phase.DISARMED
        self._closed_since = 0.0
        self._pressed_until = -math.inf
        self._queued = 0  # clicks waiting for the press under way and its release: each pressed after the one before
        self._returned_pressed = False  # what update returned last: a queued click waits for a returned release

    def catch_up(self, samples: Iterable[Tuple[float, float]], now: float) -> None:
        """Feeds the (time [s], gripper angle [rad]) samples a stalled loop did not read: a stall delays a click.

        Only a scripted backend knows them; without them, a stall can swallow a click or stretch it into a grip.
        Clicks found among them are pressed from ``now`` (or after the press under way and its release), one
        ``pulse_duration`` pulse each with as long a release between them (a double click stays two clicks, closer
        together than the GUI's double-click window).
        """
        found = sum(self._recognise(time, angle) for time, angle in samples)
        if found:
            self._press(now, found)

    def update(self, time: float, gripper_angle: float) -> bool:
        """Feeds one gripper angle [rad] taken at ``time`` [s]; returns the button state."""
        parameters = self.parameters
        if self._queued and not self._returned_pressed and time >= self._pressed_until + parameters.pulse_duration:
            self._queued -= 1
            self._pressed_until = time + parameters.pulse_duration
        if self._recognise(time, gripper_angle):
            self._press(time, 1)
        self._returned_pressed = time < self._pressed_until
        return self._returned_pressed

    def _press(self, time: float, clicks: int) -> None:
        """``clicks`` completed at ``time``: the first pressed now if the button is free, the others queued."""
        busy = self._returned_pressed or time < self._pressed_until + self.parameters.pulse_duration
        if self._queued or busy:
            self._queued += clicks  # after the press under way and its release: every click its own rising edge
        else:
            self._pressed_until = time + self.parameters.pulse_duration
            self._queued = clicks - 1

    def _recognise(self, time: float, gripper_angle: float) -> bool:
        """Advances the gesture by one sample; True when it completes a click (counted in ``clicks``)."""
        parameters = self.parameters
        if self._phase is _Phase.DISARMED:
            if gripper_angle > parameters.release_threshold:
                self._phase = _Phase.OPEN
        elif self._phase is _Phase.OPEN:
            if gripper_angle < parameters.close_threshold:
                self._phase = _Phase.CLOSED
                self._closed_since = time
        elif gripper_angle > parameters.release_threshold:
            self._phase = _Phase.OPEN
            if time - self._closed_since <= parameters.max_duration:
                self.clicks += 1
                return True
        elif time - self._closed_since > parameters.max_duration:
            self._phase = _Phase.DISARMED
        return False


def flick_gripper_angle(base_angle: float, time_since_start: float, duration: float) -> float:
    """The gripper angle [rad] during a scripted click, ``time_since_start`` [s] after it began.

    A raised-cosine dip from ``base_angle`` to fully closed (0 rad) at ``duration / 2`` and back at ``duration``;
    outside [0, duration] the angle is ``base_angle``.
    """
    if not 0.0 <= time_since_start <= duration:
        return base_angle
    depth = 0.5 * (1.0 - math.cos(2.0 * math.pi * time_since_start / duration))
    return base_angle * (1.0 - depth)
