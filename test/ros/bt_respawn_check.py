#!/usr/bin/env python3
"""rostest check: SIGKILL of behaviour_tree after the operator removed PlaceItem; roslaunch respawns it and the new
process starts from the edited tree (not the default one) and runs it."""

import os
import signal
import unittest

import rospy
import rostest
from bt_ros_support import THESIS_SEQUENCE, TreeView
from ros_processes import node_pid

RESPAWN_TIMEOUT = 60.0  # [s] wall: respawn_delay plus the node's start on a loaded machine
EDITED = [name for name in THESIS_SEQUENCE if name != "PlaceItem"]


class TreeRespawned(unittest.TestCase):
    def test_respawned_tree_resumes_the_edited_tree(self):
        view = TreeView()
        view.wait_for(lambda: view.status("PickItem") == "RUNNING", 60, "PickItem running")
        self.assertTrue(view.change("PlaceItem", "remove").success)
        view.wait_for(lambda: view.children("BehaviorExecution") == EDITED, 10, "PlaceItem removed")
        killed = node_pid("/behaviour_tree")
        os.kill(killed, signal.SIGKILL)
        view.wait_respawned("/behaviour_tree", killed, RESPAWN_TIMEOUT)
        with view.lock:
            view.tree = None  # from here on only the new process's tree counts
        view.wait_for(lambda: view.status("PickItem") == "RUNNING", 60, "the respawned tree running PickItem")
        # Expect the operator's edit kept: the respawned node resumed the saved tree instead of config/tree.yaml
        self.assertEqual(view.children("BehaviorExecution"), EDITED)


if __name__ == "__main__":
    rospy.init_node("bt_respawn_check")
    rostest.rosrun("teleteach", "bt_respawn_check", TreeRespawned)
