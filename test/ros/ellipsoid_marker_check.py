#!/usr/bin/env python3
"""rostest check of the ellipsoid marker node: placement, size and orientation, rejection of bad messages, and the end
effector's pose heard only while the marker is viewed."""

import math
import time
import unittest

import rosgraph
import rospy
import rostest
from geometry_msgs.msg import PoseStamped, QuaternionStamped, Vector3Stamped
from visualization_msgs.msg import Marker


class EllipsoidMarkerNode(unittest.TestCase):
    def setUp(self):
        self.markers = []
        self.viewer = rospy.Subscriber("/visualization_marker", Marker, self.markers.append)
        self.eigenvalues = rospy.Publisher("/eigenvalues", Vector3Stamped, queue_size=10)
        self.eigenvectors = rospy.Publisher("/eigenvectors", QuaternionStamped, queue_size=10)
        self.pose = rospy.Publisher("/cartesian_pose", PoseStamped, queue_size=10)
        self.wait_for(
            lambda: all(p.get_num_connections() for p in (self.eigenvalues, self.eigenvectors, self.pose)),
            "the node to subscribe",
        )

    def tearDown(self):
        self.viewer.unregister()

    def wait_for(self, condition, what, timeout=20.0):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if condition():
                return
            time.sleep(0.05)
        self.fail(f"timed out waiting for {what}")

    def send(self, values=None, quaternion=None, position=None):
        if values is not None:
            message = Vector3Stamped()
            message.header.frame_id = "base_link"
            message.vector.x, message.vector.y, message.vector.z = values
            self.eigenvalues.publish(message)
        if quaternion is not None:
            message = QuaternionStamped()
            message.header.frame_id = "base_link"
            q = message.quaternion
            q.x, q.y, q.z, q.w = quaternion
            self.eigenvectors.publish(message)
        if position is not None:
            message = PoseStamped()
            message.header.frame_id = "base_link"
            message.pose.position.x, message.pose.position.y, message.pose.position.z = position
            message.pose.orientation.w = 1.0
            self.pose.publish(message)

    def latest_scale(self):
        return (self.markers[-1].scale.x, self.markers[-1].scale.y, self.markers[-1].scale.z) if self.markers else None

    def test_marker_follows_good_input_and_keeps_the_last_good_one(self):
        yaw45 = (0.0, 0.0, math.sin(math.pi / 8), math.cos(math.pi / 8))
        self.send((500.0, 1000.0, 3000.0), yaw45, (0.5, -0.1, 0.7))
        # Expect 2e-4 m per N/m (launch param), clamped at 0.5 m: 0.1, 0.2, 0.5 m
        self.wait_for(lambda: self.latest_scale() == (0.1, 0.2, 0.5), "the first marker")
        marker = self.markers[-1]
        self.assertEqual((marker.type, marker.action, marker.header.frame_id), (Marker.SPHERE, Marker.ADD, "base_link"))
        self.assertEqual((marker.pose.position.x, marker.pose.position.y, marker.pose.position.z), (0.5, -0.1, 0.7))
        self.assertAlmostEqual(marker.pose.orientation.z, math.sin(math.pi / 8))
        # Bad messages: NaN and negative stiffness, zero and non-unit quaternions, NaN position
        self.send(values=(float("nan"), 100.0, 100.0))
        self.send(values=(100.0, -5.0, 100.0), quaternion=(0.0, 0.0, 0.0, 0.0), position=(float("nan"), 0.0, 0.0))
        self.send(quaternion=(0.0, 0.0, 0.5, 0.5))
        # Expect the last good ellipsoid, unchanged: nothing new is drawn (the node looks at it 30 times a second)
        count = len(self.markers)
        time.sleep(1.0)
        self.assertEqual(len(self.markers), count, "a marker was published although nothing good changed")
        marker = self.markers[-1]
        self.assertEqual(self.latest_scale(), (0.1, 0.2, 0.5))
        self.assertAlmostEqual(marker.pose.orientation.z, math.sin(math.pi / 8))
        self.assertEqual(marker.pose.position.x, 0.5)
        # A good message is taken again
        self.send(values=(250.0, 250.0, 250.0), position=(0.6, 0.0, 0.5))
        self.wait_for(lambda: self.latest_scale() == (0.05, 0.05, 0.05), "the marker to follow good input again")
        self.wait_for(lambda: self.markers[-1].pose.position.x == 0.6, "the marker to follow the end effector")

    def test_a_display_that_starts_later_gets_the_marker(self):
        self.send((500.0, 500.0, 500.0), (0.0, 0.0, 0.0, 1.0), (0.4, 0.0, 0.6))
        self.wait_for(lambda: self.markers and self.markers[-1].pose.position.x == 0.4, "a marker")
        # Expect the latched marker for a new subscriber, without any change of the input
        late = []
        subscriber = rospy.Subscriber("/visualization_marker", Marker, late.append)
        self.wait_for(lambda: late, "the marker for the late subscriber", timeout=5.0)
        self.assertEqual(late[-1].pose.position.x, 0.4)
        subscriber.unregister()

    def test_the_pose_is_heard_only_while_someone_views_the_marker(self):
        self.send((500.0, 500.0, 500.0), (0.0, 0.0, 0.0, 1.0), (0.4, 0.0, 0.6))
        self.wait_for(lambda: self.markers and self.markers[-1].pose.position.x == 0.4, "a marker")
        self.viewer.unregister()
        # Expect the node to leave /cartesian_pose within its 1 s look at the master, and the stiffness kept
        self.wait_for(lambda: not self.pose_heard(), "the node to stop hearing the pose", timeout=5.0)
        self.assertTrue(self.subscribers("/eigenvalues") and self.subscribers("/eigenvectors"))
        self.send(values=(1000.0, 1000.0, 1000.0))
        # A display that comes back: the pose is heard again within the next look, and the marker follows it
        self.viewer = rospy.Subscriber("/visualization_marker", Marker, self.markers.append)
        self.wait_for(self.pose_heard, "the node to hear the pose again", timeout=2.0)
        self.wait_for(lambda: self.pose.get_num_connections(), "the pose's connection", timeout=5.0)
        self.send(position=(0.7, 0.0, 0.6))
        self.wait_for(lambda: self.markers[-1].pose.position.x == 0.7, "the marker to follow the pose again")
        self.assertEqual(self.latest_scale(), (0.2, 0.2, 0.2))

    def subscribers(self, topic):
        _, subscriptions, _ = rosgraph.Master(rospy.get_name()).getSystemState()
        return next((nodes for name, nodes in subscriptions if name == topic), [])

    def pose_heard(self):
        return "/ellipsoid_marker" in self.subscribers("/cartesian_pose")


if __name__ == "__main__":
    rospy.init_node("ellipsoid_marker_check")
    rostest.rosrun("teleteach", "ellipsoid_marker_check", EllipsoidMarkerNode)
