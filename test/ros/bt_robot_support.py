"""Helpers for the behaviour-tree rostests on the real robot (robot_sim + skill_server): where the products are
(/teleteach/scene), and which skill goals were sent (each server's goal topic), in order."""

import threading
import time

import rospy
from visualization_msgs.msg import MarkerArray

from teleteach.msg import ExecuteSkillActionGoal
from teleteach.sim.scene import load_scene, product_positions
from teleteach.skills.predefined import PREDEFINED_SKILLS


class RobotView:
    """The products' latest positions in world and the skill goals sent so far."""

    def __init__(self):
        self.scene = load_scene()
        self.lock = threading.Lock()
        self.products = {}
        self.goals = []
        rospy.Subscriber("/teleteach/scene", MarkerArray, self._on_scene, queue_size=1)
        for name in PREDEFINED_SKILLS:
            rospy.Subscriber(f"/skills/{name}/goal", ExecuteSkillActionGoal, self._on_goal, queue_size=10)

    def _on_scene(self, message):
        with self.lock:
            self.products.update(product_positions(message.markers))

    def _on_goal(self, message):
        with self.lock:
            self.goals.append(message.goal.skill)

    def sent_goals(self):
        with self.lock:
            return list(self.goals)

    def goals_sent_as(self, expected):
        """Whether the goals seen were sent in this order, each once (the first one may have left before this node
        subscribed: goal topics are not latched)."""
        goals = self.sent_goals()
        return goals in (list(expected), list(expected)[1:])

    def product_names(self, timeout=30.0):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline and not rospy.is_shutdown():
            with self.lock:
                if self.products:
                    return set(self.products)
            time.sleep(0.05)
        raise AssertionError("no products on /teleteach/scene")

    def product(self, name):
        # the scene is published at 10 Hz of sim time: wait for one published after the tree finished
        start = rospy.get_time()
        while rospy.get_time() - start < 0.5 and not rospy.is_shutdown():
            rospy.sleep(0.05)
        with self.lock:
            return self.products[name].copy()

    def gap_distance(self, name, gap="gap_1"):
        """Horizontal and vertical distance [m] of the product's centre from a gap target of the scene file."""
        return self.scene.gap(gap).distance(self.product(name))

    def in_gap(self, name, gap):
        """(whether the product's centre is within the gap's tolerance and 2 cm of its height, what was seen)."""
        horizontal, vertical = self.gap_distance(name, gap)
        inside = horizontal <= self.scene.gap(gap).tolerance and vertical < 0.02
        return inside, f"{name}: {1000 * horizontal:.1f} mm beside and {1000 * vertical:.1f} mm off {gap}'s target"
