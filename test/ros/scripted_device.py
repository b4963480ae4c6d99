#!/usr/bin/env python3
"""Test stand-in for the haptic device: publishes /sigma7/* at --rate following a fixed teaching script, then exits.

The script (device frame, [m], [rad]) drives the real GUI: START -> HIGH-LEVEL (x < 0, click); select one of the
first tree leaves (x = -0.085, click); select "remove" (y = -0.075, click); gripper fully open -> START; LOW-LEVEL
(x > 0, click); shape the ellipsoid (x, y, z, yaw) in jumps, holding each; gripper fully open -> START.
"""

import argparse

import numpy as np
import rospy
from geometry_msgs.msg import PoseStamped, TwistStamped
from scipy.spatial.transform import Rotation
from std_msgs.msg import Bool, Float64

STEP = 1e-6  # [s] a jump: no sample falls inside it
# t [s], x, y, z [m], yaw [rad], gripper [rad]
KEYFRAMES = np.array(
    [
        (0.0, -0.05, 0.0, 0.0, 0.0, 0.25),
        (2.0, -0.05, 0.0, 0.0, 0.0, 0.25),
        (3.0, -0.085, 0.0, 0.0, 0.0, 0.25),
        (4.5, -0.085, 0.0, 0.0, 0.0, 0.25),
        (5.5, -0.085, -0.075, 0.0, 0.0, 0.25),
        (7.0, -0.085, -0.075, 0.0, 0.0, 0.25),
        (7.5, -0.085, -0.075, 0.0, 0.0, 0.5),
        (8.0, -0.085, -0.075, 0.0, 0.0, 0.25),
        (9.0, 0.05, 0.0, 0.0, 0.0, 0.25),
        # LOW-LEVEL: three ellipsoids, each reached by a jump and held 1.5 s (the GUI's deadband makes the value
        # reached at the end of a slow ramp depend on which samples it took; a jump makes it exact)
        (11.5, 0.05, 0.0, 0.0, 0.0, 0.25),
        (11.5 + STEP, 0.08, -0.02, 0.03, 0.4, 0.25),
        (13.0, 0.08, -0.02, 0.03, 0.4, 0.25),
        (13.0 + STEP, 0.02, 0.07, 0.03, 0.7, 0.25),
        (14.5, 0.02, 0.07, 0.03, 0.7, 0.25),
        (15.0, 0.02, 0.07, 0.03, 0.7, 0.5),
        (15.5, 0.02, 0.07, 0.03, 0.7, 0.25),
    ]
)
CLICKS = (1.5, 4.0, 6.5, 10.0)  # [s] start of each click: gripper closed and button pressed for CLICK_LENGTH
CLICK_LENGTH = 0.1  # [s]


def state(t):
    x, y, z, yaw, gripper = (np.interp(t, KEYFRAMES[:, 0], KEYFRAMES[:, column]) for column in range(1, 6))
    clicking = any(start <= t < start + CLICK_LENGTH for start in CLICKS)
    return x, y, z, yaw, (0.0 if clicking else gripper), clicking


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--rate", type=float, default=200.0)
    arguments = parser.parse_args(rospy.myargv()[1:])
    rospy.init_node("scripted_device")
    publishers = {
        "pose": rospy.Publisher("/sigma7/pose", PoseStamped, queue_size=100),
        "twist": rospy.Publisher("/sigma7/twist", TwistStamped, queue_size=100),
        "gripper": rospy.Publisher("/sigma7/gripper_angle", Float64, queue_size=100),
        "button": rospy.Publisher("/sigma7/button", Bool, queue_size=100),
    }
    rospy.sleep(1.0)  # let the subscribers connect
    rate = rospy.Rate(arguments.rate)
    start = rospy.get_time()
    duration = KEYFRAMES[-1, 0]
    while not rospy.is_shutdown() and rospy.get_time() - start < duration:
        t = rospy.get_time() - start
        x, y, z, yaw, gripper, clicking = state(t)
        pose = PoseStamped()
        pose.header.stamp, pose.header.frame_id = rospy.Time.now(), "sigma7"
        pose.pose.position.x, pose.pose.position.y, pose.pose.position.z = x, y, z
        o = pose.pose.orientation
        o.x, o.y, o.z, o.w = Rotation.from_euler("ZYX", [yaw, 0.0, 0.0]).as_quat()
        twist = TwistStamped()
        twist.header = pose.header
        publishers["pose"].publish(pose)
        publishers["twist"].publish(twist)
        publishers["gripper"].publish(Float64(gripper))
        publishers["button"].publish(Bool(clicking))
        rate.sleep()
    rospy.sleep(0.5)  # let the last messages leave


if __name__ == "__main__":
    main()
