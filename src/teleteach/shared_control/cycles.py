"""The shared controller's 50 Hz clock: every cycle gets a state, and a cycle that comes out late is counted.

A timer that falls behind skips cycles without a word (rospy.Rate jumps ahead when it is more than two periods
late): the equilibrium then moves at a fraction of the operator's speed and the state rate drops (issue 31: 16 Hz
at the boundary). ``CycleSchedule`` keeps the nominal grid t_k = start + k dt instead. A cycle is late when its
state is ready after t_k + dt; when the next cycle is already due, the node catches up by following the previous
plan without solving, so the output keeps the rate whatever the solver does. Only after ``max_lag`` (a suspended
process, a jump of simulated time) does the grid restart at the current time, with the cycles in between counted
as late and skipped.
"""

import collections
import dataclasses
from typing import Deque, Dict, Optional

import numpy as np


class CycleSchedule:
    """Nominal cycle times start + k period, and how many cycles came out late.

    Args:
        start: time of the first cycle [s].
        period: cycle period [s].
        max_lag: lag behind the grid after which the grid restarts at the current time [s].
    """

    def __init__(self, start: float, period: float, max_lag: float):
        if not period > 0 or not max_lag >= period:
            raise ValueError(f"period must be > 0 and max_lag >= period, got {period}, {max_lag}")
        self.start = float(start)
        self.period = float(period)
        self.max_lag = float(max_lag)
        self.cycles = 0  # cycles done
        self.late = 0  # of which late or skipped
        self.skipped = 0  # of which skipped (no state) after a lag over max_lag

    def next_time(self) -> float:
        """Nominal time of the next cycle [s]."""
        return self.start + self.cycles * self.period

    def wait(self, now: float) -> float:
        """Time until the next cycle is due [s] (0 when it is due or overdue)."""
        return max(self.next_time() - now, 0.0)

    def behind(self, now: float) -> bool:
        """True when the next cycle's deadline has already passed: it should catch up rather than solve."""
        return now > self.next_time() + self.period

    def restart_if_lost(self, now: float) -> int:
        """Give up the cycles more than ``max_lag`` behind (counted late and skipped); returns how many."""
        lag = now - self.next_time()
        if lag <= self.max_lag:
            return 0
        missed = int(lag // self.period)
        self.cycles += missed
        self.late += missed
        self.skipped += missed
        return missed

    def finish(self, now: float) -> bool:
        """The next cycle's state is ready at ``now``; returns whether it is late."""
        late = now > self.next_time() + self.period
        self.cycles += 1
        self.late += late
        return late


@dataclasses.dataclass
class CycleStatistics:
    """The node's periodic cycle report: rate, late cycles, modes and solve times over the last ``period``.

    Args:
        period: seconds between reports [s].
        mode_names: name of each mode number.
    """

    period: float
    mode_names: Dict[int, str]
    started: Optional[float] = None
    late: int = 0
    modes: Deque[int] = dataclasses.field(default_factory=collections.deque)
    solve_times: Deque[float] = dataclasses.field(default_factory=collections.deque)

    def add(self, now: float, mode: int, solve_time: float, late: bool) -> Optional[str]:
        """Count one cycle; returns the report line when ``period`` has passed since the last one, else None."""
        if self.started is None:
            self.started = now
        self.modes.append(mode)
        if solve_time > 0.0:
            self.solve_times.append(solve_time)
        self.late += late
        elapsed = now - self.started
        if elapsed < self.period:
            return None
        line = self.summary(elapsed)
        self.started, self.late = now, 0
        self.modes.clear()
        self.solve_times.clear()
        return line

    def summary(self, elapsed: float) -> str:
        """One line: cycles, rate, late cycles, share of each mode, solve time mean and p99."""
        count = len(self.modes)
        shares = collections.Counter(self.modes)
        modes = ", ".join(f"{self.mode_names.get(m, m)} {100 * n / count:.1f} %" for m, n in sorted(shares.items()))
        line = f"{count} cycles in {elapsed:.1f} s ({count / elapsed:.1f} Hz), {self.late} late; {modes}"
        if self.solve_times:
            times = 1e3 * np.array(self.solve_times)
            line += f"; solve {times.mean():.2f} ms mean, {np.percentile(times, 99):.2f} ms p99"
        return line
