#!/usr/bin/env python3
"""rostest check: the operator teaches the tree to place products with demonstrated and learned skills, and the world
says whether they did. A placing skill with an empty hand, and one that stops in front of the shelf (and so keeps the
product in the hand), each make the tree ask for help with the product, the gap and the distance; the DMP learned
from the placing demonstration by `learn_skill --add` then places product_pick_2 into gap_2 (demonstrated at gap_1,
reused from gap_2's base pose)."""

import dataclasses
import pathlib
import subprocess
import sys
import unittest

import numpy as np
import rospy
import rostest
from bt_robot_support import RobotView
from bt_ros_support import TreeView

from teleteach.core import skill_file
from teleteach.learning.synthetic import placement_on_trajectory

HELP_TIMEOUT = 240.0  # [s] wall: sim, skill servers and tree starting on a loaded machine, then a skill
RUN_TIMEOUT = 300.0  # [s] wall: several skills on the simulated robot


class TaughtSkillsDoTheJob(unittest.TestCase):
    def test_placing_skills_are_judged_by_where_the_product_ends(self):
        view = TreeView()
        robot = RobotView(view)
        data = pathlib.Path(rospy.get_param("~data_dir")) / "demonstrations"
        data.mkdir(parents=True, exist_ok=True)
        before = {name: robot.product(name) for name in robot.product_names()}
        self.ask_for_help(view, "DropItem", "no product in the gripper to drop")

        # the operator's demonstration (III-C, recorded at gap_1), its first 5 s, and the DMP learned from it
        demonstration = skill_file.save(placement_on_trajectory("perpendicular"), data / "DemonstratedPlace_1.npz")
        short = dataclasses.replace(placement_on_trajectory("perpendicular", until=5.0), name="PlaceShort")
        short_file = skill_file.save(short, data / "PlaceShort.npz")
        self.assertTrue(view.add_skill(name="PlaceShort", kind="stiffness", data_file=str(short_file)).success)
        command = [sys.executable, str(pathlib.Path(__file__).parents[2] / "nodes" / "learn_skill"), str(demonstration)]
        command += ["--name", "PlaceLearned", "--data-dir", str(data.parent), "--add", "--timeout", "30"]
        learned = subprocess.run(command, capture_output=True, text=True, timeout=120, check=False)
        self.assertEqual(learned.returncode, 0, learned.stdout + learned.stderr)
        view.wait_for(lambda: "PlaceLearned" in (view.library.names if view.library else []), 10, "PlaceLearned")

        # 1. a placing skill taught at a gap, run at the start pose with the hand empty: it finds no gap where it
        #    would place, fails before moving, the tree asks for help
        self.edit(view, ("PlaceLearned", "insert", 2), ("DropItem", "remove"))
        self.ask_for_help(
            view, "PlaceLearned", "PlaceLearned places relative to a gap like gap_1, but perception reports none within"
        )

        # 2. the demonstration's first 5 s after the move to gap_2: it stops in front of the shelf, so the product
        #    stays in the hand
        self.edit(view, ("PlaceLearned", "remove"), ("PlaceShort", "insert", 3))
        reason = self.ask_for_help(view, "PlaceShort", "product_pick_2 ended ")
        self.assertRegex(reason, r"^product_pick_2 ended 1\d\.\d cm from gap_2 \(.*\); it is still in the hand$")
        horizontal, _ = robot.gap_distance("product_pick_2", "gap_2")
        self.assertGreater(horizontal, 0.1)

        # 3. the learned skill, reused at gap_2, does the job from there: it goes after the failed leaf, which goes
        self.edit(view, ("PlaceLearned", "insert", 4), ("PlaceShort", "remove"))
        view.wait_completed(timeout=RUN_TIMEOUT)
        message = view.nodes()["PlaceLearned"].message
        self.assertEqual(view.status("PlaceLearned"), "SUCCESS", message)
        self.assertIn("replayed PlaceLearned (dmp)", message)
        self.assertIn("product_pick_2 released upright in gap_2", message)
        # Expect, from /teleteach/true_scene: product_pick_2 in gap_2, and no product that stood on the shelf moved
        self.assertTrue(*robot.in_gap("product_pick_2", "gap_2"))
        for name, position in before.items():
            if name.startswith("product_shelf") or name.startswith("product_low"):
                self.assertLess(np.linalg.norm(robot.product(name) - position), 0.01, name)

    def ask_for_help(self, view, node, reason_start):
        """Wait for the tree's help request about node; check its reason and that the tree paused."""
        view.wait_for(lambda: view.help is not None and view.help.node_name == node, HELP_TIMEOUT, f"help for {node}")
        self.assertTrue(view.help.reason.startswith(reason_start), view.help.reason)
        view.wait_for(lambda: view.status("PauseCondition") == "SUCCESS", 10, "the tree paused")
        return view.help.reason

    def edit(self, view, *edits):
        """/change_tree requests while the tree waits for help, each of which must succeed; then the tree goes on."""
        for arguments in edits:
            response = view.change(*arguments)
            self.assertTrue(response.success, f"{arguments}: {response.message}")
        view.pause(False)


if __name__ == "__main__":
    rospy.init_node("bt_reuse_check")
    rostest.rosrun("teleteach", "bt_reuse_check", TaughtSkillsDoTheJob)
