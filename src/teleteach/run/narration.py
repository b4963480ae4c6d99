"""The main job's live output of the operator's steps, as they happen, in the words of the run's summary.

Only finished tree steps were printed: the reader saw "DropItem: product_pick_1 is on the shelf in gap_1" and never
the tree edit, the LOW-LEVEL teaching that had put it there, nor the ellipsoid turned 45 degrees. Each method takes
what one topic said and returns the line to print, or None when nothing the operator did changed. No ROS here: the
runner's monitor feeds it (teleteach.run.thesis).
"""

import math
from typing import Optional, Sequence, Tuple

from teleteach.core.active_tab import Tab
from teleteach.run import outcome

STIFFNESS_CHANGE = 0.2  # a principal stiffness said again once it changed by this share of the last said value [-]
YAW_CHANGE = 10.0  # the ellipsoid's yaw said again once it turned this far from the last said yaw [deg]
STEADY_STIFFNESS = 0.02  # ... and only once it held within this share (the handle stopped) [-]
STEADY_YAW = 1.0  # ... and within this [deg]
HOLD = 0.5  # ... for this long in ROS time: late messages on a loaded machine do not make a moving handle still [s]


def _axes_difference(first: float, second: float) -> float:
    """[deg] between two axis directions: an axis has no sign, so 180 degrees apart is the same axis."""
    return abs((first - second + 90.0) % 180.0 - 90.0)


class Narration:
    """The operator's steps, one line each: tabs, recordings, tree edits, taught skills, the stiffness set by hand.

    Args:
        initial_children: the execution sequence as the tree file has it (the first edit is against this).
    """

    def __init__(self, initial_children: Sequence[str]):
        self._children = tuple(initial_children)
        self._tab: Optional[int] = None
        self._recording = False
        self._taught: Tuple[str, ...] = ()
        self._said_stiffness: Optional[Tuple[Tuple[float, ...], float]] = None
        self._holding: Optional[Tuple[Tuple[Tuple[float, ...], float], float]] = None  # (stiffness, since [s])

    def tab(self, tab: int) -> Optional[str]:
        """The tab the operator opened (/teleteach/active_tab)."""
        previous, self._tab = self._tab, tab
        if tab == previous or (previous is None and tab == Tab.START):  # the GUI opens in START by itself
            return None
        self._said_stiffness = self._holding = None  # each LOW-LEVEL visit says its stiffness afresh
        name = Tab(tab).title if tab in list(Tab) else str(tab)
        return f"operator: opened {name}"

    def recording(self, on: bool) -> Optional[str]:
        """A demonstration's recording starting or stopping (/teleteach/recording)."""
        if on == self._recording:
            return None
        self._recording = on
        where = Tab(self._tab).title if self._tab in list(Tab) else "the GUI"
        return f"operator: {where} teaching: recording {'started' if on else 'stopped'}"

    def tree(self, children: Sequence[str]) -> Optional[str]:
        """The execution sequence's children now: an edit is said in the summary's words (outcome.describe_edit)."""
        children = tuple(children)
        if children == self._children:
            return None
        before, self._children = self._children, children
        return f"operator: tree edit: {outcome.describe_edit(before, children)}"

    def taught(self, names: Sequence[str]) -> Optional[str]:
        """The demonstrated skills in the library: a new one is what the operator just taught."""
        new = [name for name in names if name not in self._taught]
        self._taught = tuple(names)
        if not new:
            return None
        return f"operator: taught {', '.join(new)} (a new HIGH-LEVEL button)"

    @staticmethod
    def help_request(node: str, reason: str) -> str:
        """A leaf asking the operator for help (/behaviour_tree/help_request), as the summary lists it."""
        return f"help request: {node}: {reason}"

    def stiffness(self, time: float, values: Sequence[float], yaw_deg: float) -> Optional[str]:
        """The ellipsoid set by hand in LOW-LEVEL at ``time`` [s]: principal stiffnesses [N/m], yaw [deg].

        Said when a value changed by STIFFNESS_CHANGE or the yaw by YAW_CHANGE since last said, once the handle has
        held it for HOLD: the teaching's phases and the turned ellipsoid, not every step of the handle on its way.
        """
        if self._tab != Tab.LOW_LEVEL or not all(math.isfinite(value) for value in (*values, yaw_deg)):
            return None
        now = (tuple(float(value) for value in values), (float(yaw_deg) + 90.0) % 180.0 - 90.0)  # an axis: no sign
        if self._holding is None or not _close(now, self._holding[0], STEADY_STIFFNESS, STEADY_YAW):
            self._holding = (now, time)
            return None
        if time - self._holding[1] < HOLD:
            return None
        if self._said_stiffness is not None and _close(now, self._said_stiffness, STIFFNESS_CHANGE, YAW_CHANGE):
            return None
        self._said_stiffness = now
        stiffness = "/".join(f"{value:.0f}" for value in now[0])
        return f"operator: stiffness X/Y/Z {stiffness} N/m, ellipsoid turned {now[1]:.0f} deg about Z"


def _close(first, second, share: float, degrees: float) -> bool:
    """Whether two (stiffnesses, yaw) are within ``share`` of each other per value and ``degrees`` in yaw."""
    values_close = all(abs(a - b) <= share * max(abs(b), 1.0) for a, b in zip(first[0], second[0]))
    return values_close and _axes_difference(first[1], second[1]) <= degrees
