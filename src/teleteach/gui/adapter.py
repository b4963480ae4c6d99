"""What a tab is to the window (``TabParts``) and what its ROS side offers the worker (``TabAdapter``); no rospy.

Each tab is a package of ``teleteach.gui``: ``view.py`` its widgets, ``ros.py`` its adapter and ``build(window)``, which
wires the two into the window and says what the tab does for the teaching session's actions.

A tab's adapter owns the subscribers and publishers only that tab needs; it lives in the worker's thread (the
worker adopts it) and speaks to its widgets only through its own signals, queued into the GUI thread. The worker
calls these hooks from its thread: ``start`` and ``stop`` once, ``tab_changed`` on every change of the active tab,
``tick`` at ``publish_rate`` while the adapter's tab is active and commands a stiffness, ``on_arm`` with every
/cartesian_pose while its tab is active and ``hears_arm``.
"""

import dataclasses
from typing import Callable, Mapping, Optional

import numpy as np
from PyQt5.QtCore import QObject
from PyQt5.QtWidgets import QWidget


class TabAdapter(QObject):
    """Hooks with no effect; an adapter overrides those it needs.

    Attributes:
        tab: the index of its tab (teleteach.core.active_tab.Tab).
        hears_arm: while its tab is active the worker hears the arm (/cartesian_pose, /joint_states) and runs the
            stiffness stream (``tick``).
        hears_scene: while its tab is active the worker hears the perceived scene and TF (``worker.perception``).
    """

    hears_arm = False
    hears_scene = False

    def __init__(self, tab: int):
        super().__init__()
        self.tab = tab
        self.worker = None  # the RosWorker that hosts it, from start() on

    @property
    def active(self) -> bool:
        """Whether its tab is the active one (as the GUI thread set it last)."""
        return self.worker is not None and self.worker.active_tab == self.tab

    def start(self, worker) -> None:
        """Subscribe and advertise (worker thread)."""
        self.worker = worker

    def stop(self) -> None:
        """Unsubscribe and unadvertise (worker thread)."""

    def tab_changed(self, tab: int) -> None:
        """The active tab is now ``tab`` (worker thread)."""

    def tick(self) -> None:
        """One step of the stiffness stream, at publish_rate while the tab is active (worker thread)."""

    def on_arm(self, stamp: float, pose: np.ndarray) -> None:
        """The arm's /cartesian_pose (x y z qx qy qz qw, base frame), while the tab is active (a rospy thread)."""

    def measured_pose(self) -> Optional[np.ndarray]:
        """The arm's latest /cartesian_pose as the worker heard it, or None."""
        return None if self.worker is None else self.worker.arm.hand_pose()


@dataclasses.dataclass
class TabParts:
    """What a tab brings to the window: its package's ``build(window)`` returns it (teleteach.gui.app.TABS).

    Attributes:
        title: the tab's title.
        widget: its widgets, with an ``active`` attribute, an ``on_click(stamp)`` slot and, if it uses the device's
            position, ``on_device(sample)``; only the active tab receives them. ``show_device_lost(lost)`` if it says
            so.
        adapter: its ROS side, or None.
        actions: what it does for the teaching session's actions (teleteach.gui.session.Action).
    """

    title: str
    widget: QWidget
    adapter: Optional[TabAdapter] = None
    actions: Mapping[object, Callable[[], None]] = dataclasses.field(default_factory=dict)
