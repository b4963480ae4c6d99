#!/usr/bin/env python3
"""The whole predefined sequence through the action servers: product_pick_1 must end in the shelf's gap_1."""

import math
import pathlib
import tempfile
import threading
import unittest

import actionlib
import numpy as np
import rospy
import rostest
from actionlib_msgs.msg import GoalStatus
from geometry_msgs.msg import PoseStamped
from scipy.spatial.transform import Rotation
from visualization_msgs.msg import MarkerArray

from teleteach import skill_file
from teleteach.msg import ExecuteSkillAction, ExecuteSkillGoal
from teleteach.sim.scene import load_scene, product_positions
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
        rospy.Subscriber("/teleteach/scene", MarkerArray, cls.on_scene, queue_size=1)

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

    def run_skill(self, name, skill=None, parameters="", cancel_after=None):
        client = actionlib.SimpleActionClient(f"/skills/{name}", ExecuteSkillAction)
        self.assertTrue(client.wait_for_server(rospy.Duration(60.0)), f"/skills/{name} is not served")
        feedback = []
        goal = ExecuteSkillGoal(skill=skill or name, parameters=parameters)
        client.send_goal(goal, feedback_cb=lambda msg: feedback.append(msg.progress))
        if cancel_after is not None:
            rospy.sleep(cancel_after)
            client.cancel_goal()
        self.assertTrue(client.wait_for_result(rospy.Duration(SKILL_TIMEOUT)), f"{name} did not finish")
        result = client.get_result()
        rospy.loginfo(f"{name}: {client.get_state()} {result.message}")
        return client.get_state(), result, feedback

    def assert_progress_to_the_end(self, feedback):
        """Progress never goes back and gets to the end: the server's last feedback is 1.0, but actionlib drops
        feedback that lands after the result, so the last one or two received may be a step or two short of it."""
        steps = [later - earlier for earlier, later in zip(feedback, feedback[1:])]
        self.assertTrue(all(step >= 0.0 for step in steps), feedback[-10:])
        self.assertGreaterEqual(feedback[-1], 1.0 - 2.0 * max(steps, default=0.0) - 1e-6, feedback[-5:])

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

    def write_skill(self, folder, duration):
        pose = rospy.wait_for_message("/cartesian_pose", PoseStamped, 30.0).pose
        start = np.array([pose.position.x, pose.position.y, pose.position.z])
        quaternion = [pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w]
        fractions = np.linspace(0.0, 1.0, 21)[:, None]
        positions = start + fractions * np.array([0.0, 0.04, 0.0])
        poses = np.hstack([positions, np.tile(quaternion, (21, 1))])
        rotated = Rotation.from_euler("z", math.pi / 4).as_matrix()
        final = rotated @ np.diag([300.0, 1500.0, 1000.0]) @ rotated.T
        stiffness = np.array([(1 - f) * np.diag([800.0] * 3) + f * final for f in fractions[:, 0]])
        skill = skill_file.Skill("replayed", "stiffness", np.linspace(0.0, duration, 21), stiffness, poses, poses)
        return skill_file.save(skill, pathlib.Path(folder) / f"replayed_{duration:.0f}")

    def test_replay_of_a_stiffness_skill_and_its_preemption(self):
        with tempfile.TemporaryDirectory() as folder:
            path = self.write_skill(folder, 1.0)
            parameters = f"{{data_file: {path}, kind: stiffness}}"
            state, result, feedback = self.run_skill("ReplaySkill", "replayed", parameters)
            self.assertEqual(state, GoalStatus.SUCCEEDED, result.message)
            self.assertIn("final end-effector error", result.message)
            self.assert_progress_to_the_end(feedback)
            self.assertEqual(self.running_controllers(), ["position_joint_trajectory_controller"])
            # Expect: a cancelled replay ends preempted, back on the position controller
            path = self.write_skill(folder, 4.0)
            parameters = f"{{data_file: {path}, kind: stiffness}}"
            state, result, _ = self.run_skill("ReplaySkill", "replayed", parameters, cancel_after=1.5)
            self.assertEqual(state, GoalStatus.PREEMPTED, result.message)
            self.assertEqual(self.running_controllers(), ["position_joint_trajectory_controller"])
            # Expect: a bad file is refused with the skill file's own error
            state, result, _ = self.run_skill("ReplaySkill", "replayed", f"{{data_file: {folder}/missing.npz}}")
            self.assertEqual(state, GoalStatus.ABORTED)
            self.assertEqual(result.message, f"skill file {folder}/missing.npz does not exist")


if __name__ == "__main__":
    rostest.rosrun("teleteach", "pick_and_place_check", PickAndPlaceTest)
