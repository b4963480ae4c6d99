#!/usr/bin/env python3
"""rostest check: the tree and library survive SIGKILL. Starts behaviour_tree itself (~resume true) in a fresh data
directory, edits, kills it right after the service answered, restarts it and reads the edits back from log/tree."""

import os
import pathlib
import signal
import subprocess
import sys
import tempfile
import time
import unittest

import numpy as np
import rospkg
import rospy
import rostest
from bt_ros_support import THESIS_SEQUENCE

from teleteach.core import skill_file
from teleteach.msg import BehaviourTree, HelpRequest, SkillLibrary
from teleteach.srv import AddSkill, ChangeTree


def start_node(data_dir):
    node = pathlib.Path(rospkg.RosPack().get_path("teleteach")) / "nodes" / "behaviour_tree"
    # No robot here: tick at once instead of waiting startup_timeout for skill servers that never come
    command = [sys.executable, str(node), "_resume:=true", f"_data_dir:={data_dir}", "_startup_timeout:=0"]
    return subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)


def kill(process):
    os.killpg(process.pid, signal.SIGKILL)
    process.wait(timeout=10)


def latest(topic, message_type):
    return rospy.wait_for_message(topic, message_type, timeout=20)


class SurvivesSigkill(unittest.TestCase):
    def test_edits_survive_sigkill(self):
        data_dir = pathlib.Path(tempfile.mkdtemp(prefix="teleteach_bt_persistence_"))
        count = 5
        pose = np.tile([0.5, 0.0, 0.4, 0.0, 0.0, 0.0, 1.0], (count, 1))
        skill_file.save(
            skill_file.Skill(
                "Wipe", "stiffness", np.arange(count) * 0.1, np.tile(np.eye(3) * 500, (count, 1, 1)), pose, pose
            ),
            data_dir / "skills" / "wipe.npz",
        )
        first = start_node(data_dir)
        try:
            rospy.wait_for_service("/change_tree", timeout=30)
            change = rospy.ServiceProxy("/change_tree", ChangeTree)
            add_skill = rospy.ServiceProxy("/behaviour_tree/add_skill", AddSkill)
            self.assertTrue(add_skill(name="Wipe", kind="stiffness", data_file="skills/wipe.npz").success)
            self.assertTrue(change(node_name="PlaceItem", operation="remove").success)
            response = change(node_name="Wipe", operation="insert", index=1)
            self.assertTrue(response.success, response.message)
            response = change(node_name="PickItem", operation="add")
            self.assertEqual(response.new_node_name, "PickItem_2")
        finally:
            kill(first)  # right after the last answer: no clean shutdown
        second = start_node(data_dir)
        try:
            rospy.wait_for_service("/change_tree", timeout=30)
            expected = ["LookToShelf", "Wipe", *[n for n in THESIS_SEQUENCE[1:] if n != "PlaceItem"], "PickItem_2"]
            deadline = time.monotonic() + 20
            while time.monotonic() < deadline:
                tree = latest("/behaviour_tree/log/tree", BehaviourTree)
                by_id = {b.own_id: b.name for b in tree.behaviours}
                execution = next(b for b in tree.behaviours if b.name == "BehaviorExecution")
                if [by_id[i] for i in execution.child_ids] == expected:
                    break
            # Expect the restarted node to hold the edited tree and the taught skill
            self.assertEqual([by_id[i] for i in execution.child_ids], expected)
            copy = next(b for b in tree.behaviours if b.name == "PickItem_2")
            self.assertEqual(copy.class_name, "PickItem")
            library = latest("/behaviour_tree/skill_library", SkillLibrary)
            self.assertIn("Wipe", library.names)
            self.assertEqual(library.kinds[list(library.names).index("Wipe")], "stiffness")
            # Expect a missing skill server to fail the first leaf after a short wait and ask for help, not hang
            deadline = time.monotonic() + 20
            help_request = latest("/behaviour_tree/help_request", HelpRequest)
            while help_request.node_name == "" and time.monotonic() < deadline:
                time.sleep(0.2)
                help_request = latest("/behaviour_tree/help_request", HelpRequest)
            self.assertEqual(help_request.node_name, "LookToShelf")
            self.assertIn("no action server /skills/LookToShelf", help_request.reason)
        finally:
            kill(second)


if __name__ == "__main__":
    rospy.init_node("bt_persistence_check")
    rostest.rosrun("teleteach", "bt_persistence_check", SurvivesSigkill)
