"""Helpers for the behaviour-tree rostest checks: watch /behaviour_tree/log/tree and the test skill server's events,
call /change_tree, wait for conditions with a deadline (a failing check reports what it saw, never hangs)."""

import json
import os
import signal
import threading
import time

import rospy
from ros_processes import node_pid
from std_msgs.msg import Bool, String

from teleteach.msg import Behaviour, BehaviourTree, HelpRequest, SkillLibrary
from teleteach.skills.predefined import PREDEFINED_SKILLS
from teleteach.srv import AddSkill, ChangeTree

THESIS_SEQUENCE = list(PREDEFINED_SKILLS)  # the thesis tree's leaves, in the order it runs them
STATUS = {Behaviour.INVALID: "INVALID", Behaviour.RUNNING: "RUNNING", Behaviour.SUCCESS: "SUCCESS", 4: "FAILURE"}


class TreeView:
    """The latest log/tree, help request, skill library and skill server events of the tree in namespace (e.g.
    /robot_1; the root namespace by default)."""

    def __init__(self, namespace=""):
        self.lock = threading.Lock()
        self.tree = None
        self.help = None
        self.library = None
        self.histories = {}  # skill_test_server process id -> its events (a respawned server is a new process)
        ns = namespace.rstrip("/")
        rospy.Subscriber(f"{ns}/behaviour_tree/log/tree", BehaviourTree, self._on_tree, queue_size=10)
        rospy.Subscriber(f"{ns}/behaviour_tree/help_request", HelpRequest, self._on_help, queue_size=10)
        rospy.Subscriber(f"{ns}/behaviour_tree/skill_library", SkillLibrary, self._on_library, queue_size=10)
        rospy.Subscriber(f"{ns}/skill_test_server/events", String, self._on_event, queue_size=100)
        self.pause_publisher = rospy.Publisher(f"{ns}/behaviour_tree/pause", Bool, queue_size=1, latch=True)
        rospy.wait_for_service(f"{ns}/change_tree", timeout=30)
        self.change_tree = rospy.ServiceProxy(f"{ns}/change_tree", ChangeTree)
        self.add_skill = rospy.ServiceProxy(f"{ns}/behaviour_tree/add_skill", AddSkill)

    def _on_tree(self, message):
        with self.lock:
            self.tree = message

    def _on_help(self, message):
        with self.lock:
            self.help = message

    def _on_library(self, message):
        with self.lock:
            self.library = message

    def _on_event(self, message):
        history = json.loads(message.data)
        with self.lock:
            self.histories[history["pid"]] = [tuple(event) for event in history["events"]]

    @property
    def events(self):
        """Every skill server event so far, (event, server, skill, parameters), servers in the order they started."""
        with self.lock:
            return [event for events in self.histories.values() for event in events]

    def change(self, node_name, operation, index=0, parent="", node_type="", parameter=0.0):
        return self.change_tree(
            node_name=node_name,
            operation=operation,
            index=index,
            parent=parent,
            node_type=node_type,
            parameter=parameter,
        )

    def pause(self, paused):
        self.pause_publisher.publish(Bool(data=paused))

    def nodes(self):
        with self.lock:
            return {} if self.tree is None else {b.name: b for b in self.tree.behaviours}

    def status(self, name):
        node = self.nodes().get(name)
        return STATUS.get(node.status) if node is not None else None

    def children(self, name):
        """The children's names of the node called name; None while the tree has no such node."""
        nodes = self.nodes()
        if name not in nodes:
            return None
        by_id = {b.own_id: b.name for b in nodes.values()}
        return [by_id[i] for i in nodes[name].child_ids]

    def structure(self):
        nodes = self.nodes()
        by_id = {b.own_id: b.name for b in nodes.values()}
        return {b.name: [by_id[i] for i in b.child_ids] for b in nodes.values()}

    def started(self, server=None):
        return [e[2] for e in self.events if e[0] == "start" and (server is None or e[1] == server)]

    def event_list(self, kind):
        return [e for e in self.events if e[0] == kind]

    def wait_for(self, condition, timeout, what):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline and not rospy.is_shutdown():
            if condition():
                return
            time.sleep(0.05)
        raise AssertionError(f"timed out after {timeout} s waiting for {what}; tree: {self.summary()}")

    def summary(self):
        return {name: (STATUS.get(b.status), b.message) for name, b in self.nodes().items()}

    def kill_while_running(self, node, leaf, help_timeout):
        """SIGKILL the node that serves leaf; wait for the tree's help request about leaf and its pause.

        Returns the killed process id (a respawned node has another).
        """
        killed = node_pid(node)
        os.kill(killed, signal.SIGKILL)
        self.wait_for(lambda: self.help is not None and self.help.node_name == leaf, help_timeout, "help")
        self.wait_for(lambda: self.status("PauseCondition") == "SUCCESS", 10, "the tree paused")
        return killed

    @staticmethod
    def wait_respawned(node, killed, timeout):
        """Until a new process serves node."""
        deadline = time.monotonic() + timeout
        while node_pid(node, missing=None) in (None, killed):
            if time.monotonic() > deadline:
                raise AssertionError(f"{node} was not respawned within {timeout} s")
            time.sleep(0.2)

    def wait_completed(self, timeout=60):
        self.wait_for(lambda: self.status("BehaviorExecution") == "SUCCESS", timeout, "BehaviorExecution SUCCESS")
