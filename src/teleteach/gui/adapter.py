"""What a tab's ROS side (its ``ros.py``) offers the worker that hosts it: the one interface, without rospy.

A tab's adapter owns the subscribers and publishers only that tab needs; it lives in the worker's thread (the
worker adopts it) and speaks to its widgets only through its own signals, queued into the GUI thread. The worker
calls these hooks from its thread: ``start`` and ``stop`` once, ``tab_changed`` on every change of the active tab,
``tick`` at ``publish_rate`` while the adapter's tab is active and commands a stiffness, ``on_arm`` with every
/cartesian_pose while its tab is active and ``hears_arm``.
"""

from typing import Optional

import numpy as np
from PyQt5.QtCore import QObject


class TabAdapter(QObject):
    """Hooks with no effect; an adapter overrides those it needs.

    Attributes:
        tab: the index of its tab (teleteach.core.active_tab.Tab).
        hears_arm: while its tab is active the worker hears the arm (/cartesian_pose, /joint_states) and runs the
            stiffness stream (``tick``).
    """

    hears_arm = False

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
        return None if self.worker is None else self.worker.hand_pose()
