#!/usr/bin/env python3
"""rostest check of a wipe under shared control through the real nodes, judged from the world (issue 49).

The base drives to the counter (move_base), the check sends the taught stiffness (3000 N/m along the board, 300 N/m
along its normal, axes those of the board as perceived) and enables shared control, which locates the board through
perception and TF; then a scripted operator wipes with a wave from right to left and on into the boundary. Every
check is on what the world did: the force the board puts on the tool along its true normal, the TCP in the true
board's frame, and what the controller recognised.
"""

import math
import threading
import unittest

import actionlib
import numpy as np
import rospy
import rostest
import tf2_ros
from geometry_msgs.msg import PoseStamped, QuaternionStamped, Vector3Stamped, WrenchStamped
from move_base_msgs.msg import MoveBaseAction, MoveBaseGoal
from scipy.spatial.transform import Rotation
from std_msgs.msg import Bool
from visualization_msgs.msg import MarkerArray

from teleteach.core.frames import Transform
from teleteach.core.observed import observed_from_markers
from teleteach.core.scene import load_scene
from teleteach.msg import SharedControlState
from teleteach.shared_control.models import synthetic_commands
from teleteach.shared_control.surface import wiping_box

BOARD = "counter_board"
TAUGHT = (3000.0, 3000.0, 300.0)  # [N/m] along u, along v, along the normal
RATE = 50.0  # [Hz] of the operator's commands
WAVE = (0.03, 20.0, 0.0)  # amplitude [m], spatial frequency [1/m], phase [m]
SPEED = 0.05  # [m/s]
CONTACT = 1.0  # [N] a normal force below this is no contact
BOUNDARY_TOLERANCE = 0.005  # [m] the tool's centre beyond the boundary (the arm tracks within a few mm)


def transform_of(box) -> Transform:
    return Transform(np.asarray(box.position), Rotation.from_quat(box.quaternion))


class Record:
    """The force on the tool, the TCP and the controller's states, by sim time."""

    def __init__(self):
        self.lock = threading.Lock()
        self.forces, self.poses, self.states = [], [], []
        rospy.Subscriber("/force_torque_ext", WrenchStamped, self._on_force, queue_size=1000)
        rospy.Subscriber("/cartesian_pose", PoseStamped, self._on_pose, queue_size=1000)
        rospy.Subscriber("/shared_control/state", SharedControlState, self._on_state, queue_size=1000)

    def _on_force(self, message):
        f = message.wrench.force
        with self.lock:
            self.forces.append((message.header.stamp.to_sec(), np.array([f.x, f.y, f.z])))

    def _on_pose(self, message):
        p = message.pose.position
        with self.lock:
            self.poses.append((message.header.stamp.to_sec(), np.array([p.x, p.y, p.z])))

    def _on_state(self, message):
        with self.lock:
            self.states.append(message)

    def between(self, store, start, end):
        with self.lock:
            return np.array([value for stamp, value in getattr(self, store) if start <= stamp <= end])


class WipeUnderSharedControl(unittest.TestCase):
    def wait_for(self, condition, what, timeout=60.0):
        deadline = rospy.Time.now().to_sec() + timeout
        while rospy.Time.now().to_sec() < deadline and not rospy.is_shutdown():
            value = condition()
            if value:
                return value
            rospy.sleep(0.05)
        self.fail(f"timed out waiting for {what}")

    def scene(self, topic):
        message = rospy.wait_for_message(topic, MarkerArray, timeout=30.0)
        return observed_from_markers(message.markers)[0].surfaces[BOARD]

    def test_the_taught_stiffness_keeps_the_tool_on_the_board_along_a_wave_inside_the_marked_area(self):
        scene = load_scene()
        record = Record()
        base = actionlib.SimpleActionClient("/move_base", MoveBaseAction)
        self.assertTrue(base.wait_for_server(rospy.Duration(60.0)), "no move_base server")
        pose = scene.base_poses["wipe_counter"]
        goal = MoveBaseGoal()
        goal.target_pose.header.frame_id = "world"
        goal.target_pose.header.stamp = rospy.Time.now()
        goal.target_pose.pose.position.x, goal.target_pose.pose.position.y = pose.x, pose.y
        goal.target_pose.pose.orientation.z, goal.target_pose.pose.orientation.w = (
            math.sin(pose.yaw / 2),
            math.cos(pose.yaw / 2),
        )
        base.send_goal(goal)
        self.assertTrue(base.wait_for_result(rospy.Duration(90.0)), "the base did not arrive at the counter")
        buffer = tf2_ros.Buffer()
        tf2_ros.TransformListener(buffer)
        rospy.sleep(1.0)  # perception reports the board from the new viewpoint
        stamped = buffer.lookup_transform("base_link", "world", rospy.Time(0), rospy.Duration(10.0)).transform
        world_in_base = Transform(
            np.array([stamped.translation.x, stamped.translation.y, stamped.translation.z]),
            Rotation.from_quat([stamped.rotation.x, stamped.rotation.y, stamped.rotation.z, stamped.rotation.w]),
        )
        seen_in_base = world_in_base * transform_of(self.scene("/teleteach/scene"))
        true_in_base = world_in_base * transform_of(self.scene("/teleteach/true_scene"))

        eigenvalues = rospy.Publisher("/eigenvalues", Vector3Stamped, queue_size=1, latch=True)
        eigenvectors = rospy.Publisher("/eigenvectors", QuaternionStamped, queue_size=1, latch=True)
        values = Vector3Stamped()
        values.header.stamp = rospy.Time.now()
        values.vector.x, values.vector.y, values.vector.z = TAUGHT
        axes = QuaternionStamped()
        axes.header.stamp = values.header.stamp
        axes.quaternion.x, axes.quaternion.y, axes.quaternion.z, axes.quaternion.w = seen_in_base.rotation.as_quat()
        eigenvectors.publish(axes)
        eigenvalues.publish(values)
        enable = rospy.Publisher("/shared_control/enable", Bool, queue_size=1, latch=True)
        command = rospy.Publisher("/shared_control/operator_command", Vector3Stamped, queue_size=10)
        rospy.sleep(0.5)
        enable.publish(Bool(data=True))
        self.wait_for(lambda: record.states, "the approach to the board (then /shared_control/state)", 90.0)

        start = rospy.Time.now().to_sec()
        rate = rospy.Rate(RATE)
        times = np.arange(0.0, 9.0, 1.0 / RATE)
        bad = rospy.Publisher("/eigenvalues", Vector3Stamped, queue_size=1)  # a bad message mid-wipe changes nothing
        for k, (x, y) in enumerate(
            synthetic_commands("wave", WAVE, math.pi, SPEED, times, 0.005, np.random.default_rng(49))
        ):
            message = Vector3Stamped()
            message.header.stamp = rospy.Time.now()
            message.vector.x, message.vector.y = float(x), float(y)
            command.publish(message)
            if k == len(times) // 2:
                nan = Vector3Stamped()
                nan.header.stamp = message.header.stamp
                nan.vector.x = nan.vector.y = nan.vector.z = float("nan")
                bad.publish(nan)
            rate.sleep()
        end = rospy.Time.now().to_sec()
        # The operator's input is lost (nothing more is sent): the tool must leave the board and the node stop.
        rospy.sleep(4.0)
        after = rospy.Time.now().to_sec()

        normal = true_in_base.rotation.apply([0.0, 0.0, 1.0])
        pressing = record.between("forces", start + 1.0, end) @ normal
        self.assertGreater(len(pressing), 100, "too few force samples")
        in_contact = float(np.mean(pressing >= CONTACT))
        self.assertGreaterEqual(in_contact, 0.9, f"in contact {in_contact:.0%} of the wipe")
        self.assertTrue(4.0 <= float(np.median(pressing)) <= 16.0, f"median force {np.median(pressing):.1f} N for 10 N")

        reach = scene.wiping_tool.reach
        tcp = record.between("poses", start, end)
        face = np.array([true_in_base.inverse().apply_point(point) for point in tcp])
        box = wiping_box(scene.surface(BOARD), scene.wiping_tool.size[:2])

        def beyond(points):
            return np.maximum.reduce(
                [box.x_min - points[:, 0], points[:, 0] - box.x_max, box.y_min - points[:, 1], points[:, 1] - box.y_max]
            )

        # The controller keeps the boundary where perception put the board; the world's marked area differs by
        # perception's in-plane bias (a few mm), which the controller cannot see.
        outside = beyond(np.array([seen_in_base.inverse().apply_point(point) for point in tcp]))
        outside_true = beyond(face)
        self.assertLessEqual(float(outside.max()), BOUNDARY_TOLERANCE, "the tool left the boundary")
        self.assertLess(float(face[:, 0].min()), box.x_min + 0.03, "the wipe did not reach the area's left edge")
        self.assertGreater(float(np.ptp(face[:, 1])), 0.03, "no wave across the board")
        self.assertTrue(np.all(np.abs(face[:, 2] - reach) < 0.03), "the TCP was not at the tool's reach over the board")

        lifted = record.between("forces", after - 0.5, after) @ normal
        last_face = true_in_base.inverse().apply_point(record.between("poses", after - 0.5, after)[-1])[2] - reach
        with record.lock:
            shared = [
                state.skill for state in record.states if state.header.stamp.to_sec() >= start + 2.0 and state.skill
            ]
            stopped = all(state.header.stamp.to_sec() < end + 2.5 for state in record.states)
            cycles, late = record.states[-1].cycle, record.states[-1].late_cycles
        print(
            f"input lost: force {np.max(lifted):.2f} N at most, the eraser's face {1000 * last_face:.0f} mm off the "
            f"board, shared control {'stopped' if stopped else 'still running'}",
            flush=True,
        )
        print(
            f"wipe: in contact {in_contact:.0%}, median force {np.median(pressing):.1f} N, tool outside the boundary "
            f"by at most {1000 * max(float(outside.max()), 0.0):.1f} mm as perceived, "
            f"{1000 * max(float(outside_true.max()), 0.0):.1f} mm in the world, u down to {face[:, 0].min():.3f} m, "
            f"v spans {np.ptp(face[:, 1]):.3f} m, recognised wave in {shared.count('wave')} of {len(shared)} cycles, "
            f"{late} of {cycles} cycles late",
            flush=True,
        )
        self.assertGreater(len(shared), 50)
        self.assertGreaterEqual(shared.count("wave") / len(shared), 0.9, f"recognised {set(shared)}")
        self.assertLess(float(np.max(lifted)), CONTACT, "the tool still pressed after the input was lost")
        self.assertGreater(last_face, 0.015, "the tool did not retract off the board")
        self.assertTrue(stopped, "shared control went on without input")


if __name__ == "__main__":
    rospy.init_node("shared_control_wipe_check")
    rostest.rosrun("teleteach", "shared_control_wipe_check", WipeUnderSharedControl)
