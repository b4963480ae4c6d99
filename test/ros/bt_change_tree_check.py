#!/usr/bin/env python3
"""rostest check: thesis experiment III-B over ROS (remove PlaceItem while running -> Fig. B.1 bottom), a taught
skill added to the library and inserted at an index, and bad requests that change nothing."""

import pathlib
import unittest

import numpy as np
import rospy
import rostest
import yaml
from bt_ros_support import THESIS_SEQUENCE, TreeView

from teleteach.core import skill_file

FIG_B1_BOTTOM = [name for name in THESIS_SEQUENCE if name != "PlaceItem"]


def taught_skill(path):
    count = 20
    pose = np.tile([0.5, 0.0, 0.4, 0.0, 0.0, 0.0, 1.0], (count, 1))
    skill = skill_file.Skill(
        name="PlaceStiff",
        kind="stiffness",
        time=np.linspace(0.0, 2.0, count),
        stiffness=np.tile(np.diag([300.0, 800.0, 1500.0]), (count, 1, 1)),
        equilibrium_pose=pose,
        cartesian_pose=pose,
    )
    return skill_file.save(skill, path)


class ChangeTreeOverRos(unittest.TestCase):
    def test_thesis_experiment_and_bad_requests(self):
        view = TreeView()
        view.wait_for(lambda: view.status("PickItem") == "RUNNING", 30, "PickItem running")
        response = view.change("PlaceItem", "remove")
        self.assertTrue(response.success, response.message)
        # Expect the tree of thesis Fig. B.1 (bottom), PickItem still running on its first goal
        view.wait_for(lambda: view.children("BehaviorExecution") == FIG_B1_BOTTOM, 5, "Fig. B.1 bottom")
        self.assertEqual(view.children("Root"), ["PauseCondition", "BehaviorExecution"])
        self.assertEqual(view.status("PickItem"), "RUNNING")

        before = view.structure()
        bad = [
            (("PlaceItem", "remove"), "no node named 'PlaceItem'"),
            (("PickItem", "swap"), "unknown operation 'swap'"),
            (("", "add"), "empty node name"),
            (("Nothing", "insert", 2), "neither a node of the tree nor a skill"),
            (("DropItem", "insert", 10), "index 10 is out of range"),
            (("DropItem", "add", 0, "MoveBase"), "'MoveBase' is not a composite"),
            (("DropItem", "add", 0, "Nowhere"), "no composite named 'Nowhere'"),
            (("Root", "remove"), "root"),
            (("PauseCondition", "remove"), "pauses the tree"),
            (("BehaviorExecution", "remove"), "edits by default"),
            (("PickItem", "remove"), "it is running"),
        ]
        for arguments, expected in bad:
            response = view.change(*arguments)
            self.assertFalse(response.success, arguments)
            self.assertIn(expected, response.message, arguments)
        rospy.sleep(0.3)
        self.assertEqual(view.structure(), before)
        self.assertEqual(view.status("PickItem"), "RUNNING")

        data_dir = pathlib.Path(rospy.get_param("~data_dir"))
        taught_skill(data_dir / "skills" / "place_stiff.npz")
        response = view.add_skill(name="PlaceStiff", kind="stiffness", data_file="skills/place_stiff.npz")
        self.assertTrue(response.success, response.message)
        response = view.add_skill(name="Broken", kind="stiffness", data_file="skills/missing.npz")
        self.assertFalse(response.success)
        self.assertIn("does not exist", response.message)
        view.wait_for(lambda: "PlaceStiff" in view.library.names, 5, "PlaceStiff in the skill library")
        self.assertEqual(view.library.kinds[list(view.library.names).index("PlaceStiff")], "stiffness")

        response = view.change("PlaceStiff", "insert", 3)
        self.assertTrue(response.success, response.message)
        self.assertEqual(response.new_node_name, "PlaceStiff")
        expected = [*FIG_B1_BOTTOM[:3], "PlaceStiff", *FIG_B1_BOTTOM[3:]]
        view.wait_for(lambda: view.children("BehaviorExecution") == expected, 5, "PlaceStiff at index 3")
        self.assertEqual(view.nodes()["PlaceStiff"].class_name, "PlaceStiff")

        view.wait_completed(timeout=60)
        # Expect PickItem started once (never restarted by the edits), PlaceItem never run, the taught skill replayed
        self.assertEqual(view.event_list("cancel"), [])
        self.assertEqual(view.started(), expected)
        replay = [e for e in view.event_list("start") if e[1] == "ReplaySkill"]
        self.assertEqual(len(replay), 1)
        parameters = yaml.safe_load(replay[0][3])
        self.assertEqual(parameters["kind"], "stiffness")
        self.assertEqual(pathlib.Path(parameters["data_file"]), (data_dir / "skills" / "place_stiff.npz").resolve())


if __name__ == "__main__":
    rospy.init_node("bt_change_tree_check")
    rostest.rosrun("teleteach", "bt_change_tree_check", ChangeTreeOverRos)
