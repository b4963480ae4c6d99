#!/usr/bin/env python3
"""rostest check: skills in the target's frame through the real skill server, judged from the true scene.

With MoveBase's error and perception's noise on (config/uncertainty.yaml): a skill taught at gap_1 is refused before
it moves when asked for a gap perception does not report; replayed at the held-out gap_6 (the end cap, turned -45 deg,
15 cm higher) without naming it, it finds the gap and places product_pick_1 there; a skill whose insertion runs the
product's bottom into the shelf's lip pushes it hard enough to slip and turn in the fingers (measured from the true
scene and TF)."""

import dataclasses
import math
import pathlib
import tempfile
import threading
import time
import unittest

import actionlib
import numpy as np
import rospy
import rostest
import tf2_ros
from actionlib_msgs.msg import GoalStatus
from geometry_msgs.msg import Vector3Stamped
from scipy.spatial.transform import Rotation
from sensor_msgs.msg import JointState
from visualization_msgs.msg import MarkerArray

from teleteach.core import skill_file
from teleteach.core.observed import observed_from_markers
from teleteach.core.placement import judge
from teleteach.core.scene import load_scene
from teleteach.learning.synthetic import placement_on_trajectory
from teleteach.msg import ExecuteSkillAction, ExecuteSkillGoal, SkillAuthority

SKILL_TIMEOUT = 180.0  # [s] sim time per skill
DROP = 0.03  # [m] the pushing skill's reference runs this much lower from the alignment on: into the lip
LIFT = 0.005  # [m] the operator's correction while the skill is reused at gap_6 (base_link z)


def pushing_skill(taught: skill_file.Skill) -> skill_file.Skill:
    """The taught placement with its reference DROP lower from the alignment on: the product's bottom meets the lip."""
    poses = taught.equilibrium_pose.copy()
    poses[taught.time - taught.time[0] > 3.5, 2] -= DROP
    return dataclasses.replace(taught, name="IntoTheLip", equilibrium_pose=poses, cartesian_pose=poses)


class SkillTargetFrameTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.scene = load_scene()
        cls.lock = threading.Lock()
        cls.truth = None
        cls.joints = None
        cls.history = []  # (product_pick_2's position and rotation in the TCP's frame, finger opening)
        cls.tf = tf2_ros.Buffer()
        cls.listener = tf2_ros.TransformListener(cls.tf)
        rospy.Subscriber("/teleteach/true_scene", MarkerArray, cls.on_truth, queue_size=1)
        rospy.Subscriber("/joint_states", JointState, cls.on_joints, queue_size=1)
        cls.folder = tempfile.TemporaryDirectory()
        taught = placement_on_trajectory("perpendicular")
        cls.taught = skill_file.save(taught, pathlib.Path(cls.folder.name) / "DemonstratedPlace_1")
        cls.pushing = skill_file.save(pushing_skill(taught), pathlib.Path(cls.folder.name) / "IntoTheLip")

    @classmethod
    def tearDownClass(cls):
        cls.folder.cleanup()

    @classmethod
    def on_truth(cls, message):
        scene, _ = observed_from_markers(message.markers)
        with cls.lock:
            cls.truth = scene
        cls.record_in_hand(scene)

    @classmethod
    def on_joints(cls, message):
        with cls.lock:
            cls.joints = np.array(message.position)

    @classmethod
    def record_in_hand(cls, scene):
        try:
            stamped = cls.tf.lookup_transform("world", "panda_grasptarget", rospy.Time(0))
        except (tf2_ros.LookupException, tf2_ros.ConnectivityException, tf2_ros.ExtrapolationException):
            return
        t, r = stamped.transform.translation, stamped.transform.rotation
        hand = Rotation.from_quat([r.x, r.y, r.z, r.w])
        if "product_pick_2" not in scene.products:
            return
        product = scene.products["product_pick_2"]
        offset = hand.inv().apply(product.position - np.array([t.x, t.y, t.z]))
        turn = hand.inv() * Rotation.from_quat(product.quaternion)
        with cls.lock:
            if cls.joints is not None:
                cls.history.append((offset, turn, float(cls.joints[7] + cls.joints[8])))

    def world(self):
        deadline = time.monotonic() + 30.0
        while time.monotonic() < deadline:
            with self.lock:
                if self.truth is not None:
                    return self.truth
            time.sleep(0.05)
        raise AssertionError("no /teleteach/true_scene")

    def run_skill(self, name, parameters=""):
        client = actionlib.SimpleActionClient(f"/skills/{name}", ExecuteSkillAction)
        self.assertTrue(client.wait_for_server(rospy.Duration(60.0)), f"/skills/{name} is not served")
        client.send_goal(ExecuteSkillGoal(skill=name, parameters=parameters))
        self.assertTrue(client.wait_for_result(rospy.Duration(SKILL_TIMEOUT)), f"{name} did not finish")
        result = client.get_result()
        rospy.loginfo(f"{name}: {client.get_state()} {result.message}")
        return client.get_state(), result

    def joint_positions(self):
        with self.lock:
            return None if self.joints is None else self.joints.copy()

    @staticmethod
    def correct(done):
        """The operator: LIFT in base_link at 30 Hz, each followed by one in world and one with NaN (refused)."""
        publisher = rospy.Publisher("/skills/correction", Vector3Stamped, queue_size=10)
        while not done.is_set() and not rospy.is_shutdown():
            for frame, vector in (
                ("base_link", (0.0, 0.0, LIFT)),
                ("world", (0.3, 0.0, LIFT)),
                ("base_link", (math.nan, 0.0, 0.0)),
            ):
                message = Vector3Stamped()
                message.header.frame_id = frame
                message.vector.x, message.vector.y, message.vector.z = vector
                publisher.publish(message)
                time.sleep(0.01)
        publisher.unregister()

    def placed(self, product, gap, before):
        rospy.sleep(0.5)  # a true scene published after the skill ended
        truth = self.world()
        final = {name: box.position for name, box in truth.products.items()}
        box = truth.products[product]
        return judge(truth, product, (box.position, box.quaternion), before, final, gap)

    def test_refused_without_its_target_then_placed_at_a_held_out_gap_then_slipping_under_a_hard_push(self):
        for name, parameters in (("LookToShelf", ""), ("PickItem", ""), ("MoveBase", "{base_pose: place_gap_6}")):
            state, result = self.run_skill(name, parameters)
            self.assertEqual(state, GoalStatus.SUCCEEDED, f"{name}: {result.message}")

        # 1. asked for a gap perception does not report: refused before moving, naming the skill and the gap
        before = self.joint_positions()
        state, result = self.run_skill("ReplaySkill", f"{{data_file: {self.taught}, target: gap_9}}")
        self.assertEqual(state, GoalStatus.ABORTED)
        self.assertTrue(
            result.message.startswith(
                "DemonstratedPlace_1 (taught at gap_1) cannot be replayed at gap_9: perception reports no gap_9"
            ),
            result.message,
        )
        rospy.sleep(0.5)
        self.assertLess(np.abs(self.joint_positions()[:7] - before[:7]).max(), 0.005)

        # 2. reused at the held-out gap_6 without naming it: found and placed there, judged from the true scene,
        # while the operator lifts it a little (/skills/correction), between corrections in the wrong frame and NaN
        start = {name: box.position for name, box in self.world().products.items()}
        reports = []
        listener = rospy.Subscriber("/skills/authority", SkillAuthority, reports.append, queue_size=100)
        operator = threading.Event()
        thread = threading.Thread(target=self.correct, args=(operator,), daemon=True)
        thread.start()
        try:
            state, result = self.run_skill("ReplaySkill", f"{{data_file: {self.taught}}}")
        finally:
            operator.set()
            thread.join(timeout=2.0)
            listener.unregister()
        self.assertEqual(state, GoalStatus.SUCCEEDED, result.message)
        self.assertIn("relative to gap_6 (taught at gap_1)", result.message)
        placement = self.placed("product_pick_1", "gap_6", start)
        self.assertEqual(placement.problems("gap_6"), [])
        # Expect who leads reported while it replayed: one demonstration (spread_unknown) at a target other than the
        # taught one: neither leads alone; the correction applied is the operator's, weighted; the refused ones none
        self.assertGreater(len(reports), 20)
        last = reports[-1]
        self.assertEqual({report.skill for report in reports}, {"DemonstratedPlace_1"})
        self.assertTrue(0.1 < last.confidence < 0.9, last.confidence)
        self.assertAlmostEqual(last.operator_weight, 1.0 - last.confidence, places=6)
        self.assertAlmostEqual(last.correction.z, last.operator_weight * LIFT, delta=2e-4)
        self.assertEqual(max(abs(r.correction.x) + abs(r.correction.y) for r in reports), 0.0)

        # 3. product_pick_2 run into gap_7's lip by a skill aimed too low: it slips and turns between the fingers
        for name, parameters in (
            ("MoveBaseToStart", ""),
            ("LookToShelfAgain", ""),
            ("PickItem2", ""),
            ("MoveBase", "{base_pose: place_gap_7}"),
        ):
            state, result = self.run_skill(name, parameters)
            self.assertEqual(state, GoalStatus.SUCCEEDED, f"{name}: {result.message}")
        with self.lock:
            self.history.clear()
        state, result = self.run_skill("ReplaySkill", f"{{data_file: {self.pushing}, target: gap_7}}")
        self.assertEqual(state, GoalStatus.ABORTED, result.message)
        with self.lock:
            held = [(offset, turn) for offset, turn, width in self.history if width < 0.065]
        self.assertGreater(len(held), 10, "no true scene while the product was held")
        start, start_turn = held[0]
        # Expect: held 3.5 cm below the TCP at first; then the lip stops its bottom while the insertion pushes on
        # (2100 N/m): the product slips (> 1 cm) or turns (> 10 deg) in the fingers
        self.assertAlmostEqual(float(start[2]), 0.035, delta=0.003)
        shift = max(float(np.linalg.norm(offset - start)) for offset, _ in held)
        turn = max(float(np.degrees((rotation * start_turn.inv()).magnitude())) for _, rotation in held)
        self.assertTrue(shift > 0.01 or turn > 10.0, f"shift {1000 * shift:.1f} mm, turn {turn:.1f} deg")


if __name__ == "__main__":
    rospy.init_node("skill_target_frame_check")
    rostest.rosrun("teleteach", "skill_target_frame_check", SkillTargetFrameTest)
