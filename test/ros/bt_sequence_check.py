#!/usr/bin/env python3
"""rostest check: the behaviour_tree node runs the thesis sequence to completion against real action servers."""

import unittest

import rospy
import rostest
from bt_ros_support import THESIS_SEQUENCE, TreeView
from std_msgs.msg import String

from teleteach.msg import Behaviour


class ThesisSequence(unittest.TestCase):
    def test_runs_the_thesis_sequence_to_completion(self):
        view = TreeView()
        view.wait_completed(timeout=60)
        # Expect every leaf done, in the thesis order, each goal sent once, nothing cancelled, nobody asked for help
        self.assertEqual(view.children("BehaviorExecution"), THESIS_SEQUENCE)
        for name in THESIS_SEQUENCE:
            self.assertEqual(view.status(name), "SUCCESS", name)
        self.assertEqual(view.status("PauseCondition"), "FAILURE")
        self.assertEqual(view.started(), THESIS_SEQUENCE)
        self.assertEqual(view.event_list("cancel"), [])
        view.wait_for(lambda: view.help is not None, 5, "the latched help_request")
        self.assertEqual(view.help.node_name, "")
        view.wait_for(lambda: view.library is not None, 5, "the latched skill library")
        self.assertEqual(list(view.library.names), [*THESIS_SEQUENCE, "ProductInHand", "ProductInGap"])
        self.assertEqual(list(view.library.kinds), ["predefined"] * len(THESIS_SEQUENCE) + ["condition"] * 2)
        # Expect the py_trees renderings (made once somebody subscribes) and the tip
        ascii_tree = rospy.wait_for_message("/behaviour_tree/ascii/tree", String, timeout=10).data
        self.assertEqual(ascii_tree.splitlines()[0].split()[-1], "Root")
        self.assertEqual([line.split()[-1] for line in ascii_tree.splitlines()[3:]], THESIS_SEQUENCE)
        snapshot = rospy.wait_for_message("/behaviour_tree/ascii/snapshot", String, timeout=10).data
        self.assertIn("Idle [o] -- Idle done", snapshot)
        dot = rospy.wait_for_message("/behaviour_tree/dot/tree", String, timeout=10).data
        self.assertTrue(dot.startswith("digraph"))
        self.assertIn("BehaviorExecution -> Idle;", dot)
        tip = rospy.wait_for_message("/behaviour_tree/tip", Behaviour, timeout=10)
        self.assertEqual(tip.name, "Idle")  # py_trees keeps the last child of a finished sequence as its tip
        nodes = view.nodes()
        self.assertEqual(nodes["Idle"].parent_id, nodes["BehaviorExecution"].own_id)
        self.assertEqual(nodes["Idle"].type, Behaviour.BEHAVIOUR)
        self.assertEqual(nodes["BehaviorExecution"].type, Behaviour.SEQUENCE)
        self.assertEqual(nodes["Root"].type, Behaviour.SELECTOR)
        self.assertEqual(nodes["Root"].child_ids, [nodes["PauseCondition"].own_id, nodes["BehaviorExecution"].own_id])


if __name__ == "__main__":
    rospy.init_node("bt_sequence_check")
    rostest.rosrun("teleteach", "bt_sequence_check", ThesisSequence)
