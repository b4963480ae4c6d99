"""actionlib helpers: a server's connection asked without waiting, and servers' status published on wall time.

:func:`server_ready` is shared by the bt leaves and the skills' robot; :class:`WallStatusTimer` by the skill server and
robot_sim.

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


class WallStatusTimer:
    """Publishes the status of several actionlib servers from one thread that sleeps on wall time.

    actionlib gives each server a ``rospy.Timer`` for its status (5 Hz by default). Under /use_sim_time that timer
    sleeps on ROS time, and rospy wakes every thread sleeping on ROS time at each /clock message: at 250 Hz the skill
    server's 13 servers woke 3250 times a second to send 65 messages. This thread sends the same messages
    (``ActionServer.publish_status_async``) on wall time, at ``frequency``; the servers' timers are shut down. Status
    changes are still published by the servers themselves, at once, and latched: the periodic message is only a
    heartbeat, which nobody here times (a lost server is a closed connection, ``server_ready``), so a node's yaml sets
    it low.

    Args:
        servers: started ``actionlib.ActionServer`` or ``SimpleActionServer`` objects.
        frequency: [Hz of wall time] of the periodic status messages, > 0.
    """

    def __init__(self, servers, frequency: float) -> None:
        import math
        import threading

        import rospy

        if not (math.isfinite(frequency) and frequency > 0.0):
            raise ValueError(f"action status frequency must be a finite number > 0 Hz, got {frequency}")
        self._servers = [getattr(server, "action_server", server) for server in servers]
        for server in self._servers:
            if server.status_timer is not None:
                server.status_timer.shutdown()  # kept: ActionServer.stop() shuts it down again
        self._period = 1.0 / frequency
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="action_status", daemon=True)
        rospy.on_shutdown(self.shutdown)  # before rospy closes the status topics (its client hooks run first)
        self._thread.start()

    def _run(self) -> None:
        import rospy

        from teleteach.node import shutting_down

        while not self._stop.wait(self._period):
            for server in self._servers:
                try:
                    server.publish_status_async(None)
                except rospy.ROSException:
                    if not shutting_down():
                        raise
                    return  # Ctrl-C closed the topics while this cycle was sending: nothing to report

    def shutdown(self) -> None:
        """Stop publishing (the servers keep running)."""
        self._stop.set()
