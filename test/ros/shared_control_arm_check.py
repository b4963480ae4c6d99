#!/usr/bin/env python3
"""rostest check of shared control on the simulated arm, judged where the arm is (/cartesian_pose on the plane).

A scripted operator rests for a different time before each push (start timings), pushes a wave or a cycloid, then
keeps pushing outside the boundary and into an obstacle edge. Every check is on positions in sim time.
"""

import bisect
import math
import threading
import unittest

import numpy as np
import rospy
import rostest
from geometry_msgs.msg import PoseStamped, Vector3Stamped

from teleteach.msg import SharedControlState
from teleteach.shared_control.constraints import Box, StraightEdge, violation
from teleteach.shared_control.models import synthetic_commands
from teleteach.shared_control.plane import TaskPlane

STIFFNESS = 1500.0  # [N/m] as in issue 15
SPEED = 0.05  # [m/s] the paper's v0
RHO = (0.03, 20.0, 0.0)  # the paper's amplitude/radius [m], spatial frequency [1/m], phase [m]
RATE = 50.0  # [Hz] of the operator's commands
BOUNDARY_TOLERANCE = 0.005  # [m] "never leaves the boundary by more than a few millimetres"
EDGE_TOLERANCE = 0.0  # [m] the arm never crosses the edge: the plan keeps a 5 mm margin (config/shared_control.yaml)
OBSTACLE = StraightEdge(0.0, -0.05, math.pi / 2)  # free side up: the arm must stay above y = -0.05 m
REACH = 0.1  # [m] each push goes on until the arm has moved this far the operator's way


class Recorder:
    """Keeps /cartesian_pose and /equilibrium_pose on the task plane, keyed by their sim-time stamps."""

    def __init__(self, plane: TaskPlane):
        self.plane = plane
        self.lock = threading.Lock()
        self.arm = ([], [])  # stamps [s], plane points [m]
        self.equilibrium = ([], [])
        self.states = []
        rospy.Subscriber("/cartesian_pose", PoseStamped, self._on_pose, (self.arm,), queue_size=1000)
        rospy.Subscriber("/equilibrium_pose", PoseStamped, self._on_pose, (self.equilibrium,), queue_size=1000)
        rospy.Subscriber("/shared_control/state", SharedControlState, self.states.append, queue_size=1000)

    def _on_pose(self, message, store):
        p = message.pose.position
        with self.lock:
            store[0][0].append(message.header.stamp.to_sec())
            store[0][1].append(self.plane.to_plane((p.x, p.y, p.z)))

    def arm_between(self, start, end):
        with self.lock:
            stamps, points = self.arm
            return np.array([q for t, q in zip(stamps, points) if start <= t <= end])

    def tracking_errors(self, start, end):
        """Distance from each arm pose to the latest equilibrium pose stamped before it [m]."""
        with self.lock:
            reference_stamps, references = list(self.equilibrium[0]), list(self.equilibrium[1])
            samples = [(t, q) for t, q in zip(*self.arm) if start <= t <= end]
        errors = []
        for t, q in samples:
            i = bisect.bisect_right(reference_stamps, t) - 1
            if i >= 0:
                errors.append(float(np.linalg.norm(q - references[i])))
        return np.array(errors)


class SharedControlOnTheArm(unittest.TestCase):
    def setUp(self):
        params = rospy.get_param("/shared_control")
        self.plane = TaskPlane.from_params(params["plane"])
        self.box = Box(*params["boundary"])
        self.recorder = Recorder(self.plane)
        self.command = rospy.Publisher("/shared_control/operator_command", Vector3Stamped, queue_size=10)
        self.obstacle = rospy.Publisher("/shared_control/obstacle", PoseStamped, queue_size=10)
        self.eigenvalues = rospy.Publisher("/eigenvalues", Vector3Stamped, queue_size=1, latch=True)
        self.wait_for(lambda: self.recorder.states and self.recorder.arm[0], "robot_sim and shared_control")
        stiffness = Vector3Stamped()
        stiffness.vector.x = stiffness.vector.y = stiffness.vector.z = STIFFNESS
        self.eigenvalues.publish(stiffness)
        self.rate = rospy.Rate(RATE)
        self.obstacle_on = False

    def wait_for(self, condition, what, timeout=60.0):
        deadline = rospy.Time.now().to_sec() + timeout
        while rospy.Time.now().to_sec() < deadline and not rospy.is_shutdown():
            if condition():
                return
            rospy.sleep(0.05)
        self.fail(f"timed out waiting for {what}")

    def operate(self, commands, until=None):
        """Publish commands at 50 Hz in sim time (the obstacle too, while on), stopping early once ``until(start)``
        holds (checked every 0.5 s); returns (start, end) sim times."""
        start = rospy.Time.now().to_sec()
        for k, (x, y) in enumerate(commands):
            if until is not None and k % 25 == 0 and until(start):
                break
            message = Vector3Stamped()
            message.header.stamp = rospy.Time.now()
            message.vector.x, message.vector.y = float(x), float(y)
            self.command.publish(message)
            if self.obstacle_on:
                edge = PoseStamped()
                edge.header.stamp = message.header.stamp
                edge.pose.position.x, edge.pose.position.y = OBSTACLE.x, OBSTACLE.y
                edge.pose.orientation.z = math.sin(OBSTACLE.yaw / 2)
                edge.pose.orientation.w = math.cos(OBSTACLE.yaw / 2)
                self.obstacle.publish(edge)
            self.rate.sleep()
        return start, rospy.Time.now().to_sec()

    def rest(self, seconds):
        return self.operate(np.zeros((int(round(seconds * RATE)), 2)))

    def push(self, skill, heading, seconds, seed, until=None):
        """The operator draws ``skill`` towards ``heading`` for ``seconds`` at most (less once ``until`` holds)."""
        times = np.arange(0.0, seconds, 1.0 / RATE)
        rng = np.random.default_rng(seed)
        return self.operate(synthetic_commands(skill, RHO, heading, SPEED, times, 0.005, rng), until)

    def arm_since(self, start):
        """The arm's plane points since ``start`` (2 columns, maybe none)."""
        return self.recorder.arm_between(start, math.inf).reshape(-1, 2)

    def moved_along(self, start, end, heading):
        points = self.recorder.arm_between(start, end)
        return float((points[-1] - points[0]) @ np.array([math.cos(heading), math.sin(heading)]))

    def around_worst_excursion(self, start, end):
        """Where and when the arm was furthest outside the boundary, with the controller's states around then."""
        with self.recorder.lock:
            samples = [(t, q) for t, q in zip(*self.recorder.arm) if start <= t <= end]
        t, q = max(samples, key=lambda sample: violation(sample[1], self.box, None))
        states = [
            (
                round(s.header.stamp.to_sec() - t, 2),
                s.mode,
                round(s.authority, 2),
                tuple(np.round([s.state.x, s.state.y], 3)),
            )
            for s in self.recorder.states
            if abs(s.header.stamp.to_sec() - t) < 0.3
        ]
        return f"at {t - start:.2f} s, arm {np.round(q, 4)}; states (dt, mode, authority, state): {states}"

    def test_arm_follows_the_operator_within_the_constraints(self):
        self.rest(3.0)  # the arm reaches the initial state and the stiffness its target
        run_start = rospy.Time.now().to_sec()
        # Each push lasts until the arm has gone 10 cm the operator's way (at most 12 s: an arm going the other way
        # never gets there), so the check does not depend on how fast the machine runs the nodes.
        pushes = [
            # (rest before [s], skill, heading [rad]): each rest ends at another phase of the idle restart
            (0.4, "wave", 0.0),
            (1.0, "cycloid", math.pi),
            (1.7, "wave", math.pi / 2),
        ]
        for seed, (rest, skill, heading) in enumerate(pushes):
            self.rest(rest)

            def far_enough(start, heading=heading):
                points = self.arm_since(start)
                direction = np.array([math.cos(heading), math.sin(heading)])
                return len(points) > 1 and (points[-1] - points[0]) @ direction > REACH

            start, end = self.push(skill, heading, 12.0, seed, far_enough)
            along = self.moved_along(start, end, heading)
            rospy.loginfo(f"rest {rest} s, {skill} at {heading:.2f} rad: the arm moved {along:.3f} m that way")
            self.assertGreater(along, REACH, f"{skill} after {rest} s of rest went {along:.3f} m")
        # The operator keeps pushing up across the top of the boundary for 3 s.
        self.push(
            "wave", math.pi / 2, 12.0, 5, lambda start: np.any(self.arm_since(start)[:, 1] > self.box.y_max - 0.01)
        )
        self.push("wave", math.pi / 2, 3.0, 6)
        # The operator pushes down into an obstacle edge until the arm is at it, and keeps pushing for 3 s.
        self.obstacle_on = True
        self.rest(1.2)
        obstacle_start, _ = self.push(
            "wave", -math.pi / 2, 15.0, 7, lambda start: np.any(self.arm_since(start)[:, 1] < OBSTACLE.y + 0.01)
        )
        _, end = self.push("wave", -math.pi / 2, 3.0, 8)
        self.obstacle_on = False
        self.rest(1.0)
        run_end = rospy.Time.now().to_sec()

        arm = self.recorder.arm_between(run_start, run_end).T
        outside = violation(arm, self.box, None)
        rospy.loginfo(f"worst excursion beyond the boundary: {1e3 * outside:.1f} mm")
        self.assertLessEqual(outside, BOUNDARY_TOLERANCE, self.around_worst_excursion(run_start, run_end))
        self.assertGreater(arm[1].max(), self.box.y_max - 0.02)  # it did go up to the boundary
        pressed = self.recorder.arm_between(obstacle_start + 0.2, end).T
        crossed = float(-OBSTACLE.distance(pressed).min())
        rospy.loginfo(f"worst crossing of the obstacle edge: {1e3 * crossed:.1f} mm; lowest y {pressed[1].min():.3f}")
        self.assertLessEqual(crossed, EDGE_TOLERANCE)
        during = [s for s in self.recorder.states if obstacle_start <= s.header.stamp.to_sec() <= end]
        summary = [(s.mode, s.skill, round(s.state.y, 3), s.message[:60]) for s in during[::25]]
        self.assertLess(pressed[1].min(), OBSTACLE.y + 0.02, summary)  # it did go down to the edge

        errors = self.recorder.tracking_errors(run_start, run_end)
        p50, p95 = (1e3 * float(np.percentile(errors, q)) for q in (50, 95))
        rospy.loginfo(f"arm to latest /equilibrium_pose on the plane: p50 {p50:.1f} mm, p95 {p95:.1f} mm")
        print(f"\ntracking on the plane: p50 {p50:.1f} mm, p95 {p95:.1f} mm, n {len(errors)}")
        # It follows the plan: 19 mm before x_dot_r and Lambda x_ddot_r (issue 15); 3-4 mm on an idle machine, the
        # goal of 5 mm is not asserted because missed cycles on a loaded machine add to it.
        self.assertLessEqual(p95, 10.0)
        modes = [s.mode for s in self.recorder.states if run_start <= s.header.stamp.to_sec() <= run_end]
        self.assertIn(SharedControlState.SHARED, modes)


if __name__ == "__main__":
    rospy.init_node("shared_control_arm_check")
    rostest.rosrun("teleteach", "shared_control_arm_check", SharedControlOnTheArm)
