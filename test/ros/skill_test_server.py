#!/usr/bin/env python3
"""Stand-in skill server for the behaviour-tree rostests: real actionlib servers /skills/<Name> whose goals take a
configurable time and succeed or fail as configured. ~events (latched) carries, after every goal event, this process'
whole history as JSON ``{"pid": pid, "events": [[event, server, skill, parameters], ...]}`` (events: start,
succeed, fail, cancel), so a check that subscribes late still sees the first event, and a respawned server's events
are told apart from its predecessor's.

Params: ~skills (names; default: config/skills.yaml + ReplaySkill), ~duration [s] (default 0.3),
~durations {skill: s}, ~failures {skill: reason} (those goals always fail).
"""

import json
import os
import threading

import actionlib
import rospkg
import rospy
from std_msgs.msg import String

from teleteach.bt.library import SkillLibrary
from teleteach.msg import ExecuteSkillAction, ExecuteSkillFeedback, ExecuteSkillResult


class SkillTestServer:
    def __init__(self):
        config = rospkg.RosPack().get_path("teleteach") + "/config/skills.yaml"
        default = [entry.name for entry in SkillLibrary.load(config)] + ["ReplaySkill"]
        self.duration = float(rospy.get_param("~duration", 0.3))
        self.durations = rospy.get_param("~durations", {})
        self.failures = rospy.get_param("~failures", {})
        self.events = rospy.Publisher("~events", String, queue_size=100, latch=True)
        self.history = []
        self.lock = threading.Lock()
        self.by_name = {}
        for name in rospy.get_param("~skills", default):
            server = actionlib.SimpleActionServer(
                f"/skills/{name}",
                ExecuteSkillAction,
                execute_cb=lambda goal, name=name: self.execute(name, goal),
                auto_start=False,
            )
            self.by_name[name] = server
            server.start()

    def emit(self, event, server, goal):
        with self.lock:
            self.history.append([event, server, goal.skill, goal.parameters])
            self.events.publish(String(data=json.dumps({"pid": os.getpid(), "events": self.history})))

    def execute(self, name, goal):
        server = self.by_name[name]
        self.emit("start", name, goal)
        duration = float(self.durations.get(goal.skill, self.durations.get(name, self.duration)))
        end = rospy.get_time() + duration
        while rospy.get_time() < end and not rospy.is_shutdown():
            if server.is_preempt_requested():
                self.emit("cancel", name, goal)
                server.set_preempted(ExecuteSkillResult(success=False, message="cancelled"))
                return
            remaining = end - rospy.get_time()
            server.publish_feedback(ExecuteSkillFeedback(progress=1.0 - remaining / max(duration, 1e-6), phase="run"))
            rospy.sleep(0.02)
        reason = self.failures.get(goal.skill)
        if reason:
            self.emit("fail", name, goal)
            server.set_aborted(ExecuteSkillResult(success=False, message=reason))
        else:
            self.emit("succeed", name, goal)
            server.set_succeeded(ExecuteSkillResult(success=True, message=f"{goal.skill} done"))


if __name__ == "__main__":
    rospy.init_node("skill_test_server")
    SkillTestServer()
    rospy.spin()
