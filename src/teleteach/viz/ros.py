"""The ellipsoid marker's ROS layer: the commanded stiffness in, the RViz marker of ``viz.ellipsoid`` out."""

import math
import threading

import rospy
from geometry_msgs.msg import PoseStamped, QuaternionStamped, Vector3Stamped
from visualization_msgs.msg import Marker

from teleteach.control.validation import InvalidCommandError
from teleteach.node import node_parameters
from teleteach.viz.ellipsoid import EllipsoidMarkerBuilder, EllipsoidScale, drawn_as


class EllipsoidMarkerPublisher:
    """ROS wiring: /eigenvalues + /eigenvectors + /cartesian_pose in, /visualization_marker out when it changes.

    The marker is looked at ``rate`` times a second of wall time (not on every 100+ Hz pose, which keeps RViz's load
    independent of the controller rate) and published only when it would be drawn differently, latched: RViz keeps a
    marker until it is replaced, a display that starts later gets the last one, and a still arm under a constant
    stiffness costs no message. A plain thread keeps the rate: a rospy.Timer sleeps on ROS time, and under
    /use_sim_time rospy wakes it at every /clock message.

    Args:
        builder: holds the state and builds the marker.
        rate: how often the marker is looked at [Hz], and so its highest publication rate.

    ROS Subscribers:
        /eigenvalues (geometry_msgs/Vector3Stamped), /eigenvectors (geometry_msgs/QuaternionStamped),
        /cartesian_pose (geometry_msgs/PoseStamped)

    ROS Publishers:
        /visualization_marker (visualization_msgs/Marker)
    """

    WARN_PERIOD = 5.0
    """Seconds between two warnings about the same topic's bad messages."""

    @classmethod
    def from_params(cls) -> "EllipsoidMarkerPublisher":
        """Build from the private parameters (defaults: config/ellipsoid_marker.yaml)."""
        params = node_parameters("ellipsoid_marker.yaml")
        scale = EllipsoidScale(
            metres_per_stiffness=float(params["metres_per_stiffness"]),
            min_diameter=float(params["min_diameter"]),
            max_diameter=float(params["max_diameter"]),
        )
        return cls(EllipsoidMarkerBuilder(scale, frame_id=params["frame_id"]), rate=float(params["rate"]))

    def __init__(self, builder: EllipsoidMarkerBuilder, rate: float):
        if not (math.isfinite(rate) and rate > 0.0):
            raise ValueError(f"rate must be a finite number > 0 Hz, got {rate}")
        self.builder = builder
        self.publisher = rospy.Publisher("visualization_marker", Marker, queue_size=1, latch=True)
        self._shown = None
        self._subscribers = [
            rospy.Subscriber("eigenvalues", Vector3Stamped, self._guarded(builder.set_eigenvalues), queue_size=1),
            rospy.Subscriber("eigenvectors", QuaternionStamped, self._guarded(builder.set_eigenvectors), queue_size=1),
            rospy.Subscriber("cartesian_pose", PoseStamped, self._guarded(builder.set_pose), queue_size=1),
        ]
        self._stop = threading.Event()
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
        while not self._stop.wait(period) and not rospy.is_shutdown():
            self._publish()

    def _publish(self) -> None:
        marker = self.builder.marker()
        if marker is not None and drawn_as(marker) != self._shown:
            self._shown = drawn_as(marker)
            self.publisher.publish(marker)

    def shutdown(self) -> None:
        """Stop looking at the marker and unregister the topics."""
        self._stop.set()
        for subscriber in self._subscribers:
            subscriber.unregister()
        self.publisher.unregister()
