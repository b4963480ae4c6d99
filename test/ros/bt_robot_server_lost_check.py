#!/usr/bin/env python3
"""rostest check: SIGKILL of the real skill_server while PickItem moves the arm. Expect a help request naming the lost
server within seconds (not a tree that waits forever); once sim.launch has respawned skill_server, the operator
unpauses, PickItem runs again on the new server and the thesis sequence completes with the product in the gap."""

import unittest

import rospy
import rostest
from bt_robot_support import RobotView
from bt_ros_support import THESIS_SEQUENCE, TreeView

STARTUP_TIMEOUT = 180.0  # [s] wall: sim, skill servers and tree on a loaded machine
HELP_TIMEOUT = 15.0  # [s] wall: lost_timeout (1 s) plus ticks, on a loaded machine
RESPAWN_TIMEOUT = 90.0  # [s] wall: respawn_delay plus the server's start (imports, IK model)
COMPLETION_TIMEOUT = 480.0  # [s] wall: the rest of the sequence


class SkillServerKilledOnTheRobot(unittest.TestCase):
    def test_killed_server_asks_for_help_and_the_respawned_one_completes_the_task(self):
        view = TreeView()
        robot = RobotView(view)

        def picking():
            node = view.nodes().get("PickItem")
            return node is not None and view.status("PickItem") == "RUNNING" and "%" in node.message

        view.wait_for(picking, STARTUP_TIMEOUT, "PickItem moving the arm (progress feedback)")
        killed = view.kill_while_running("/skill_server", "PickItem", HELP_TIMEOUT)
        # Expect the true reason, with the progress the skill had made
        self.assertIn("lost the skill server /skill_server of /skills/PickItem", view.help.reason)
        self.assertIn("%", view.help.reason)
        self.assertNotIn("MoveBase", robot.sent_goals())
        view.wait_respawned("/skill_server", killed, RESPAWN_TIMEOUT)
        view.pause(False)
        view.wait_completed(timeout=COMPLETION_TIMEOUT)
        # Expect every leaf done, PickItem sent twice (to the killed and to the new server), the help request closed
        for name in THESIS_SEQUENCE:
            self.assertEqual(view.status(name), "SUCCESS", f"{name}: {view.summary()[name]}")
        self.assertTrue(robot.goals_sent_as(["LookToShelf", "PickItem", *THESIS_SEQUENCE[1:]]), robot.sent_goals())
        view.wait_for(lambda: view.help.node_name == "", 5, "the help request closed")
        self.assertTrue(*robot.in_gap("product_pick_1", "gap_1"))


if __name__ == "__main__":
    rospy.init_node("bt_robot_server_lost_check")
    rostest.rosrun("teleteach", "bt_robot_server_lost_check", SkillServerKilledOnTheRobot)
