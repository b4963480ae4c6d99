"""Starting a teleteach ROS node: rospy.init_node plus the one parameter that keeps rospy's logging cheap."""

import typing

ROSOUT_TOPICS_PARAM = "/rosout_disable_topics_generation"


def init_node(name: str, **kwargs: typing.Any) -> None:
    """``rospy.init_node``, then make sure ``/rosout_disable_topics_generation`` exists (default value, false).

    rospy reads that parameter through its cache on every log call, but never caches a parameter that is not set:
    each ``rospy.loginfo`` then costs an XML-RPC round trip to the master (about half of a /change_tree answer).
    Setting it to its default changes nothing else; a value the user set is kept, and later changes still reach
    every node through the parameter subscription.
    """
    import rospy

    rospy.init_node(name, **kwargs)
    if not rospy.has_param(ROSOUT_TOPICS_PARAM):
        rospy.set_param(ROSOUT_TOPICS_PARAM, False)
