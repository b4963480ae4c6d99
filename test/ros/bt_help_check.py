#!/usr/bin/env python3
"""rostest check: a failing skill pauses the tree with a help request; removing the failed leaf lets it complete."""

import unittest

import rospy
import rostest
from bt_ros_support import TreeView


class HelpRequestThenEdit(unittest.TestCase):
    def test_failed_skill_asks_for_help_and_the_edit_completes_the_task(self):
        view = TreeView()
        view.wait_for(lambda: view.help is not None and view.help.node_name == "PickItem2", 60, "a help request")
        # Expect the reason of the skill server, the tree paused and the failed leaf shown as FAILURE
        self.assertEqual(view.help.reason, "product_pick_2 is not on the shelf")
        view.wait_for(lambda: view.status("PauseCondition") == "SUCCESS", 10, "the tree paused")
        self.assertEqual(view.status("PickItem2"), "FAILURE")
        self.assertNotIn("MoveBase2", view.started())
        response = view.change("PickItem2", "remove")
        self.assertTrue(response.success, response.message)
        view.pause(False)
        view.wait_completed(timeout=30)
        # Expect the sequence to continue after the removed leaf, and the help request to be answered
        self.assertEqual(view.started()[-3:], ["PickItem2", "MoveBase2", "Idle"])
        self.assertEqual(view.started().count("PickItem2"), 1)
        self.assertNotIn("PickItem2", view.children("BehaviorExecution"))
        view.wait_for(lambda: view.help.node_name == "", 5, "the help request closed")


if __name__ == "__main__":
    rospy.init_node("bt_help_check")
    rostest.rosrun("teleteach", "bt_help_check", HelpRequestThenEdit)
