#!/usr/bin/env python3
"""Two simulated systems on one master, in /robot_1 and /robot_2 (test/ros/two_systems.test): both trees run their
skills on their own robots; robot_1's tree is edited through /robot_1/change_tree and robot_2's is not touched (its
published tree and its saved file), and the other way round; each namespace has its own TF and services, and only
robot_1 publishes /clock."""

import pathlib
import threading
import time
import unittest

import numpy as np
import rosgraph
import rospy
import rostest
import yaml
from bt_ros_support import TreeView
from sensor_msgs.msg import JointState

ARM = [f"panda_joint{number}" for number in range(1, 8)]
MOVED = 0.2  # [rad] an arm whose joints went this far from where they were first heard moved under its skills


class Arm:
    """One robot's arm as its own /<ns>/joint_states says: the first and the farthest joint positions heard."""

    def __init__(self, namespace):
        self.lock = threading.Lock()
        self.first = None
        self.farthest = 0.0
        rospy.Subscriber(f"{namespace}/joint_states", JointState, self._on_joints, queue_size=1)

    def _on_joints(self, message):
        if not set(ARM) <= set(message.name):
            return
        positions = np.array([message.position[message.name.index(joint)] for joint in ARM])
        with self.lock:
            if self.first is None:
                self.first = positions
            self.farthest = max(self.farthest, float(np.max(np.abs(positions - self.first))))

    def moved(self):
        with self.lock:
            return self.farthest


def publishers():
    """Topic -> the nodes publishing it, from the master."""
    state = rosgraph.Master("/two_systems_check").getSystemState()
    return {topic: set(nodes) for topic, nodes in state[0]}


def execution_children(path):
    """The names of BehaviorExecution's children in a saved tree file."""
    root = yaml.safe_load(path.read_text())["root"]
    execution = next(child for child in root["children"] if child["name"] == "BehaviorExecution")
    return [child["name"] for child in execution["children"]]


def services():
    state = rosgraph.Master("/two_systems_check").getSystemState()
    return {service: set(nodes) for service, nodes in state[2]}


class TwoSystemsTest(unittest.TestCase):
    def test_an_edit_of_one_tree_leaves_the_other_alone(self):
        one, two = TreeView("/robot_1"), TreeView("/robot_2")
        arms = {"robot_1": Arm("/robot_1"), "robot_2": Arm("/robot_2")}
        # Expect: both trees ran their first skill (each robot's own arm is checked at the end)
        for name, view in (("robot_1", one), ("robot_2", two)):
            view.wait_for(lambda view=view: view.status("LookToShelf") == "SUCCESS", 300, f"{name}'s LookToShelf")
        self.assertIn("PlaceItem", one.children("BehaviorExecution"))
        # Expect: every name in its namespace: TF, the controller manager, the skills, the robot's actions
        topics, served = publishers(), services()
        for ns in ("/robot_1", "/robot_2"):
            self.assertEqual(topics[f"{ns}/tf"], {f"{ns}/robot_sim", f"{ns}/robot_state_publisher"})
            self.assertIn(f"{ns}/teleteach/scene", topics)
            self.assertIn(f"{ns}/franka_gripper/grasp/status", topics)
            self.assertIn(f"{ns}/move_base/status", topics)
            self.assertIn(f"{ns}/skills/PickItem/status", topics)
            self.assertEqual(served[f"{ns}/change_tree"], {f"{ns}/behaviour_tree"})
            self.assertEqual(served[f"{ns}/controller_manager/switch_controller"], {f"{ns}/robot_sim"})
        self.assertNotIn("/tf", topics)
        self.assertNotIn("/change_tree", served)
        # Expect: one clock on the master, robot_1's; robot_2's simulation follows it
        self.assertEqual(topics["/clock"], {"/robot_1/robot_sim"})

        # Remove PlaceItem from robot_1's tree (it has not run yet: PickItem takes 7 s)
        answer = one.change("PlaceItem", "remove")
        self.assertTrue(answer.success, answer.message)
        one.wait_for(lambda: "PlaceItem" not in one.children("BehaviorExecution"), 30, "robot_1's tree without it")
        # Expect: robot_2's tree, published after robot_1's change, still has PlaceItem and keeps running
        published = two.tree.header.stamp
        two.wait_for(lambda: two.tree.header.stamp > published, 30, "a newer tree from robot_2")
        self.assertIn("PlaceItem", two.children("BehaviorExecution"))
        self.assertNotIn("FAILURE", {two.status(name) for name in two.children("BehaviorExecution")})
        # The other way round: remove MoveBase2 from robot_2's tree; robot_1's keeps it
        answer = two.change("MoveBase2", "remove")
        self.assertTrue(answer.success, answer.message)
        two.wait_for(lambda: "MoveBase2" not in two.children("BehaviorExecution"), 30, "robot_2's tree without it")
        published = one.tree.header.stamp
        one.wait_for(lambda: one.tree.header.stamp > published, 30, "a newer tree from robot_1")
        self.assertIn("MoveBase2", one.children("BehaviorExecution"))
        self.assertIn("PlaceItem", two.children("BehaviorExecution"))
        # Expect: the saved trees too, each under trees/<namespace>/ of the shared data directory
        trees = pathlib.Path(rospy.get_param("~data_dir")) / "trees"
        saved = {ns: execution_children(trees / ns / "current_tree.yaml") for ns in ("robot_1", "robot_2")}
        self.assertEqual(saved["robot_1"], one.children("BehaviorExecution"))
        self.assertEqual(saved["robot_2"], two.children("BehaviorExecution"))
        self.assertTrue("PlaceItem" not in saved["robot_1"] and "MoveBase2" in saved["robot_1"], saved)
        self.assertTrue("PlaceItem" in saved["robot_2"] and "MoveBase2" not in saved["robot_2"], saved)
        self.assertFalse((trees / "current_tree.yaml").exists())
        # Expect: each robot's own arm moved under its tree's skills (a tree driving the other namespace's robot would
        # leave its own arm where it was first heard)
        deadline = time.monotonic() + 300.0
        while min(arm.moved() for arm in arms.values()) < MOVED and time.monotonic() < deadline:
            time.sleep(0.2)
        moved = {name: arm.moved() for name, arm in arms.items()}
        self.assertGreaterEqual(min(moved.values()), MOVED, moved)


if __name__ == "__main__":
    rospy.init_node("two_systems_check")
    rostest.rosrun("teleteach", "two_systems_check", TwoSystemsTest)
