"""Reading stiffness demonstrations from a session bag (opened by teleteach.recording.session, with ``rosbags``).

The GUI publishes the principal stiffnesses on ``/eigenvalues`` (Vector3Stamped [N/m]) and the principal axes on
``/eigenvectors`` (QuaternionStamped, V = R(q)); the controller publishes ``/cartesian_pose`` and the trajectory
player ``/equilibrium_pose`` (PoseStamped). K = V diag(lambda) V^T (thesis eq 1), each eigenvalue message paired
with the eigenvector message nearest in time. Times are header stamps (the bag's receive time when a stamp is 0).

A stream's messages are put in stamp order, and messages that share a stamp become one sample, the last one: under
simulated time the GUI publishes (200 Hz) faster than /clock ticks, so consecutive commands carry the same stamp.

A session bag holds more than demonstrations: the GUI streams the stiffness all the time LOW-LEVEL is open, and the
tree's replay of a taught skill publishes the same topics. A demonstration is one LOW-LEVEL recording, from the double
click that starts it to the one that stops it, found in this order:

1. ``/teleteach/recording`` (std_msgs/Bool, the GUI's) true while ``/teleteach/active_tab`` shows LOW-LEVEL: from
   where it turns true to where it turns false, or to the bag's end;
2. in a bag without ``/teleteach/recording`` (recorded before session bags carried it): the GUI's own
   ``/equilibrium_pose`` in the LOW-LEVEL tab, which its trajectory player sends only while it records; each run of
   it is one recording (a pause longer than :data:`PLAYER_PAUSE` ends it). The GUI is the node (the connection's
   callerid) that publishes ``/teleteach/active_tab``, so a skill the tree replays meanwhile does not count;
3. a bag with neither topic (a ``rosbag record`` of the stiffness and pose topics alone) is one demonstration.

A recording's times are the bag's receive times (its topics have no header) in seconds since the bag's first message;
a demonstration is made of the messages received during it.
"""

import dataclasses
import pathlib
from typing import Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from teleteach.control.stiffness import translational_stiffnesses
from teleteach.core.active_tab import Tab
from teleteach.learning.preprocess import LearningError
from teleteach.recording.session import SessionError, open_bag

EIGENVALUES = "/eigenvalues"
EIGENVECTORS = "/eigenvectors"
POSE_TOPICS = {"cartesian_pose": "/cartesian_pose", "equilibrium_pose": "/equilibrium_pose"}
ACTIVE_TAB = "/teleteach/active_tab"
RECORDING = "/teleteach/recording"
MARKERS = {ACTIVE_TAB: "std_msgs/msg/Int8", RECORDING: "std_msgs/msg/Bool"}
"""The GUI's topics that say when a demonstration was recorded, with the type each must have."""

PLAYER_PAUSE = 0.5
"""[s] Longer without the GUI's /equilibrium_pose (sent at 100 Hz, config/gui.yaml) ends a recording (rule 2)."""

Span = Tuple[float, float]


@dataclasses.dataclass(frozen=True)
class Recording:
    """One LOW-LEVEL recording of a session bag: its number (from 1) and its times [s since the bag's start]."""

    number: int
    start: float
    end: float

    @property
    def duration(self) -> float:
        """Length [s]."""
        return self.end - self.start

    @property
    def span(self) -> str:
        """Where it is in the bag, for the operator: "18.6-31.1 s into the bag"."""
        return f"{self.start:.1f}-{self.end:.1f} s into the bag"

    def __str__(self) -> str:
        return f"demonstration {self.number}: {self.span} ({self.duration:.1f} s)"


@dataclasses.dataclass
class Stream:
    """One topic's messages: receive times [s since the bag's start], header stamps [s] and values (one row each)."""

    received: np.ndarray
    stamps: np.ndarray
    values: np.ndarray

    def during(self, recording: Optional[Recording]) -> "Stream":
        """The messages received during ``recording`` (None: all of them)."""
        if recording is None:
            return self
        keep = (self.received >= recording.start) & (self.received <= recording.end)
        return Stream(self.received[keep], self.stamps[keep], self.values[keep])


@dataclasses.dataclass
class SessionBag:
    """A bag's stiffness and pose messages and the demonstrations recorded in it.

    Attributes:
        path: the bag.
        streams: topic -> its messages, for /eigenvalues, /eigenvectors and the pose topics the bag has.
        recordings: the LOW-LEVEL recordings in time order; None when the bag marks none (rule 3: all of it is one).
        found_by: how the recordings were looked for (rule 1, 2 or 3 of the module's docstring).
    """

    path: pathlib.Path
    streams: Dict[str, Stream]
    recordings: Optional[List[Recording]]
    found_by: str

    def demonstration(
        self, recording: Optional[Recording] = None
    ) -> Tuple[np.ndarray, np.ndarray, Dict[str, Tuple[np.ndarray, np.ndarray]]]:
        """(stiffness times, stiffness (n, 3, 3), poses name -> (times, (k, 7))) received during ``recording``.

        None: the whole bag. Raises:
            LearningError: /eigenvalues, /eigenvectors or /cartesian_pose has no message then, or an eigenvector
                message is not a unit quaternion.
        """
        streams = {topic: stream.during(recording) for topic, stream in self.streams.items()}
        during = "" if recording is None else f" during {recording}"
        for topic in (EIGENVALUES, EIGENVECTORS, POSE_TOPICS["cartesian_pose"]):
            if topic not in streams or not streams[topic].stamps.size:
                raise LearningError(f"bag {self.path} has no {topic} messages{during}")
        value_times, eigenvalues = one_per_stamp(streams[EIGENVALUES].stamps, streams[EIGENVALUES].values)
        vector_times, quaternions = one_per_stamp(streams[EIGENVECTORS].stamps, streams[EIGENVECTORS].values)
        norms = np.linalg.norm(quaternions, axis=1)
        bad = np.flatnonzero(~(np.abs(norms - 1.0) <= 1e-3))
        if bad.size:
            raise LearningError(f"{EIGENVECTORS} message {bad[0]} is not a unit quaternion (norm {norms[bad[0]]:.4f})")
        nearest = np.zeros(value_times.size, dtype=int)
        if vector_times.size > 1:
            right = np.clip(np.searchsorted(vector_times, value_times), 1, vector_times.size - 1)
            left = right - 1
            closer_left = np.abs(value_times - vector_times[left]) <= np.abs(vector_times[right] - value_times)
            nearest = np.where(closer_left, left, right)
        stiffness = translational_stiffnesses(eigenvalues, quaternions[nearest])
        poses = {
            name: one_per_stamp(streams[topic].stamps, streams[topic].values)
            for name, topic in POSE_TOPICS.items()
            if topic in streams and streams[topic].stamps.size
        }
        return value_times, stiffness, poses


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


def spans(changes: Sequence[Tuple[float, int]], value, end: float) -> List[Span]:
    """Where a topic of states (receive time, state) was in ``value``.

    From each change into it to the next change out of it, or to ``end``.
    """
    result, since = [], None
    for time, state in changes:
        if state == value and since is None:
            since = time
        elif state != value and since is not None:
            result.append((since, time))
            since = None
    if since is not None:
        result.append((since, end))
    return result


def runs(times: np.ndarray, pause: float) -> List[Span]:
    """The runs of messages at ``times`` (sorted): a pause longer than ``pause`` [s] ends one."""
    if not times.size:
        return []
    breaks = np.flatnonzero(np.diff(times) > pause)
    return list(zip(times[np.r_[0, breaks + 1]], times[np.r_[breaks, times.size - 1]]))


def find_recordings(
    tabs: Sequence[Tuple[float, int]],
    flags: Sequence[Tuple[float, int]],
    gui_equilibrium: np.ndarray,
    end: float,
) -> Tuple[Optional[List[Recording]], str]:
    """The LOW-LEVEL recordings (rules 1-3 of the module's docstring) and how they were found.

    Args:
        tabs: /teleteach/active_tab's messages (receive time [s], tab).
        flags: /teleteach/recording's messages (receive time [s], 0 or 1).
        gui_equilibrium: receive times [s] of the GUI's /equilibrium_pose messages, sorted.
        end: the bag's end [s].
    """
    if flags:
        tab_times = np.array([time for time, _ in tabs])
        found = []
        for start, stop in spans(flags, 1, end):
            index = np.searchsorted(tab_times, start, side="right") - 1  # the tab shown when the recording started
            if index < 0 or tabs[index][1] == Tab.LOW_LEVEL:  # (none recorded yet: only the flag says)
                found.append((start, stop))
        how = f"{RECORDING} in the LOW-LEVEL tab"
    elif tabs:
        found = []
        for start, stop in spans(tabs, Tab.LOW_LEVEL, end):
            inside = gui_equilibrium[(gui_equilibrium >= start) & (gui_equilibrium <= stop)]
            found += runs(inside, PLAYER_PAUSE)
        how = f"the teaching GUI's trajectory on /equilibrium_pose in the LOW-LEVEL tab, as the bag has no {RECORDING}"
    else:
        return None, f"the bag has no {RECORDING} or {ACTIVE_TAB}, so all of it is one demonstration"
    return [Recording(number, float(start), float(stop)) for number, (start, stop) in enumerate(found, 1)], how


def read_session_bag(path: Union[str, pathlib.Path]) -> SessionBag:
    """The stiffness and pose messages of a session bag and the demonstrations recorded in it.

    Raises:
        LearningError: the bag is missing or unreadable.
    """
    path = pathlib.Path(path).expanduser()
    if not path.is_file():
        raise LearningError(f"bag file {path} does not exist")
    rows: Dict[str, List[Tuple[float, float, List[float]]]] = {
        EIGENVALUES: [],
        EIGENVECTORS: [],
        **{topic: [] for topic in POSE_TOPICS.values()},
    }
    markers: Dict[str, List[Tuple[float, int]]] = {topic: [] for topic in MARKERS}
    gui_equilibrium: List[float] = []
    try:
        with open_bag(path) as reader:
            start = reader.start_time if reader.message_count else 0
            end = (reader.end_time - start) * 1e-9 if reader.message_count else 0.0
            gui = {connection.ext.callerid for connection in reader.connections if connection.topic == ACTIVE_TAB}
            connections = [
                connection
                for connection in reader.connections
                if connection.topic in rows or MARKERS.get(connection.topic) == connection.msgtype
            ]
            for connection, received, raw in reader.messages(connections=connections):
                topic, message = connection.topic, reader.deserialize(raw, connection.msgtype)
                since = (received - start) * 1e-9
                if topic in markers:
                    markers[topic].append((since, int(message.data)))
                    continue
                rows[topic].append((since, _stamp(message, received), _values(topic, message)))
                if topic == POSE_TOPICS["equilibrium_pose"] and connection.ext.callerid in gui:
                    gui_equilibrium.append(since)
    except SessionError as error:
        raise LearningError(str(error)) from None
    streams = {
        topic: Stream(*(np.array(column, dtype=float) for column in zip(*messages)))
        for topic, messages in rows.items()
        if messages
    }
    recordings, found_by = find_recordings(
        markers[ACTIVE_TAB], markers[RECORDING], np.sort(np.array(gui_equilibrium, dtype=float)), end
    )
    return SessionBag(path, streams, recordings, found_by)


def read_bag(path: Union[str, pathlib.Path]) -> Tuple[np.ndarray, np.ndarray, Dict[str, Tuple[np.ndarray, np.ndarray]]]:
    """(stiffness times, stiffness (n, 3, 3), poses name -> (times, (k, 7))) of the whole bag, recordings or not.

    Raises:
        LearningError: the bag is missing or unreadable, or lacks /eigenvalues, /eigenvectors or /cartesian_pose.
    """
    return read_session_bag(path).demonstration()
