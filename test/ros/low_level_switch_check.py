#!/usr/bin/env python3
"""rostest check: the impedance controller takes the arm only after the tree's running skill stopped, and the skill
does not fail for it.

Judged from the outside: the skills' goal and result topics, /joint_states and the controller manager
(list_controllers, polled), while the hand (sigma7/input/*) enters LOW-LEVEL in the middle of PickItem.
"""

import unittest

import rospy
import rostest
from actionlib_msgs.msg import GoalStatus
from full_system_support import ControllerWatch, Hand, Observer

from teleteach.msg import TreeExecution

REST_SPEED = 0.05  # [rad/s] config/gui.yaml arm_rest_speed


class SwitchAfterTheSkill(unittest.TestCase):
    def test_low_level_waits_for_the_running_skill_and_nothing_fails(self):
        observer, hand, controllers = Observer(), Hand(), ControllerWatch()
        observer.wait(lambda: observer.execution is not None, 120, "behaviour_tree/execution")
        hand.start_tree(observer)
        observer.wait(lambda: "PickItem" in observer.goals, 120, "PickItem running")
        rospy.sleep(1.0)  # simulated: PickItem (7 s) is moving the arm
        with observer.lock:
            self.assertGreater(observer.joints[-1][2], REST_SPEED, "the arm should be moving for PickItem")
        self.assertIsNone(controllers.switched_at())
        hand.move(x=0.05)  # START: LOW-LEVEL
        entered = rospy.get_time()
        hand.click()
        observer.wait(lambda: controllers.switched_at() is not None, 60, "the impedance controller running")
        switched = controllers.switched_at()
        with observer.lock:
            ended = [(stamp, status, text) for stamp, name, status, text in observer.results if name == "PickItem"]
            at_switch = [speed for stamp, _, speed in observer.joints if stamp <= switched][-1]
            state = observer.execution.state
        # Expect PickItem ended (preempted by the pause, confirmed by its server) before the switch, the arm at rest
        self.assertEqual(len(ended), 1, ended)
        stamp, status, text = ended[0]
        self.assertEqual(status, GoalStatus.PREEMPTED, text)
        self.assertGreater(stamp, entered)
        self.assertLessEqual(stamp, switched, f"switched at {switched:.2f} s, PickItem ended at {stamp:.2f} s")
        self.assertLess(at_switch, REST_SPEED, f"the arm moved at {at_switch:.2f} rad/s when the controller switched")
        self.assertEqual(state, TreeExecution.PAUSED)
        # Back to START: the position controller, the tree resumes, PickItem starts again and succeeds
        hand.move(x=0.0)
        hand.open_gripper()
        succeeded = ("PickItem", GoalStatus.SUCCEEDED)
        observer.wait(
            lambda: any((name, status) == succeeded for _, name, status, _ in observer.results),
            180,
            "PickItem run again to success",
        )
        with observer.lock:
            self.assertEqual(observer.goals.count("PickItem"), 2, observer.goals)
            self.assertEqual(observer.help_requests, [])
            aborted = [(name, text) for _, name, status, text in observer.results if status == GoalStatus.ABORTED]
        self.assertEqual(aborted, [])


if __name__ == "__main__":
    rospy.init_node("low_level_switch_check")
    rostest.rosrun("teleteach", "low_level_switch", SwitchAfterTheSkill)
