#!/usr/bin/env python3
"""rostest check: the tree does not tick before its skill servers are up (startup_timeout), so a robot that starts
slower than server_timeout does not turn into a help request; edits are served while it waits."""

import threading
import unittest

import rospy
import rostest
from bt_ros_support import STATUS, THESIS_SEQUENCE, TreeView
from ros_processes import node_pid

from teleteach.msg import BehaviourTree


class StatusesSeen:
    """Every status of one node on every log/tree message, in order."""

    def __init__(self, name):
        self.name = name
        self.lock = threading.Lock()
        self.statuses = []
        rospy.Subscriber("/behaviour_tree/log/tree", BehaviourTree, self._on_tree, queue_size=100)

    def _on_tree(self, message):
        status = next(STATUS[b.status] for b in message.behaviours if b.name == self.name)
        with self.lock:
            self.statuses.append(status)

    def so_far(self):
        with self.lock:
            return list(self.statuses)


class WaitsForTheRobot(unittest.TestCase):
    def test_first_tick_waits_for_the_skill_servers(self):
        seen = StatusesSeen("LookToShelf")
        view = TreeView()
        view.wait_for(lambda: view.tree is not None, 10, "the first log/tree")
        # The skill server starts 8 s after the tree (the launch file): the tree is waiting for it now
        self.assertIsNone(node_pid("/skill_test_server", missing=None), "the skill server started too early to test")
        response = view.change("Idle", "add")
        self.assertTrue(response.success, response.message)
        view.wait_for(lambda: "Idle_2" in view.nodes(), 3, "the edit on log/tree while waiting")
        view.wait_for(lambda: node_pid("/skill_test_server", missing=None) is not None, 30, "the skill server")
        before_the_server = seen.so_far()
        # Expect the edit served while waiting, and LookToShelf never ticked on any log/tree before the server was up
        self.assertGreaterEqual(len(before_the_server), 2, "the initial tree and the edit")
        self.assertEqual(set(before_the_server), {"INVALID"}, before_the_server)
        # Expect the sequence to start once the servers are up, and run to the end without a help request
        view.wait_completed(timeout=60)
        self.assertEqual(view.started(), [*THESIS_SEQUENCE, "Idle"])
        self.assertTrue(view.help is None or view.help.node_name == "", view.help)


if __name__ == "__main__":
    rospy.init_node("bt_startup_check")
    rostest.rosrun("teleteach", "bt_startup_check", WaitsForTheRobot)
