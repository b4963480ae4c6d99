"""The ROS layers of what only RViz shows: the stiffness ellipsoid (``viz.ellipsoid``) and the scene (``viz.scene``)."""

import threading
import time

import rosgraph
import rospy
from geometry_msgs.msg import PoseStamped, QuaternionStamped, Vector3Stamped
from visualization_msgs.msg import Marker, MarkerArray

from teleteach.core.observed import SCENE_TOPIC
from teleteach.core.validation import InvalidCommandError
from teleteach.runtime.node import node_parameters
from teleteach.viz.ellipsoid import EllipsoidMarkerBuilder, EllipsoidMarkerConfig, drawn_as
from teleteach.viz.scene import SCENE_RVIZ_TOPIC, rviz_markers


class EllipsoidMarkerPublisher:
    """ROS wiring: /eigenvalues + /eigenvectors + /cartesian_pose in, /visualization_marker out when it changes.

    The marker is looked at ``rate`` times a second of wall time (not on every 100+ Hz pose, which keeps RViz's load
    independent of the controller rate) and published only when it would be drawn differently, latched: RViz keeps a
    marker until it is replaced, a display that starts later gets the last one, and a still arm under a constant
    stiffness costs no message. A plain thread keeps the rate: a rospy.Timer sleeps on ROS time, and under
    /use_sim_time rospy wakes it at every /clock message.

    The end effector's pose (200 Hz, most of the node's CPU) is heard only while someone subscribes to the marker,
    as the master says every ``VIEWERS_PERIOD`` (a publisher itself only learns of a lost subscriber when it
    writes, and a still marker writes nothing). The stiffness topics, sent when the stiffness changes, are always
    heard, so a display that starts later sees the current one (latched at once, where the pose last put it).

    Args:
        builder: holds the state and builds the marker.
        rate: how often the marker is looked at [Hz], and so its highest publication rate.

    ROS Subscribers:
        /eigenvalues (geometry_msgs/Vector3Stamped), /eigenvectors (geometry_msgs/QuaternionStamped),
        /cartesian_pose (geometry_msgs/PoseStamped; while the marker has a subscriber)

    ROS Publishers:
        /visualization_marker (visualization_msgs/Marker)
    """

    WARN_PERIOD = 5.0
    """Seconds between two warnings about the same topic's bad messages."""

    VIEWERS_PERIOD = 1.0
    """Seconds between two questions to the master whether anyone still subscribes to the marker."""

    @classmethod
    def from_params(cls) -> "EllipsoidMarkerPublisher":
        """Build from the private parameters (config/ellipsoid_marker.yaml, :class:`EllipsoidMarkerConfig`)."""
        config = EllipsoidMarkerConfig.from_mapping(node_parameters("ellipsoid_marker.yaml"))
        return cls(config.builder(), config.rate)

    def __init__(self, builder: EllipsoidMarkerBuilder, rate: float):
        self.builder = builder
        self.publisher = rospy.Publisher("visualization_marker", Marker, queue_size=1, latch=True)
        self._shown = None
        self._subscribers = [
            rospy.Subscriber("eigenvalues", Vector3Stamped, self._guarded(builder.set_eigenvalues), queue_size=1),
            rospy.Subscriber("eigenvectors", QuaternionStamped, self._guarded(builder.set_eigenvectors), queue_size=1),
        ]
        self._pose_subscriber = None
        self._master = rosgraph.Master(rospy.get_name())
        self._thread = threading.Thread(target=self._run, args=(1.0 / rate,), name="marker", daemon=True)
        self._thread.start()

    def _guarded(self, setter):
        def callback(message):
            try:
                setter(message)
            except InvalidCommandError as error:
                rospy.logwarn_throttle(self.WARN_PERIOD, f"ellipsoid_marker: rejected a message: {error}")

        return callback

    def _run(self, period: float) -> None:
        next_look = 0.0
        while not rospy.is_shutdown():
            time.sleep(period)
            if time.monotonic() >= next_look:
                self._hear_pose(self._viewed())
                next_look = time.monotonic() + self.VIEWERS_PERIOD
            self._publish()

    def _viewed(self) -> bool:
        """Whether the master lists the marker's topic (only while it has a subscriber); True if it cannot be asked."""
        try:
            _, subscriptions, _ = self._master.getSystemState()
        except (OSError, rosgraph.MasterException):
            return True
        return any(topic == self.publisher.resolved_name for topic, _ in subscriptions)

    def _hear_pose(self, viewed: bool) -> None:
        if viewed and self._pose_subscriber is None:
            self._pose_subscriber = rospy.Subscriber(
                "cartesian_pose", PoseStamped, self._guarded(self.builder.set_pose), queue_size=1
            )
        elif not viewed and self._pose_subscriber is not None:
            self._pose_subscriber.unregister()
            self._pose_subscriber = None

    def _publish(self) -> None:
        marker = self.builder.marker()
        if marker is not None and drawn_as(marker) != self._shown:
            self._shown = drawn_as(marker)
            self.publisher.publish(marker)


class SceneLabelsPublisher(rospy.SubscribeListener):
    """ROS wiring: teleteach/scene in, teleteach/scene_rviz out (:func:`teleteach.viz.scene.rviz_markers`).

    Each scene message becomes one message for RViz, latched, but only while someone subscribes to it (the conversion
    is a few ms per scene, 10 scenes a second in a simulation): a subscriber that comes later gets the latest scene at
    once. A named object that is no object (NaN, a tilted gap, a name taken) gets no label, with a warning at most
    every ``WARN_PERIOD``; its shape is drawn as RViz draws it.

    ROS Subscribers:
        teleteach/scene (visualization_msgs/MarkerArray)

    ROS Publishers:
        teleteach/scene_rviz (visualization_msgs/MarkerArray; latched)
    """

    WARN_PERIOD = 5.0
    """Seconds between two warnings about markers that got no label."""

    def __init__(self):
        super().__init__()
        self._lock = threading.Lock()
        self._latest = None
        self.publisher = rospy.Publisher(
            SCENE_RVIZ_TOPIC, MarkerArray, queue_size=1, latch=True, subscriber_listener=self
        )
        self._subscriber = rospy.Subscriber(SCENE_TOPIC, MarkerArray, self._on_scene, queue_size=1)

    def _on_scene(self, message: MarkerArray) -> None:
        with self._lock:
            self._latest = message
            if self.publisher.get_num_connections() > 0:
                self._publish(message)

    def peer_subscribe(self, topic_name, topic_publish, peer_publish) -> None:
        """A new subscriber (RViz): the latest scene, converted now (nothing was converted while nobody listened)."""
        with self._lock:
            if self._latest is not None:
                self._publish(self._latest)

    def _publish(self, message: MarkerArray) -> None:
        markers, rejected = rviz_markers(message.markers)
        if rejected:
            rospy.logwarn_throttle(self.WARN_PERIOD, f"scene_labels: no label for {'; '.join(rejected)}")
        self.publisher.publish(MarkerArray(markers=markers))
