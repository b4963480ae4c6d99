"""actionlib helpers: a server's connection asked without waiting, and servers' status published on wall time.

:func:`server_ready` is shared by the bt leaves and the skills' robot; :class:`WallStatusTimer` and
:class:`OneGoalActionServer` by the skill server and robot_sim.

``ActionClient.wait_for_server`` waits on ROS time: under /use_sim_time a stopped clock (a dead simulator) never ends
its timeout. This is its test, done once: the last status message names the server node, and the goal and cancel
publishers and the result and feedback subscribers must all be connected to that node. It reads rospy's connection
objects (``Publisher.impl.has_connection``, ``Subscriber.impl.connections`` and their ``callerid_pub``), as
``wait_for_server`` itself does; test/ros/test_bt_action_internals.py pins that layout against the installed rospy.

:class:`OneGoalActionServer` is SimpleActionServer's policy without its always-awake thread, for both servers' goals.
"""

import math
import threading

import actionlib
import rospy
from actionlib_msgs.msg import GoalStatus

from teleteach.runtime.node import shutting_down


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
        servers: started ``actionlib.ActionServer`` objects, or objects holding one as ``action_server``
            (``SimpleActionServer``, :class:`OneGoalActionServer`).
        frequency: [Hz of wall time] of the periodic status messages, > 0.
    """

    def __init__(self, servers, frequency: float) -> None:
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


class OneGoalActionServer:
    """actionlib's SimpleActionServer policy on its ActionServer, with a thread only while a goal runs.

    One goal at a time: a new goal asks the running one to stop (``is_preempt_requested``) and starts once it has
    ended; a newer goal replaces a waiting one (which is cancelled); a cancel asks the running goal to stop, or drops
    the waiting one. ``execute_cb(goal)`` runs in a thread of its own and ends the goal with ``set_succeeded``,
    ``set_aborted`` or ``set_preempted``; one that ends without (or raises) is aborted, as SimpleActionServer does.
    SimpleActionServer keeps a thread per server that wakes ten times a second to look for a goal: thirteen of them
    cost 1 % of a core with nothing to do, half of what an idle skill server may spend.

    Args:
        name: the action's namespace.
        action_spec: the action type (e.g. ``ExecuteSkillAction``).
        execute_cb: runs one goal.
    """

    def __init__(self, name: str, action_spec, execute_cb) -> None:
        self._execute_cb = execute_cb
        self._lock = threading.Lock()
        self._running = None
        self._waiting = None
        self._preempt_requested = False
        self.action_server = actionlib.ActionServer(
            name, action_spec, goal_cb=self._on_goal, cancel_cb=self._on_cancel, auto_start=False
        )

    def start(self) -> None:
        """Start serving goals."""
        self.action_server.start()

    def is_preempt_requested(self) -> bool:
        """Whether the running goal was cancelled, or a newer goal waits for it to end."""
        return self._preempt_requested

    def publish_feedback(self, feedback) -> None:
        """Feedback of the running goal."""
        self._running.publish_feedback(feedback)

    def set_succeeded(self, result=None, text: str = "") -> None:
        """End the running goal as succeeded."""
        self._running.set_succeeded(result, text)

    def set_aborted(self, result=None, text: str = "") -> None:
        """End the running goal as aborted."""
        self._running.set_aborted(result, text)

    def set_preempted(self, result=None, text: str = "") -> None:
        """End the running goal as preempted."""
        self._running.set_canceled(result, text)

    def _on_goal(self, handle) -> None:
        with self._lock:
            if self._running is None:
                self._start(handle)
                return
            if self._waiting is not None:
                self._waiting.set_canceled(None, "replaced by a newer goal before it started")
            self._waiting, self._preempt_requested = handle, True

    def _on_cancel(self, handle) -> None:
        with self._lock:
            if handle == self._running:
                self._preempt_requested = True
            elif handle == self._waiting:
                self._waiting.set_canceled(None, "cancelled before it started")
                self._waiting = None

    def _start(self, handle) -> None:
        """Accept ``handle`` and run it in a new thread (the lock held)."""
        handle.set_accepted("")
        self._running, self._preempt_requested = handle, False
        name = f"goal {handle.get_goal_id().id}"
        threading.Thread(target=self._execute, args=(handle,), name=name, daemon=True).start()

    def _execute(self, handle) -> None:
        failure = "the execution ended without a result"
        try:
            self._execute_cb(handle.get_goal())
        except Exception as error:  # SimpleActionServer's policy: log it, abort the goal
            failure = f"the execution raised {error!r}"
            rospy.logerr(f"{self.action_server.ns}: {failure}", exc_info=True)
        if handle.get_goal_status().status in (GoalStatus.ACTIVE, GoalStatus.PREEMPTING):
            rospy.logerr(f"{self.action_server.ns}: {failure}: the goal is aborted")
            handle.set_aborted(None, failure)
        with self._lock:
            self._running = None
            if self._waiting is not None:
                waiting, self._waiting = self._waiting, None
                self._start(waiting)
