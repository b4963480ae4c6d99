"""Helpers for the behaviour-tree rostests on the real robot (robot_sim + skill_server): where the products are
(/teleteach/true_scene: the world as it is, not as the robot perceives it), and which skill goals were sent (each
server's goal topic), in order."""

import threading
import time

import rospy
from visualization_msgs.msg import MarkerArray

from teleteach.msg import Behaviour, ExecuteSkillActionGoal
from teleteach.perception.observed import product_positions
from teleteach.scene import load_scene
from teleteach.skills.predefined import CONDITIONS, PREDEFINED_SKILLS


class RobotView:
    """The products' latest positions in world and the skill goals sent so far."""

    def __init__(self, tree_view, timeout=60.0):
        """Subscribes to every skill's goal topic and waits until each is connected; then notes which of
        ``tree_view``'s leaves had started already (their goals may have left before this node listened)."""
        self.scene = load_scene()
        self.lock = threading.Lock()
        self.products = {}
        self.goals = []
        rospy.Subscriber("/teleteach/true_scene", MarkerArray, self._on_scene, queue_size=1)
        goal_topics = [
            rospy.Subscriber(f"/skills/{name}/goal", ExecuteSkillActionGoal, self._on_goal, queue_size=10)
            for name in (*PREDEFINED_SKILLS, *CONDITIONS)
        ]
        deadline = time.monotonic() + timeout
        while any(topic.get_num_connections() == 0 for topic in goal_topics) or tree_view.tree is None:
            if time.monotonic() > deadline or rospy.is_shutdown():
                raise AssertionError(f"skill goal topics or the tree not connected within {timeout} s")
            time.sleep(0.05)
        self.started_before = {name for name, node in tree_view.nodes().items() if node.status != Behaviour.INVALID}

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
        """Whether the goals seen were sent in this order, each once; goal topics are not latched, so the first ones
        may be missing when their leaves had started before every goal topic was connected."""
        goals, expected = self.sent_goals(), list(expected)
        missable = next((k for k, name in enumerate(expected) if name not in self.started_before), len(expected))
        return any(goals == expected[k:] for k in range(max(missable, 1) + 1))

    def product_names(self, timeout=30.0):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline and not rospy.is_shutdown():
            with self.lock:
                if self.products:
                    return set(self.products)
            time.sleep(0.05)
        raise AssertionError("no products on /teleteach/true_scene")

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
