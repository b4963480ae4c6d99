"""Device input for the GUI: validation, deadbands, axis locking, scaling to the screen, clicks and gestures.

The Sigma.7 is "very sensitive to small movements" (thesis III-B and IV): a per-axis deadband holds an axis until it
moved more than a threshold, and locked axes are ignored altogether.
"""

import dataclasses
import math
from typing import Optional, Sequence, Tuple

from teleteach.core.gui_config import DEVICE_AXES, GuiConfig
from teleteach.core.rotations import quaternion_to_rpy


@dataclasses.dataclass(frozen=True)
class DeviceSample:
    """One device reading: position [m] and angles [rad] with R = Rz(yaw) Ry(pitch) Rx(roll)."""

    x: float
    y: float
    z: float
    roll: float
    pitch: float
    yaw: float

    def as_tuple(self) -> Tuple[float, ...]:
        """The six values in the order of ``DEVICE_AXES``."""
        return (self.x, self.y, self.z, self.roll, self.pitch, self.yaw)


def parse_pose(position: Sequence[float], quaternion: Sequence[float], config: GuiConfig) -> Optional[DeviceSample]:
    """A :class:`DeviceSample` from a device pose, or None when it is NaN, out of range or not a rotation."""
    values = (*position, *quaternion)
    if len(values) != 7 or not all(math.isfinite(value) for value in values):
        return None
    if any(abs(value) > config.reject_position_beyond for value in position):
        return None
    norm = math.sqrt(sum(value * value for value in quaternion))
    if abs(norm - 1.0) > 0.01:
        return None
    angles = quaternion_to_rpy([value / norm for value in quaternion])
    if any(abs(angle) > config.reject_angle_beyond for angle in angles):
        return None
    return DeviceSample(*position, *angles)


class DeviceFilter:
    """Per-axis deadband (an axis moves only once it left a band around its last accepted value) and locking."""

    def __init__(self, config: GuiConfig):
        self._bands = [config.deadband_position] * 3 + [config.deadband_angle] * 3
        self._locked = [axis in config.locked_axes for axis in DEVICE_AXES]
        self._held: Optional[list] = None

    def reset(self) -> None:
        """Forget the held values: the next sample is taken as it is."""
        self._held = None

    def apply(self, sample: DeviceSample) -> DeviceSample:
        """The sample as the GUI should see it."""
        values = sample.as_tuple()
        if self._held is None:
            self._held = [0.0 if locked else value for value, locked in zip(values, self._locked)]
            return DeviceSample(*self._held)
        for index, value in enumerate(values):
            if not self._locked[index] and abs(value - self._held[index]) >= self._bands[index]:
                self._held[index] = value
        return DeviceSample(*self._held)


def scale(value: float, half_range: float, low: float, high: float) -> float:
    """Map ``value`` in [-half_range, half_range] linearly onto [low, high], clamped (device to screen)."""
    fraction = (value + half_range) / (2.0 * half_range)
    return low + min(1.0, max(0.0, fraction)) * (high - low)


def scale_to_index(value: float, half_range: float, count: int) -> int:
    """Map ``value`` in [-half_range, half_range] onto 0..count-1 in equal bins (a slider position)."""
    if count <= 1:
        return 0
    fraction = min(1.0, max(0.0, (value + half_range) / (2.0 * half_range)))
    return min(count - 1, int(fraction * count))


class ClickClassifier:
    """Tells single clicks from double clicks (LOW-LEVEL: click = next mode, double click = start/stop recording).

    A click is reported as single only once the double-click window has passed without a second click. Clicks are
    stamped with the device's own clock (the stamp of its latest pose), not when the GUI thread gets to them: a busy
    GUI thread or a slow simulation then neither splits a double click into two singles nor joins two singles into a
    double. ``poll`` is told when the last click arrived, so it does not call a click single while the next one is
    still on its way to the GUI. Two clicks a little too far apart for a double (``NEAR_MISS`` windows) were most
    likely meant as one: :meth:`missed_double_hint` says so, for the tab to show.
    """

    SINGLE = "single"
    DOUBLE = "double"
    NEAR_MISS = 2.0  # a second click within this many windows of the first was most likely meant as a double click

    def __init__(self, window: float):
        self.window = window
        self._pending: Optional[float] = None
        self._single: float = -math.inf  # [s] the last click that was no part of a double (pending or single)
        self.missed_double: Optional[float] = None  # [s] between the last two clicks, when a double was missed

    def reset(self) -> None:
        """Drop a pending click (e.g. when the tab is left)."""
        self._pending, self._single = None, -math.inf

    @property
    def pending(self) -> bool:
        """True while a first click waits for a possible second one."""
        return self._pending is not None

    def click(self, stamp: float) -> Optional[str]:
        """Register a click that arrived at ``stamp`` [s].

        Returns DOUBLE when it completes a double click, SINGLE when it follows a pending click whose window had
        passed (that one was single), else None.
        """
        self.missed_double = None
        if self._pending is not None and stamp - self._pending <= self.window:
            self._pending, self._single = None, -math.inf
            return self.DOUBLE
        if stamp - self._single <= self.NEAR_MISS * self.window:
            self.missed_double = stamp - self._single
        expired = self._pending is not None
        self._pending = self._single = stamp
        return self.SINGLE if expired else None

    def missed_double_hint(self) -> str:
        """What to tell the operator when the last two clicks came too far apart for a double ("" otherwise)."""
        if self.missed_double is None:
            return ""
        gap, window = self.missed_double, self.window
        return f"two single clicks {gap:.2f} s apart: a double click needs both within {window:.1f} s"

    def poll(self, now: float, last_arrival: float = -math.inf) -> Optional[str]:
        """Returns SINGLE once a pending click has outlived the window and no later click has arrived since."""
        if self._pending is not None and now - self._pending > self.window and last_arrival <= self._pending:
            self._pending = None
            return self.SINGLE
        return None


class EdgeDetector:
    """Rising edges with hysteresis: button presses (0 -> 1) and the gripper opened fully (back to START)."""

    def __init__(self, threshold: float, rearm_below: float):
        self.threshold = threshold
        self.rearm_below = rearm_below
        self._armed = False
        self._seen = False

    def update(self, value: float) -> bool:
        """True exactly once each time ``value`` rises to the threshold after having been below ``rearm_below``.

        The first value only arms: a device that starts pressed or open does not fire.
        """
        if not math.isfinite(value):
            return False
        if not self._seen:
            self._seen = True
            self._armed = value < self.rearm_below
            return False
        if value >= self.threshold and self._armed:
            self._armed = False
            return True
        if value < self.rearm_below:
            self._armed = True
        return False
