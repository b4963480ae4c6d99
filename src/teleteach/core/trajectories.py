"""The kinematic trajectory an operator teaches stiffness along (thesis II-C, A.2.2).

Predefined in ``config/trajectories/*.yaml``, or taught with the device in TELEOP (thesis III-C: it "could be
generated remotely with the same haptic device") and kept in the data directory's ``trajectories/``.

A list of timed waypoints, interpolated linearly in position and by slerp in orientation, in base_link or relative to
a target (a shelf gap: the trajectory then places at whichever gap the robot perceives, wherever the base stopped); it
may start where the hand is when the recording starts. A taught one is the mean of its demonstrations
(:func:`mean_trajectory`), with their spread at each waypoint. Shared by the GUI, which plays and teaches it, and the
synthetic demonstrations of teleteach.learning, so it lives below both.

The minimum-jerk profile (Flash and Hogan 1985) that every smooth move of teleteach follows, the robot's and the
modelled operator's, lives here too: :func:`minimum_jerk` and its rate.
"""

import pathlib
from typing import List, Optional, Sequence, Tuple, Union

import numpy as np
import yaml
from scipy.spatial.transform import Rotation, Slerp

from teleteach.core.datadir import atomic_write_text
from teleteach.core.frames import Transform, continuous_quaternions
from teleteach.core.paths import config_file
from teleteach.core.skill_file import BASE_FRAME, TARGET_FRAME

MINIMUM_JERK_PEAK = 1.875  # a minimum-jerk move's peak speed over its mean speed (15/8)


def minimum_jerk(fraction):
    """The minimum-jerk profile s = 10 tau^3 - 15 tau^4 + 6 tau^5 at tau = ``fraction`` of the move's time, in [0, 1].

    ``fraction`` is a number or an array, clipped to [0, 1]: the profile is 0 before the move and 1 after it.
    """
    tau = np.clip(fraction, 0.0, 1.0)
    return tau**3 * (10.0 - 15.0 * tau + 6.0 * tau**2)


def minimum_jerk_rate(fraction):
    """ds/dtau = 30 tau^2 (1 - tau)^2 of :func:`minimum_jerk` (divide by the move's duration for a rate per second)."""
    tau = np.clip(fraction, 0.0, 1.0)
    return 30.0 * tau**2 * (1.0 - tau) ** 2


class TrajectoryError(ValueError):
    """A trajectory file is missing or malformed."""


class Trajectory:
    """Timed waypoints (t [s], position [m], quaternion x y z w) in ``frame``, interpolated on demand.

    Args:
        frame: base_link, or target (the frame of the gap named ``target``: origin where the placed product's centre
            belongs, x into the shelf, z up).
        target: the gap a target-frame trajectory is relative to.
        starts_at_hand: the trajectory begins (t = 0) where the hand is when it starts; the waypoints follow.
        spread: [m] at each waypoint, how far the demonstrations it is the mean of lay from it (RMS); None: predefined.
        demonstrations: how many demonstrations it is the mean of (0: predefined).
    """

    def __init__(
        self,
        times: Sequence[float],
        positions,
        quaternions,
        frame: str = BASE_FRAME,
        name: str = "",
        target: Optional[str] = None,
        starts_at_hand: bool = False,
        spread: Optional[Sequence[float]] = None,
        demonstrations: int = 0,
    ):
        self.times = np.asarray(times, dtype=float)
        self.positions = np.asarray(positions, dtype=float)
        self.quaternions = np.asarray(quaternions, dtype=float)
        self.frame = frame
        self.name = name
        self.target = target
        self.starts_at_hand = starts_at_hand
        self.spread = None if spread is None else np.asarray(spread, dtype=float)
        self.demonstrations = demonstrations
        count = self.times.shape[0]
        fewest = 1 if starts_at_hand else 2
        if count < fewest or self.positions.shape != (count, 3) or self.quaternions.shape != (count, 4):
            raise TrajectoryError(
                f"trajectory {name!r} needs >= {fewest} waypoints with position (3) and orientation (4)"
            )
        if frame not in (BASE_FRAME, TARGET_FRAME):
            raise TrajectoryError(f"trajectory {name!r}: frame must be {BASE_FRAME} or {TARGET_FRAME}, got {frame!r}")
        if (frame == TARGET_FRAME) != bool(target):
            raise TrajectoryError(f"trajectory {name!r}: a target-frame trajectory names its target (and only it)")
        if not (np.all(np.isfinite(self.times)) and np.all(np.isfinite(self.positions))):
            raise TrajectoryError(f"trajectory {name!r} has non-finite values")
        if np.any(np.diff(self.times) <= 0) or (starts_at_hand and self.times[0] <= 0.0):
            raise TrajectoryError(
                f"trajectory {name!r}: waypoint times must increase strictly"
                + (" and start after 0 (t = 0 is the hand)" if starts_at_hand else "")
            )
        norms = np.linalg.norm(self.quaternions, axis=1)
        if np.any(np.abs(norms - 1.0) > 1e-3):
            raise TrajectoryError(f"trajectory {name!r}: orientations must be unit quaternions (x, y, z, w)")
        if self.spread is not None and (
            self.spread.shape != (count,) or not np.all(np.isfinite(self.spread)) or np.any(self.spread < 0.0)
        ):
            raise TrajectoryError(f"trajectory {name!r}: spread must be one distance >= 0 [m] per waypoint")
        self._slerp = Slerp(self.times, Rotation.from_quat(self.quaternions)) if count >= 2 else None

    @property
    def duration(self) -> float:
        """Time of the last waypoint [s] (the first is at ``times[0]``)."""
        return float(self.times[-1])

    def sample(self, t: float) -> np.ndarray:
        """Pose (x, y, z, qx, qy, qz, qw) at ``t`` [s]; held at the ends."""
        if self.starts_at_hand:
            raise TrajectoryError(f"trajectory {self.name!r} starts at the hand: play resolve(...) of it")
        t = float(np.clip(t, self.times[0], self.times[-1]))
        position = np.array([np.interp(t, self.times, self.positions[:, axis]) for axis in range(3)])
        return np.concatenate([position, self._slerp([t]).as_quat()[0]])

    def resolve(self, target_in_base: Optional[Transform], hand: Optional[np.ndarray]) -> "Trajectory":
        """The trajectory to play, from the hand when it starts at the hand.

        Its waypoints are composed with the target's pose in base_link (a target-frame trajectory; the identity keeps
        it in the target's frame), after the hand's pose (x y z qx qy qz qw, in the frame played in).
        """
        poses = np.hstack([self.positions, self.quaternions])
        if self.frame == TARGET_FRAME:
            if target_in_base is None:
                raise TrajectoryError(f"trajectory {self.name!r} is relative to {self.target}: its pose is needed")
            poses = target_in_base.apply_poses(poses)
        times = self.times
        if self.starts_at_hand:
            if hand is None:
                raise TrajectoryError(f"trajectory {self.name!r} starts at the hand: its pose is needed")
            poses = np.vstack([np.asarray(hand, dtype=float), poses])
            times = np.concatenate([[0.0], times])
        return Trajectory(times, poses[:, :3], poses[:, 3:], BASE_FRAME, self.name)

    def relative_to(self, target: str, target_in_base: Transform) -> "Trajectory":
        """This base_link trajectory in the frame of the gap ``target`` (whose pose in base_link is given)."""
        if self.frame != BASE_FRAME:
            raise TrajectoryError(f"trajectory {self.name!r} is not in {BASE_FRAME}")
        poses = target_in_base.inverse().apply_poses(np.hstack([self.positions, self.quaternions]))
        return Trajectory(self.times, poses[:, :3], poses[:, 3:], TARGET_FRAME, self.name, target, self.starts_at_hand)

    def save(self, path: Union[str, pathlib.Path]) -> pathlib.Path:
        """Write the trajectory as a yaml that :meth:`load` reads (atomically: the old file or the new one)."""
        data = {"name": self.name, "frame": self.frame, "start": "hand" if self.starts_at_hand else "first_waypoint"}
        if self.target:
            data["target"] = self.target
        if self.demonstrations:
            data["demonstrations"] = self.demonstrations
        data["waypoints"] = [
            {
                "t": round(float(t), 4),
                "position": [round(float(value), 5) for value in position],
                "orientation": [round(float(value), 6) for value in quaternion / np.linalg.norm(quaternion)],
                **({} if self.spread is None else {"spread": round(float(self.spread[index]), 5)}),
            }
            for index, (t, position, quaternion) in enumerate(zip(self.times, self.positions, self.quaternions))
        ]
        path = pathlib.Path(path)
        atomic_write_text(path, yaml.safe_dump(data, sort_keys=False, default_flow_style=None))
        return path

    @classmethod
    def load(cls, name_or_path: Union[str, pathlib.Path]) -> "Trajectory":
        """A trajectory by name (``config/trajectories/<name>.yaml``) or by path."""
        path = pathlib.Path(name_or_path)
        if not path.suffix:
            path = config_file("trajectories", f"{name_or_path}.yaml")
        if not path.is_file():
            raise TrajectoryError(f"trajectory file {path} does not exist")
        data = yaml.safe_load(path.read_text()) or {}
        start = data.get("start", "first_waypoint")
        if start not in ("first_waypoint", "hand"):
            raise TrajectoryError(f"trajectory file {path}: start must be first_waypoint or hand, got {start!r}")
        try:
            waypoints = data["waypoints"]
            return cls(
                [point["t"] for point in waypoints],
                [point["position"] for point in waypoints],
                [point["orientation"] for point in waypoints],
                frame=data.get("frame", BASE_FRAME),
                name=data.get("name", path.stem),
                target=data.get("target"),
                starts_at_hand=start == "hand",
                spread=[point["spread"] for point in waypoints]
                if all("spread" in point for point in waypoints)
                else None,
                demonstrations=int(data.get("demonstrations", 0)),
            )
        except (KeyError, TypeError) as error:
            raise TrajectoryError(f"trajectory file {path}: missing or malformed {error}") from None


def phase_of(trajectory: Trajectory) -> np.ndarray:
    """Each waypoint's progress along the path, 0 to 1: by distance travelled, or by time for a path that only turns."""
    steps = np.linalg.norm(np.diff(trajectory.positions, axis=0), axis=1)
    travelled = np.concatenate([[0.0], np.cumsum(steps)])
    if travelled[-1] > 1e-6:
        return travelled / travelled[-1]
    return (trajectory.times - trajectory.times[0]) / (trajectory.times[-1] - trajectory.times[0])


MEAN_WAYPOINT_PERIOD = 0.05  # [s] a mean's waypoints are this far apart (of its longest demonstration), 2 to 400


def _at_progress(demonstration: Trajectory, grid: np.ndarray) -> Tuple[np.ndarray, np.ndarray, Rotation]:
    """Times, positions and orientations at which a demonstration reached each progress of ``grid``, so they align."""
    phase = phase_of(demonstration)
    keep = np.concatenate([[True], np.diff(phase) > 0.0])  # a pause (no progress) keeps its first instant
    phase, kept_times = phase[keep], demonstration.times[keep]
    at = np.interp(grid, phase, kept_times)
    positions = np.array([np.interp(at, demonstration.times, demonstration.positions[:, axis]) for axis in range(3)]).T
    return at, positions, Slerp(demonstration.times, Rotation.from_quat(demonstration.quaternions))(at)


def mean_trajectory(demonstrations: List[Trajectory], name: str, points: Optional[int] = None) -> Trajectory:
    """The mean of demonstrations of one path, aligned by progress along it, with their spread at each waypoint.

    Each demonstration is resampled at ``points`` (default: one per MEAN_WAYPOINT_PERIOD) equal steps of its own
    progress (distance travelled: an operator who went slower somewhere still lines up); the mean's waypoint is the
    mean position, the mean orientation and the mean time of reaching that progress; its spread the RMS distance of
    the demonstrations' positions from it.
    All must be in the same frame (and relative to the same target).
    """
    if not demonstrations:
        raise TrajectoryError(f"trajectory {name!r}: no demonstrations")
    first = demonstrations[0]
    if any(
        (d.frame, d.target, d.starts_at_hand) != (first.frame, first.target, first.starts_at_hand)
        for d in demonstrations
    ):
        raise TrajectoryError(f"trajectory {name!r}: the demonstrations are not in one frame (and target)")
    if points is None:
        longest = max(d.duration - d.times[0] for d in demonstrations)
        points = int(np.clip(round(longest / MEAN_WAYPOINT_PERIOD) + 1, 2, 400))
    grid = np.linspace(0.0, 1.0, points)
    positions, rotations, times = [], [], []
    for demonstration in demonstrations:
        at, position, rotation = _at_progress(demonstration, grid)
        times.append(at)
        positions.append(position)
        rotations.append(rotation)
    mean_positions = np.mean(positions, axis=0)
    mean_times = np.mean(times, axis=0)
    mean_times = mean_times[0] + np.maximum.accumulate(mean_times - mean_times[0])
    mean_times += np.arange(points) * 1e-4  # strictly increasing even where every demonstration paused
    quaternions = continuous_quaternions(
        np.array([Rotation.concatenate([r[index] for r in rotations]).mean().as_quat() for index in range(points)])
    )
    spread = np.sqrt(np.mean([np.sum((p - mean_positions) ** 2, axis=1) for p in positions], axis=0))
    return Trajectory(
        mean_times,
        mean_positions,
        quaternions,
        first.frame,
        name,
        first.target,
        first.starts_at_hand,
        spread=spread,
        demonstrations=len(demonstrations),
    )
