#!/usr/bin/env python3
"""rostest check: the tree does not tick before its skill servers are up (startup_timeout), so a robot that starts
slower than server_timeout does not turn into a help request; edits are served while it waits."""

import time
import unittest

import rospy
import rostest
from bt_ros_support import THESIS_SEQUENCE, TreeView


class WaitsForTheRobot(unittest.TestCase):
    def test_first_tick_waits_for_the_skill_servers(self):
        view = TreeView()
        view.wait_for(lambda: view.tree is not None, 10, "the first log/tree")
        started = time.monotonic()
        # Expect nothing ticked while the servers are missing (longer than server_timeout), and edits served
        time.sleep(3.0)
        self.assertEqual(view.status("LookToShelf"), "INVALID")
        self.assertEqual(view.status("BehaviorExecution"), "INVALID")
        response = view.change("Idle", "add")
        self.assertTrue(response.success, response.message)
        view.wait_for(lambda: "Idle_2" in view.nodes(), 3, "the edit on log/tree while waiting")
        self.assertEqual(view.status("LookToShelf"), "INVALID")
        # Expect the sequence to start once the servers are up, and run to the end without a help request
        view.wait_for(lambda: "LookToShelf" in view.started(), 30, "the LookToShelf goal at the server")
        self.assertGreater(time.monotonic() - started, 1.0)
        view.wait_completed(timeout=60)
        self.assertEqual(view.started(), [*THESIS_SEQUENCE, "Idle"])
        self.assertTrue(view.help is None or view.help.node_name == "", view.help)


if __name__ == "__main__":
    rospy.init_node("bt_startup_check")
    rostest.rosrun("teleteach", "bt_startup_check", WaitsForTheRobot)
