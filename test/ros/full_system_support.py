"""Helpers for the rostests that run full.launch with the device backend topic: an observer of what the system does
to the robot (skill goals and results, /joint_states, the tree's execution state, help requests), a hand that
holds the handle, moves it and clicks (sigma7/input/*), and a watch of the controller manager."""

import threading
import time

import numpy as np
import rospy
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64

from teleteach.msg import ExecuteSkillActionGoal, ExecuteSkillActionResult, HelpRequest, TreeExecution
from teleteach.skills.predefined import CONDITIONS, PREDEFINED_SKILLS
from teleteach.srv import ListControllers

IMPEDANCE = "cartesian_impedance_controller"
REST, CLOSED, OPEN = 0.25, 0.0, 0.5  # [rad] gripper angles: resting, closed for a click, fully open (back to START)
SKILLS = (*PREDEFINED_SKILLS, *CONDITIONS, "ReplaySkill")


class Observer:
    """The goals sent and their results, the arm's joints, the tree's execution state and help requests."""

    def __init__(self):
        self.lock = threading.Lock()
        self.goals = []  # skill names, in order
        self.results = []  # (stamp [s], skill, GoalStatus status, text)
        self.joints = []  # (stamp [s], arm joint positions, fastest joint speed [rad/s])
        self.execution = None
        self.help_requests = []
        for name in SKILLS:
            rospy.Subscriber(f"/skills/{name}/goal", ExecuteSkillActionGoal, self._on_goal, queue_size=10)
            rospy.Subscriber(
                f"/skills/{name}/result", ExecuteSkillActionResult, self._on_result, callback_args=name, queue_size=10
            )
        rospy.Subscriber("/joint_states", JointState, self._on_joints, queue_size=100)
        rospy.Subscriber("/behaviour_tree/execution", TreeExecution, self._on_execution, queue_size=10)
        rospy.Subscriber("/behaviour_tree/help_request", HelpRequest, self._on_help, queue_size=10)

    def _on_goal(self, message):
        with self.lock:
            self.goals.append(message.goal.skill)

    def _on_result(self, message, name):
        with self.lock:
            status = message.status
            self.results.append((message.header.stamp.to_sec(), name, status.status, status.text))

    def _on_joints(self, message):
        arm = [(p, v) for n, p, v in zip(message.name, message.position, message.velocity) if n.startswith("panda_j")]
        with self.lock:
            positions = np.array([p for p, _ in arm])
            self.joints.append((message.header.stamp.to_sec(), positions, max(abs(v) for _, v in arm)))

    def _on_execution(self, message):
        with self.lock:
            self.execution = message

    def _on_help(self, message):
        with self.lock:
            if message.node_name:
                self.help_requests.append(f"{message.node_name}: {message.reason}")

    def wait(self, condition, timeout, what):
        """Poll ``condition()`` (under the lock) until it holds, for at most ``timeout`` s of wall time."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline and not rospy.is_shutdown():
            with self.lock:
                if condition():
                    return
            time.sleep(0.02)
        raise AssertionError(f"timed out after {timeout} s (wall) waiting for {what}")


class Hand:
    """Holds the device's handle (backend topic) where it is told, and clicks or opens the gripper."""

    def __init__(self):
        self.pose = rospy.Publisher("/sigma7/input/pose", PoseStamped, queue_size=10)
        self.gripper = rospy.Publisher("/sigma7/input/gripper_angle", Float64, queue_size=10)
        self.position = (0.0, 0.0, 0.0)  # centred: START's neutral zone
        self.angle = REST
        self.silent = False  # True: nothing is sent, as when the device is unplugged
        threading.Thread(target=self._hold, daemon=True).start()

    def _hold(self):
        while not rospy.is_shutdown():
            if self.silent:
                time.sleep(0.01)
                continue
            message = PoseStamped()
            message.header.stamp, message.header.frame_id = rospy.Time.now(), "sigma7"
            p = message.pose.position
            p.x, p.y, p.z = self.position
            message.pose.orientation.w = 1.0
            try:
                self.pose.publish(message)
                self.gripper.publish(Float64(self.angle))
            except rospy.ROSException:
                return  # the test is over: rospy closed the topics
            time.sleep(0.01)

    def move(self, x=0.0, y=0.0, z=0.0):
        self.position = (x, y, z)
        time.sleep(0.5)

    def glide(self, to, seconds):
        """Move the handle in a straight line to ``to`` over ``seconds`` (wall time, 100 steps a second)."""
        start, end = np.array(self.position), np.array(to, dtype=float)
        steps = max(1, round(seconds * 100))
        for step in range(1, steps + 1):
            self.position = tuple(start + (end - start) * step / steps)
            time.sleep(seconds / steps)

    def click(self):
        self.angle = CLOSED
        time.sleep(0.15)
        self.angle = REST
        time.sleep(0.5)

    def start_tree(self, observer, timeout=60.0):
        """START's start gesture (handle centred, click), clicked again like a patient operator until the tree runs:
        the GUI may not listen to the device yet when the tree first says it waits."""
        self.move(0.0, 0.0, 0.0)
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline and not rospy.is_shutdown():
            self.click()
            try:
                observer.wait(lambda: observer.execution.state == TreeExecution.RUNNING, 3.0, "the tree running")
                return
            except AssertionError:
                continue
        raise AssertionError(f"the tree did not start within {timeout} s of start gestures")

    def open_gripper(self):
        self.angle = OPEN
        time.sleep(0.5)
        self.angle = REST
        time.sleep(0.5)


class ControllerWatch:
    """Polls list_controllers: (simulated time, whether the impedance controller runs), in order."""

    def __init__(self):
        rospy.wait_for_service("/controller_manager/list_controllers", timeout=120)
        self.list = rospy.ServiceProxy("/controller_manager/list_controllers", ListControllers)
        self.lock = threading.Lock()
        self.samples = []
        threading.Thread(target=self._poll, daemon=True).start()

    def _poll(self):
        while not rospy.is_shutdown():
            try:
                running = {c.name for c in self.list().controller if c.state == "running"}
            except (rospy.ServiceException, OSError):
                continue
            with self.lock:
                self.samples.append((rospy.get_time(), IMPEDANCE in running))
            time.sleep(0.02)

    def switched_at(self):
        """The simulated time of the first poll that found the impedance controller running, or None."""
        with self.lock:
            return next((stamp for stamp, running in self.samples if running), None)

    def impedance_running(self):
        """Whether the latest poll found the impedance controller running (None before the first)."""
        with self.lock:
            return self.samples[-1][1] if self.samples else None
