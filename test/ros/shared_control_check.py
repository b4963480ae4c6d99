#!/usr/bin/env python3
"""rostest check of the shared-control node: modes, skill, boundary and obstacle kept, bad messages rejected."""

import functools
import math
import time
import unittest

import numpy as np
import rospy
import rostest
from geometry_msgs.msg import PolygonStamped, PoseStamped, Vector3Stamped
from nav_msgs.msg import Path

from teleteach.msg import SharedControlState
from teleteach.shared_control.models import synthetic_commands
from teleteach.shared_control.plane import TaskPlane

# From the .test file
BOUNDARY = (-0.25, -0.05, 0.25, 0.08)


@functools.lru_cache(maxsize=1)
def task_plane():
    """The plane the node was given (read once: a parameter lookup per pose took minutes on a loaded machine)."""
    return TaskPlane.from_params(rospy.get_param("/shared_control/plane"))


def to_plane(pose):
    """(task-plane point, distance from the plane) of a pose."""
    p = pose.pose.position
    position = np.array([p.x, p.y, p.z])
    point = task_plane().to_plane(position)
    return point, float(np.linalg.norm(position - task_plane().to_base(point)))


def to_plane_point(point):
    """Task-plane point of a geometry_msgs/Point32."""
    return task_plane().to_plane((point.x, point.y, point.z))


class SharedControlNode(unittest.TestCase):
    def setUp(self):
        self.states, self.poses, self.plans = [], [], []
        rospy.Subscriber("/shared_control/plan", Path, self.plans.append)
        rospy.Subscriber("/shared_control/state", SharedControlState, self.states.append)
        rospy.Subscriber("/equilibrium_pose", PoseStamped, self.poses.append)
        self.command = rospy.Publisher("/shared_control/operator_command", Vector3Stamped, queue_size=10)
        self.obstacle = rospy.Publisher("/shared_control/obstacle", PoseStamped, queue_size=10)
        self.wait_for(lambda: self.states and self.command.get_num_connections(), "the node")

    def wait_for(self, condition, what, timeout=30.0):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if condition():
                return
            time.sleep(0.05)
        self.fail(f"timed out waiting for {what}")

    def send(self, x, y, ahead=0.0):
        message = Vector3Stamped()
        message.header.stamp = rospy.Time.now() + rospy.Duration(ahead)
        message.vector.x, message.vector.y = x, y
        self.command.publish(message)

    def send_obstacle(self, x, y, yaw):
        message = PoseStamped()
        message.pose.position.x, message.pose.position.y = x, y
        message.pose.orientation.z, message.pose.orientation.w = math.sin(yaw / 2), math.cos(yaw / 2)
        self.obstacle.publish(message)

    def test_wave_is_identified_and_constraints_are_kept(self):
        # The operator waves right to left while drifting up towards the boundary y = 0.08 m.
        commands = synthetic_commands("wave", (0.03, 20.0, 0.0), math.pi - 0.5, 0.05, np.arange(0, 5.0, 0.02))
        rate = rospy.Rate(50)
        first = len(self.states)
        obstacle_time = None
        for k, (x, y) in enumerate(commands):
            if k == 100:
                self.send(float("nan"), 0.0)  # rejected by the node, which keeps running
            if k == 120:
                self.send(1.0, 1.0, ahead=1.0)  # stamped a second in the future: rejected too
            self.send(float(x), float(y))
            if k >= 150:
                # A straight edge below the robot, free side up: the robot must stay above y = -0.02.
                self.send_obstacle(0.0, -0.02, math.pi / 2)
                obstacle_time = obstacle_time or rospy.get_time()
            rate.sleep()
        self.wait_for(lambda: len(self.states) > first + 200, "state messages during the run")
        states = self.states[first:]
        modes = [s.mode for s in states]
        self.assertIn(SharedControlState.DIRECT, modes)
        self.assertIn(SharedControlState.SHARED, modes)
        shared = [s for s in states if s.mode == SharedControlState.SHARED]
        self.assertGreater(sum(s.skill == "wave" for s in shared), 0.9 * len(shared))
        # The last solved cycle (a late cycle that caught up by following the plan has no fit to report).
        solved = [s for s in shared if "late cycle" not in s.message]
        self.assertEqual(list(solved[-1].skills), ["wave", "cycloid"])
        self.assertEqual(len(solved[-1].fitting_errors), 2)
        self.assertEqual(len(solved[-1].parameters), 7)
        # Every equilibrium pose lies on the task plane, inside the boundary; after the obstacle appeared, above it.
        for pose in self.poses:
            self.assertEqual(pose.header.frame_id, "base_link")
            point, depth = to_plane(pose)
            self.assertAlmostEqual(depth, 0.0)
            self.assertGreaterEqual(point[0], BOUNDARY[0] - 1e-6)
            self.assertGreaterEqual(point[1], BOUNDARY[1] - 1e-6)
            self.assertLessEqual(point[0], BOUNDARY[2] + 1e-6)
            self.assertLessEqual(point[1], BOUNDARY[3] + 1e-6)
        top = max(to_plane(p)[0][1] for p in self.poses)
        self.assertGreater(top, 0.06)  # it did reach the boundary region rather than stand still
        after = [s for s in states if s.header.stamp.to_sec() > obstacle_time + 0.1]
        self.assertGreater(len(after), 10)
        for state in after:
            self.assertGreaterEqual(state.state.y, -0.02 - 1e-6)
        # The planned horizon: published each cycle, on the plane and inside the boundary, non-empty when sharing.
        self.assertTrue(any(len(plan.poses) > 10 for plan in self.plans))
        for plan in self.plans:
            self.assertEqual(plan.header.frame_id, "base_link")
            for pose in plan.poses:
                point, depth = to_plane(pose)
                self.assertAlmostEqual(depth, 0.0)
                self.assertTrue(BOUNDARY[0] - 1e-6 <= point[0] <= BOUNDARY[2] + 1e-6, point)
                self.assertTrue(BOUNDARY[1] - 1e-6 <= point[1] <= BOUNDARY[3] + 1e-6, point)
        # The latched boundary: the box's corners in base_link.
        boundary = rospy.wait_for_message("/shared_control/boundary", PolygonStamped, timeout=5)
        corners = sorted(tuple(np.round(to_plane_point(c), 6)) for c in boundary.polygon.points)
        self.assertEqual(corners, sorted([(-0.25, -0.05), (-0.25, 0.08), (0.25, -0.05), (0.25, 0.08)]))
        # The state message mirrors the executed state, and the command is the operator's.
        self.assertTrue(all(math.isfinite(s.command.x) for s in states))
        # Each bad message is named in a state's message, and the equilibrium never jumps: no step between two
        # states is longer than the fastest command allowed (max_command_speed) for one cycle.
        messages = " ".join(s.message for s in states)
        self.assertIn("rejected a message: operator command has non-finite values", messages)
        self.assertIn("s in the future", messages)
        points = np.array([(s.state.x, s.state.y) for s in states])
        self.assertLess(np.max(np.linalg.norm(np.diff(points, axis=0), axis=1)), 1.0 * 0.02 + 1e-9)


if __name__ == "__main__":
    rospy.init_node("shared_control_check")
    rostest.rosrun("teleteach", "shared_control_check", SharedControlNode)
