"""ROS layer of perception: the static_scene node.

robot_sim and static_scene publish ``teleteach/scene``; its format, both ways, is in teleteach.core.observed.
"""

import threading

import rospy
import tf2_ros
from actionlib_msgs.msg import GoalStatus
from sensor_msgs.msg import JointState
from visualization_msgs.msg import MarkerArray

from teleteach.core.observed import WORLD_FRAME, scene_markers
from teleteach.msg import GraspActionResult
from teleteach.perception.static import StaticScene, StaticSceneConfig


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
        """From the private parameters (config/static_scene.yaml, :class:`StaticSceneConfig`).

        A bad parameter raises ValueError, a bad scene file SceneError (a ValueError), each naming it.
        """
        from teleteach.core.scene import load_objects
        from teleteach.runtime.node import node_parameters

        config = StaticSceneConfig.from_mapping(node_parameters("static_scene.yaml"))
        objects = load_objects(config.scene_file or None)
        scene = StaticScene(objects, config.attach_distance, config.release_margin)
        node = cls(scene, config.rate, config.tcp_frame, config.finger_joints)
        source = config.scene_file or "config/supermarket.yaml"
        rospy.loginfo(f"static_scene: {len(objects.products)} products, {len(objects.gaps)} gaps from {source}")
        return node

    def _on_joint_states(self, msg):
        positions = dict(zip(msg.name, msg.position))
        if all(name in positions for name in self.finger_joints):
            with self._lock:
                self._width = float(sum(positions[name] for name in self.finger_joints))

    def _tcp(self):
        """The newest TCP pose in world as (stamp [s], position, quaternion), or None while TF does not have it."""
        try:
            transform = self._tf_buffer.lookup_transform(WORLD_FRAME, self.tcp_frame, rospy.Time(0))
        except (tf2_ros.LookupException, tf2_ros.ConnectivityException, tf2_ros.ExtrapolationException):
            return None
        t, r = transform.transform.translation, transform.transform.rotation
        return transform.header.stamp.to_sec(), (t.x, t.y, t.z), (r.x, r.y, r.z, r.w)

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
            name = self.scene.grasped(*tcp[1:], self._width)
        if name:
            rospy.loginfo(f"static_scene: {name} is in the hand")
        else:
            rospy.logwarn("static_scene: a grasp succeeded with no product of the scene file at the TCP")

    def _tick(self, _event):
        """Publish the belief, stamped with the time of the TF it was computed from.

        A loaded process holds TF from before the arm or the base stopped while its clock says now: stamped now, a
        carried product would look out of the hand in a scene that skills (skills.ros) and checks take as fresh.
        """
        tcp = self._tcp()
        with self._lock:
            released = None if tcp is None or self._width is None else self.scene.follow(*tcp[1:], self._width)
            observed = self.scene.observed(rospy.get_time() if tcp is None else tcp[0])
        if released:
            rospy.loginfo(f"static_scene: {released} released where the hand left it")
        self._publisher.publish(scene_markers(observed, observed.stamp))
