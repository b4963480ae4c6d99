"""Reading a stiffness demonstration from a session bag (opened by teleteach.recording.session, with ``rosbags``).

The GUI publishes the principal stiffnesses on ``/eigenvalues`` (Vector3Stamped [N/m]) and the principal axes on
``/eigenvectors`` (QuaternionStamped, V = R(q)); the controller publishes ``/cartesian_pose`` and the trajectory
player ``/equilibrium_pose`` (PoseStamped). K = V diag(lambda) V^T (thesis eq 1), each eigenvalue message paired
with the eigenvector message nearest in time. Times are header stamps (the bag's receive time when a stamp is 0).

A stream's messages are put in stamp order, and messages that share a stamp become one sample, the last one: under
simulated time the GUI publishes (200 Hz) faster than /clock ticks, so consecutive commands carry the same stamp.
"""

import pathlib
from typing import Dict, List, Tuple, Union

import numpy as np

from teleteach.control.stiffness import translational_stiffnesses
from teleteach.learning.preprocess import LearningError
from teleteach.recording.session import SessionError, open_bag

EIGENVALUES = "/eigenvalues"
EIGENVECTORS = "/eigenvectors"
POSE_TOPICS = {"cartesian_pose": "/cartesian_pose", "equilibrium_pose": "/equilibrium_pose"}


def _stamp(message, received: int) -> float:
    stamp = message.header.stamp
    seconds = stamp.sec + stamp.nanosec * 1e-9
    return seconds if seconds > 0 else received * 1e-9


def _values(topic: str, message) -> List[float]:
    if topic == EIGENVALUES:
        return [message.vector.x, message.vector.y, message.vector.z]
    if topic == EIGENVECTORS:
        quaternion = message.quaternion
        return [quaternion.x, quaternion.y, quaternion.z, quaternion.w]
    position, orientation = message.pose.position, message.pose.orientation
    return [position.x, position.y, position.z, orientation.x, orientation.y, orientation.z, orientation.w]


def one_per_stamp(times: np.ndarray, values: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """The samples in stamp order, one per stamp: of messages that share a stamp, the last one received."""
    order = np.argsort(times, kind="stable")
    times, values = times[order], np.asarray(values, dtype=float)[order]
    last = np.append(np.diff(times) > 0.0, True)
    return times[last], values[last]


def read_bag(path: Union[str, pathlib.Path]) -> Tuple[np.ndarray, np.ndarray, Dict[str, Tuple[np.ndarray, np.ndarray]]]:
    """(stiffness times, stiffness (n, 3, 3), poses name -> (times, (k, 7))) from a session bag.

    Raises:
        LearningError: the bag is missing or unreadable, or lacks /eigenvalues, /eigenvectors or /cartesian_pose.
    """
    path = pathlib.Path(path).expanduser()
    if not path.is_file():
        raise LearningError(f"bag file {path} does not exist")
    rows: Dict[str, List[Tuple[float, List[float]]]] = {
        EIGENVALUES: [],
        EIGENVECTORS: [],
        **{topic: [] for topic in POSE_TOPICS.values()},
    }
    try:
        with open_bag(path) as reader:
            connections = [connection for connection in reader.connections if connection.topic in rows]
            for connection, received, raw in reader.messages(connections=connections):
                message = reader.deserialize(raw, connection.msgtype)
                rows[connection.topic].append((_stamp(message, received), _values(connection.topic, message)))
    except SessionError as error:
        raise LearningError(str(error)) from None
    for topic in (EIGENVALUES, EIGENVECTORS, POSE_TOPICS["cartesian_pose"]):
        if not rows[topic]:
            raise LearningError(f"bag {path} has no {topic} messages")

    def stream(topic):
        return one_per_stamp(np.array([row[0] for row in rows[topic]]), np.array([row[1] for row in rows[topic]]))

    value_times, eigenvalues = stream(EIGENVALUES)
    vector_times, quaternions = stream(EIGENVECTORS)
    norms = np.linalg.norm(quaternions, axis=1)
    bad = np.flatnonzero(~(np.abs(norms - 1.0) <= 1e-3))
    if bad.size:
        raise LearningError(f"{EIGENVECTORS} message {bad[0]} is not a unit quaternion (norm {norms[bad[0]]:.4f})")
    order = np.argsort(vector_times, kind="stable")
    right = np.clip(np.searchsorted(vector_times[order], value_times), 1, max(order.size - 1, 1))
    left = right - 1
    closer_left = np.abs(value_times - vector_times[order][left]) <= np.abs(vector_times[order][right] - value_times)
    nearest = order[np.where(closer_left, left, right)] if order.size > 1 else np.zeros(value_times.size, dtype=int)
    stiffness = translational_stiffnesses(eigenvalues, quaternions[nearest])
    poses = {name: stream(topic) for name, topic in POSE_TOPICS.items() if rows[topic]}
    return value_times, stiffness, poses
