#!/usr/bin/env python3
"""rostest check: SIGKILL of the skill server while PickItem runs makes the tree ask for help (not wait forever) with
the true reason; once the server is respawned and the operator unpauses, PickItem runs again and the tree completes."""

import unittest

import rospy
import rostest
from bt_ros_support import THESIS_SEQUENCE, TreeView

HELP_TIMEOUT = 10.0  # [s] wall: the leaf notices the lost connection within lost_timeout (1 s) plus a few ticks


class SkillServerKilled(unittest.TestCase):
    def test_killed_server_asks_for_help_and_the_respawned_one_continues(self):
        view = TreeView()
        view.wait_for(lambda: "PickItem" in view.started(), 60, "PickItem started at the skill server")
        killed = view.kill_while_running("/skill_test_server", "PickItem", HELP_TIMEOUT)
        # Expect the true reason (the lost server), the tree paused and the leaf shown as failed
        self.assertIn("lost the skill server /skill_test_server of /skills/PickItem", view.help.reason)
        self.assertIn("PickItem", view.help.reason)
        self.assertEqual(view.status("PickItem"), "FAILURE")
        view.wait_respawned("/skill_test_server", killed, 30)
        view.pause(False)
        view.wait_completed(timeout=60)
        # Expect PickItem retried once on the new server, the rest of the sequence run, the help request closed
        self.assertEqual(view.started(), [*THESIS_SEQUENCE[:2], *THESIS_SEQUENCE[1:]])
        self.assertEqual(len(view.histories), 2)
        view.wait_for(lambda: view.help.node_name == "", 5, "the help request closed")


if __name__ == "__main__":
    rospy.init_node("bt_server_lost_check")
    rostest.rosrun("teleteach", "bt_server_lost_check", SkillServerKilled)
