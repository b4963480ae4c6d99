#!/usr/bin/env python3
"""rostest check: an operator pushing into the boundary for 20 s, then switching pattern, over ROS (issue 31)."""

import math
import time
import unittest

import numpy as np
import rospy
import rostest
from geometry_msgs.msg import Vector3Stamped

from teleteach.msg import SharedControlState
from teleteach.shared_control.models import synthetic_commands

DT = 0.02
SPEED = 0.05
PUSH = 20.0  # [s] pushing into the boundary before the switch
AFTER = 6.0  # [s] after the switch


class BoundaryPush(unittest.TestCase):
    def setUp(self):
        self.states = []
        rospy.Subscriber("/shared_control/state", SharedControlState, self.states.append, queue_size=1000)
        self.command = rospy.Publisher("/shared_control/operator_command", Vector3Stamped, queue_size=100)
        deadline = time.monotonic() + 600.0  # without the compiled cache the node compiles before it starts
        while not (self.states and self.command.get_num_connections()):
            self.assertLess(time.monotonic(), deadline, "the node did not come up")
            time.sleep(0.1)
        self.boundary = rospy.get_param("/shared_control/boundary")

    def test_pushing_into_the_boundary_keeps_the_rate_the_pattern_and_the_switch(self):
        # The operator: a wave (0.7 Hz, 1.5 cm) at 5 cm/s towards -x from the origin meets x_min after about
        # 5 s and keeps pushing for PUSH s; then a cycloid (1.1 Hz, 1.2 cm), still pushing.
        rng = np.random.default_rng(31)
        reach = -self.boundary[0] / SPEED
        before = synthetic_commands(
            "wave", (0.015, 14.0, 0.0), math.pi, SPEED, np.arange(0, reach + PUSH, DT), 0.008, rng
        )
        after = synthetic_commands("cycloid", (0.012, 22.0, 0.0), math.pi, SPEED, np.arange(0, AFTER, DT), 0.008, rng)
        commands = np.vstack([before, after])
        message = Vector3Stamped()
        start = rospy.get_time()
        first = len(self.states)
        while (now := rospy.get_time()) < start + len(commands) * DT:
            index = min(int((now - start) / DT), len(commands) - 1)
            message.header.stamp = rospy.Time.from_sec(now)
            message.vector.x, message.vector.y = commands[index]
            self.command.publish(message)
            time.sleep(max(start + DT * (index + 1) - rospy.get_time(), 0.0))
        end = rospy.get_time()
        switch = start + len(before) * DT
        time.sleep(0.3)
        states = [s for s in self.states[first:] if start <= s.header.stamp.to_sec() <= end]
        # Expect: a state every cycle, or a missing cycle counted late (the node skips only after 1 s behind the
        # grid, and says so), few of them late, the boundary kept.
        cycles = [s.cycle for s in states]
        for before, after in zip(states, states[1:]):
            self.assertGreaterEqual(after.late_cycles - before.late_cycles, after.cycle - before.cycle - 1)
        self.assertGreater(len(states) / (end - start), 45.0)
        # Late cycles are counted, never more than the cycles; the share is the bench's goal (0.5 %), here only a
        # bound that a working machine keeps (59 % were late under a load average of 20 on two cores).
        lates = [s.late_cycles for s in states]
        self.assertEqual(lates, sorted(lates))
        self.assertLessEqual(lates[-1], cycles[-1])
        late = (lates[-1] - lates[0]) / len(states)
        self.assertLess(late, 0.5)
        for state in states:
            self.assertGreaterEqual(state.state.x, self.boundary[0] - 1e-6)
            self.assertLessEqual(state.state.x, self.boundary[2] + 1e-6)
            self.assertGreaterEqual(state.state.y, self.boundary[1] - 1e-6)
            self.assertLessEqual(state.state.y, self.boundary[3] + 1e-6)
        # At the boundary for PUSH s: few FALLBACK cycles, the wave kept while pushing.
        pushing = [s for s in states if start + reach + 1.0 <= s.header.stamp.to_sec() < switch]
        self.assertLess(min(s.state.x for s in pushing), self.boundary[0] + 0.01)
        fallback = sum(s.mode == SharedControlState.FALLBACK for s in pushing) / len(pushing)
        self.assertLess(fallback, 0.05, [s.message for s in pushing if s.mode == SharedControlState.FALLBACK][:3])
        shared = [s for s in pushing if s.mode in (SharedControlState.SHARED, SharedControlState.UNKNOWN)]
        self.assertGreater(sum(s.skill == "wave" for s in shared), 0.9 * len(pushing))
        # The switch is recognised within 1.5 s.
        detected = next(
            s.header.stamp.to_sec() for s in states if s.header.stamp.to_sec() >= switch and s.skill == "cycloid"
        )
        rospy.loginfo(
            f"boundary push: {len(states) / (end - start):.1f} Hz, {100 * late:.1f} % late, FALLBACK "
            f"{100 * fallback:.1f} % while pushing, switch after {detected - switch:.2f} s"
        )
        self.assertLess(detected - switch, 1.5)


if __name__ == "__main__":
    rospy.init_node("shared_control_boundary_check")
    rostest.rosrun("teleteach", "shared_control_boundary_check", BoundaryPush)
