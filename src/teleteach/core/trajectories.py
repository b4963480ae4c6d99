"""The predefined kinematic trajectory an operator teaches along (thesis II-C, A.2.2), ``config/trajectories/*.yaml``.

A list of timed waypoints, interpolated linearly in position and by slerp in orientation, in base_link or relative to
a target (a shelf gap: the trajectory then places at whichever gap the robot perceives, wherever the base stopped); it
may start where the hand is when the recording starts. Shared by the GUI, which plays it, and the synthetic
demonstrations of teleteach.learning, so it lives below both.
"""

import pathlib
from typing import Optional, Sequence, Union

import numpy as np
import yaml
from scipy.spatial.transform import Rotation, Slerp

from teleteach.core.frames import Transform
from teleteach.core.paths import config_file
from teleteach.core.skill_file import BASE_FRAME, TARGET_FRAME


class TrajectoryError(ValueError):
    """A trajectory file is missing or malformed."""


class Trajectory:
    """Timed waypoints (t [s], position [m], quaternion x y z w) in ``frame``, interpolated on demand.

    Args:
        frame: base_link, or target (the frame of the gap named ``target``: origin where the placed product's centre
            belongs, x into the shelf, z up).
        target: the gap a target-frame trajectory is relative to.
        starts_at_hand: the trajectory begins (t = 0) where the hand is when it starts; the waypoints follow.
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
    ):
        self.times = np.asarray(times, dtype=float)
        self.positions = np.asarray(positions, dtype=float)
        self.quaternions = np.asarray(quaternions, dtype=float)
        self.frame = frame
        self.name = name
        self.target = target
        self.starts_at_hand = starts_at_hand
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
            )
        except (KeyError, TypeError) as error:
            raise TrajectoryError(f"trajectory file {path}: missing or malformed {error}") from None
