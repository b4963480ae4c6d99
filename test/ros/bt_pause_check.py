#!/usr/bin/env python3
"""rostest check: pausing keeps the running skill's goal alive (no cancel, no restart) and the leaf resumes after."""

import time
import unittest

import rospy
import rostest
from bt_ros_support import THESIS_SEQUENCE, TreeView


class PauseKeepsTheGoal(unittest.TestCase):
    def test_pause_suspends_and_resumes_the_running_leaf(self):
        view = TreeView()
        view.wait_for(lambda: "MoveBase" in view.started(), 30, "the MoveBase goal at the server")
        view.wait_for(lambda: view.status("MoveBase") == "RUNNING", 5, "MoveBase running")
        view.pause(True)
        view.wait_for(lambda: view.status("PauseCondition") == "SUCCESS", 10, "PauseCondition SUCCESS")
        # Expect the suspended leaf still RUNNING, its goal alive on the server, nothing after it started
        time.sleep(1.0)
        self.assertEqual(view.status("MoveBase"), "RUNNING")
        self.assertEqual(view.status("BehaviorExecution"), "RUNNING")
        self.assertEqual(view.event_list("cancel"), [])
        self.assertEqual(view.started(), ["LookToShelf", "PickItem", "MoveBase"])
        nodes = view.nodes()
        self.assertFalse(nodes["MoveBase"].is_active, "a suspended leaf is not ticked")
        self.assertTrue(nodes["PauseCondition"].is_active)
        view.pause(False)
        view.wait_completed(timeout=60)
        # Expect the same MoveBase goal to have finished: started once, never cancelled, then the rest ran
        self.assertEqual(view.started(), THESIS_SEQUENCE)
        self.assertEqual(view.event_list("cancel"), [])
        self.assertEqual([e[2] for e in view.event_list("succeed")], THESIS_SEQUENCE)


if __name__ == "__main__":
    rospy.init_node("bt_pause_check")
    rostest.rosrun("teleteach", "bt_pause_check", PauseKeepsTheGoal)
