"""ROS layer of perception: the ``teleteach/scene`` MarkerArray of an observed scene, and the static_scene node.

robot_sim and static_scene publish the message; its format is in teleteach.perception.observed.
"""

import threading
from typing import Iterable

import rospy
import tf2_ros
from actionlib_msgs.msg import GoalStatus
from sensor_msgs.msg import JointState
from std_msgs.msg import Header
from visualization_msgs.msg import Marker, MarkerArray

from teleteach.msg import GraspActionResult
from teleteach.perception.observed import GAPS, PRODUCTS, TABLES, WORLD_FRAME, ObservedScene, gap_box
from teleteach.perception.static import StaticScene

PRODUCT_COLOUR = (0.8, 0.2, 0.2, 1.0)
GAP_COLOUR = (0.1, 0.8, 0.1, 0.5)
TABLE_COLOUR = (0.5, 0.5, 0.5, 1.0)


def box_marker(header, namespace, marker_id, position, quaternion, size, colour, text) -> Marker:
    """A CUBE marker: centre [m], (x, y, z, w) quaternion, size [m], RGBA colour, name in text."""
    marker = Marker(header=header, ns=namespace, id=marker_id, type=Marker.CUBE, action=Marker.ADD, text=text)
    marker.pose.position.x, marker.pose.position.y, marker.pose.position.z = (float(v) for v in position)
    orientation = marker.pose.orientation
    orientation.x, orientation.y, orientation.z, orientation.w = (float(v) for v in quaternion)
    marker.scale.x, marker.scale.y, marker.scale.z = (float(v) for v in size)
    marker.color.r, marker.color.g, marker.color.b, marker.color.a = colour
    return marker


def scene_markers(observed: ObservedScene, stamp: float, extras: Iterable[Marker] = ()) -> MarkerArray:
    """The ``teleteach/scene`` message of an observed scene, stamped stamp [s], after the extras (RViz only)."""
    header = Header(stamp=rospy.Time.from_sec(stamp), frame_id=WORLD_FRAME)
    markers = list(extras)
    for index, table in enumerate(observed.tables.values()):
        markers.append(
            box_marker(header, TABLES, index, table.position, table.quaternion, table.size, TABLE_COLOUR, table.name)
        )
    for index, gap in enumerate(observed.gaps.values()):
        markers.append(box_marker(header, GAPS, index, *gap_box(gap), GAP_COLOUR, gap.name))
    for index, product in enumerate(observed.products.values()):
        markers.append(
            box_marker(
                header,
                PRODUCTS,
                index,
                product.position,
                product.quaternion,
                product.size,
                PRODUCT_COLOUR,
                product.name,
            )
        )
    return MarkerArray(markers=markers)


class StaticSceneNode:
    """static_scene: teleteach/scene from a scene file, the held product following the hand (perception.static).

    Args:
        scene: the belief.
        rate: publication rate [Hz].
        tcp_frame: the TF frame of the tool centre point (between the fingertips).
        finger_joints: the two finger joints in joint_states (their positions add up to the opening).

    ROS Publishers: teleteach/scene (visualization_msgs/MarkerArray, world, at rate).
    ROS Subscribers: joint_states (the fingers' opening), franka_gripper/grasp/result (a grasp that succeeded
    attaches the product at the TCP); TF world -> tcp_frame.
    """

    def __init__(self, scene: StaticScene, rate: float, tcp_frame: str, finger_joints):
        self.scene = scene
        self.tcp_frame = tcp_frame
        self.finger_joints = list(finger_joints)
        self._lock = threading.Lock()
        self._width = None
        self._tf_buffer = tf2_ros.Buffer(cache_time=rospy.Duration(10.0))
        self._tf_listener = tf2_ros.TransformListener(self._tf_buffer)
        self._publisher = rospy.Publisher("teleteach/scene", MarkerArray, queue_size=1, latch=True)
        self._subscribers = [
            rospy.Subscriber("joint_states", JointState, self._on_joint_states, queue_size=1),
            rospy.Subscriber("franka_gripper/grasp/result", GraspActionResult, self._on_grasp, queue_size=5),
        ]
        self._timer = rospy.Timer(rospy.Duration(1.0 / rate), self._tick)

    @classmethod
    def from_params(cls) -> "StaticSceneNode":
        """From the private parameters (defaults: config/static_scene.yaml); a bad scene file raises SceneError."""
        from teleteach.node import node_parameters
        from teleteach.scene import load_objects

        params = node_parameters("static_scene.yaml")
        objects = load_objects(params["scene_file"] or None)
        scene = StaticScene(objects, params["attach_distance"], params["release_margin"])
        node = cls(scene, float(params["rate"]), params["tcp_frame"], params["finger_joints"])
        source = params["scene_file"] or "config/supermarket.yaml"
        rospy.loginfo(f"static_scene: {len(objects.products)} products, {len(objects.gaps)} gaps from {source}")
        return node

    def _on_joint_states(self, msg):
        positions = dict(zip(msg.name, msg.position))
        if all(name in positions for name in self.finger_joints):
            with self._lock:
                self._width = float(sum(positions[name] for name in self.finger_joints))

    def _tcp(self):
        """The TCP pose in world (position, quaternion), or None while TF does not have it."""
        try:
            transform = self._tf_buffer.lookup_transform(WORLD_FRAME, self.tcp_frame, rospy.Time(0))
        except (tf2_ros.LookupException, tf2_ros.ConnectivityException, tf2_ros.ExtrapolationException):
            return None
        t, r = transform.transform.translation, transform.transform.rotation
        return (t.x, t.y, t.z), (r.x, r.y, r.z, r.w)

    def _on_grasp(self, msg):
        if msg.status.status != GoalStatus.SUCCEEDED or not msg.result.success:
            return
        tcp = self._tcp()
        with self._lock:
            if tcp is None or self._width is None:
                rospy.logwarn(
                    f"static_scene: a grasp succeeded, but the TCP ({self.tcp_frame}) or the fingers are unknown"
                )
                return
            name = self.scene.grasped(*tcp, self._width)
        if name:
            rospy.loginfo(f"static_scene: {name} is in the hand")
        else:
            rospy.logwarn("static_scene: a grasp succeeded with no product of the scene file at the TCP")

    def _tick(self, _event):
        tcp = self._tcp()
        with self._lock:
            released = None if tcp is None or self._width is None else self.scene.follow(*tcp, self._width)
            observed = self.scene.observed(rospy.get_time())
        if released:
            rospy.loginfo(f"static_scene: {released} released where the hand left it")
        self._publisher.publish(scene_markers(observed, observed.stamp))
