#!/usr/bin/env python3
"""rostest check of the sigma7 node playing test/ros/sigma7_scenario.yaml: values at the keyframes, twist on a
linear segment, gripper, and exactly one rising edge on /sigma7/button for the one scripted flick."""

import bisect
import math
import threading
import time
import unittest

import numpy as np
import rospy
import rostest
import yaml
from geometry_msgs.msg import PoseStamped, TwistStamped
from std_msgs.msg import Bool, Float64

TAIL = 0.3  # [s] of scenario time received after the last keyframe before checking


def rotation_matrix(roll, pitch, yaw):
    """R = Rz(yaw) Ry(pitch) Rx(roll), written out here instead of taken from the code under test."""
    cr, sr, cp, sp = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    return rz @ ry @ rx


def quaternion_matrix(x, y, z, w):
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def rotation_angle(first, second):
    return math.acos(max(-1.0, min(1.0, (np.trace(first.T @ second) - 1.0) / 2.0)))


class Sigma7Scenario(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("sigma7_check")
        with open(rospy.get_param("~scenario")) as stream:
            cls.keyframes = yaml.safe_load(stream)["keyframes"]
        cls.lock = threading.Lock()
        cls.poses, cls.twists, cls.grippers, cls.buttons = [], [], [], []
        rospy.Subscriber("/sigma7/pose", PoseStamped, cls.store(cls.poses, lambda msg: msg))
        rospy.Subscriber("/sigma7/twist", TwistStamped, cls.store(cls.twists, lambda msg: msg))
        rospy.Subscriber("/sigma7/gripper_angle", Float64, cls.store(cls.grippers, lambda msg: msg.data))
        rospy.Subscriber("/sigma7/button", Bool, cls.store(cls.buttons, lambda msg: msg.data))
        start_param = rospy.get_param("~start_param")
        cls.wait_for(lambda: rospy.has_param(start_param), "the scenario start time")
        cls.start = rospy.get_param(start_param)
        end = keyframes_end = cls.keyframes[-1]["t"] + TAIL
        cls.wait_for(lambda: cls.poses and cls.scenario_time(cls.poses[-1][1]) > end, f"{keyframes_end} s of poses")
        time.sleep(0.5)  # the other topics' last messages of the same cycles
        with cls.lock:
            cls.pose_stamps = [pose.header.stamp.to_sec() - cls.start for _, pose in cls.poses]

    @classmethod
    def store(cls, into, convert):
        def callback(msg):
            with cls.lock:
                into.append((rospy.get_time(), convert(msg)))

        return callback

    @classmethod
    def scenario_time(cls, pose):
        return pose.header.stamp.to_sec() - cls.start

    @staticmethod
    def wait_for(condition, what, timeout=60.0):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline and not rospy.is_shutdown():
            if condition():
                return
            time.sleep(0.05)
        raise AssertionError(f"timed out waiting for {what}")

    def nearest_pose(self, scenario_time):
        index = bisect.bisect_left(self.pose_stamps, scenario_time)
        candidates = [i for i in (index - 1, index) if 0 <= i < len(self.pose_stamps)]
        best = min(candidates, key=lambda i: abs(self.pose_stamps[i] - scenario_time))
        return self.pose_stamps[best] - scenario_time, self.poses[best][1].pose

    def test_subscribed_before_the_motion_started(self):
        self.assertLess(self.pose_stamps[0], self.keyframes[1]["t"], "the checker subscribed too late")

    def test_poses_stream_in_order_through_the_scenario(self):
        # Expect one pose per cycle in stamp order, from before the motion to its end (the 1 kHz rate itself is
        # measured by bench/sigma7.py: wall-clock rates are no test on a shared machine)
        stamps = self.pose_stamps
        self.assertTrue(all(later > earlier for earlier, later in zip(stamps, stamps[1:])), "stamps out of order")
        self.assertGreater(stamps[-1], self.keyframes[-1]["t"])
        self.assertGreater(len(stamps), 10 * len(self.keyframes))

    def segment_speeds(self, index):
        """Largest linear [m/s] and angular [rad/s] speed on the segments next to keyframe `index` (both constant
        along a segment with linear interpolation and Slerp)."""
        linear, angular = 0.0, 0.0
        for first, second in ((index - 1, index), (index, index + 1)):
            if 0 <= first and second < len(self.keyframes):
                a, b = self.keyframes[first], self.keyframes[second]
                duration = b["t"] - a["t"]
                linear = max(linear, np.linalg.norm(np.subtract(b["position"], a["position"])) / duration)
                turn = rotation_angle(rotation_matrix(*a["rpy"]), rotation_matrix(*b["rpy"]))
                angular = max(angular, turn / duration)
        return linear, angular

    def test_pose_at_keyframes(self):
        checked = 0
        for index, keyframe in enumerate(self.keyframes):
            if keyframe["t"] < self.pose_stamps[0]:
                continue
            offset, pose = self.nearest_pose(keyframe["t"])
            self.assertLess(abs(offset), 0.05, f"no pose within 50 ms of keyframe {index}")
            # The pose nearest the keyframe is `offset` away from it: it may differ by at most speed * |offset|
            linear_speed, angular_speed = self.segment_speeds(index)
            position = [pose.position.x, pose.position.y, pose.position.z]
            distance = np.linalg.norm(np.subtract(position, keyframe["position"]))
            self.assertLessEqual(distance, linear_speed * abs(offset) + 1e-6, f"position at keyframe {index}")
            orientation = pose.orientation
            actual = quaternion_matrix(orientation.x, orientation.y, orientation.z, orientation.w)
            angle = rotation_angle(actual, rotation_matrix(*keyframe["rpy"]))
            self.assertLessEqual(angle, angular_speed * abs(offset) + 1e-6, f"orientation at keyframe {index}")
            checked += 1
        self.assertGreaterEqual(checked, len(self.keyframes) - 1)
        self.assertEqual(self.poses[-1][1].header.frame_id, "sigma7")

    def test_twist_on_the_linear_segment(self):
        # Keyframes 1 -> 2: 1 s of constant velocity; the 20 Hz filter has settled after 0.3 s
        first, second = self.keyframes[1], self.keyframes[2]
        duration = second["t"] - first["t"]
        expected_linear = (np.array(second["position"]) - np.array(first["position"])) / duration
        expected_angular = (np.array(second["rpy"]) - np.array(first["rpy"])) / duration  # yaw only: fixed axis z
        window = [
            twist.twist
            for _, twist in self.twists
            if first["t"] + 0.3 <= twist.header.stamp.to_sec() - self.start <= second["t"] - 0.02
        ]
        self.assertGreater(len(window), 100)
        for twist in window:
            np.testing.assert_allclose([twist.linear.x, twist.linear.y, twist.linear.z], expected_linear, atol=2e-3)
            np.testing.assert_allclose([twist.angular.x, twist.angular.y, twist.angular.z], expected_angular, atol=2e-2)

    def test_gripper_follows_the_keyframes_and_flicks_closed_once(self):
        angles = np.array([angle for _, angle in self.grippers])
        self.assertAlmostEqual(angles[-1], self.keyframes[-1]["gripper"], places=9)
        self.assertAlmostEqual(angles.max(), max(keyframe["gripper"] for keyframe in self.keyframes), places=9)
        self.assertLess(angles.min(), 0.01, "the scripted flick closes the gripper")
        resting = [angle for received, angle in self.grippers if received - self.start < self.keyframes[3]["t"] - 0.5]
        self.assertTrue(resting)
        np.testing.assert_allclose(resting, self.keyframes[0]["gripper"], atol=1e-9)

    def test_one_flick_gives_exactly_one_rising_edge(self):
        states = [state for _, state in self.buttons]
        edges = [
            received - self.start
            for (received, state), previous in zip(self.buttons[1:], states)
            if state and not previous
        ]
        self.assertFalse(states[0])
        self.assertEqual(len(edges), 1, f"rising edges at {edges} s")
        click = next(keyframe["t"] for keyframe in self.keyframes if keyframe.get("click"))
        self.assertGreater(edges[0], click)
        self.assertLess(edges[0], click + 1.0)


if __name__ == "__main__":
    rostest.rosrun("teleteach", "sigma7_check", Sigma7Scenario)
