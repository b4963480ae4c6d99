"""Whether an actionlib server is connected, asked without waiting (the bt leaves and the skills' robot share it).

``ActionClient.wait_for_server`` waits on ROS time: under /use_sim_time a stopped clock (a dead simulator) never ends
its timeout. This is its test, done once: the last status message names the server node, and the goal and cancel
publishers and the result and feedback subscribers must all be connected to that node. It reads rospy's connection
objects (``Publisher.impl.has_connection``, ``Subscriber.impl.connections`` and their ``callerid_pub``), as
``wait_for_server`` itself does; test/ros/test_bt_action_internals.py pins that layout against the installed rospy.
"""


def server_ready(client) -> bool:
    """Whether the server of an ``actionlib.ActionClient`` is connected now."""
    status = client.last_status_msg
    if status is None:
        return False
    server_id = status._connection_header["callerid"]
    if not (client.pub_goal.impl.has_connection(server_id) and client.pub_cancel.impl.has_connection(server_id)):
        return False
    result = any(c.callerid_pub == server_id for c in client.result_sub.impl.connections)
    feedback = any(c.callerid_pub == server_id for c in client.feedback_sub.impl.connections)
    return result and feedback
