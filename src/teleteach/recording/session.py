"""A recorded teaching session read offline from its bag with the ``rosbags`` library (no ROS master).

Only what the report and the run's checks need is deserialised: device pose, gripper and button, active tab,
eigenvalues and eigenvectors, end-effector position, the tree log, the products' poses (from /teleteach/true_scene,
the world as it is, when a simulation recorded it; else from /teleteach/scene, what perception reported), the gaps as
perceived and as they are, and robot_sim's MoveBase errors (/robot_sim/base_error).
Times are seconds since the bag's first message (the bag's receive time, so topics without a header line up with
the others).
"""

import contextlib
import dataclasses
import pathlib
import struct
from typing import Dict, Iterator, List, Optional, Tuple, Union

import numpy as np

from teleteach.core.observed import SCENE_TOPIC, TRUE_SCENE_TOPIC, observed_from_markers
from teleteach.core.rotations import quaternion_to_rpy, wrap_angle, yaw_rotation
from teleteach.core.validation import InvalidCommandError, validate_eigenvalues, validate_quaternion
from teleteach.recording.bags import BagError, check_bag

RUNNING, SUCCESS = 2, 3  # teleteach/Behaviour statuses (the message module needs the catkin build, this does not)


class SessionError(ValueError):
    """The bag cannot be read; the message names the file and the problem."""


@dataclasses.dataclass
class Series:
    """Samples of one topic: ``times`` [s since bag start] and ``values`` (one row per message)."""

    times: np.ndarray
    values: np.ndarray

    def __len__(self) -> int:
        return len(self.times)

    def at(self, times: np.ndarray) -> np.ndarray:
        """The value held at each of ``times`` (last sample at or before it; the first sample before it starts)."""
        index = np.clip(np.searchsorted(self.times, times, side="right") - 1, 0, len(self.times) - 1)
        return self.values[index]


@dataclasses.dataclass
class TreeSnapshot:
    """The tree at one time: behaviour names depth-first, each composite's children in order, the running leaves.

    ``types`` holds each behaviour's teleteach/Behaviour type (SEQUENCE, SELECTOR, ...): a conversion changes it.
    """

    time: float
    names: Tuple[str, ...]
    children: Dict[str, Tuple[str, ...]]
    running: Tuple[str, ...] = ()
    types: Dict[str, int] = dataclasses.field(default_factory=dict)


@dataclasses.dataclass
class TopicInfo:
    """What the bag holds on one topic."""

    msgtype: str
    count: int


@dataclasses.dataclass
class Session:
    """A teaching session's data. A series is None when its topic is missing from the bag or empty."""

    path: pathlib.Path
    start_ns: int
    duration: float
    topics: Dict[str, TopicInfo]
    device_position: Optional[Series] = None
    device_yaw: Optional[Series] = None
    gripper: Optional[Series] = None
    button: Optional[Series] = None
    active_tab: Optional[Series] = None
    eigenvalues: Optional[Series] = None
    eigenvectors: Optional[Series] = None
    cartesian_position: Optional[Series] = None
    trees: List[TreeSnapshot] = dataclasses.field(default_factory=list)
    products: Dict[str, Series] = dataclasses.field(default_factory=dict)
    rejected: Dict[str, int] = dataclasses.field(default_factory=dict)
    products_from: str = ""
    perceived_gaps: Dict[str, Series] = dataclasses.field(default_factory=dict)
    true_gaps: Dict[str, Series] = dataclasses.field(default_factory=dict)
    base_errors: Optional[Series] = None

    def gap_perception_error(self, gap: str, time: float) -> Optional[np.ndarray]:
        """How far off perception saw ``gap`` at time [s], in the true gap's frame; None without both views of it.

        Returns (depth, across, height [m], yaw [rad]).
        """
        if gap not in self.perceived_gaps or gap not in self.true_gaps:
            return None
        seen, truth = self.perceived_gaps[gap].at(time), self.true_gaps[gap].at(time)
        offset = yaw_rotation(truth[3]).inv().apply(seen[:3] - truth[:3])
        return np.array([*offset, wrap_angle(seen[3] - truth[3])])

    def base_error(self, time: float) -> Optional[np.ndarray]:
        """Where the last MoveBase before time [s] stopped in its goal's frame (x, y [m], yaw [rad]); None: none."""
        if self.base_errors is None or not len(self.base_errors) or self.base_errors.times[0] > time:
            return None
        return self.base_errors.at(time)


def yaw_of(quaternions_xyzw: np.ndarray) -> np.ndarray:
    """Rotation about Z [rad] of R = Rz(yaw) Ry(pitch) Rx(roll), unwrapped over time.

    NaN where a quaternion is zero or not finite: a bad device sample must not stop the report.
    """
    quaternions = np.asarray(quaternions_xyzw, dtype=float).reshape(-1, 4)
    yaw = np.full(len(quaternions), np.nan)
    valid = np.all(np.isfinite(quaternions), axis=1) & (np.linalg.norm(quaternions, axis=1) > 1e-9)
    if np.any(valid):
        yaw[valid] = np.unwrap(quaternion_to_rpy(quaternions[valid])[:, 2])
    return yaw


def axes_yaw_of(quaternions_xyzw: np.ndarray) -> np.ndarray:
    """Rotation about Z [rad] of an ellipsoid's principal axes: modulo pi, since an axis has no sign.

    The same ellipsoid comes as R and as R with two axes flipped (yaw + pi from an eigendecomposition's sign choice),
    so the yaw is continuous over time modulo pi and starts in [-pi/2, pi/2). NaN where ``yaw_of`` gives NaN.
    """
    yaw = yaw_of(quaternions_xyzw)
    valid = np.isfinite(yaw)
    if np.any(valid):
        axes = np.unwrap(2.0 * yaw[valid]) / 2.0
        yaw[valid] = axes - np.pi * np.floor(axes[0] / np.pi + 0.5)
    return yaw


def accepted_stiffness(eigenvalues: Series, eigenvectors: Series) -> Tuple[Series, Series, int, int]:
    """The stiffness messages the controller accepts (teleteach.core.validation), and how many were rejected."""
    good_values = [
        index
        for index, row in enumerate(eigenvalues.values)
        if _accepted(lambda values: validate_eigenvalues(values, np.inf), row)
    ]
    good_vectors = [index for index, row in enumerate(eigenvectors.values) if _accepted(validate_quaternion, row)]
    return (
        Series(eigenvalues.times[good_values], eigenvalues.values[good_values]),
        Series(eigenvectors.times[good_vectors], eigenvectors.values[good_vectors]),
        len(eigenvalues) - len(good_values),
        len(eigenvectors) - len(good_vectors),
    )


def _accepted(validate, row) -> bool:
    try:
        validate(row)
    except InvalidCommandError:
        return False
    return True


def tree_structure(behaviours) -> Tuple[Tuple[str, ...], Dict[str, Tuple[str, ...]]]:
    """Depth-first names and children of a teleteach/BehaviourTree message's behaviours (statuses ignored)."""
    by_id = {behaviour.own_id: behaviour for behaviour in behaviours}
    child_ids = {child for behaviour in behaviours for child in behaviour.child_ids}
    roots = [behaviour for behaviour in behaviours if behaviour.own_id not in child_ids]
    names: List[str] = []
    children: Dict[str, Tuple[str, ...]] = {}
    seen = set()

    def visit(behaviour):
        if behaviour.own_id in seen:
            return
        seen.add(behaviour.own_id)
        names.append(behaviour.name)
        kids = [by_id[child] for child in behaviour.child_ids if child in by_id]
        if kids:
            children[behaviour.name] = tuple(kid.name for kid in kids)
        for kid in kids:
            visit(kid)

    for root in roots:
        visit(root)
    for behaviour in behaviours:  # ids that do not form a tree: keep the message order for the rest
        visit(behaviour)
    return tuple(names), children


def running_leaves(behaviours) -> Tuple[str, ...]:
    """Names of the leaves of a teleteach/BehaviourTree message that are running: none while the tree is paused.

    A pause suspends the running leaf (it keeps its RUNNING status, unticked); a succeeding PauseCondition says so.
    """
    if any(b.class_name == "PauseCondition" and b.status == SUCCESS for b in behaviours):
        return ()
    return tuple(b.name for b in behaviours if not b.child_ids and b.status == RUNNING)


_READ = {
    "/sigma7/pose": "geometry_msgs/msg/PoseStamped",
    "/sigma7/gripper_angle": "std_msgs/msg/Float64",
    "/sigma7/button": "std_msgs/msg/Bool",
    "/teleteach/active_tab": "std_msgs/msg/Int8",
    "/eigenvalues": "geometry_msgs/msg/Vector3Stamped",
    "/eigenvectors": "geometry_msgs/msg/QuaternionStamped",
    "/cartesian_pose": "geometry_msgs/msg/PoseStamped",
    "/behaviour_tree/log/tree": "teleteach/msg/BehaviourTree",
    f"/{SCENE_TOPIC}": "visualization_msgs/msg/MarkerArray",
    f"/{TRUE_SCENE_TOPIC}": "visualization_msgs/msg/MarkerArray",
    "/robot_sim/base_error": "geometry_msgs/msg/PoseStamped",
}
"""Topics the report reads, with the type it expects on each (others are counted, not read)."""


def _row(topic: str, message) -> tuple:
    if topic in ("/sigma7/pose", "/cartesian_pose"):
        p, q = message.pose.position, message.pose.orientation
        return (p.x, p.y, p.z, q.x, q.y, q.z, q.w)
    if topic == "/eigenvalues":
        return (message.vector.x, message.vector.y, message.vector.z)
    if topic == "/eigenvectors":
        q = message.quaternion
        return (q.x, q.y, q.z, q.w)
    if topic == "/robot_sim/base_error":
        p, q = message.pose.position, message.pose.orientation
        return (p.x, p.y, quaternion_to_rpy([q.x, q.y, q.z, q.w])[2])
    return (float(message.data),)


def _series(times: List[float], rows: List[tuple]) -> Optional[Series]:
    if not times:
        return None
    return Series(np.asarray(times, dtype=float), np.asarray(rows, dtype=float))


@contextlib.contextmanager
def open_bag(path: Union[str, pathlib.Path]) -> Iterator:
    """A ``rosbags`` reader of a session bag: the one place where teleteach opens bags (report, run checks, learning).

    Raises:
        SessionError: "cannot read bag <file>: <what is wrong>", also for errors while its messages are read.
    """
    from rosbags.highlevel import AnyReader, AnyReaderError
    from rosbags.rosbag1 import ReaderError

    try:
        path = check_bag(path)
    except BagError as error:
        raise SessionError(f"cannot read bag {path}: {error}") from None
    if path.suffix != ".bag":
        raise SessionError(
            f"cannot read bag {path}: it does not end in .bag (an unfinished recording? run `rosbag reindex` first)"
        )
    try:
        with AnyReader([path]) as reader:
            yield reader
    except (
        AnyReaderError,
        ReaderError,
        KeyError,
        ValueError,
        EOFError,
        OSError,
        AssertionError,
        struct.error,
    ) as error:
        reason = str(error) or type(error).__name__
        raise SessionError(f"cannot read bag {path}: {reason} (truncated or damaged?)") from None


def read_session(path: Union[str, pathlib.Path]) -> Session:
    """Read a session bag, or raise :class:`SessionError` naming the file and what is wrong with it."""
    with open_bag(path) as reader:
        return _read(reader, pathlib.Path(path).expanduser())


def _read_messages(reader, start: int):
    """Deserialise the messages of the topics read (times [s] from ``start`` [ns]); the others are never unpacked.

    Returns the times and rows of each topic of ``_READ``, the tree snapshots, and the perceived and true scenes.
    """
    wanted = [
        connection
        for connection in reader.connections
        if _READ.get(connection.topic) == connection.msgtype and connection.msgcount > 0
    ]
    times: Dict[str, List[float]] = {topic: [] for topic in _READ}
    rows: Dict[str, List[tuple]] = {topic: [] for topic in _READ}
    trees: List[TreeSnapshot] = []
    scenes = {f"/{SCENE_TOPIC}": _SceneSeries(), f"/{TRUE_SCENE_TOPIC}": _SceneSeries()}
    for connection, timestamp, raw in reader.messages(connections=wanted):
        message = reader.deserialize(raw, connection.msgtype)
        time = (timestamp - start) / 1e9
        if connection.topic == "/behaviour_tree/log/tree":
            names, children = tree_structure(message.behaviours)
            types = {behaviour.name: behaviour.type for behaviour in message.behaviours}
            trees.append(TreeSnapshot(time, names, children, running_leaves(message.behaviours), types))
        elif connection.topic in scenes:
            scenes[connection.topic].add(time, message.markers)
        else:
            times[connection.topic].append(time)
            rows[connection.topic].append(_row(connection.topic, message))
    return times, rows, trees, scenes


def _stiffness_series(times: Dict[str, List[float]], rows: Dict[str, List[tuple]]):
    """The eigenvalues and eigenvectors the controller accepts (None if none), and how many of each it rejects."""
    rejected = {}
    eigenvalues = _series(times["/eigenvalues"], rows["/eigenvalues"])
    eigenvectors = _series(times["/eigenvectors"], rows["/eigenvectors"])
    if eigenvalues is not None and eigenvectors is not None:
        eigenvalues, eigenvectors, rejected["/eigenvalues"], rejected["/eigenvectors"] = accepted_stiffness(
            eigenvalues, eigenvectors
        )
        eigenvalues = eigenvalues if len(eigenvalues) else None
        eigenvectors = eigenvectors if len(eigenvectors) else None
    return eigenvalues, eigenvectors, rejected


def _read(reader, path: pathlib.Path) -> Session:
    start = reader.start_time if reader.message_count else 0
    duration = (reader.end_time - reader.start_time) / 1e9 if reader.message_count else 0.0
    topics = {topic: TopicInfo(info.msgtype or "", info.msgcount) for topic, info in reader.topics.items()}
    times, rows, trees, scenes = _read_messages(reader, start)
    eigenvalues, eigenvectors, rejected = _stiffness_series(times, rows)
    truth, perceived = scenes[f"/{TRUE_SCENE_TOPIC}"], scenes[f"/{SCENE_TOPIC}"]
    judged = truth if truth.products else perceived
    device = _series(times["/sigma7/pose"], rows["/sigma7/pose"])
    cartesian = _series(times["/cartesian_pose"], rows["/cartesian_pose"])
    button = _series(times["/sigma7/button"], rows["/sigma7/button"])
    return Session(
        path=path,
        start_ns=start,
        duration=duration,
        topics=topics,
        device_position=Series(device.times, device.values[:, :3]) if device else None,
        device_yaw=Series(device.times, yaw_of(device.values[:, 3:])) if device else None,
        gripper=_series(times["/sigma7/gripper_angle"], rows["/sigma7/gripper_angle"]),
        button=button,
        active_tab=_series(times["/teleteach/active_tab"], rows["/teleteach/active_tab"]),
        eigenvalues=eigenvalues,
        eigenvectors=eigenvectors,
        cartesian_position=Series(cartesian.times, cartesian.values[:, :3]) if cartesian else None,
        trees=trees,
        products=judged.products_series(),
        rejected={topic: count for topic, count in rejected.items() if count},
        products_from=(TRUE_SCENE_TOPIC if judged is truth else SCENE_TOPIC) if judged.products else "",
        perceived_gaps=perceived.gaps_series(),
        true_gaps=truth.gaps_series(),
        base_errors=_series(times["/robot_sim/base_error"], rows["/robot_sim/base_error"]),
    )


class _SceneSeries:
    """Products' poses (x y z qx qy qz qw) and gaps' poses (x y z yaw) over time, from one scene topic."""

    def __init__(self):
        self.products: Dict[str, Tuple[List[float], List[tuple]]] = {}
        self.gaps: Dict[str, Tuple[List[float], List[tuple]]] = {}

    def add(self, time: float, markers) -> None:
        scene, _ = observed_from_markers(markers)
        for name, box in scene.products.items():
            self.products.setdefault(name, ([], []))
            self.products[name][0].append(time)
            self.products[name][1].append((*box.position, *box.quaternion))
        for name, gap in scene.gaps.items():
            self.gaps.setdefault(name, ([], []))
            self.gaps[name][0].append(time)
            self.gaps[name][1].append((*gap.position, gap.yaw))

    def products_series(self) -> Dict[str, Series]:
        return {name: _series(*samples) for name, samples in self.products.items()}

    def gaps_series(self) -> Dict[str, Series]:
        return {name: _series(*samples) for name, samples in self.gaps.items()}
