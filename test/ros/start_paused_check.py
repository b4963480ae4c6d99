#!/usr/bin/env python3
"""rostest check of start_paused: nothing moves until the operator's start gesture, then the tree runs.

From the outside only: every skill's goal topic, /joint_states (the arm), behaviour_tree/execution (what the tree
says), and the device's input topics (sigma7/input/*: the hand holds the handle centred, then clicks).
"""

import unittest

import numpy as np
import rospy
import rostest
from full_system_support import Hand, Observer

from teleteach.msg import TreeExecution

QUIET = 20.0  # [s] of simulated time during which nothing may move
STILL = 0.005  # [rad] largest change of any arm joint that counts as not moving (position control holding it)


class StartPaused(unittest.TestCase):
    def test_nothing_moves_until_the_operator_starts_the_tree(self):
        observer = Observer()
        hand = Hand()
        observer.wait(lambda: observer.execution is not None, 120, "behaviour_tree/execution")
        self.assertEqual(observer.execution.state, TreeExecution.WAITING, observer.execution)
        observer.wait(lambda: observer.joints, 60, "/joint_states")
        start = rospy.get_time()
        rospy.sleep(QUIET)  # simulated time
        with observer.lock:
            goals = list(observer.goals)
            window = [joints for stamp, joints, _ in observer.joints if stamp >= start]
        # Expect no goal at all, the arm still, the tree still waiting
        self.assertEqual(goals, [])
        self.assertGreater(len(window), 100)
        moved = np.max(np.abs(np.array(window) - window[0]))
        self.assertLess(moved, STILL, f"the arm moved {moved:.4f} rad while the tree waited")
        self.assertEqual(observer.execution.state, TreeExecution.WAITING)
        # The START gesture: handle centred (held since the beginning), a click
        hand.start_tree(observer)
        observer.wait(lambda: observer.goals, 60, "a skill goal after the start gesture")
        with observer.lock:
            self.assertEqual(observer.goals[0], "LookToShelf")
            before = observer.joints[-1][1]
        observer.wait(lambda: np.max(np.abs(observer.joints[-1][1] - before)) > 0.05, 60, "the arm moving")


if __name__ == "__main__":
    rospy.init_node("start_paused_check")
    rostest.rosrun("teleteach", "start_paused", StartPaused)
