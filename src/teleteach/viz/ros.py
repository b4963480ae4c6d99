"""The ellipsoid marker's ROS layer: the commanded stiffness in, the RViz marker of ``viz.ellipsoid`` out."""

import math

import rospy
from geometry_msgs.msg import PoseStamped, QuaternionStamped, Vector3Stamped
from visualization_msgs.msg import Marker

from teleteach.control.validation import InvalidCommandError
from teleteach.viz.ellipsoid import EllipsoidMarkerBuilder


class EllipsoidMarkerPublisher:
    """ROS wiring: /eigenvalues + /eigenvectors + /cartesian_pose in, /visualization_marker out at a fixed rate.

    Publishing on a timer (not on every 100+ Hz pose) keeps RViz's load independent of the controller rate.

    Args:
        builder: holds the state and builds the marker.
        rate: publication rate [Hz].

    ROS Subscribers:
        /eigenvalues (geometry_msgs/Vector3Stamped), /eigenvectors (geometry_msgs/QuaternionStamped),
        /cartesian_pose (geometry_msgs/PoseStamped)

    ROS Publishers:
        /visualization_marker (visualization_msgs/Marker)
    """

    WARN_PERIOD = 5.0
    """Seconds between two warnings about the same topic's bad messages."""

    def __init__(self, builder: EllipsoidMarkerBuilder, rate: float):
        if not (math.isfinite(rate) and rate > 0.0):
            raise ValueError(f"rate must be a finite number > 0 Hz, got {rate}")
        self.builder = builder
        self.publisher = rospy.Publisher("visualization_marker", Marker, queue_size=1)
        self._subscribers = [
            rospy.Subscriber("eigenvalues", Vector3Stamped, self._guarded(builder.set_eigenvalues), queue_size=1),
            rospy.Subscriber("eigenvectors", QuaternionStamped, self._guarded(builder.set_eigenvectors), queue_size=1),
            rospy.Subscriber("cartesian_pose", PoseStamped, self._guarded(builder.set_pose), queue_size=1),
        ]
        self._timer = rospy.Timer(rospy.Duration(1.0 / rate), self._publish)

    def _guarded(self, setter):
        def callback(message):
            try:
                setter(message)
            except InvalidCommandError as error:
                rospy.logwarn_throttle(self.WARN_PERIOD, f"ellipsoid_marker: rejected a message: {error}")

        return callback

    def _publish(self, _event) -> None:
        marker = self.builder.marker()
        if marker is not None:
            self.publisher.publish(marker)

    def shutdown(self) -> None:
        """Stop the timer and unregister the topics."""
        self._timer.shutdown()
        for subscriber in self._subscribers:
            subscriber.unregister()
        self.publisher.unregister()
