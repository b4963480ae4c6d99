#!/usr/bin/env python3
"""rostest check of robot_sim's controller manager and command validation over ROS."""

import math
import threading
import unittest

import actionlib
import numpy as np
import rospy
import rostest
from actionlib_msgs.msg import GoalStatus
from geometry_msgs.msg import PoseStamped, QuaternionStamped, Vector3Stamped
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from teleteach.msg import MoveAction, MoveGoal
from teleteach.srv import ListControllers, SwitchController, SwitchControllerRequest

IMPEDANCE = "cartesian_impedance_controller"
TRAJECTORY = "position_joint_trajectory_controller"
STRICT, BEST_EFFORT = SwitchControllerRequest.STRICT, SwitchControllerRequest.BEST_EFFORT
ARM = [f"panda_joint{i}" for i in range(1, 8)]


class Robot:
    """Records /cartesian_pose, /joint_states and ~rejected; sends commands."""

    def __init__(self):
        self.lock = threading.Lock()
        self.poses = []  # (sim time, position)
        self.pose_msg = None
        self.joints = None
        self.rejections = []
        rospy.Subscriber("/cartesian_pose", PoseStamped, self._on_pose)
        rospy.Subscriber("/joint_states", JointState, self._on_joints)
        rospy.Subscriber("/robot_sim/rejected", String, self._on_rejected)
        self.equilibrium = rospy.Publisher("/equilibrium_pose", PoseStamped, queue_size=10)
        self.eigenvalues = rospy.Publisher("/eigenvalues", Vector3Stamped, queue_size=10)
        self.eigenvectors = rospy.Publisher("/eigenvectors", QuaternionStamped, queue_size=10)
        self.trajectory = rospy.Publisher(
            "/position_joint_trajectory_controller/command", JointTrajectory, queue_size=10
        )
        self.gripper = actionlib.SimpleActionClient("/franka_gripper/move", MoveAction)
        assert self.gripper.wait_for_server(rospy.Duration(60)), "no /franka_gripper/move"
        rospy.wait_for_service("/controller_manager/switch_controller", timeout=60)
        self.switch = rospy.ServiceProxy("/controller_manager/switch_controller", SwitchController)
        self.list = rospy.ServiceProxy("/controller_manager/list_controllers", ListControllers)

    def _on_pose(self, msg):
        with self.lock:
            self.pose_msg = msg
            p = msg.pose.position
            self.poses.append((msg.header.stamp.to_sec(), np.array([p.x, p.y, p.z])))

    def _on_joints(self, msg):
        with self.lock:
            self.joints = dict(zip(msg.name, msg.position))

    def _on_rejected(self, msg):
        with self.lock:
            self.rejections.append(msg.data)

    def states(self):
        return {c.name: c.state for c in self.list().controller}

    def position(self):
        with self.lock:
            return self.poses[-1][1].copy()

    def max_motion(self, duration):
        """Largest distance [m] of the TCP from where it is now, over the next duration [s] of sim time."""
        start_time = rospy.Time.now().to_sec()
        start = self.position()
        rospy.sleep(duration)
        with self.lock:
            window = [p for t, p in self.poses if t >= start_time]
        return max(np.linalg.norm(p - start) for p in window)

    def wait_rejections(self, count, timeout=10.0):
        deadline = rospy.Time.now() + rospy.Duration(timeout)
        while rospy.Time.now() < deadline:
            with self.lock:
                if len(self.rejections) >= count:
                    return list(self.rejections)
            rospy.sleep(0.05)
        with self.lock:
            return list(self.rejections)


def pose_msg(position, quaternion, frame="base_link", stamp=None):
    msg = PoseStamped()
    msg.header.frame_id = frame
    msg.header.stamp = stamp if stamp is not None else rospy.Time.now()
    msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = position
    o = msg.pose.orientation
    o.x, o.y, o.z, o.w = quaternion
    return msg


class ControllerSwitch(unittest.TestCase):
    def test_controller_manager(self):
        robot = Robot()
        while rospy.Time.now().to_sec() < 3.0 or robot.pose_msg is None:
            rospy.sleep(0.1)

        # Expect: the position controller holds the arm at start, both listed with their joints
        listing = {c.name: c for c in robot.list().controller}
        self.assertEqual(sorted(listing), sorted([IMPEDANCE, TRAJECTORY]))
        self.assertEqual(listing[TRAJECTORY].state, "running")
        self.assertEqual(listing[IMPEDANCE].state, "stopped")
        self.assertEqual(listing[IMPEDANCE].claimed_resources[0].resources, ARM)
        self.assertEqual(
            listing[IMPEDANCE].claimed_resources[0].hardware_interface, "hardware_interface::EffortJointInterface"
        )

        # STRICT fails on an unknown controller, on stopping a stopped one, on a resource conflict: nothing changes
        self.assertFalse(robot.switch([IMPEDANCE, "no_such_controller"], [TRAJECTORY], STRICT, False, 0.0).ok)
        self.assertFalse(robot.switch([], [IMPEDANCE], STRICT, False, 0.0).ok)
        self.assertFalse(robot.switch([IMPEDANCE], [], STRICT, False, 0.0).ok)
        self.assertEqual(robot.states(), {TRAJECTORY: "running", IMPEDANCE: "stopped"})

        # BEST_EFFORT skips the unknown one and switches: no jump in the 0.5 s after
        self.assertTrue(robot.switch([IMPEDANCE, "no_such_controller"], [TRAJECTORY], BEST_EFFORT, False, 0.0).ok)
        self.assertEqual(robot.states(), {TRAJECTORY: "stopped", IMPEDANCE: "running"})
        self.assertLess(robot.max_motion(0.5), 0.005)

        # Bad commands are rejected, each with its reason, while the arm holds
        held = robot.pose_msg.pose
        position = [held.position.x, held.position.y, held.position.z]
        quaternion = [held.orientation.x, held.orientation.y, held.orientation.z, held.orientation.w]
        now = rospy.Time.now()
        far = [position[0], position[1], position[2] - 0.04]
        robot.equilibrium.publish(pose_msg([math.nan, 0.0, 0.5], quaternion))
        robot.equilibrium.publish(pose_msg(far, quaternion, frame="world"))
        robot.equilibrium.publish(pose_msg(far, [0.0, 0.0, 0.0, 0.0]))
        robot.equilibrium.publish(pose_msg(far, [0.0, 0.0, 0.0, 2.0]))
        robot.equilibrium.publish(pose_msg(far, quaternion, stamp=now - rospy.Duration(2.5)))
        eigenvalues = Vector3Stamped()
        eigenvalues.header.stamp = now
        eigenvalues.vector.x, eigenvalues.vector.y, eigenvalues.vector.z = 10.0, -5.0, 10.0
        robot.eigenvalues.publish(eigenvalues)
        eigenvalues.vector.y = math.inf
        robot.eigenvalues.publish(eigenvalues)
        eigenvectors = QuaternionStamped()
        eigenvectors.header.stamp = now
        robot.eigenvectors.publish(eigenvectors)
        robot.gripper.send_goal(MoveGoal(width=-0.01, speed=0.1))
        bad_trajectory = JointTrajectory(
            joint_names=["panda_joint1"],
            points=[JointTrajectoryPoint(positions=[0.1], time_from_start=rospy.Duration(1.0))],
        )
        robot.trajectory.publish(bad_trajectory)
        rejections = robot.wait_rejections(10)
        text = "\n".join(rejections)
        self.assertEqual(len(rejections), 10, text)
        for reason in [
            "NaN or inf",
            "frame 'world' is wrong",
            "orientation is zero",
            "not unit",
            "stale stamp",
            "negative stiffness",
            "eigenvectors is zero",
            "/franka_gripper/move: width -0.01 m is outside [0, 0.08] m",
            "joint names",
        ]:
            self.assertIn(reason, text)
        # the bad gripper goal was aborted, saying why (franka_gripper's result fields)
        self.assertTrue(robot.gripper.wait_for_result(rospy.Duration(5.0)))
        self.assertEqual(robot.gripper.get_state(), GoalStatus.ABORTED)
        self.assertFalse(robot.gripper.get_result().success)
        self.assertIn("width -0.01 m is outside", robot.gripper.get_result().error)
        self.assertLess(robot.max_motion(0.5), 0.005)

        # A good reference is followed: 3 cm down (stiffness 800 N/m in the config)
        target = [position[0], position[1], position[2] - 0.03]
        robot.equilibrium.publish(pose_msg(target, quaternion))
        rospy.sleep(2.0)
        self.assertLess(np.linalg.norm(robot.position() - np.array(target)), 0.003)

        # Back to the position controller, STRICT: bumpless again
        self.assertTrue(robot.switch([TRAJECTORY], [IMPEDANCE], STRICT, False, 0.0).ok)
        self.assertEqual(robot.states(), {TRAJECTORY: "running", IMPEDANCE: "stopped"})
        self.assertLess(robot.max_motion(0.5), 0.005)
        # STRICT refuses to start a running controller; BEST_EFFORT accepts doing nothing
        self.assertFalse(robot.switch([TRAJECTORY], [], STRICT, False, 0.0).ok)
        self.assertTrue(robot.switch([TRAJECTORY], [], BEST_EFFORT, False, 0.0).ok)
        self.assertEqual(robot.states(), {TRAJECTORY: "running", IMPEDANCE: "stopped"})

        # A joint trajectory is followed and its last point held
        with robot.lock:
            start = [robot.joints[name] for name in ARM]
        goal = list(start)
        goal[0] += 0.2
        trajectory = JointTrajectory(joint_names=list(reversed(ARM)))
        trajectory.points = [JointTrajectoryPoint(positions=list(reversed(goal)), time_from_start=rospy.Duration(1.0))]
        robot.trajectory.publish(trajectory)
        rospy.sleep(1.5)
        with robot.lock:
            reached = [robot.joints[name] for name in ARM]
        np.testing.assert_allclose(reached, goal, atol=2e-3)


if __name__ == "__main__":
    rospy.init_node("controller_switch_check")
    rostest.rosrun("teleteach", "controller_switch_check", ControllerSwitch)
