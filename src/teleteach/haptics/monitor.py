"""What the sigma7 node published, summed up for a person: counts, rates, ranges and clicks (the device demo).

The monitor is fed from rospy callbacks (several threads), so every update takes a lock. Times are ROS times [s]:
the header stamps of pose and twist (so their rates are the publication rates, even if the monitor lags behind),
the receipt times of gripper angle and button, which have no header.
"""

import dataclasses
import math
import threading
from typing import List, Optional, Sequence

import numpy as np

from teleteach.core.rotations import quaternion_to_rpy

TOPICS = ("/sigma7/pose", "/sigma7/twist", "/sigma7/gripper_angle", "/sigma7/button")


@dataclasses.dataclass
class TopicCount:
    """Messages received on one topic and when the first and last arrived [s]."""

    count: int = 0
    first: Optional[float] = None
    last: Optional[float] = None

    def add(self, time: float) -> None:
        """Counts one message received at ``time``."""
        self.count += 1
        if self.first is None:
            self.first = time
        self.last = time

    @property
    def rate(self) -> float:
        """[Hz] average rate between the first and the last message (0 with fewer than two)."""
        if self.count < 2 or self.last <= self.first:
            return 0.0
        return (self.count - 1) / (self.last - self.first)


class _Range:
    """Running minimum and maximum of a vector."""

    def __init__(self, size: int) -> None:
        self.low = np.full(size, np.inf)
        self.high = np.full(size, -np.inf)

    def add(self, values) -> None:
        self.low = np.minimum(self.low, values)
        self.high = np.maximum(self.high, values)

    def describe(self, index: int, unit: str) -> str:
        if not np.isfinite(self.low[index]):
            return "no data"
        return f"{self.low[index]:+.3f} .. {self.high[index]:+.3f} {unit}"


class DeviceMonitor:
    """Accumulates what arrives on the four device topics.

    Args:
        start_time: [s] ROS time the scenario started (click times are reported relative to it); None = absolute.
    """

    def __init__(self, start_time: Optional[float] = None) -> None:
        self.start_time = start_time
        self.counts = {topic: TopicCount() for topic in TOPICS}
        self.click_times: List[float] = []
        self._lock = threading.Lock()
        self._position = _Range(3)
        self._rpy = _Range(3)
        self._gripper = _Range(1)
        self._speed = _Range(1)
        self._button = False

    def on_pose(self, time: float, position: Sequence[float], orientation: Sequence[float]) -> None:
        """A /sigma7/pose message received at ``time``."""
        rpy = quaternion_to_rpy(orientation)
        with self._lock:
            self.counts["/sigma7/pose"].add(time)
            self._position.add(position)
            self._rpy.add(rpy)

    def on_twist(self, time: float, linear: Sequence[float]) -> None:
        """A /sigma7/twist message received at ``time``."""
        speed = math.sqrt(sum(component * component for component in linear))
        with self._lock:
            self.counts["/sigma7/twist"].add(time)
            self._speed.add([speed])

    def on_gripper(self, time: float, angle: float) -> None:
        """A /sigma7/gripper_angle message received at ``time``."""
        with self._lock:
            self.counts["/sigma7/gripper_angle"].add(time)
            self._gripper.add([angle])

    def on_button(self, time: float, pressed: bool) -> None:
        """A /sigma7/button message received at ``time``; a rising edge is a click."""
        with self._lock:
            self.counts["/sigma7/button"].add(time)
            if pressed and not self._button:
                self.click_times.append(time if self.start_time is None else time - self.start_time)
            self._button = pressed

    def summary(self) -> str:
        """A short human-readable report of everything received so far."""
        with self._lock:
            lines = ["sigma7 device monitor: what was published"]
            for topic, count in self.counts.items():
                lines.append(f"  {topic:<22} {count.count:6d} messages  {count.rate:7.1f} Hz")
            for index, axis in enumerate("xyz"):
                lines.append(f"  position {axis}   {self._position.describe(index, 'm')}")
            for index, angle in enumerate(("roll", "pitch", "yaw")):
                lines.append(f"  {angle:<10} {self._rpy.describe(index, 'rad')}")
            lines.append(f"  gripper    {self._gripper.describe(0, 'rad')}")
            lines.append(f"  speed      {self._speed.describe(0, 'm/s')}")
            since = "s after the scenario start" if self.start_time is not None else "s (ROS time)"
            times = ", ".join(f"{time:.3f}" for time in self.click_times)
            lines.append(f"  clicks     {len(self.click_times)}" + (f" at {times} {since}" if times else ""))
            return "\n".join(lines)
