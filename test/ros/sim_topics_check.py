#!/usr/bin/env python3
"""rostest check of robot_sim's published topics, TF, and its base (move_base) and gripper (franka_gripper) actions."""

import math
import threading
import time
import unittest

import actionlib
import numpy as np
import rospy
import rostest
import tf2_ros
from actionlib_msgs.msg import GoalStatus, GoalStatusArray
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped, WrenchStamped
from move_base_msgs.msg import MoveBaseAction, MoveBaseGoal
from sensor_msgs.msg import JointState
from visualization_msgs.msg import MarkerArray

from teleteach.core.observed import observed_from_markers
from teleteach.core.scene import load_scene
from teleteach.msg import (
    GraspAction,
    GraspEpsilon,
    GraspGoal,
    HomingAction,
    HomingGoal,
    MoveAction,
    MoveGoal,
    StopAction,
    StopGoal,
)
from teleteach.sim.robot_sim import load_controller_config


def client(name, action):
    """A SimpleActionClient whose server is up."""
    made = actionlib.SimpleActionClient(name, action)
    assert made.wait_for_server(rospy.Duration(60.0)), f"no {name}"
    return made


def base_goal(x, frame="world"):
    goal = MoveBaseGoal()
    goal.target_pose.header.frame_id = frame
    goal.target_pose.header.stamp = rospy.Time.now()
    goal.target_pose.pose.position.x = x
    goal.target_pose.pose.orientation.w = 1.0
    return goal


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
    def test_action_status_is_a_heartbeat_at_the_configured_wall_rate(self):
        # actionlib's own timer would send 5 a second, on simulated time (here many times faster than the wall)
        rate = load_controller_config()["simulation"]["action_status_rate"]
        arrivals = []
        rospy.Subscriber("/move_base/status", GoalStatusArray, lambda message: arrivals.append(time.monotonic()))
        client("/move_base", MoveBaseAction)
        time.sleep(1.5)  # past the latched status a new subscriber gets at once
        start = time.monotonic()
        time.sleep(5.0)
        count = sum(start <= arrival < start + 5.0 for arrival in arrivals)
        print(f"/move_base/status: {count} messages in 5 s of wall time (configured {rate} Hz)")
        self.assertTrue(0.5 * 5.0 * rate <= count <= 1.5 * 5.0 * rate + 1, count)

    def test_topics_tf_and_commands(self):
        pose = Latest("/cartesian_pose", PoseStamped)
        joints = Latest("/joint_states", JointState)
        scene = Latest("/teleteach/scene", MarkerArray)
        truth = Latest("/teleteach/true_scene", MarkerArray)
        base_error = Latest("/robot_sim/base_error", PoseStamped)
        wrench = Latest("/force_torque_ext", WrenchStamped)
        diagnostics = Latest("/diagnostics", DiagnosticArray)
        tf_buffer = tf2_ros.Buffer()
        tf2_ros.TransformListener(tf_buffer)
        move_base = client("/move_base", MoveBaseAction)
        gripper = {
            name: client(f"/franka_gripper/{name}", action)
            for name, action in (
                ("move", MoveAction),
                ("grasp", GraspAction),
                ("homing", HomingAction),
                ("stop", StopAction),
            )
        }
        pose.wait()
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
        # ... and read as the skills read it (teleteach.perception): every product, both gaps, the pick table
        perceived, rejected = observed_from_markers(markers)
        self.assertEqual(rejected, [])
        self.assertEqual(set(perceived.products), products)
        file_scene = load_scene()
        self.assertEqual(sorted(perceived.gaps), sorted(file_scene.gaps))
        self.assertEqual(list(perceived.tables), ["pick_table"])
        # ... with perception's errors (config/uncertainty.yaml), while /teleteach/true_scene has the world as it is
        actual, rejected = observed_from_markers(truth.wait().markers)
        self.assertEqual(rejected, [])
        self.assertEqual(set(actual.products), products)
        for name, gap in file_scene.gaps.items():
            self.assertEqual(actual.gaps[name].position, gap.position)
            offset = np.linalg.norm(np.subtract(perceived.gaps[name].position, gap.position))
            self.assertTrue(0.0 < offset < 0.02, f"{name} perceived {1000 * offset:.1f} mm off")
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

        # /move_base: TF world -> base_link drives there at <= 0.5 m/s, with feedback, and the goal succeeds there
        feedback = []
        started = rospy.Time.now()
        move_base.send_goal(base_goal(1.0), feedback_cb=lambda message: feedback.append(message.base_position))
        rospy.sleep(1.0)
        moved = tf_buffer.lookup_transform("world", "base_link", rospy.Time(0), rospy.Duration(5.0))
        elapsed = (moved.header.stamp - started).to_sec()
        self.assertGreater(moved.transform.translation.x, 0.2)
        self.assertLessEqual(moved.transform.translation.x, 0.5 * elapsed + 0.02)
        self.assertTrue(move_base.wait_for_result(rospy.Duration(10.0)))
        self.assertEqual(move_base.get_state(), GoalStatus.SUCCEEDED)
        rospy.sleep(0.3)  # TF reaches this listener a little after the result
        arrived = tf_buffer.lookup_transform("world", "base_link", rospy.Time(0), rospy.Duration(5.0))
        # Expect: it stopped near the goal, off by the error robot_sim drew and announced (config/uncertainty.yaml)
        error = base_error.wait().pose.position
        self.assertEqual(base_error.message.header.frame_id, "move_base_goal")
        self.assertTrue(0.0 < math.hypot(error.x, error.y) <= 0.03, (error.x, error.y))
        self.assertAlmostEqual(arrived.transform.translation.x, 1.0 + error.x, places=3)
        self.assertAlmostEqual(arrived.transform.translation.y, error.y, places=3)
        self.assertTrue(feedback and all(0.0 <= f.pose.position.x <= 1.0 for f in feedback), feedback[-1:])
        self.assertEqual(feedback[-1].header.frame_id, "world")
        # cancelled on the way back, the base stops where it is; a goal in another frame is aborted, saying why
        move_base.send_goal(base_goal(0.0))
        rospy.sleep(1.0)
        move_base.cancel_goal()
        self.assertTrue(move_base.wait_for_result(rospy.Duration(10.0)))
        self.assertEqual(move_base.get_state(), GoalStatus.PREEMPTED)
        rospy.sleep(0.3)
        stopped = tf_buffer.lookup_transform("world", "base_link", rospy.Time(0), rospy.Duration(5.0))
        rospy.sleep(1.0)
        later = tf_buffer.lookup_transform("world", "base_link", rospy.Time(0), rospy.Duration(5.0))
        self.assertTrue(0.2 < stopped.transform.translation.x < 0.8, stopped.transform.translation.x)
        self.assertAlmostEqual(later.transform.translation.x, stopped.transform.translation.x, places=2)
        move_base.send_goal(base_goal(2.0, frame="base_link"))
        self.assertTrue(move_base.wait_for_result(rospy.Duration(10.0)))
        self.assertEqual(move_base.get_state(), GoalStatus.ABORTED)
        self.assertIn("frame 'base_link' is wrong", move_base.get_goal_status_text())

        # /franka_gripper/move: both fingers go to half the width; the result says success
        gripper["move"].send_goal(MoveGoal(width=0.02, speed=0.1))
        self.assertTrue(gripper["move"].wait_for_result(rospy.Duration(10.0)))
        self.assertTrue(gripper["move"].get_result().success, gripper["move"].get_result().error)
        rospy.sleep(0.2)
        with joints.lock:
            fingers = joints.message.position[7:]
        np.testing.assert_allclose(fingers, [0.01, 0.01], atol=1e-3)
        # /franka_gripper/homing opens fully; a grasp on nothing closes and fails (judged from the width, as
        # franka_gripper does: the goal succeeds, its result does not)
        gripper["homing"].send_goal(HomingGoal())
        self.assertTrue(gripper["homing"].wait_for_result(rospy.Duration(10.0)))
        self.assertTrue(gripper["homing"].get_result().success)
        grasp = GraspGoal(width=0.05, epsilon=GraspEpsilon(inner=0.005, outer=0.005), speed=0.1, force=20.0)
        gripper["grasp"].send_goal(grasp)
        self.assertTrue(gripper["grasp"].wait_for_result(rospy.Duration(10.0)))
        self.assertEqual(gripper["grasp"].get_state(), GoalStatus.SUCCEEDED)
        self.assertFalse(gripper["grasp"].get_result().success)
        self.assertIn("outside [0.0450, 0.0550] m", gripper["grasp"].get_result().error)
        # /franka_gripper/stop ends a slow move half-way: the move's result is unsuccessful, the fingers stay
        gripper["move"].send_goal(MoveGoal(width=0.08, speed=0.01))
        rospy.sleep(1.0)
        gripper["stop"].send_goal(StopGoal())
        self.assertTrue(gripper["stop"].wait_for_result(rospy.Duration(10.0)))
        self.assertTrue(gripper["stop"].get_result().success)
        self.assertTrue(gripper["move"].wait_for_result(rospy.Duration(10.0)))
        self.assertFalse(gripper["move"].get_result().success)
        self.assertIn("stopped", gripper["move"].get_result().error)
        with joints.lock:
            stopped_width = sum(joints.message.position[7:])
        rospy.sleep(0.5)
        with joints.lock:
            self.assertAlmostEqual(sum(joints.message.position[7:]), stopped_width, places=3)
        self.assertLess(stopped_width, 0.03)


if __name__ == "__main__":
    rospy.init_node("sim_topics_check")
    rostest.rosrun("teleteach", "sim_topics_check", SimTopics)
