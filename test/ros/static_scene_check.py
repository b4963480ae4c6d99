#!/usr/bin/env python3
"""The skills on a robot without perception: static_scene publishes teleteach/scene from config/supermarket.yaml,
robot_sim's own (true) scene goes to /true_scene, which only this check reads. The pick-and-place skills succeed on the
belief, and the belief agrees with the world: product_pick_1 carried, then standing in gap_1, in both."""

import threading
import unittest

import actionlib
import numpy as np
import rospy
import rostest
from actionlib_msgs.msg import GoalStatus
from visualization_msgs.msg import MarkerArray

from teleteach.core.observed import observed_from_markers
from teleteach.core.scene import load_objects
from teleteach.msg import ExecuteSkillAction, ExecuteSkillGoal

SKILL_TIMEOUT = 120.0  # [s] sim time per skill
AGREEMENT = 0.02  # [m] belief and world agree on a product's centre within this
SETTLE = 0.5  # [s] sim time after a skill's end: the scenes compared are stamped at least this much later
SCENE_WAIT = 30.0  # [s] wall time to wait for such scenes (a loaded machine runs every process late)


class Scenes:
    """The latest believed (teleteach/scene) and true (/true_scene) scenes."""

    def __init__(self):
        self.lock = threading.Condition()
        self.latest = {}
        self.rejected = []  # (which scene, marker rejected): asserted by the test, not in the callback's thread
        rospy.Subscriber("/teleteach/scene", MarkerArray, self._keep, "believed", queue_size=1)
        rospy.Subscriber("/true_scene", MarkerArray, self._keep, "true", queue_size=1)

    def _keep(self, msg, which):
        scene, rejected = observed_from_markers(msg.markers)
        with self.lock:
            self.latest[which] = scene
            self.rejected += [(which, marker) for marker in rejected]
            self.lock.notify_all()

    def get(self, which, after):
        """The latest scene of which, once one stamped after `after` [s] (the robot's clock) has come."""
        with self.lock:
            fresh = self.lock.wait_for(lambda: which in self.latest and self.latest[which].stamp >= after, SCENE_WAIT)
            assert fresh, f"no {which} scene stamped after {after:.2f} s came in {SCENE_WAIT:.0f} s"
            assert self.rejected == [], self.rejected  # every marker of both scenes is one the skills can read
            return self.latest[which]


class StaticSceneTest(unittest.TestCase):
    def test_the_skills_run_on_the_belief_and_it_agrees_with_the_world(self):
        scenes = Scenes()
        objects = load_objects()
        gap = objects.gap("gap_1")
        clients = {}
        for name in ("LookToShelf", "PickItem", "MoveBase", "PlaceItem", "DropItem", "PickItem"):
            if name not in clients:
                clients[name] = actionlib.SimpleActionClient(f"/skills/{name}", ExecuteSkillAction)
                self.assertTrue(clients[name].wait_for_server(rospy.Duration(600.0)), name)  # sim time runs fast
            client = clients[name]
            client.send_goal(ExecuteSkillGoal(skill=name))
            self.assertTrue(client.wait_for_result(rospy.Duration(SKILL_TIMEOUT)), name)
            state, message = client.get_state(), client.get_result().message
            rospy.loginfo(f"{name}: {state} {message}")
            after = rospy.get_time() + SETTLE
            believed, true = scenes.get("believed", after), scenes.get("true", after)
            held = believed.product("product_pick_1").position
            actual = true.product("product_pick_1").position
            # Expect: belief and world agree where product_pick_1 is after every skill
            self.assertLess(np.linalg.norm(held - actual), AGREEMENT, (name, held, actual))
            if name == "PickItem" and state == GoalStatus.SUCCEEDED:
                self.assertGreater(held[2], 0.6)  # lifted off the table (top at 0.43 m)
            if name == "DropItem":
                self.assertEqual(state, GoalStatus.SUCCEEDED, message)
                horizontal, vertical = gap.distance(held)
                self.assertLessEqual(horizontal, gap.tolerance)
                self.assertLess(vertical, 0.02)
                self.assertLessEqual(gap.distance(actual)[0], gap.tolerance)
        # Expect: the second pick is refused: the belief has product_pick_1 in the shelf, as the world does
        self.assertEqual(state, GoalStatus.ABORTED)
        self.assertEqual(message, "product_pick_1 is not on the table")
        # Expect: the other products of the file stand where the file puts them (the belief moves only the held one)
        for product in objects.products:
            if product.name != "product_pick_1":
                np.testing.assert_allclose(believed.product(product.name).position, product.position)


if __name__ == "__main__":
    rospy.init_node("static_scene_check")
    rostest.rosrun("teleteach", "static_scene_check", StaticSceneTest)
