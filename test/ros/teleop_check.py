#!/usr/bin/env python3
"""rostest check of TELEOP: the device moves the simulated arm through the clutch, within its limits.

Judged from the outside: where the TCP is (TF base_link -> panda_grasptarget, which robot_state_publisher computes
from /joint_states), whether the arm rests (/joint_states), what the GUI commands (/equilibrium_pose) and which
controller runs (list_controllers), while the hand (sigma7/input/*) opens TELEOP and moves the handle.

The hand moves on the wall clock, as an operator's; every wait for the system lasts its time on the wall clock and on
the ROS clock both (:func:`pause`). The GUI times the clutch (teleop/clutch_hold) and the arm moves on the ROS clock,
which the simulation runs slower than the wall when the machine is busy: a clutch held 1 s of wall time engaged after
the handle had started to move, and the arm ended short by what the handle moved before (14 mm once on a fresh machine;
at real_time_factor 0.5 the quick stroke moved nothing).
"""

import os
import pathlib
import threading
import time
import unittest

import numpy as np
import rospy
import rostest
import tf2_ros
from full_system_support import CLOSED, REST, ControllerWatch, Hand, Observer
from geometry_msgs.msg import PoseStamped
from std_msgs.msg import Int8

from teleteach.runtime.processes import screenshot

TELEOP = 4  # /teleteach/active_tab
TCP, BASE = "panda_grasptarget", "base_link"
TRACKING = 0.008  # [m] the arm on the impedance controller settles this close to where it was sent
REST_SPEED = 0.05  # [rad/s] config/gui.yaml arm_rest_speed
MAX_SPEED = 0.1  # [m/s] config/gui.yaml teleop/max_speed
WORKSPACE_X = 0.37  # [m] teleop.test's workspace_high x
CLUTCH = 1.0  # [s] the gripper held closed this long engages the clutch (teleop/clutch_hold 0.6 s of ROS time)
CLOCK_STOPPED = 30.0  # [s] of wall time without the ROS clock reaching a pause's end: the simulation stopped
ARTIFACTS = pathlib.Path(__file__).resolve().parents[2] / "test-artifacts"


def pause(seconds):
    """Wait ``seconds`` of wall time and of ROS time, whichever ends later.

    The wall clock times the device's timeouts and the messages' way; the ROS clock the clutch and the arm. The
    simulation runs slower than the wall under load (a real-time factor of 0.7 for a second with three busy loops on
    two cores), and after a lag shorter than 0.2 s it catches up faster than the wall (sim/ros.py).
    """
    end = rospy.get_time() + seconds
    time.sleep(seconds)
    deadline = time.monotonic() + CLOCK_STOPPED
    while rospy.get_time() < end:
        if time.monotonic() > deadline or rospy.is_shutdown():
            raise AssertionError(f"the ROS clock did not reach {end:.2f} s within {CLOCK_STOPPED:g} s")
        time.sleep(0.01)


class Arm:
    """The TCP from TF and the equilibria the GUI sends, each with its simulated time."""

    def __init__(self):
        self.buffer = tf2_ros.Buffer(cache_time=rospy.Duration(30.0))
        self.listener = tf2_ros.TransformListener(self.buffer)
        self.lock = threading.Lock()
        self.equilibria = []  # (stamp [s], position [m])
        self.tab = None
        rospy.Subscriber("/equilibrium_pose", PoseStamped, self._on_equilibrium, queue_size=1000)
        rospy.Subscriber("/teleteach/active_tab", Int8, self._on_tab, queue_size=10)

    def _on_equilibrium(self, message):
        p = message.pose.position
        with self.lock:
            self.equilibria.append((message.header.stamp.to_sec(), np.array([p.x, p.y, p.z])))

    def _on_tab(self, message):
        self.tab = message.data

    def tcp(self):
        """The TCP's position in base_link now [m]."""
        stamped = self.buffer.lookup_transform(BASE, TCP, rospy.Time(0), rospy.Duration(5.0))
        t = stamped.transform.translation
        return np.array([t.x, t.y, t.z])

    def fastest_equilibrium(self, since):
        """The equilibrium's fastest speed [m/s] between messages at least 10 ms apart, since ``since`` [s]."""
        with self.lock:
            samples = [(t, p) for t, p in self.equilibria if t >= since]
        speeds, previous = [], None
        for stamp, position in samples:
            if previous is not None and stamp - previous[0] >= 0.01:
                speeds.append(np.linalg.norm(position - previous[1]) / (stamp - previous[0]))
                previous = (stamp, position)
            elif previous is None:
                previous = (stamp, position)
        return max(speeds, default=0.0), len(samples)


class TeleopOnTheArm(unittest.TestCase):
    def assert_near(self, position, expected, what):
        error = np.abs(np.asarray(position) - np.asarray(expected))
        self.assertTrue(np.all(error < TRACKING), f"{what}: TCP at {np.round(position, 4)}, expected {expected}")

    def assert_resting(self, observer, what):
        with observer.lock:
            speed = observer.joints[-1][2]
        self.assertLess(speed, REST_SPEED, f"{what}: the arm moves at {speed:.3f} rad/s")

    def test_the_handle_moves_the_arm_only_through_the_clutch_within_the_limits(self):
        observer, hand, controllers, arm = Observer(), Hand(), ControllerWatch(), Arm()
        observer.wait(lambda: observer.execution is not None, 120, "behaviour_tree/execution")
        hand.move(y=-0.08)  # START: TELEOP, below the other modes
        deadline = time.monotonic() + 30.0
        while arm.tab != TELEOP:  # clicked again like a patient operator: the GUI may not listen to the device yet
            self.assertLess(time.monotonic(), deadline, f"TELEOP did not open (tab {arm.tab})")
            hand.click()
        observer.wait(lambda: controllers.switched_at() is not None, 60, "the impedance controller running")
        hand.move(0.0, 0.0, 0.0)
        pause(1.0)
        start = arm.tcp()
        self.assert_near(start, [0.307, 0.0, 0.885], "the ready posture")

        # Expect: the handle alone, and a click, move nothing
        hand.glide((0.0, 0.03, 0.0), 1.0)
        hand.click()
        hand.glide((0.0, 0.0, 0.0), 1.0)
        self.assert_near(arm.tcp(), start, "without the clutch")
        self.assert_resting(observer, "without the clutch")

        # Expect: held closed, the handle 4 cm away moves the TCP 4 cm forward (the operator behind the robot)
        hand.angle = CLOSED
        pause(CLUTCH)
        hand.glide((0.0, 0.04, 0.0), 2.0)
        pause(1.5)
        forward = start + np.array([0.04, 0.0, 0.0])
        self.assert_near(arm.tcp(), forward, "4 cm forward")
        if os.environ.get("DISPLAY"):  # the window as the operator sees it, the arm where the handle put it
            ARTIFACTS.mkdir(exist_ok=True)
            screenshot(os.environ["DISPLAY"], ARTIFACTS / "teleop_engaged.png")

        # Expect: released, the handle comes back without the arm
        hand.angle = REST
        pause(0.3)
        hand.glide((0.0, 0.0, 0.0), 1.0)
        pause(0.5)
        self.assert_near(arm.tcp(), forward, "after the release")
        self.assert_resting(observer, "after the release")

        # Expect: a quick stroke (3.5 cm up in 0.1 s of the handle) makes the equilibrium go no faster than the limit
        hand.angle = CLOSED
        pause(CLUTCH)
        quick = rospy.get_time()
        hand.glide((0.0, 0.0, 0.035), 0.1)
        pause(1.5)
        fastest, count = arm.fastest_equilibrium(quick)
        self.assertGreater(count, 50, "the GUI sent no equilibria")
        self.assertLess(fastest, MAX_SPEED * 1.1, f"the equilibrium moved at {fastest:.3f} m/s")
        self.assertGreater(fastest, MAX_SPEED * 0.8, f"the equilibrium was slow: {fastest:.3f} m/s")
        up = forward + np.array([0.0, 0.0, 0.035])
        self.assert_near(arm.tcp(), up, "3.5 cm up")

        # Expect: the workspace ends at x 0.37 m: another 4 cm forward stops there
        hand.glide((0.0, 0.04, 0.035), 2.0)
        pause(1.5)
        self.assert_near(arm.tcp(), [WORKSPACE_X, up[1], up[2]], "at the workspace's end")

        # Expect: the device lost while the clutch holds, the arm holds; back with the gripper still closed and
        # elsewhere, it does not follow until the gripper opened and closed again
        here = arm.tcp()
        hand.silent = True
        pause(1.5)
        self.assert_near(arm.tcp(), here, "the device lost")
        hand.position = (0.0, 0.0, 0.0)
        hand.silent = False
        pause(0.5)
        hand.glide((0.0, 0.0, -0.03), 1.0)
        pause(0.5)
        self.assert_near(arm.tcp(), here, "the device back, the gripper still closed")
        hand.angle = REST
        pause(0.3)
        hand.angle = CLOSED
        pause(CLUTCH)
        hand.glide((0.0, 0.0, -0.06), 1.0)
        pause(1.5)
        self.assert_near(arm.tcp(), here - np.array([0.0, 0.0, 0.03]), "the clutch closed again")

        # Expect: back in START, the position controller holds the arm where teleoperation left it
        left = arm.tcp()
        hand.angle = REST
        pause(0.3)
        hand.open_gripper()
        observer.wait(lambda: arm.tab == 0 and controllers.impedance_running() is False, 30, "START, position control")
        pause(1.0)
        self.assert_near(arm.tcp(), left, "back in START")
        self.assert_resting(observer, "back in START")


if __name__ == "__main__":
    rospy.init_node("teleop_check")
    rostest.rosrun("teleteach", "teleop", TeleopOnTheArm)
