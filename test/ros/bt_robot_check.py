#!/usr/bin/env python3
"""rostest check: the behaviour_tree node drives the real skill servers and the simulation through the thesis
sequence; thesis experiment III-B (remove PlaceItem while the tree runs -> Fig. B.1 bottom) on the way, then a
placement skill inserted back at its index; the tree completes and product_pick_1 stands in the shelf's gap."""

import unittest

import rospy
import rostest
from bt_robot_support import RobotView
from bt_ros_support import THESIS_SEQUENCE, TreeView

FIG_B1_BOTTOM = [name for name in THESIS_SEQUENCE if name != "PlaceItem"]
STARTUP_TIMEOUT = 180.0  # [s] wall: sim, skill servers and tree on a loaded machine
COMPLETION_TIMEOUT = 480.0  # [s] wall: the whole sequence


class ThesisTreeOnTheRobot(unittest.TestCase):
    def test_thesis_experiment_then_the_whole_sequence_places_the_product(self):
        view = TreeView()
        robot = RobotView(view)
        view.wait_for(lambda: view.status("PickItem") == "RUNNING", STARTUP_TIMEOUT, "PickItem running")
        response = view.change("PlaceItem", "remove")
        self.assertTrue(response.success, response.message)
        # Expect the tree of thesis Fig. B.1 (bottom) while the robot keeps working
        view.wait_for(lambda: view.children("BehaviorExecution") == FIG_B1_BOTTOM, 10, "Fig. B.1 bottom")
        self.assertEqual(view.children("Root"), ["PauseCondition", "BehaviorExecution"])
        self.assertEqual(view.status("BehaviorExecution"), "RUNNING")
        self.assertNotEqual(view.status("DropItem"), "SUCCESS")
        # The operator puts a placement skill where PlaceItem was (thesis III-B: the gap needs one before DropItem)
        response = view.change("PlaceItem", "insert", 3)
        self.assertTrue(response.success, response.message)
        self.assertEqual(response.new_node_name, "PlaceItem")
        view.wait_for(lambda: view.children("BehaviorExecution") == THESIS_SEQUENCE, 10, "PlaceItem at index 3")
        self.assertNotIn("DropItem", robot.sent_goals())

        view.wait_completed(timeout=COMPLETION_TIMEOUT)
        # Expect every leaf done, each goal sent once in the thesis order (PickItem never restarted by the edits)
        for name in THESIS_SEQUENCE:
            self.assertEqual(view.status(name), "SUCCESS", f"{name}: {view.summary()[name]}")
        self.assertEqual(view.status("PauseCondition"), "FAILURE")
        self.assertTrue(robot.goals_sent_as(THESIS_SEQUENCE), robot.sent_goals())
        view.wait_for(lambda: view.help is not None, 5, "the latched help_request")
        self.assertEqual(view.help.node_name, "")
        # Expect product_pick_1 in the gap of the scene file, product_pick_2 carried off the table
        self.assertTrue(*robot.in_gap("product_pick_1", "gap_1"))
        table = robot.scene.pick_table
        self.assertGreater(robot.product("product_pick_2")[2], table.center[2] + table.size[2] / 2.0 + 0.2)


if __name__ == "__main__":
    rospy.init_node("bt_robot_check")
    rostest.rosrun("teleteach", "bt_robot_check", ThesisTreeOnTheRobot)
