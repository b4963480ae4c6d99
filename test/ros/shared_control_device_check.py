#!/usr/bin/env python3
"""rostest check: shared control driven by the real device node through the real GUI, judged on the arm.

The scripted hand (config/scenarios/shared_control_push.yaml) rests, pushes right, then away across the boundary.
From /sigma7/pose (the hand, mapped on the task plane by the node's twist_projection) and /cartesian_pose (the arm,
projected on the task plane), both in sim time: wherever the hand has moved steadily one way for a while and the
arm is clear of the boundary, the arm moves that way too; it never leaves the boundary by more than a few
millimetres, though the hand goes on pushing; and it ends up at the boundary the hand pushed it to.
"""

import threading
import unittest

import numpy as np
import rospy
import rostest
from geometry_msgs.msg import PoseStamped

from teleteach.msg import SharedControlState
from teleteach.shared_control.constraints import Box, violation
from teleteach.shared_control.plane import TaskPlane

SCENARIO_TIMEOUT = 240.0  # [s] wall: GUI, simulator and the scripted hand on a loaded machine
WINDOW = 0.5  # [s] of sim time over which the hand's and the arm's ways are compared
STEADY = 1.0  # [s] the hand must have gone the same way this long before a window counts
LAG = 0.3  # [s] the arm's way is taken this much later than the hand's (command delay, tracking)
CLEAR = 0.02  # [m] windows with the arm nearer the boundary are left out (it must stop there, not follow)
BOUNDARY_TOLERANCE = 0.005  # [m] "never leaves the boundary by more than a few millimetres"
SETTLE = 1.0  # [s] after the MPC's first cycle (the reference has reached the plane) the arm catches up


class Track:
    """Stamped plane points of one pose topic."""

    def __init__(self, topic, to_plane):
        self.lock = threading.Lock()
        self.stamps, self.points = [], []
        self.to_plane = to_plane
        rospy.Subscriber(topic, PoseStamped, self._on_pose, queue_size=1000)

    def _on_pose(self, message):
        p = message.pose.position
        with self.lock:
            self.stamps.append(message.header.stamp.to_sec())
            self.points.append(self.to_plane(np.array([p.x, p.y, p.z])))

    def at(self, times):
        """The plane point at each of ``times`` (linear interpolation)."""
        with self.lock:
            stamps, points = np.array(self.stamps), np.array(self.points)
        return np.column_stack([np.interp(times, stamps, points[:, axis]) for axis in range(2)])

    def all(self):
        with self.lock:
            return np.array(self.stamps), np.array(self.points)


class States:
    """/shared_control/state's mode and command speed by stamp: what moved the reference when it stepped."""

    def __init__(self):
        self.lock = threading.Lock()
        self.cycles = []
        rospy.Subscriber("/shared_control/state", SharedControlState, self._on_state, queue_size=1000)

    def _on_state(self, message):
        speed = float(np.hypot(message.command.x, message.command.y))
        with self.lock:
            self.cycles.append((message.header.stamp.to_sec(), message.mode, speed))

    def at(self, stamp, around=0.1):
        """Stamps, modes and command speeds of the cycles within ``around`` seconds of ``stamp``."""
        with self.lock:
            near = [cycle for cycle in self.cycles if abs(cycle[0] - stamp) <= around]
        return [round(c[0], 3) for c in near], [c[1] for c in near], [round(c[2], 3) for c in near]


class SharedControlFromTheDevice(unittest.TestCase):
    def test_the_arm_goes_the_hands_way_and_stays_inside(self):
        params = rospy.get_param("/shared_control")
        plane, box = TaskPlane.from_params(params["plane"]), Box(*params["boundary"])
        projection = float(params["twist_scale"]) * np.array(params["twist_projection"], dtype=float)
        hand = Track("/sigma7/pose", lambda p: projection @ p)
        arm = Track("/cartesian_pose", plane.to_plane)
        reference = Track("/equilibrium_pose", lambda p: p)  # in base_link: the approach leaves the plane
        states = States()
        driving = rospy.wait_for_message("/shared_control/state", SharedControlState, timeout=SCENARIO_TIMEOUT)
        settled = driving.header.stamp.to_sec() + SETTLE  # from here on the MPC holds the arm in the task plane
        deadline = rospy.get_time() + SCENARIO_TIMEOUT
        while not rospy.get_param("/sigma7_node/scenario_played", False):
            self.assertLess(rospy.get_time(), deadline, "the scripted hand did not finish (did the GUI open?)")
            rospy.sleep(0.2)
        rospy.sleep(1.0)
        stamps, _ = hand.all()
        times = np.arange(stamps[0] + STEADY, stamps[-1] - WINDOW - LAG, 0.1)
        compared, against = 0, []
        for t in times:
            before, now, after = hand.at([t - STEADY, t, t + WINDOW])
            way, earlier = after - now, now - before
            if np.linalg.norm(way) < 0.01 or way @ earlier < 0.9 * np.linalg.norm(way) * np.linalg.norm(earlier):
                continue  # the hand is not moving steadily one way here
            start, end = arm.at([t + LAG, t + LAG + WINDOW])
            clearance = min(end[0] - box.x_min, box.x_max - end[0], end[1] - box.y_min, box.y_max - end[1])
            if clearance < CLEAR:
                continue
            compared += 1
            moved = end - start
            cosine = float(moved @ way / (np.linalg.norm(moved) * np.linalg.norm(way) + 1e-12))
            if cosine < 0.7:
                against.append((round(t - stamps[0], 1), np.round(way, 3).tolist(), np.round(moved, 3).tolist()))
        arm_stamps, arm_points = arm.all()
        arm_points = arm_points[arm_stamps >= settled]
        outside = violation(arm_points.T, box, None)
        rospy.loginfo(
            f"{compared} windows compared, {len(against)} against the hand; worst excursion {outside:.4f} m; "
            f"the arm ended at {np.round(arm_points[-1], 3)}"
        )
        # Expect: the reference never jumped, not even when the GUI switched shared control on with the arm off the
        # task plane (the jump this guards against was 25 cm). A cycle moves it at most as fast as the fastest thing
        # that moves it: the operator's own command in direct control, clipped at max_command_speed (1 m/s, 2 cm per
        # 50 Hz cycle), is faster than any plan (speed_bounds' top) or the approach. Allowed: that speed over the
        # time between two messages plus one cycle. A loop that fell behind catches up with cycles stamped back to
        # back, and the publisher keeps only the last of them: two cycles of a 0.1 m/s plan then arrive as 4 mm with
        # no time between (CI failed at 0.2 m/s as the bound; a fresh machine at load 7 showed 12.9 mm after three
        # late cycles).
        stamps, references = reference.all()
        steps = np.linalg.norm(np.diff(references, axis=0), axis=1)
        period = 1.0 / float(params["rate"])
        fastest = max(float(params["speed_bounds"][1]), float(params["max_command_speed"]))
        allowed = fastest * (np.maximum(np.diff(stamps), 0.0) + period) + 1e-4
        worst = int(np.argmax(steps / allowed))
        mode_stamps, modes, commands = states.at(stamps[worst + 1])
        rospy.loginfo(
            f"worst /equilibrium_pose step {steps[worst]:.4f} m in {stamps[worst + 1] - stamps[worst]:.3f} s "
            f"({steps[worst] / allowed[worst]:.0%} of the allowed), {modes} with commands {commands} m/s"
        )
        self.assertLessEqual(
            steps[worst],
            allowed[worst],
            f"/equilibrium_pose stepped {steps[worst]:.4f} m in {stamps[worst + 1] - stamps[worst]:.3f} s at "
            f"{stamps[worst + 1]:.3f}; shared control's cycles then: {mode_stamps}, {modes}, commands {commands} m/s",
        )
        # Expect: the check saw the pushes, the arm went the hand's way in (nearly) all of them
        self.assertGreaterEqual(compared, 20, "too few windows with the hand moving steadily and the arm clear")
        self.assertLessEqual(len(against), compared // 10, f"arm against the hand (t, hand, arm): {against}")
        # Expect: pushed across the top of the boundary, the arm stops at it
        self.assertLessEqual(outside, BOUNDARY_TOLERANCE)
        self.assertGreater(arm_points[-1][1], box.y_max - 0.02, f"the arm ended at {arm_points[-1]}")
        self.assertGreater(arm_points[-1][0], 0.08, f"the arm ended at {arm_points[-1]} (pushed right 12 cm)")


if __name__ == "__main__":
    rospy.init_node("shared_control_device_check")
    rostest.rosrun("teleteach", "shared_control_device_check", SharedControlFromTheDevice)
