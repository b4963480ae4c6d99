#!/usr/bin/env python3
"""rostest check: the tree policy through /change_tree and the tree's own topics (help request, log/tree) and its
saved policy: unsure -> asks with the proposal attached, confirmed, learned; confident -> applied alone, announced,
the tree goes on after the veto window; an undo within the window -> the tree restored, asking again."""

import pathlib
import threading
import unittest

import rospy
import rostest
import yaml
from bt_ros_support import TreeView
from std_srvs.srv import Trigger

from teleteach.bt.editor import EditRequest
from teleteach.msg import HelpRequest

WINDOW = 4.0  # [s] the launch's veto_window
ACT = 0.8  # the launch's act_confidence


class HelpHistory:
    """Every help request the tree published, in order (TreeView keeps only the latest)."""

    def __init__(self):
        self.lock = threading.Lock()
        self.messages = []
        rospy.Subscriber("/behaviour_tree/help_request", HelpRequest, self._on_help, queue_size=50)

    def _on_help(self, message):
        with self.lock:
            self.messages.append(message)

    def latest(self):
        with self.lock:
            return self.messages[-1] if self.messages else None

    def about(self, node_name):
        with self.lock:
            return [message for message in self.messages if message.node_name == node_name]


class TreePolicyOverRos(unittest.TestCase):
    def setUp(self):
        self.view = TreeView()
        self.history = HelpHistory()
        self.start_tree = rospy.ServiceProxy("/behaviour_tree/start", Trigger)
        trees = pathlib.Path(rospy.get_param("/behaviour_tree/data_dir")) / "trees"
        self.policy_file = trees / "tree_policy.yaml"

    def test_unsure_asks_confident_acts_and_an_undo_in_the_veto_window_restores_the_tree(self):
        self.answer_the_first_three_failures()
        self.confident_it_applies_alone_and_goes_on()
        self.an_undo_in_the_window_vetoes()

    def answer_the_first_three_failures(self):
        view = self.view
        asked = self.wait_help("PickItem")
        self.assertEqual((list(asked.suggestion), list(asked.proposal)), ([], []))  # nothing demonstrated yet
        self.edit("PickItem", "remove")
        view.pause(False)
        # Expect (a): the drive's failure was never demonstrated: it asks, its proposal attached, confidence 0
        asked = self.wait_help("MoveBase")
        self.assertEqual((list(asked.proposal), asked.applied), (["remove MoveBase"], False))
        self.assertEqual(list(asked.suggestion), [])  # nothing remembered of this failure
        self.assertEqual(asked.confidence, 0.0)
        self.assertIn("base_not_reached", asked.why)
        self.assertIn("MoveBase", view.children("BehaviorExecution"))
        self.edit("MoveBase", "repair")  # the operator confirms with one click (nothing remembered: the proposal)
        view.wait_for(lambda: "MoveBase" not in view.children("BehaviorExecution"), 5, "the tree edited")
        view.pause(False)
        self.wait_demonstrations(2)
        self.assertEqual(self.demonstrations()[1]["edits"], [self.removal("MoveBase")])
        self.wait_help("PlaceItem")
        self.edit("LookToShelf", "insert", view.children("BehaviorExecution").index("PlaceItem"))
        self.edit("PlaceItem", "remove")
        view.pause(False)
        view.wait_completed(timeout=30)
        self.assertEqual(len(self.demonstrations()), 3)

    def confident_it_applies_alone_and_goes_on(self):
        view = self.view
        self.edit("PickItem", "insert", 1)  # the failing pick again, where it was: a situation the policy knows
        self.assertTrue(self.start_tree().success)
        # Expect (b): applied alone (the pick removed), announced with its confidence and the veto window, paused
        applied = self.wait_help("PickItem", lambda message: message.applied)
        self.assertEqual(list(applied.proposal), ["remove PickItem"])
        self.assertGreaterEqual(applied.confidence, ACT)
        self.assertAlmostEqual(applied.veto_window, WINDOW, places=3)
        view.wait_for(lambda: "PickItem" not in view.children("BehaviorExecution"), 5, "the proposal applied")
        # Expect: nobody vetoes, so the tree goes on by itself after the window and completes
        history = self.history
        view.wait_for(lambda: history.latest().node_name == "", WINDOW + 5, "the help request closed by the tree")
        closed = history.latest().header.stamp - applied.header.stamp
        self.assertGreaterEqual(closed.to_sec(), WINDOW - 0.5)
        view.wait_completed(timeout=30)
        self.assertEqual(len(self.demonstrations()), 3)  # the robot's own edit teaches nothing

    def an_undo_in_the_window_vetoes(self):
        view = self.view
        self.edit("PickItem", "insert", 1)
        view.wait_for(lambda: "PickItem" in view.children("BehaviorExecution"), 5, "the pick inserted")
        before = view.structure()
        self.assertTrue(self.start_tree().success)
        applied_before = len(self.history.about("PickItem"))
        self.wait_help("PickItem", lambda message: message.applied, skip=applied_before)
        view.wait_for(lambda: "PickItem" not in view.children("BehaviorExecution"), 5, "the proposal applied")
        self.edit("", "undo")
        # Expect (c): the tree as before the proposal, the help request open and asking, and no resume after the window
        view.wait_for(lambda: view.structure() == before, 5, "the tree restored")
        vetoed = self.wait_help("PickItem", lambda message: not message.applied, skip=applied_before)
        self.assertTrue(vetoed.why.startswith("vetoed by the operator"), vetoed.why)
        self.assertEqual(vetoed.veto_window, 0.0)
        rospy.sleep(WINDOW + 1.0)
        self.assertEqual((view.help.node_name, view.status("PauseCondition")), ("PickItem", "SUCCESS"))
        self.assertEqual(view.structure(), before)
        # Expect: the operator's own answer (a look instead of the pick) becomes the fourth demonstration
        self.edit("LookToShelf", "insert", 1)
        self.edit("PickItem", "remove")
        view.pause(False)
        self.wait_demonstrations(4)
        self.assertEqual(self.demonstrations()[3]["edits"][1], self.removal("PickItem"))
        view.wait_completed(timeout=30)

    def edit(self, node_name, operation, index=0):
        response = self.view.change(node_name, operation, index)
        self.assertTrue(response.success, response.message)
        return response

    def wait_help(self, node_name, condition=lambda message: True, skip=0):
        """The first help request about node_name (after the first skip of them) that meets condition."""
        found = []

        def arrived():
            found[:] = [message for message in self.history.about(node_name)[skip:] if condition(message)]
            return bool(found)

        self.view.wait_for(arrived, 60, f"a help request about {node_name}")
        return found[0]

    def demonstrations(self):
        if not self.policy_file.is_file():
            return []
        return yaml.safe_load(self.policy_file.read_text())["demonstrations"]

    def wait_demonstrations(self, count):
        self.view.wait_for(lambda: len(self.demonstrations()) == count, 10, f"{count} demonstrations saved")

    @staticmethod
    def removal(node_name):
        """A removal of node_name as the saved policy writes it (EditRequest's fields)."""
        return dict(EditRequest(node_name, "remove")._asdict())


if __name__ == "__main__":
    rospy.init_node("bt_tree_policy_check")
    rostest.rosrun("teleteach", "bt_tree_policy_check", TreePolicyOverRos)
