#!/usr/bin/env python3
"""rostest check: convert, wrap, unwrap, undo and redo over /change_tree while the tree runs on the simulated robot
(product_pick_1 absent): a retry around PickItem makes two attempts before the help request; undo and redo move the
decorator out and back without touching the waiting leaf; PickItem2 inserted in front runs first, an inverter
around the retry lets the tree go on; the product ends in the gap; the saved tree holds the decorators and history,
and the repair memory the edits that answered the help request."""

import pathlib
import unittest

import rospy
import rostest
import yaml
from bt_robot_support import RobotView
from bt_ros_support import TreeView

from teleteach.msg import Behaviour

STARTUP_TIMEOUT = 180.0  # [s] wall: sim, skill servers and tree on a loaded machine
COMPLETION_TIMEOUT = 480.0  # [s] wall: the rest of the sequence
EDITED = [
    "LookToShelf",
    "PickItem2",
    "InverterRetryPickItem",
    "MoveBase",
    "PlaceItem",
    "DropItem",
    "MoveBaseToStart",
    "LookToShelfAgain",
    "Idle",
]


class EditsOnTheRobot(unittest.TestCase):
    def change(self, view, *arguments, **keywords):
        response = view.change(*arguments, **keywords)
        self.assertTrue(response.success, f"{arguments} {keywords}: {response.message}")
        return response

    def test_decorators_undo_and_conversion_while_the_robot_works(self):
        view = TreeView()
        robot = RobotView(view)
        self.assertNotIn("product_pick_1", robot.product_names())
        view.wait_for(lambda: view.status("LookToShelf") == "RUNNING", STARTUP_TIMEOUT, "LookToShelf running")
        wrapped = self.change(view, "PickItem", "wrap", node_type="retry", parameter=2)
        self.assertEqual(wrapped.new_node_name, "RetryPickItem")
        # Expect the decorator in the published tree with PickItem inside, LookToShelf going on
        view.wait_for(lambda: view.children("RetryPickItem") == ["PickItem"], 10, "RetryPickItem around PickItem")
        self.assertEqual(view.nodes()["RetryPickItem"].type, Behaviour.DECORATOR)
        view.wait_for(lambda: view.help is not None and view.help.node_name == "PickItem", STARTUP_TIMEOUT, "help")
        # Expect two attempts (one absorbed by the retry), then the skill server's reason and the tree paused
        self.assertEqual(view.help.reason, "product_pick_1 is not on the table")
        self.assertTrue(robot.goals_sent_as(["LookToShelf", "PickItem", "PickItem"]), robot.sent_goals())
        view.wait_for(lambda: view.status("PauseCondition") == "SUCCESS", 10, "the tree paused")

        before = view.structure()
        for arguments, keywords, expected in [
            (("BehaviorExecution", "convert"), {"node_type": "selector"}, "while it runs"),
            (("Root", "wrap"), {"node_type": "inverter"}, "root of the tree"),
            (("PickItem", "wrap"), {"node_type": "retry", "parameter": 0}, "whole number >= 1, got 0"),
            (("PickItem", "unwrap"), {}, "not a decorator or a composite of one child"),
            (("", "redo"), {}, "nothing to redo"),
        ]:
            response = view.change(*arguments, **keywords)
            self.assertFalse(response.success, arguments)
            self.assertIn(expected, response.message, arguments)
        undone = self.change(view, "", "undo")
        self.assertEqual(undone.message, "undo: unwrapped 'PickItem' from the retry 'RetryPickItem'")
        view.wait_for(lambda: view.children("PickItem") == [] and "RetryPickItem" not in view.nodes(), 10, "unwrapped")
        self.assertEqual(view.children("BehaviorExecution")[1], "PickItem")
        self.change(view, "", "redo")
        view.wait_for(lambda: view.structure() == before, 10, "the retry back around PickItem")
        self.assertEqual(view.status("PauseCondition"), "SUCCESS")

        # The operator's repair: the second pick goes, the other product is picked first, the retry may fail
        for arguments in [("PickItem2", "remove"), ("MoveBase2", "remove"), ("PickItem2", "insert", 1)]:
            self.change(view, *arguments)
        self.change(view, "RetryPickItem", "wrap", node_type="inverter")
        view.wait_for(lambda: view.children("BehaviorExecution") == EDITED, 10, "the edited tree")
        view.pause(False)

        view.wait_completed(timeout=COMPLETION_TIMEOUT)
        # Expect PickItem2 run before the retried PickItem (two more attempts), the rest once, the product placed
        self.assertTrue(
            robot.goals_sent_as(
                ["LookToShelf", "PickItem", "PickItem", "PickItem2", "PickItem", "PickItem", *EDITED[3:]]
            ),
            robot.sent_goals(),
        )
        self.assertTrue(*robot.in_gap("product_pick_2", "gap_1"))

        converted = self.change(view, "BehaviorExecution", "convert", node_type="selector")
        self.assertEqual(converted.message, "converted 'BehaviorExecution' from a sequence to a selector")
        view.wait_for(lambda: view.nodes()["BehaviorExecution"].type == Behaviour.SELECTOR, 10, "a selector")
        self.change(view, "", "undo")
        view.wait_for(lambda: view.nodes()["BehaviorExecution"].type == Behaviour.SEQUENCE, 10, "a sequence again")

        # Expect the saved tree to hold both decorators and every edit, the last conversion waiting for redo
        saved_file = pathlib.Path(rospy.get_param("/behaviour_tree/data_dir")) / "trees" / "current_tree.yaml"
        view.wait_for(lambda: "convert" in str(saved_history(saved_file)["redo"]), 10, f"the history in {saved_file}")
        saved = yaml.safe_load(saved_file.read_text())
        self.assertIn("'type': 'inverter'", str(saved["root"]))
        self.assertEqual(
            [edit["edit"] for edit in saved["history"]["undo"]], ["wrap", "remove", "remove", "insert", "wrap"]
        )
        self.assertEqual([edit["edit"] for edit in saved["history"]["redo"]], ["convert"])
        # Expect the answer to the help request remembered as the repair of that failure (the undone wrap and its
        # redo came before it: not part of it)
        repairs = yaml.safe_load((saved_file.parent / "repairs.yaml").read_text())["repairs"]
        self.assertEqual(
            [(r["node"], r["reason"]) for r in repairs], [("PickItem", "product_pick_1 is not on the table")]
        )
        self.assertEqual(
            [(edit["operation"], edit["node_name"]) for edit in repairs[0]["edits"]],
            [("remove", "PickItem2"), ("remove", "MoveBase2"), ("insert", "PickItem2"), ("wrap", "RetryPickItem")],
        )


def saved_history(path):
    """The history of the saved tree (empty while it is being replaced)."""
    try:
        return (yaml.safe_load(path.read_text()) or {}).get("history") or {"undo": [], "redo": []}
    except (OSError, yaml.YAMLError):
        return {"undo": [], "redo": []}


if __name__ == "__main__":
    rospy.init_node("bt_robot_edits_check")
    rostest.rosrun("teleteach", "bt_robot_edits_check", EditsOnTheRobot)
