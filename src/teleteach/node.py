"""Starting a teleteach ROS node: rospy.init_node plus the parameter that keeps rospy's logging cheap; parameters."""

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


def node_parameters(
    defaults_file: str, get_param: typing.Optional[typing.Callable[[str, typing.Any], typing.Any]] = None
) -> typing.Dict[str, typing.Any]:
    """The node's parameters: the keys of ``config/<defaults_file>``, each overridden by its private parameter.

    The yaml is the one place of their defaults; a launch file's ``<param>`` or ``_name:=value`` overrides one.
    ``get_param(name, default)`` is ``rospy.get_param`` unless given.
    """
    import yaml

    from teleteach.paths import config_file

    if get_param is None:
        import rospy

        get_param = rospy.get_param
    defaults = yaml.safe_load(config_file(defaults_file).read_text()) or {}
    return {name: get_param(f"~{name}", value) for name, value in defaults.items()}
