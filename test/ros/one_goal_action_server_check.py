#!/usr/bin/env python3
"""rostest check of OneGoalActionServer: the goals' policy seen through actionlib's client, and its threads."""

import threading
import time
import unittest

import actionlib
import rospy
import rostest
from actionlib_msgs.msg import GoalStatus
from ros_processes import wait_until

from teleteach.msg import ExecuteSkillAction, ExecuteSkillFeedback, ExecuteSkillGoal, ExecuteSkillResult
from teleteach.runtime.ros_actions import OneGoalActionServer


class Skill:
    """An execute_cb the test steers by the goal's ``skill`` field: "work" runs until preempted or released."""

    def __init__(self):
        self.server = OneGoalActionServer("/one_goal", ExecuteSkillAction, execute_cb=self.execute)
        self.server.start()
        self.started = []
        self.release = threading.Event()
        self.may_stop = threading.Event()  # cleared: a preempted "work" holds on before it stops
        self.may_stop.set()

    def execute(self, goal):
        self.started.append(goal.skill)
        if goal.skill == "raise":
            raise RuntimeError("the skill broke")
        if goal.skill == "forget":
            return
        self.server.publish_feedback(ExecuteSkillFeedback(progress=0.5, phase="working"))
        while not self.server.is_preempt_requested():
            if self.release.wait(0.01):
                self.server.set_succeeded(ExecuteSkillResult(success=True, message="done"), "done")
                return
        self.may_stop.wait(10.0)
        self.server.set_preempted(ExecuteSkillResult(success=False, message="preempted"), "preempted")


class OneGoal(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.skill = Skill()
        cls.client = actionlib.ActionClient("/one_goal", ExecuteSkillAction)
        assert cls.client.wait_for_server(rospy.Duration(20.0))

    def setUp(self):
        self.skill.started.clear()
        self.skill.release.clear()
        self.skill.may_stop.set()

    def send(self, skill):
        feedback = []
        handle = self.client.send_goal(ExecuteSkillGoal(skill=skill), feedback_cb=lambda _, f: feedback.append(f))
        handle.feedback = feedback
        return handle

    def wait_done(self, handle):
        wait_until(lambda: handle.get_comm_state() == actionlib.CommState.DONE, 10.0, "the goal to end")
        return handle.get_goal_status(), handle.get_goal_status_text()

    def test_a_goal_runs_with_feedback_and_succeeds(self):
        goal = self.send("work")
        wait_until(lambda: self.skill.started == ["work"] and goal.feedback, 10.0, "the goal to run")
        self.skill.release.set()
        self.assertEqual(self.wait_done(goal), (GoalStatus.SUCCEEDED, "done"))
        self.assertEqual(goal.get_result().message, "done")
        self.assertEqual(goal.feedback[0].phase, "working")

    def test_a_new_goal_preempts_the_running_one_and_a_newer_one_replaces_it_while_it_waits(self):
        first = self.send("work")
        wait_until(lambda: self.skill.started == ["work"], 10.0, "the first goal to run")
        self.skill.release.clear()
        # the second waits while the first stops; the third replaces it before it started
        second, third = self.send("second"), self.send("work")
        self.assertEqual(self.wait_done(first), (GoalStatus.PREEMPTED, "preempted"))
        self.assertEqual(self.wait_done(second)[0], GoalStatus.RECALLED)
        wait_until(lambda: self.skill.started == ["work", "work"], 10.0, "the newest goal to run")
        self.assertNotEqual(third.get_goal_status(), GoalStatus.PREEMPTED)
        third.cancel()
        self.assertEqual(self.wait_done(third), (GoalStatus.PREEMPTED, "preempted"))

    def test_a_cancel_drops_a_waiting_goal_that_never_runs(self):
        running = self.send("work")
        wait_until(lambda: self.skill.started == ["work"], 10.0, "the goal to run")
        self.skill.may_stop.clear()
        waiting = self.send("never")
        # Goal and cancel travel on separate topics: a cancel sent at once may overtake its goal, which is then
        # recalled before the server sees it (a fresh machine saw that). So the cancel goes once the server holds the
        # goal (it asked the running one to stop), and the running one stops only after that.
        wait_until(self.skill.server.is_preempt_requested, 10.0, "the server to hold the second goal")
        waiting.cancel()
        self.assertEqual(self.wait_done(waiting)[0], GoalStatus.RECALLED)
        self.skill.may_stop.set()
        self.assertEqual(self.wait_done(running)[0], GoalStatus.PREEMPTED)  # the waiting goal had asked it to stop
        time.sleep(0.3)
        self.assertEqual(self.skill.started, ["work"])

    def test_an_execution_that_ends_without_a_result_or_raises_is_aborted(self):
        self.assertEqual(
            self.wait_done(self.send("forget")), (GoalStatus.ABORTED, "the execution ended without a result")
        )
        status, text = self.wait_done(self.send("raise"))
        self.assertEqual(status, GoalStatus.ABORTED)
        self.assertIn("the skill broke", text)
        # the server still takes goals
        goal = self.send("work")
        wait_until(lambda: self.skill.started[-1:] == ["work"], 10.0, "the next goal to run")
        self.skill.release.set()
        self.assertEqual(self.wait_done(goal)[0], GoalStatus.SUCCEEDED)

    def test_no_thread_waits_for_goals_while_none_runs(self):
        # SimpleActionServer's loop thread would stay; a goal's thread ends with the goal
        before = threading.active_count()
        goal = self.send("work")
        wait_until(lambda: self.skill.started == ["work"], 10.0, "the goal to run")
        self.assertEqual(threading.active_count(), before + 1)
        self.skill.release.set()
        self.wait_done(goal)
        wait_until(lambda: threading.active_count() == before, 10.0, "the goal's thread to end")


if __name__ == "__main__":
    rospy.init_node("one_goal_action_server_check")
    rostest.rosrun("teleteach", "one_goal_action_server_check", OneGoal)
