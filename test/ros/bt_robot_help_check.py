#!/usr/bin/env python3
"""rostest check: product_pick_1 is absent from the simulation, so the real PickItem fails; the tree pauses and asks
for help; the operator replaces PickItem with PickItem2 (the other product) and drops the second pick that needed
it; unpaused, the tree completes and product_pick_2 stands in the shelf's gap."""

import unittest

import rospy
import rostest
from bt_robot_support import RobotView
from bt_ros_support import TreeView

STARTUP_TIMEOUT = 180.0  # [s] wall: sim, skill servers and tree on a loaded machine
COMPLETION_TIMEOUT = 480.0  # [s] wall: the rest of the sequence
EDITED = [
    "LookToShelf",
    "PickItem2",
    "MoveBase",
    "PlaceItem",
    "DropItem",
    "MoveBaseToStart",
    "LookToShelfAgain",
    "Idle",
]


class HelpRequestOnTheRobot(unittest.TestCase):
    def test_absent_product_asks_for_help_and_the_replacement_completes_the_task(self):
        view = TreeView()
        robot = RobotView(view)
        names = robot.product_names()
        self.assertNotIn("product_pick_1", names)
        self.assertIn("product_pick_2", names)
        view.wait_for(lambda: view.help is not None and view.help.node_name == "PickItem", STARTUP_TIMEOUT, "help")
        # Expect the skill server's reason, the tree paused, the failed leaf shown as FAILURE, nothing after it run
        self.assertEqual(view.help.reason, "product_pick_1 is not on the table")
        view.wait_for(lambda: view.status("PauseCondition") == "SUCCESS", 10, "the tree paused")
        self.assertEqual(view.status("PickItem"), "FAILURE")
        self.assertTrue(robot.goals_sent_as(["LookToShelf", "PickItem"]), robot.sent_goals())
        # The operator's edits (the BT's help semantics): the second pick needs product_pick_2, so it goes; a
        # PickItem2 inserted in front of the failed leaf runs first; then the failed leaf is removed
        for arguments in [("PickItem2", "remove"), ("MoveBase2", "remove"), ("PickItem2", "insert", 1)]:
            response = view.change(*arguments)
            self.assertTrue(response.success, f"{arguments}: {response.message}")
        self.assertEqual(response.new_node_name, "PickItem2")
        response = view.change("PickItem", "remove")
        self.assertTrue(response.success, response.message)
        view.wait_for(lambda: view.children("BehaviorExecution") == EDITED, 10, "the edited tree")
        view.pause(False)

        view.wait_completed(timeout=COMPLETION_TIMEOUT)
        # Expect the help request closed, every leaf done, each goal sent once, the failed pick never retried
        view.wait_for(lambda: view.help.node_name == "", 5, "the help request closed")
        for name in EDITED:
            self.assertEqual(view.status(name), "SUCCESS", f"{name}: {view.summary()[name]}")
        self.assertTrue(robot.goals_sent_as(["LookToShelf", "PickItem", *EDITED[1:]]), robot.sent_goals())
        self.assertTrue(*robot.in_gap("product_pick_2", "gap_1"))


if __name__ == "__main__":
    rospy.init_node("bt_robot_help_check")
    rostest.rosrun("teleteach", "bt_robot_help_check", HelpRequestOnTheRobot)
