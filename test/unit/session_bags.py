"""Writes small, scripted teaching-session bags with the real rosbag writer (what `rosbag record` uses)."""

import math

import genpy
import rosbag
from geometry_msgs.msg import PoseStamped, QuaternionStamped, Vector3Stamped
from scipy.spatial.transform import Rotation
from std_msgs.msg import Bool, Float64, Int8

from teleteach.msg import Behaviour, BehaviourTree

START = 1_700_000_000.0
SEQUENCE = ["LookToShelf", "PickItem", "MoveBase", "PlaceItem", "DropItem", "MoveBaseToStart", "Idle"]


def tree_message(sequence, running=None):
    behaviours = [
        Behaviour(name="Root", class_name="Selector", own_id="0", child_ids=["1", "2"], type=Behaviour.SELECTOR),
        Behaviour(name="PauseCondition", class_name="PauseCondition", own_id="1", parent_id="0"),
        Behaviour(
            name="BehaviorExecution",
            class_name="Sequence",
            own_id="2",
            parent_id="0",
            child_ids=[f"leaf_{name}" for name in sequence],
            type=Behaviour.SEQUENCE,
        ),
    ]
    for name in sequence:
        status = Behaviour.RUNNING if name == running else Behaviour.INVALID
        behaviours.append(
            Behaviour(name=name, class_name=name.split("_")[0], own_id=f"leaf_{name}", parent_id="2", status=status)
        )
    return BehaviourTree(behaviours=behaviours)


def eigenvalues_message(x, y, z, t=0.0):
    message = Vector3Stamped()
    message.header.stamp, message.header.frame_id = stamp(t), "base_link"
    message.vector.x, message.vector.y, message.vector.z = x, y, z
    return message


def eigenvectors_message(yaw, t=0.0):
    message = QuaternionStamped()
    message.header.stamp, message.header.frame_id = stamp(t), "base_link"
    q = message.quaternion
    q.x, q.y, q.z, q.w = Rotation.from_euler("ZYX", [yaw, 0.0, 0.0]).as_quat()
    return message


def pose_message(x=0.4, y=0.0, z=0.6, t=0.0, frame="base_link"):
    message = PoseStamped()
    message.header.stamp, message.header.frame_id = stamp(t), frame
    message.pose.position.x, message.pose.position.y, message.pose.position.z = x, y, z
    message.pose.orientation.w = 1.0
    return message


def device_state(t):
    """Scripted device input: select a node (X), pick an operation (Y), then rotate about Z by 45 degrees."""
    x = 0.08 * min(t / 2.0, 1.0) - 0.04 * max(0.0, min((t - 6.0) / 2.0, 1.0))
    y = 0.01 * t if t < 2.5 else max(0.025 - 0.03 * (t - 2.5), -0.05)
    yaw = math.radians(45.0) * max(0.0, min((t - 7.0) / 2.0, 1.0))
    click_times = (2.2, 3.8, 6.5)
    clicking = any(click <= t < click + 0.1 for click in click_times)
    gripper = 0.0 if clicking else (0.5 if 4.5 <= t < 5.0 else 0.25)
    return x, y, yaw, gripper, clicking


def stamp(t):
    return genpy.Time.from_sec(START + t)


def write_session(path, duration=10.0, device_rate=200.0, topics=None):
    """A scripted session; `topics` limits what is written (None: everything)."""

    def wanted(topic):
        return topics is None or topic in topics

    with rosbag.Bag(str(path), "w") as bag:
        steps = int(duration * device_rate)
        for step in range(steps):
            t = step / device_rate
            x, y, yaw, gripper, clicking = device_state(t)
            if wanted("/sigma7/pose"):
                pose = PoseStamped()
                pose.header.stamp, pose.header.frame_id = stamp(t), "sigma7"
                pose.pose.position.x, pose.pose.position.y = x, y
                q = Rotation.from_euler("ZYX", [yaw, 0.0, 0.0]).as_quat()
                o = pose.pose.orientation
                o.x, o.y, o.z, o.w = q
                bag.write("/sigma7/pose", pose, stamp(t))
            if wanted("/sigma7/gripper_angle"):
                bag.write("/sigma7/gripper_angle", Float64(gripper), stamp(t))
            if wanted("/sigma7/button"):
                bag.write("/sigma7/button", Bool(clicking), stamp(t))
            if step % int(device_rate / 100) == 0 and wanted("/cartesian_pose"):
                bag.write("/cartesian_pose", pose_message(0.4 + 0.03 * t, t=t), stamp(t))
            if t >= 6.0 and step % int(device_rate / 25) == 0:
                if wanted("/eigenvalues"):
                    values = (300.0 + 20000.0 * max(x, 0.0), 300.0 + 30000.0 * max(-y, 0.0), 2000.0)
                    bag.write("/eigenvalues", eigenvalues_message(*values, t=t), stamp(t))
                if wanted("/eigenvectors"):
                    bag.write("/eigenvectors", eigenvectors_message(yaw, t=t), stamp(t))
        if wanted("/teleteach/active_tab"):
            for t, tab in ((0.0, 0), (0.5, 1), (5.0, 0), (5.5, 2)):
                bag.write("/teleteach/active_tab", Int8(tab), stamp(t))
        if wanted("/behaviour_tree/log/tree"):
            removed = [name for name in SEQUENCE if name != "PlaceItem"]
            reinserted = removed[:2] + ["PlaceItem_2"] + removed[2:]
            for t, sequence, running in (
                (0.0, SEQUENCE, None),
                (1.0, SEQUENCE, "LookToShelf"),  # status only: not an edit
                (3.9, removed, "LookToShelf"),
                (9.5, reinserted, "PickItem"),
            ):
                bag.write("/behaviour_tree/log/tree", tree_message(sequence, running), stamp(t))
    return path
