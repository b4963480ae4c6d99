"""ROS layer of control: the stiffness bridge to a variable impedance controller (teleteach.control.franka_stiffness).

robot_sim's controllers have their own node (teleteach.sim.ros).
"""

import rospy
from geometry_msgs.msg import QuaternionStamped, Vector3Stamped
from std_msgs.msg import Float32MultiArray, MultiArrayDimension

from teleteach.control.franka_stiffness import STIFFNESS_VALUES, StiffnessBridgeConfig, franka_stiffness
from teleteach.core.validation import (
    InvalidCommandError,
    check_frame,
    validate_eigenvalues,
    validate_quaternion,
)

WARN_PERIOD = 1.0  # [s] between two warnings of the same kind
OFF_DIAGONAL_NOTICE = 1.0  # [N/m] off-diagonal stiffness left out beyond this is reported


class StiffnessBridgeNode:
    """stiffness_bridge: /eigenvalues + /eigenvectors -> /stiffness (platonics-delft/franka_impedance_controller).

    Publishes once both have arrived, on every good message; a bad one (NaN or inf, negative, a zero or non-unit
    quaternion, another frame) is rejected with a log line and changes nothing: the controller keeps the last good
    stiffness.

    Args:
        config: the frame, the largest principal stiffness, K_R, the nullspace stiffness (StiffnessBridgeConfig).

    ROS Subscribers: eigenvalues (geometry_msgs/Vector3Stamped), eigenvectors (geometry_msgs/QuaternionStamped).
    ROS Publishers: stiffness (std_msgs/Float32MultiArray, seven values).
    """

    def __init__(self, config: StiffnessBridgeConfig):
        self.frame = config.frame
        self.max_stiffness = config.max_stiffness
        self.rotational_stiffness = config.rotational_stiffness
        self.nullspace_stiffness = config.nullspace_stiffness
        self.eigenvalues = None
        self.eigenvectors = None
        self.publisher = rospy.Publisher("stiffness", Float32MultiArray, queue_size=10)
        self._subscribers = [
            rospy.Subscriber("eigenvalues", Vector3Stamped, self._on_eigenvalues, queue_size=10),
            rospy.Subscriber("eigenvectors", QuaternionStamped, self._on_eigenvectors, queue_size=10),
        ]

    def _on_eigenvalues(self, message):
        vector = message.vector
        eigenvalues = self._accepted(
            "eigenvalues",
            message.header.frame_id,
            lambda: validate_eigenvalues((vector.x, vector.y, vector.z), self.max_stiffness),
        )
        if eigenvalues is not None:
            self.eigenvalues = eigenvalues
            self._publish()

    def _on_eigenvectors(self, message):
        q = message.quaternion
        eigenvectors = self._accepted(
            "eigenvectors", message.header.frame_id, lambda: validate_quaternion((q.x, q.y, q.z, q.w), "eigenvectors")
        )
        if eigenvectors is not None:
            self.eigenvectors = eigenvectors
            self._publish()

    def _accepted(self, topic, frame_id, validate):
        """The message's checked value, or None when it is rejected (logged; the bridge keeps the last good one)."""
        try:
            if frame_id:
                check_frame(frame_id, self.frame)
            return validate()
        except InvalidCommandError as error:
            rospy.logwarn_throttle(WARN_PERIOD, f"stiffness_bridge rejected a message on {topic}: {error}")
            return None

    def _publish(self):
        if self.eigenvalues is None or self.eigenvectors is None:
            return
        values, left_out = franka_stiffness(
            self.eigenvalues, self.eigenvectors, self.rotational_stiffness, self.nullspace_stiffness, self.max_stiffness
        )
        if left_out > OFF_DIAGONAL_NOTICE:
            rospy.logwarn_throttle(
                WARN_PERIOD,
                f"stiffness_bridge: the controller takes a diagonal stiffness: {left_out:.0f} N/m off the diagonal "
                "(a turned ellipsoid) left out",
            )
        message = Float32MultiArray(data=[float(value) for value in values])
        message.layout.dim = [MultiArrayDimension(label="stiffness", size=STIFFNESS_VALUES, stride=STIFFNESS_VALUES)]
        self.publisher.publish(message)
