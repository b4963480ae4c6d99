#!/usr/bin/env python3
"""rostest check of stiffness_bridge: what franka_human_friendly_controllers would receive on /stiffness for the GUI's
/eigenvalues and /eigenvectors, and bad messages rejected (logged on /rosout, nothing sent, the node still bridging)."""

import math
import threading
import unittest

import numpy as np
import rospy
import rostest
from geometry_msgs.msg import QuaternionStamped, Vector3Stamped
from rosgraph_msgs.msg import Log
from std_msgs.msg import Float32MultiArray


class Bridge:
    """Publishes the eigen topics; keeps every /stiffness message and the bridge's log lines."""

    def __init__(self):
        self.lock = threading.Condition()
        self.received, self.logs = [], []
        stiffness = rospy.Subscriber("/stiffness", Float32MultiArray, self._on_stiffness)
        rosout = rospy.Subscriber("/rosout", Log, self._on_log)
        self.eigenvalues = rospy.Publisher("/eigenvalues", Vector3Stamped, queue_size=10)
        self.eigenvectors = rospy.Publisher("/eigenvectors", QuaternionStamped, queue_size=10)
        # both directions connected first: a /stiffness sent before this node hears the bridge would be lost
        for endpoint in (self.eigenvalues, self.eigenvectors, stiffness, rosout):
            while endpoint.get_num_connections() == 0 and not rospy.is_shutdown():
                rospy.sleep(0.05)

    def _on_stiffness(self, msg):
        with self.lock:
            self.received.append(list(msg.data))
            self.lock.notify_all()

    def _on_log(self, msg):
        if msg.name == "/stiffness_bridge":
            with self.lock:
                self.logs.append(msg.msg)
                self.lock.notify_all()

    def send_values(self, x, y, z, frame="base_link"):
        message = Vector3Stamped()
        message.header.frame_id = frame
        message.vector.x, message.vector.y, message.vector.z = x, y, z
        self.eigenvalues.publish(message)

    def send_vectors(self, x, y, z, w, frame="base_link"):
        message = QuaternionStamped()
        message.header.frame_id = frame
        q = message.quaternion
        q.x, q.y, q.z, q.w = x, y, z, w
        self.eigenvectors.publish(message)

    def wait(self, what, count, timeout=10.0):
        """Wait up to timeout [s] until `what` (received or logs) holds count entries; return them (fewer: too late)."""
        with self.lock:
            self.lock.wait_for(lambda: len(getattr(self, what)) >= count, timeout=timeout)
            return list(getattr(self, what))

    def wait_for_log(self, text, timeout=10.0):
        """Wait up to timeout [s] until a log line contains text; return all lines (none with it: too late)."""
        with self.lock:
            self.lock.wait_for(lambda: any(text in line for line in self.logs), timeout=timeout)
            return list(self.logs)


class StiffnessBridgeTest(unittest.TestCase):
    def test_stiffness_reaches_the_controller_and_bad_messages_do_not(self):
        bridge = Bridge()
        half = math.sqrt(0.5)
        # Expect nothing until both topics have spoken, then the diagonal of V Sigma V^T: turned a quarter about z,
        # the ellipsoid's y (3000 N/m) lies along base x; rotational 30 Nm/rad; nullspace 0.5 (config)
        # (sent again until /stiffness comes: our subscription counts its connection before the bridge's publisher
        # has taken it, and what the bridge sends meanwhile is lost; a fresh run saw nothing in 10 s)
        pairs, received = 0, []
        while not received and pairs < 10:
            bridge.send_values(1000.0, 3000.0, 2000.0)
            bridge.send_vectors(0.0, 0.0, half, half)
            pairs += 1
            received = bridge.wait("received", 1, timeout=1.0)
        while len(received) < len(more := bridge.wait("received", len(received) + 1, timeout=1.0)):
            received = more  # the later pairs' /stiffness, until none for 1 s
        self.assertGreaterEqual(len(received), 1)
        if pairs == 1:  # the eigenvalues alone sent nothing (after more pairs the first one's may have been lost)
            self.assertEqual(len(received), 1)
        for values in received:
            np.testing.assert_allclose(values, [3000.0, 1000.0, 2000.0, 30.0, 30.0, 30.0, 0.5], atol=1e-3)
        good = len(received)
        # Expect: NaN, a negative stiffness, a zero quaternion and another frame are each rejected with a log line,
        # nothing is sent for them, and the next good message is bridged
        # (the bridge logs one rejection per second at most, and two topics' callbacks run in no fixed order: each
        # checked rejection is sent alone, after the period; the NaN again until its line arrives over /rosout)
        for _ in range(8):
            bridge.send_values(math.nan, 1.0, 1.0)
            if bridge.wait("logs", 1, timeout=1.2):
                break
        rospy.sleep(1.2)
        bridge.send_values(1.0, -5.0, 1.0)
        bridge.wait_for_log("negative stiffness", timeout=5.0)
        rospy.sleep(1.2)
        bridge.send_vectors(0.0, 0.0, 0.0, 0.0)
        bridge.wait_for_log("eigenvectors is zero", timeout=5.0)
        rospy.sleep(1.2)
        bridge.send_values(1.0, 1.0, 1.0, frame="world")
        logs = bridge.wait_for_log("frame 'world' is wrong", timeout=5.0)
        bridge.send_values(500.0, 600.0, 700.0)
        received = bridge.wait("received", good + 1)
        self.assertEqual(len(received), good + 1, received)  # nothing for the four rejected messages
        np.testing.assert_allclose(received[good][:3], [600.0, 500.0, 700.0], atol=1e-3)
        rejections = [line for line in logs if "rejected" in line]
        # Expect each of the four rejections logged, on its topic, with its reason
        for said in (
            "on eigenvalues: eigenvalues contains NaN or inf",
            "on eigenvalues: negative stiffness: [1.0, -5.0, 1.0] N/m",
            "on eigenvectors: eigenvectors is zero",
            "on eigenvalues: frame 'world' is wrong",
        ):
            self.assertTrue(any(said in line for line in rejections), (said, logs))
        # Expect: a turned ellipsoid (45 degrees about z) sends its diagonal and says what the controller cannot take
        bridge.send_vectors(0.0, 0.0, math.sin(math.pi / 8), math.cos(math.pi / 8))
        received = bridge.wait("received", good + 2)
        np.testing.assert_allclose(received[good + 1][:3], [550.0, 550.0, 700.0], atol=1e-3)
        logs = bridge.wait_for_log("50 N/m off the diagonal")
        self.assertTrue(any("50 N/m off the diagonal" in line for line in logs), logs)
        self.assertFalse(any("bad callback" in line for line in logs), logs)
        self.assertTrue(all(len(values) == 7 for values in received))


if __name__ == "__main__":
    rospy.init_node("stiffness_bridge_check")
    rostest.rosrun("teleteach", "stiffness_bridge_check", StiffnessBridgeTest)
