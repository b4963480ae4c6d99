"""Operator commands placed by their header stamps, sampled on the controller's own time grid.

The estimation window must hold the operator's signal at evenly spaced times. Taking "the latest message" each cycle
makes it depend on delivery instead: a late message repeats the previous command, two bunched ones skip one, and the
fitted skill changes with the network (issue 15). Here every message is kept at its stamp and the cycle reads the
signal ``delay`` earlier than its own time: the newest command stamped at or before that time. So messages up to
``delay`` late, bunched or out of order give the same window, and a dropped one repeats its predecessor. (Linear
interpolation would need the next message too, i.e. ``delay`` longer by a period, which delays every switch.)
"""

import bisect
from typing import List, Optional, Sequence

import numpy as np


class CommandTimeline:
    """Stamped operator commands h^r, sampled at any time.

    Args:
        timeout: a sample older than this [s] means no command (zero): the operator stopped sending.
        history: samples older than this before the latest sampled time are forgotten [s].
    """

    def __init__(self, timeout: float, history: float = 1.0):
        if not timeout > 0 or not history > 0:
            raise ValueError("timeout and history must be > 0 s")
        self.timeout = float(timeout)
        self.history = float(history)
        self._stamps: List[float] = []
        self._commands: List[np.ndarray] = []

    def add(self, stamp: float, command: Sequence[float]) -> None:
        """Keep ``command`` (x, y) [m/s] at ``stamp`` [s]; a second command with the same stamp replaces the first."""
        value = np.asarray(command, dtype=float).reshape(2)
        index = bisect.bisect_left(self._stamps, stamp)
        if index < len(self._stamps) and self._stamps[index] == stamp:
            self._commands[index] = value
            return
        self._stamps.insert(index, float(stamp))
        self._commands.insert(index, value)

    def sample(self, time: float) -> np.ndarray:
        """The command at ``time`` [s]: the newest stamped at or before it, zero when that is older than ``timeout``."""
        self._forget(time - self.history)
        before = bisect.bisect_right(self._stamps, time) - 1
        if before < 0 or time - self._stamps[before] > self.timeout:
            return np.zeros(2)
        return self._commands[before].copy()

    def latest_stamp(self) -> Optional[float]:
        """Stamp of the newest command kept [s], None when empty."""
        return self._stamps[-1] if self._stamps else None

    def _forget(self, before: float) -> None:
        # Keep one sample before the cut: it brackets the next sample times.
        cut = max(bisect.bisect_left(self._stamps, before) - 1, 0)
        if cut:
            del self._stamps[:cut]
            del self._commands[:cut]
