"""What a scripted operator waits for, read from the topics a real operator sees on the GUI (scenario ``wait:``).

ROS Subscribers (all latched by their publishers):
    /teleteach/active_tab (std_msgs/Int8): the GUI's tab
    /teleteach/recording (std_msgs/Bool): whether the GUI records a demonstration
    /behaviour_tree/log/tree (teleteach/BehaviourTree): the nodes RUNNING
    /behaviour_tree/help_request (teleteach/HelpRequest): open while its node_name is not empty
"""

import dataclasses
import threading

import rospy
from std_msgs.msg import Bool, Int8

from teleteach.haptics.scenario import SystemState
from teleteach.msg import Behaviour, BehaviourTree, HelpRequest


class RosSystemView:
    """The latest :class:`SystemState` from the topics; call it to read it (any thread)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._state = SystemState()
        self._subscribers = [
            rospy.Subscriber("/teleteach/active_tab", Int8, self._update("tab", lambda m: int(m.data))),
            rospy.Subscriber("/teleteach/recording", Bool, self._update("recording", lambda m: bool(m.data))),
            rospy.Subscriber(
                "/behaviour_tree/log/tree",
                BehaviourTree,
                self._update(
                    "running", lambda m: frozenset(b.name for b in m.behaviours if b.status == Behaviour.RUNNING)
                ),
                queue_size=1,
            ),
            rospy.Subscriber(
                "/behaviour_tree/help_request", HelpRequest, self._update("help_request", lambda m: bool(m.node_name))
            ),
        ]

    def _update(self, field, convert):
        def callback(message) -> None:
            with self._lock:
                self._state = dataclasses.replace(self._state, **{field: convert(message)})

        return callback

    def __call__(self) -> SystemState:
        """The state as last heard."""
        with self._lock:
            return self._state


def _running_nodes(message: BehaviourTree) -> frozenset:
    return frozenset(b.name for b in message.behaviours if b.status == Behaviour.RUNNING)
