"""The arm as the GUI hears it in the tabs that command a stiffness: /cartesian_pose and /joint_states.

/cartesian_pose (200 Hz) is recorded with the stiffness and drawn as the arm's trail in SHARED CONTROL;
/joint_states tells when the arm rests, before the impedance controller takes it.
"""

import math
import time
from typing import Callable, Optional, Tuple

import numpy as np
import rospy
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import JointState

from teleteach.core.gui_config import GuiConfig
from teleteach.msg import TreeExecution


def pose_to_array(pose) -> np.ndarray:
    """(x, y, z, qx, qy, qz, qw) of a geometry_msgs/Pose."""
    p, q = pose.position, pose.orientation
    return np.array([p.x, p.y, p.z, q.x, q.y, q.z, q.w])


class ArmListener:
    """The arm's topics while ``listen(True)``; ``heard(stamp, pose)`` gets each finite /cartesian_pose."""

    def __init__(self, config: GuiConfig, heard: Callable[[float, np.ndarray], None]):
        self.config = config
        self._heard = heard
        self._pose: Optional[rospy.Subscriber] = None
        self._joints: Optional[rospy.Subscriber] = None
        self.measured: Optional[Tuple[float, np.ndarray]] = None  # the arm's latest /cartesian_pose: (stamp, pose)
        self._motion: Tuple[float, float] = (-math.inf, math.inf)  # (when, fastest joint speed [rad/s])

    def listen(self, hearing: bool) -> None:
        """Subscribe (worker thread), or unsubscribe and forget the arm."""
        if hearing and self._pose is None:
            self._pose = rospy.Subscriber(
                "cartesian_pose", PoseStamped, self._on_cartesian, queue_size=5, tcp_nodelay=True
            )
            self._joints = rospy.Subscriber(
                "joint_states", JointState, self._on_joint_states, queue_size=5, tcp_nodelay=True
            )
        elif not hearing:
            for subscriber in (self._pose, self._joints):
                if subscriber is not None:
                    subscriber.unregister()
            self._pose = self._joints = None
            self.measured = None  # a recording must not start from where the arm was in another tab
            self._motion = (-math.inf, math.inf)  # nor an arm count as resting on what it did back then

    def _on_cartesian(self, message: PoseStamped) -> None:
        pose = pose_to_array(message.pose)
        if not np.all(np.isfinite(pose)):
            return
        stamp = message.header.stamp.to_sec() or rospy.get_time()
        self.measured = (stamp, pose)
        self._heard(stamp, pose)

    def _on_joint_states(self, message: JointState) -> None:
        speeds = [abs(value) for value in message.velocity if math.isfinite(value)]
        self._motion = (time.monotonic(), max(speeds, default=0.0))

    def hand_pose(self) -> Optional[np.ndarray]:
        """The arm's latest /cartesian_pose (x y z qx qy qz qw, base_link), or None before the first."""
        measured = self.measured
        return None if measured is None else measured[1].copy()

    def free(self, tree: Optional[rospy.Subscriber], execution: Optional[TreeExecution]) -> Tuple[bool, str]:
        """Whether the impedance controller may take the arm now, and if not, why not.

        Free means: the behaviour tree (if one runs: ``tree``, its teleteach/TreeExecution subscriber, and its last
        ``execution``) reports no skill goal out, and the arm (if /joint_states is published) rests: every joint
        slower than ``arm_rest_speed`` in a message younger than ``device_timeout``. A publisher the master knows but
        this GUI is not connected to yet counts as there (it is on its way).
        """
        joints = self._joints
        if tree is None or joints is None:
            return False, "the GUI's subscribers are starting"
        published = None
        if tree.get_num_connections() == 0 or joints.get_num_connections() == 0:
            try:
                published = {name for name, _ in rospy.get_published_topics()}
            except (OSError, rospy.ROSException):
                return False, "the ROS master does not answer"
        if published is not None and tree.resolved_name in published and tree.get_num_connections() == 0:
            return False, "connecting to the behaviour tree"
        if published is not None and joints.resolved_name in published and joints.get_num_connections() == 0:
            return False, "connecting to /joint_states"
        if tree.get_num_connections() > 0:
            if execution is None:
                return False, "waiting for the behaviour tree's state"
            if execution.state not in (TreeExecution.PAUSED, TreeExecution.WAITING, TreeExecution.COMPLETED):
                return False, f"the tree still drives the arm ({execution.message})"
        if joints.get_num_connections() > 0:
            seen, speed = self._motion
            if time.monotonic() - seen > self.config.device_timeout:
                return False, "waiting for /joint_states"
            if speed >= self.config.arm_rest_speed:
                return False, f"the arm still moves ({speed:.2f} rad/s)"
        return True, ""
