#!/usr/bin/env python3
"""rostest check: SIGKILL of robot_sim while the real LookToShelf runs; the tree asks for help within seconds with a
reason that names the simulator (its clock stopped), and nothing after LookToShelf runs."""

import os
import signal
import unittest

import rospy
import rostest
from bt_ros_support import TreeView
from ros_processes import node_pid

STARTUP_TIMEOUT = 180.0  # [s] wall: sim, skill servers and tree on a loaded machine
HELP_TIMEOUT = 30.0  # [s] wall: clock_timeout (5 s) plus the skill server's own reaction, on a loaded machine


class SimulatorKilled(unittest.TestCase):
    def test_killed_simulator_fails_the_skill_and_asks_for_help(self):
        view = TreeView()

        def running():
            node = view.nodes().get("LookToShelf")
            return node is not None and view.status("LookToShelf") == "RUNNING" and "%" in node.message

        view.wait_for(running, STARTUP_TIMEOUT, "LookToShelf running on the robot (progress feedback)")
        os.kill(node_pid("/robot_sim"), signal.SIGKILL)
        view.wait_for(lambda: view.help is not None and view.help.node_name != "", HELP_TIMEOUT, "a help request")
        # Expect the running skill to be the one that failed, with the simulator named, and the tree paused there
        self.assertEqual(view.help.node_name, "LookToShelf")
        self.assertIn("robot_sim", view.help.reason)
        view.wait_for(lambda: view.status("PauseCondition") == "SUCCESS", 10, "the tree paused")
        self.assertEqual(view.status("PickItem"), "INVALID")


if __name__ == "__main__":
    rospy.init_node("bt_sim_lost_check")
    rostest.rosrun("teleteach", "bt_sim_lost_check", SimulatorKilled)
