"""The device loop: read, turn into the operator frame, click, twist, publish, render the guidance; at a fixed rate.

Nothing here needs ROS: the node passes the clock that stamps samples (ROS time), the publishing function and a
logger, so the whole loop runs in unit tests.
"""

import dataclasses
import time as wall_time
from typing import Callable, Optional

import numpy as np

from teleteach.haptics.axes import CONVENTIONS, AxisMapping
from teleteach.haptics.click import ClickDetector
from teleteach.haptics.device import DeviceBackend, DeviceReadError
from teleteach.haptics.guidance import GuidanceRenderer, Wrench
from teleteach.haptics.twist import StampOnWall, TwistEstimator


@dataclasses.dataclass
class DeviceState:
    """Everything published for one cycle, stamped with the time the device was read.

    Attributes:
        stamp: [s] time of the read (ROS time in the node).
        position: [m] (3,), operator frame (:mod:`teleteach.haptics.axes`).
        orientation: unit quaternion (x, y, z, w), operator frame.
        linear_velocity: [m/s] (3,), operator frame, filtered.
        angular_velocity: [rad/s] (3,), operator frame, filtered.
        gripper: [rad].
        button: emulated (or native) button state.
    """

    stamp: float
    position: np.ndarray
    orientation: np.ndarray
    linear_velocity: np.ndarray
    angular_velocity: np.ndarray
    gripper: float
    button: bool


class WallRate:
    """Keeps a loop at ``frequency`` [Hz] of wall (monotonic) time with absolute deadlines, so it does not drift.

    Each ``sleep()`` waits for the next deadline, deadline k = start + k / frequency; cycles that ran late (the
    process was not scheduled, say) are caught up by running the following ones back to back, so the average
    rate holds. After a stall longer than ``max_lag`` [s] the missed cycles are dropped (counted in
    ``overruns``) instead of being published in one long burst.
    """

    def __init__(
        self,
        frequency: float,
        max_lag: float = 1.0,
        clock: Callable[[], float] = wall_time.monotonic,
        sleep: Callable[[float], None] = wall_time.sleep,
    ) -> None:
        if not frequency > 0.0:
            raise ValueError(f"rate must be a positive number of Hz, got {frequency}")
        self.period = 1.0 / frequency
        self.max_lag = max_lag
        self.overruns = 0
        self._clock = clock
        self._sleep = sleep
        self._deadline = clock()

    def sleep(self) -> None:
        """Waits until the next deadline (returns at once when behind)."""
        self._deadline += self.period
        delay = self._deadline - self._clock()
        if delay > 0.0:
            self._sleep(delay)
        elif -delay > self.max_lag:
            self.overruns += 1
            self._deadline = self._clock()


class Decimated:
    """Passes every ``every``-th device state on to ``publish``, and at once each one whose button changed.

    The loop runs at its rate (1 kHz) for what needs it: the click emulation, the twist estimate and the guidance
    force. Its readers need far less (the GUI shows 60 Hz, the shared controller cycles at 50 Hz), and each message
    costs the node and every subscriber; a button edge is never held back, so a click reaches them in its cycle.
    """

    def __init__(self, publish: Callable[[DeviceState], None], every: int) -> None:
        self._publish = publish
        self._every = max(1, every)
        self._count = 0
        self._button: Optional[bool] = None

    def __call__(self, state: DeviceState) -> None:
        """Publishes ``state`` when it is this cycle's turn or its button changed."""
        self._count += 1
        if self._count % self._every == 0 or state.button != self._button:
            self._button = state.button
            self._publish(state)


class ThrottledLog:
    """Reports a repeating problem at most once per ``period`` [s] of wall time, with how often it happened."""

    def __init__(
        self, log: Callable[[str], None], period: float = 1.0, clock: Callable[[], float] = wall_time.monotonic
    ) -> None:
        self._log = log
        self._period = period
        self._clock = clock
        self._last_logged = -float("inf")
        self._suppressed = 0

    def __call__(self, message: str) -> None:
        """Logs ``message`` unless one was logged less than a period ago."""
        now = self._clock()
        if now - self._last_logged >= self._period:
            repeats = f" (and {self._suppressed} more times since the last report)" if self._suppressed else ""
            self._log(message + repeats)
            self._last_logged = now
            self._suppressed = 0
        else:
            self._suppressed += 1


class DeviceLoop:
    """One cycle = read the device, derive button and twist, hand the state to ``publish``.

    While reads fail nothing is published (subscribers never see stale data), the failure is logged at most once
    per ``error_log_period``, and the click and twist history is dropped so that the first good read after the
    gap starts afresh. The loop keeps trying for as long as it runs.

    Args:
        backend: where samples come from.
        publish: called with each :class:`DeviceState`.
        clock: [s] time that stamps samples (ROS time in the node). A hand's twist is differentiated over it as a
            line of ``wall_clock`` (``DeviceBackend.moves_on_wall_clock``), a scenario's over the stamps themselves.
        click_detector: emulates the button for backends without a native one.
        twist_estimator: filtered velocity from successive poses.
        log_error: receives the (throttled) read-error reports.
        log_info: receives the recovery report.
        error_log_period: [s] of wall time between two error reports.
        guidance: the guidance whose wrench the backend renders each cycle (None: no force ever); a failed read (the
            device lost) drops it and renders zero, until the next guidance message.
        publish_wrench: called with each rendered :class:`Wrench` (the node publishes a decimated share).
        axes: the backend's frame -> the operator frame (None: the same); samples are turned by it, wrenches back.
    """

    def __init__(
        self,
        backend: DeviceBackend,
        publish: Callable[[DeviceState], None],
        clock: Callable[[], float],
        click_detector: ClickDetector,
        twist_estimator: TwistEstimator,
        log_error: Callable[[str], None],
        log_info: Callable[[str], None] = lambda message: None,
        error_log_period: float = 1.0,
        wall_clock: Callable[[], float] = wall_time.monotonic,
        guidance: Optional[GuidanceRenderer] = None,
        publish_wrench: Callable[[Wrench], None] = lambda wrench: None,
        axes: Optional[AxisMapping] = None,
    ) -> None:
        self.axes = axes or AxisMapping(CONVENTIONS["operator"])
        self.guidance = guidance
        self._publish_wrench = publish_wrench
        self.backend = backend
        self._publish = publish
        self._clock = clock
        self._clicks = click_detector
        self._twist = twist_estimator
        self._stamp_on_wall = StampOnWall()
        self._log_error = ThrottledLog(log_error, error_log_period, wall_clock)
        self._wall_clock = wall_clock
        self.first_published_at: Optional[float] = None
        self.last_published_at: Optional[float] = None
        self._log_info = log_info
        self.failed_reads = 0
        self.published = 0
        self._failing_since: Optional[int] = None

    def step(self) -> bool:
        """Runs one cycle; returns whether a state was published."""
        stamp = self._clock()
        moment = self._stamp_on_wall(self._wall_clock(), stamp) if self.backend.moves_on_wall_clock else stamp
        try:
            sample = self.backend.read(stamp)
        except DeviceReadError as error:
            self.failed_reads += 1
            if self._failing_since is None:
                self._failing_since = self.failed_reads
                self._clicks.reset()
                self._twist.reset()
            self._log_error(f"device read failed, not publishing until it recovers: {error}")
            if self.guidance is not None:
                self.guidance.drop()
                self._render(Wrench.zero())
            return False
        if self._failing_since is not None:
            self._log_info(f"device reads recovered after {self.failed_reads - self._failing_since + 1} failures")
            self._failing_since = None
        sample = self.axes.to_operator(sample)
        button = sample.button
        if button is None:
            self._clicks.catch_up(self.backend.missed_gripper(), stamp)
            button = self._clicks.update(stamp, sample.gripper)
        linear, angular = self._twist.update(moment, sample.position, sample.orientation)
        self._publish(
            DeviceState(stamp, sample.position, sample.orientation, linear, angular, float(sample.gripper), button)
        )
        if self.guidance is not None:
            now = self._wall_clock()
            self._render(
                self.guidance.wrench(now, sample.position, sample.orientation, linear, angular, sample.gripper)
            )
        self.published += 1
        self.last_published_at = self._wall_clock()
        if self.first_published_at is None:
            self.first_published_at = self.last_published_at
        return True

    def _render(self, wrench: Wrench) -> None:
        """Render a wrench of the operator frame (in the device's frame); publish it as it was asked."""
        try:
            self.backend.render(self.axes.to_device(wrench))
        except DeviceReadError as error:
            self._log_error(f"device did not take the guidance force: {error}")
            return
        self._publish_wrench(wrench)

    @property
    def achieved_rate(self) -> float:
        """[Hz] average rate of publication between the first and the last published cycle (wall time)."""
        if self.published < 2 or self.last_published_at <= self.first_published_at:
            return 0.0
        return (self.published - 1) / (self.last_published_at - self.first_published_at)

    def run(self, rate: WallRate, should_stop: Callable[[], bool]) -> None:
        """Cycles at ``rate`` until ``should_stop()`` or the backend has finished."""
        while not should_stop() and not self.backend.finished:
            self.step()
            rate.sleep()
