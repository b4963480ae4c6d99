#!/usr/bin/env python3
"""The whole predefined sequence through the action servers: product_pick_1 must end in the shelf's gap_1; then a
taught placing skill, replayed, puts product_pick_2 into gap_2."""

import pathlib
import tempfile
import threading
import time
import unittest

import actionlib
import numpy as np
import rospy
import rostest
from actionlib_msgs.msg import GoalStatus
from visualization_msgs.msg import MarkerArray

from teleteach.core import skill_file
from teleteach.core.observed import product_positions
from teleteach.core.scene import load_scene
from teleteach.learning.synthetic import placement_on_trajectory
from teleteach.msg import ExecuteSkillAction, ExecuteSkillActionFeedback, ExecuteSkillGoal
from teleteach.skills.predefined import PREDEFINED_SKILLS
from teleteach.srv import ListControllers

SKILL_TIMEOUT = 120.0  # [s] sim time per skill


class PickAndPlaceTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("pick_and_place_check")
        cls.scene = load_scene()
        cls.lock = threading.Lock()
        cls.products = {}
        cls.clients = {}
        rospy.Subscriber("/teleteach/true_scene", MarkerArray, cls.on_scene, queue_size=1)  # the world, as it is

    @classmethod
    def on_scene(cls, msg):
        with cls.lock:
            cls.products.update(product_positions(msg.markers))

    def product(self, name):
        start = rospy.get_time()
        while rospy.get_time() - start < 0.5:  # [s] sim time: a scene published after the skill ended
            rospy.sleep(0.05)
        with self.lock:
            return self.products[name].copy()

    def gap_distance(self, name):
        return self.scene.gap("gap_1").distance(self.product(name))

    def client(self, name):
        """One action client per skill for the whole test: a new client's result subscription may still be connecting
        when a goal that is refused at once (a few ms) ends, and that result would be lost."""
        if name not in self.clients:
            client = actionlib.SimpleActionClient(f"/skills/{name}", ExecuteSkillAction)
            self.assertTrue(client.wait_for_server(rospy.Duration(60.0)), f"/skills/{name} is not served")
            self.clients[name] = client
        return self.clients[name]

    def run_skill(self, name, skill=None, parameters="", cancel_after=None):
        """Send a goal and wait for its result; the feedback is read from the action's feedback topic itself, since
        actionlib's client drops feedback that it processes after the result."""
        client = self.client(name)
        feedback = []
        topic = rospy.Subscriber(
            f"/skills/{name}/feedback",
            ExecuteSkillActionFeedback,
            lambda message: feedback.append(message.feedback.progress),
            queue_size=1000,
        )
        deadline = time.monotonic() + 10.0
        while topic.get_num_connections() == 0 and time.monotonic() < deadline:
            time.sleep(0.01)
        client.send_goal(ExecuteSkillGoal(skill=skill or name, parameters=parameters))
        if cancel_after is not None:
            rospy.sleep(cancel_after)
            client.cancel_goal()
        self.assertTrue(client.wait_for_result(rospy.Duration(SKILL_TIMEOUT)), f"{name} did not finish")
        result, state = client.get_result(), client.get_state()
        deadline = time.monotonic() + 10.0
        while state == GoalStatus.SUCCEEDED and (not feedback or feedback[-1] < 1.0) and time.monotonic() < deadline:
            time.sleep(0.01)  # the last feedback (1.0, published before the result) comes on its own connection
        topic.unregister()
        rospy.loginfo(f"{name}: {state} {result.message}")
        return state, result, list(feedback)

    def assert_progress_to_the_end(self, feedback):
        """Progress never goes back and ends at 1.0 (the server's last feedback before a success)."""
        steps = [later - earlier for earlier, later in zip(feedback, feedback[1:])]
        self.assertTrue(all(step >= 0.0 for step in steps), feedback[-10:])
        self.assertEqual(feedback[-1], 1.0, feedback[-5:])

    def test_predefined_sequence_places_the_product(self):
        table_top = self.scene.pick_table.center[2] + self.scene.pick_table.size[2] / 2.0
        for name in PREDEFINED_SKILLS:
            state, result, feedback = self.run_skill(name)
            self.assertEqual(state, GoalStatus.SUCCEEDED, f"{name}: {result.message}")
            self.assertTrue(result.success, result.message)
            self.assertTrue(feedback, f"{name} sent no feedback")
            self.assertTrue(all(0.0 <= value <= 1.0 for value in feedback), feedback)
            self.assert_progress_to_the_end(feedback)
            if name == "PickItem":
                # Expect: product_pick_1 lifted off the table
                self.assertGreater(self.product("product_pick_1")[2], table_top + 0.2)
            if name == "DropItem":
                horizontal, vertical = self.gap_distance("product_pick_1")
                self.assertLessEqual(horizontal, self.scene.gap("gap_1").tolerance)
                self.assertLess(vertical, 0.02)
        # Expect: at the end the first product still stands in the gap, the second one is carried
        horizontal, vertical = self.gap_distance("product_pick_1")
        self.assertLessEqual(horizontal, self.scene.gap("gap_1").tolerance)
        self.assertLess(vertical, 0.02)
        self.assertGreater(self.product("product_pick_2")[2], table_top + 0.2)
        # Expect: the neighbours in the shelf were not pushed
        for product in self.scene.products:
            if product.name.startswith("product_shelf"):
                moved = np.linalg.norm(self.product(product.name) - np.array(product.position))
                self.assertLess(moved, 0.005, product.name)
        # Expect: picking product_pick_1 again fails, saying why (the behaviour tree asks the operator for help)
        state, result, _ = self.run_skill("PickItem")
        self.assertEqual(state, GoalStatus.ABORTED)
        self.assertFalse(result.success)
        self.assertEqual(result.message, "product_pick_1 is not on the table")

    def running_controllers(self):
        rospy.wait_for_service("/controller_manager/list_controllers", 30.0)
        response = rospy.ServiceProxy("/controller_manager/list_controllers", ListControllers)()
        return [controller.name for controller in response.controller if controller.state == "running"]

    def test_replay_of_a_placing_skill_its_preemption_and_a_bad_file(self):
        """After the predefined sequence the hand holds product_pick_2 in front of gap_2 (MoveBase2)."""
        with tempfile.TemporaryDirectory() as folder:
            path = skill_file.save(placement_on_trajectory("perpendicular"), pathlib.Path(folder) / "placing")
            parameters = f"{{data_file: {path}, kind: stiffness}}"
            # Expect: a cancelled replay ends preempted, the product still in the hand, back on the position controller
            state, result, _ = self.run_skill("ReplaySkill", "replayed", parameters, cancel_after=1.5)
            self.assertEqual(state, GoalStatus.PREEMPTED, result.message)
            self.assertEqual(self.running_controllers(), ["position_joint_trajectory_controller"])
            # Expect: the whole replay puts product_pick_2 into gap_2 and lets it go; the world agrees
            state, result, feedback = self.run_skill("ReplaySkill", "replayed", parameters)
            self.assertEqual(state, GoalStatus.SUCCEEDED, result.message)
            self.assertIn("product_pick_2 released upright in gap_2", result.message)
            self.assert_progress_to_the_end(feedback)
            self.assertEqual(self.running_controllers(), ["position_joint_trajectory_controller"])
            horizontal, vertical = self.scene.gap("gap_2").distance(self.product("product_pick_2"))
            self.assertLessEqual(horizontal, self.scene.gap("gap_2").tolerance)
            self.assertLess(vertical, 0.02)
            # Expect: with the hand now empty, a placing skill is refused before it moves
            state, result, _ = self.run_skill("ReplaySkill", "replayed", parameters)
            self.assertEqual(state, GoalStatus.ABORTED)
            self.assertTrue(
                result.message.startswith(
                    "DemonstratedPlace_1 places a product, but there is none in the hand: pick one first ("
                ),
                result.message,
            )
            # Expect: a bad file is refused with the skill file's own error
            state, result, _ = self.run_skill("ReplaySkill", "replayed", f"{{data_file: {folder}/missing.npz}}")
            self.assertEqual(state, GoalStatus.ABORTED)
            self.assertEqual(result.message, f"skill file {folder}/missing.npz does not exist")


if __name__ == "__main__":
    rostest.rosrun("teleteach", "pick_and_place_check", PickAndPlaceTest)
