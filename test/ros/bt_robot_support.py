"""Helpers for the behaviour-tree rostests on the real robot (robot_sim + skill_server): where the products are
(/teleteach/true_scene: the world as it is, not as the robot perceives it), and which skill goals were sent (each
server's goal topic, and its latched status for the goals sent before this node listened), in order."""

import functools
import threading
import time

import rospy
from actionlib_msgs.msg import GoalStatusArray
from visualization_msgs.msg import MarkerArray

from teleteach.core.observed import product_positions
from teleteach.core.scene import load_scene
from teleteach.msg import Behaviour, ExecuteSkillActionGoal
from teleteach.skills.predefined import CONDITIONS, PREDEFINED_SKILLS


class RobotView:
    """The products' latest positions in world and the skill goals sent so far."""

    def __init__(self, tree_view, timeout=60.0):
        """Subscribes to every skill's goal and status topics and waits until each is connected; then notes which of
        ``tree_view``'s leaves had started already (their goals may have left before this node listened)."""
        self.scene = load_scene()
        self.lock = threading.Lock()
        self.products = {}
        self.goals = []  # (goal id, skill) of each goal seen sent
        self.tracked = {}  # goal id -> (ROS time it was sent, skill) of each goal a server's status listed
        rospy.Subscriber("/teleteach/true_scene", MarkerArray, self._on_scene, queue_size=1)
        servers = (*PREDEFINED_SKILLS, *CONDITIONS)
        goal_topics = [
            rospy.Subscriber(f"/skills/{name}/goal", ExecuteSkillActionGoal, self._on_goal, queue_size=10)
            for name in servers
        ]
        for name in servers:  # latched: the goals a server still tracks, sent before this node listened too
            rospy.Subscriber(
                f"/skills/{name}/status", GoalStatusArray, functools.partial(self._on_status, name), queue_size=10
            )
        deadline = time.monotonic() + timeout
        while any(topic.get_num_connections() == 0 for topic in goal_topics) or tree_view.tree is None:
            if time.monotonic() > deadline or rospy.is_shutdown():
                raise AssertionError(f"skill goal topics or the tree not connected within {timeout} s")
            time.sleep(0.05)
        self.listening_since = rospy.get_rostime().to_sec()
        self.started_before = {name for name, node in tree_view.nodes().items() if node.status != Behaviour.INVALID}

    def _on_scene(self, message):
        with self.lock:
            self.products.update(product_positions(message.markers))

    def _on_goal(self, message):
        with self.lock:
            self.goals.append((message.goal_id.id, message.goal.skill))

    def _on_status(self, server, message):
        with self.lock:
            for status in message.status_list:
                self.tracked.setdefault(status.goal_id.id, (status.goal_id.stamp.to_sec(), server))

    def sent_goals(self):
        """The skills of the goals sent, in order: those a server's status showed were sent before this node
        listened, then those seen on the goal topics."""
        with self.lock:
            seen = {goal_id for goal_id, _ in self.goals}
            earlier = sorted(
                (stamp, skill)
                for goal_id, (stamp, skill) in self.tracked.items()
                if goal_id not in seen and stamp < self.listening_since
            )
            return [skill for _, skill in earlier] + [skill for _, skill in self.goals]

    def goals_sent_as(self, expected):
        """Whether the goals were sent in this order, each once. A server forgets a goal a while (5 s) after it
        ended: the first goals may be missing only when the tree had started their leaves before this node listened
        (and then only those)."""
        goals, expected = self.sent_goals(), list(expected)
        missable = next((k for k, name in enumerate(expected) if name not in self.started_before), len(expected))
        return any(goals == expected[k:] for k in range(missable + 1))

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
