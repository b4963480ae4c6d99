"""The skills as actionlib servers: /skills/<Name> (teleteach/ExecuteSkill), one per skill (thesis Appendix B.2)."""

import time

import actionlib
import rospy

from teleteach.msg import ExecuteSkillAction, ExecuteSkillFeedback, ExecuteSkillResult
from teleteach.skills.robot import Execution
from teleteach.skills.runner import REPLAY_SKILL, SKILL_NAMES, SkillRunner

FEEDBACK_PERIOD = 0.1  # [s] wall time between feedback messages within one phase


class SkillServer:
    """One SimpleActionServer per skill, all executing through one SkillRunner (one skill at a time).

    Args:
        runner: executes the skills on the robot.
        namespace: where the servers live (/skills/<Name>).

    ROS Action Servers: /skills/<Name> for each predefined skill and /skills/ReplaySkill (teleteach/ExecuteSkill).
    """

    def __init__(self, runner: SkillRunner, namespace="/skills"):
        self.runner = runner
        self.servers = {}
        for name in SKILL_NAMES:
            server = actionlib.SimpleActionServer(
                f"{namespace}/{name}",
                ExecuteSkillAction,
                execute_cb=lambda goal, name=name: self._execute(name, goal),
                auto_start=False,
            )
            self.servers[name] = server
        for server in self.servers.values():
            server.start()
        rospy.loginfo(f"skill_server: serving {', '.join(f'{namespace}/{name}' for name in SKILL_NAMES)}")

    def _execute(self, name, goal):
        server = self.servers[name]
        last = {"phase": None, "time": 0.0}

        def feedback(progress, phase):
            now = time.monotonic()
            if phase != last["phase"] or now - last["time"] >= FEEDBACK_PERIOD or progress >= 1.0:
                last["phase"], last["time"] = phase, now
                server.publish_feedback(ExecuteSkillFeedback(progress=progress, phase=phase))

        label = f"{name} ({goal.skill})" if name == REPLAY_SKILL and goal.skill else name
        rospy.loginfo(f"skill_server: {label} started")
        outcome = self.runner.execute(name, goal.parameters, Execution(server.is_preempt_requested, feedback))
        result = ExecuteSkillResult(success=outcome.success, message=outcome.message)
        if outcome.success:
            feedback(1.0, "done")  # a skill may finish its last phase between two throttled feedbacks
            rospy.loginfo(f"skill_server: {label} succeeded: {outcome.message}")
            server.set_succeeded(result, outcome.message)
        elif outcome.preempted:
            rospy.logwarn(f"skill_server: {label} preempted")
            server.set_preempted(result, outcome.message)
        else:
            rospy.logwarn(f"skill_server: {label} failed: {outcome.message}")
            server.set_aborted(result, outcome.message)
