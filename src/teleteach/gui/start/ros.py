"""The START tab's ROS side (the operator's correction of a replayed skill) and its place in the window.

A click in the centre starts a tree that waits for its start; elsewhere it opens the mode chosen. While a skill
replays (skills/authority), the clutch and the handle correct it and the tab shows who leads.

ROS Subscribers: skills/authority.
ROS Publishers: skills/correction (while START is active and a skill replays).
The tree's execution (behaviour_tree/execution) is the worker's: the window's session needs it in every tab.
"""

import math
import time
from typing import Optional

import numpy as np
import rospy
from geometry_msgs.msg import Vector3Stamped
from PyQt5.QtCore import Qt, pyqtSignal

from teleteach.core.active_tab import Tab
from teleteach.core.gui_config import GuiConfig
from teleteach.core.teleoperation import ReplayCorrection
from teleteach.gui.adapter import TabAdapter, TabParts
from teleteach.gui.start.view import AuthorityView, StartTab
from teleteach.msg import SkillAuthority
from teleteach.runtime.node import publish, server_value


class StartRos(TabAdapter):
    """The correction of a replayed skill, driven by its reports (20 Hz while it replays: no timer otherwise)."""

    authority = pyqtSignal(object)  # AuthorityView: who leads the skill the robot replays (skills/authority)

    def __init__(self, config: GuiConfig):
        super().__init__(Tab.START)
        self.config = config
        self.correction = ReplayCorrection(config.teleop)
        self._subscriber: Optional[rospy.Subscriber] = None
        self._publisher: Optional[rospy.Publisher] = None

    def start(self, worker) -> None:
        """The correction's publisher, the authority's subscriber."""
        super().start(worker)
        self._publisher = rospy.Publisher("skills/correction", Vector3Stamped, queue_size=5)
        self._subscriber = rospy.Subscriber(
            "skills/authority", SkillAuthority, self._on_authority, queue_size=5, tcp_nodelay=True
        )

    def stop(self) -> None:
        """Neither any more."""
        self._subscriber.unregister()
        self._publisher.unregister()

    def _on_authority(self, message: SkillAuthority) -> None:
        """A skill replays: in START the clutch and handle correct it (skills/correction), and START shows who leads."""
        if not self.active:
            return  # a teaching tab pauses the tree: its replay is ending, and the handle is the tab's
        device = self.worker.device_pose()
        age = math.inf if device is None else time.monotonic() - device[2]
        now = rospy.get_time()
        command = self.correction.update(
            now,
            message.skill,
            message.max_correction,
            self.worker.gripper_angle,
            device and device[:2],
            age,
            self.config.device_timeout,
        )
        if command is None:
            return
        correction = Vector3Stamped()
        correction.header.stamp, correction.header.frame_id = rospy.Time.from_sec(now), self.config.base_frame
        correction.vector.x, correction.vector.y, correction.vector.z = (float(value) for value in command.pose[:3])
        publish(self._publisher, correction)
        applied = message.correction
        moved = float(np.linalg.norm([applied.x, applied.y, applied.z]))
        self.authority.emit(
            AuthorityView(
                message.skill, message.confidence, message.operator_weight, moved, command.clutch, command.reason
            )
        )


def build(window) -> TabParts:
    """START in ``window``."""
    view = StartTab(window.config)
    view.show_device(server_value("sigma7_node/backend", ""))  # set by device.launch before any node starts
    adapter = StartRos(window.config)
    adapter.authority.connect(view.show_authority, Qt.QueuedConnection)
    view.start_requested.connect(lambda: window.carry_out(window.session.start_requested()))
    view.mode_chosen.connect(window.tabs.setCurrentIndex)
    view.mode_chosen.connect(lambda tab: window.topics.send_selection(Tab.START, "mode", Tab(tab).name))
    return TabParts(Tab.START.title, view, adapter)
