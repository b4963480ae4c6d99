#!/usr/bin/env python3
"""rostest check of robot_sim's published topics, TF and the base and gripper commands."""

import math
import threading
import unittest

import numpy as np
import rospy
import rostest
import tf2_ros
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped, WrenchStamped
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64
from visualization_msgs.msg import MarkerArray


class Latest:
    """Keeps the last message and the receive count of a topic."""

    def __init__(self, topic, message_type):
        self.lock = threading.Lock()
        self.message, self.stamps = None, []
        rospy.Subscriber(topic, message_type, self._callback)

    def _callback(self, msg):
        with self.lock:
            self.message = msg
            if hasattr(msg, "header"):
                self.stamps.append(msg.header.stamp.to_sec())

    def wait(self, timeout=30.0):
        deadline = rospy.get_rostime() + rospy.Duration(timeout)
        while rospy.get_rostime() < deadline:
            with self.lock:
                if self.message is not None:
                    return self.message
            rospy.sleep(0.05)
        raise AssertionError("no message")


class SimTopics(unittest.TestCase):
    def test_topics_tf_and_commands(self):
        pose = Latest("/cartesian_pose", PoseStamped)
        joints = Latest("/joint_states", JointState)
        scene = Latest("/teleteach/scene", MarkerArray)
        wrench = Latest("/force_torque_ext", WrenchStamped)
        diagnostics = Latest("/diagnostics", DiagnosticArray)
        tf_buffer = tf2_ros.Buffer()
        tf2_ros.TransformListener(tf_buffer)
        base_goal = rospy.Publisher("/base/goal", PoseStamped, queue_size=1)
        gripper = rospy.Publisher("/gripper/command", Float64, queue_size=1)
        pose.wait()
        while base_goal.get_num_connections() == 0 or gripper.get_num_connections() == 0:
            rospy.sleep(0.05)
        rospy.sleep(1.0)

        # /cartesian_pose: base_link, >= 100 Hz of sim time
        with pose.lock:
            stamps = np.array(pose.stamps)
        recent = stamps[stamps > stamps[-1] - 0.5]
        self.assertGreaterEqual(len(recent) / 0.5, 100.0)
        self.assertEqual(pose.message.header.frame_id, "base_link")
        # /joint_states: the arm and both fingers
        self.assertEqual(
            joints.wait().name,
            [f"panda_joint{i}" for i in range(1, 8)] + ["panda_finger_joint1", "panda_finger_joint2"],
        )
        # /teleteach/scene: shelf boards and named products in world
        markers = scene.wait().markers
        self.assertTrue(all(m.header.frame_id == "world" for m in markers))
        self.assertGreaterEqual(len([m for m in markers if m.ns == "shelf"]), 2)
        products = {m.text for m in markers if m.ns == "products"}
        self.assertTrue({"product_pick_1", "product_pick_2", "product_shelf_1"} <= products)
        self.assertEqual(wrench.wait().header.frame_id, "base_link")
        status = diagnostics.wait().status[0]
        self.assertEqual(status.name, "robot_sim")
        self.assertIn("real_time_factor", [value.key for value in status.values])
        self.assertIn("base_link", rospy.get_param("/robot_description"))

        # robot_state_publisher's TF (from /robot_description and /joint_states) agrees with /cartesian_pose
        tcp = tf_buffer.lookup_transform("base_link", "panda_grasptarget", rospy.Time(0), rospy.Duration(10.0))
        reported = pose.message.pose.position
        t = tcp.transform.translation
        self.assertLess(math.dist([t.x, t.y, t.z], [reported.x, reported.y, reported.z]), 0.002)

        # /base/goal: TF world -> base_link drives there at <= 0.5 m/s
        goal = PoseStamped()
        goal.header.frame_id = "world"
        goal.header.stamp = rospy.Time.now()
        goal.pose.position.x, goal.pose.position.y = 1.0, 0.0
        goal.pose.orientation.w = 1.0
        started = rospy.Time.now()
        base_goal.publish(goal)
        rospy.sleep(1.0)
        moved = tf_buffer.lookup_transform("world", "base_link", rospy.Time(0), rospy.Duration(5.0))
        elapsed = (moved.header.stamp - started).to_sec()
        self.assertGreater(moved.transform.translation.x, 0.2)
        self.assertLessEqual(moved.transform.translation.x, 0.5 * elapsed + 0.02)
        rospy.sleep(2.5)
        arrived = tf_buffer.lookup_transform("world", "base_link", rospy.Time(0), rospy.Duration(5.0))
        self.assertAlmostEqual(arrived.transform.translation.x, 1.0, places=3)

        # /gripper/command: both fingers go to half the width
        gripper.publish(Float64(data=0.02))
        rospy.sleep(1.0)
        with joints.lock:
            fingers = joints.message.position[7:]
        np.testing.assert_allclose(fingers, [0.01, 0.01], atol=1e-3)


if __name__ == "__main__":
    rospy.init_node("sim_topics_check")
    rostest.rosrun("teleteach", "sim_topics_check", SimTopics)
