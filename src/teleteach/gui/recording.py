"""Recording a stiffness demonstration along a trajectory (thesis II-C, A.2.2), and a path taught in TELEOP.

The stiffness recorder stores the commanded stiffness, the equilibrium pose and the measured ``/cartesian_pose`` at
every sample (base_link) and turns them into a :class:`teleteach.core.skill_file.Skill`, relative to the target when
there is one. The path recorder keeps the equilibrium poses the device commands in TELEOP and turns them into a
:class:`teleteach.core.trajectories.Trajectory`.
"""

import pathlib
import threading
from typing import Iterable, List, Optional

import numpy as np
from scipy.spatial.transform import Rotation

from teleteach.core.skill_file import Skill
from teleteach.core.trajectories import Trajectory, TrajectoryError


class StiffnessRecorder:
    """Time-stamped samples of stiffness, equilibrium pose and measured pose; thread-safe."""

    def __init__(self):
        self._lock = threading.Lock()
        self._rows: List[tuple] = []
        self.active = False

    def start(self) -> None:
        """Begin a new recording (drops an old one)."""
        with self._lock:
            self._rows = []
            self.active = True

    def stop(self) -> None:
        """Stop adding samples (the buffer stays for :meth:`to_skill`)."""
        self.active = False

    def __len__(self) -> int:
        with self._lock:
            return len(self._rows)

    def add(self, t: float, stiffness: np.ndarray, equilibrium: np.ndarray, measured: Optional[np.ndarray]) -> bool:
        """Store one sample when recording and all parts are known and finite; True if stored."""
        if not self.active or measured is None or equilibrium is None:
            return False
        row = (float(t), np.array(stiffness, dtype=float), np.array(equilibrium, float), np.array(measured, float))
        if not all(np.all(np.isfinite(part)) for part in row[1:]) or not np.isfinite(row[0]):
            return False
        with self._lock:
            if self._rows and row[0] <= self._rows[-1][0]:
                return False
            self._rows.append(row)
        return True

    def to_skill(self, name: str, rotational_stiffness: float, provenance: dict, kind: str = "stiffness") -> Skill:
        """The recording as a skill of ``kind`` (raises SkillFileError if it is too short or invalid)."""
        with self._lock:
            rows = list(self._rows)
        return Skill(
            name=name,
            kind=kind,
            time=np.array([row[0] for row in rows]),
            stiffness=np.array([row[1] for row in rows]).reshape(-1, 3, 3),
            equilibrium_pose=np.array([row[2] for row in rows]).reshape(-1, 7),
            cartesian_pose=np.array([row[3] for row in rows]).reshape(-1, 7),
            rotational_stiffness=rotational_stiffness,
            provenance=provenance,
        )


class PathRecorder:
    """The equilibrium poses TELEOP commands, as a path; thread-safe.

    A pause longer than ``PAUSE`` (the clutch released, the operator's hand moving back) is left out: the path plays
    the motion at the pace it was demonstrated, without its pauses (a shorter one, such as the steps of a device
    that reports less often than the GUI commands, is motion). Waypoints are kept every ``WAYPOINT_PERIOD`` of motion.
    """

    STILL_DISTANCE = 1e-5  # [m] a pose this close to the one before (and turned less than STILL_ANGLE) held still
    STILL_ANGLE = 1e-4  # [rad]
    PAUSE = 0.25  # [s] holding still longer than this is a pause, left out of the path's time
    WAYPOINT_PERIOD = 0.05  # [s] of motion between waypoints
    SHORTEST = 0.01  # [m] a path must move the hand at least this far (or turn it SHORTEST_TURN)
    SHORTEST_TURN = 0.1  # [rad]

    def __init__(self):
        self._lock = threading.Lock()
        self._times: List[float] = []
        self._poses: List[np.ndarray] = []
        self._last: Optional[np.ndarray] = None
        self._last_time = 0.0
        self._moved_time = 0.0  # when the pose last changed
        self._clock = 0.0  # [s] of motion so far
        self.active = False

    def start(self) -> None:
        """Begin a new path (drops an old one)."""
        with self._lock:
            self._times, self._poses, self._last, self._clock = [], [], None, 0.0
            self.active = True

    def stop(self) -> None:
        """Stop adding poses (the path stays for :meth:`to_trajectory`)."""
        self.active = False

    def __len__(self) -> int:
        with self._lock:
            return len(self._poses)

    def add(self, t: float, pose: np.ndarray) -> None:
        """One commanded pose (x y z qx qy qz qw, base_link) at ``t`` [s], while recording."""
        pose = np.asarray(pose, dtype=float)
        if not self.active or pose.shape != (7,) or not np.all(np.isfinite(pose)):
            return
        with self._lock:
            if self._last is None:
                self._times, self._poses = [0.0], [pose]
                self._last, self._last_time, self._moved_time = pose, t, t
                return
            moved = np.linalg.norm(pose[:3] - self._last[:3])
            turned = (Rotation.from_quat(pose[3:]) * Rotation.from_quat(self._last[3:]).inv()).magnitude()
            if moved >= self.STILL_DISTANCE or turned >= self.STILL_ANGLE:
                still = t - self._moved_time
                self._clock += max(0.0, still if still <= self.PAUSE else t - self._last_time)
                self._moved_time = t
                if self._clock - self._times[-1] >= self.WAYPOINT_PERIOD - 1e-9:
                    self._times.append(self._clock)
                    self._poses.append(pose)
            self._last, self._last_time = pose, t

    def to_trajectory(self, name: str) -> Trajectory:
        """The path in base_link (raises TrajectoryError when it is too short to teach along)."""
        with self._lock:
            times, poses, last, clock = list(self._times), list(self._poses), self._last, self._clock
        if last is not None and clock > times[-1]:
            times.append(clock)
            poses.append(last)
        if len(poses) < 2:
            raise TrajectoryError(f"path {name!r}: the arm did not move while it was recorded")
        poses = np.array(poses)
        travelled = float(np.sum(np.linalg.norm(np.diff(poses[:, :3], axis=0), axis=1)))
        turned = (Rotation.from_quat(poses[-1, 3:]) * Rotation.from_quat(poses[0, 3:]).inv()).magnitude()
        if travelled < self.SHORTEST and turned < self.SHORTEST_TURN:
            raise TrajectoryError(
                f"path {name!r}: the arm moved {travelled * 1000:.1f} mm and turned {turned:.2f} rad; a path needs "
                f"{self.SHORTEST * 1000:.0f} mm or {self.SHORTEST_TURN:g} rad"
            )
        return Trajectory(times, poses[:, :3], poses[:, 3:], name=name)


def unique_skill_name(prefix: str, taken: Iterable[str], directory: Optional[pathlib.Path] = None) -> str:
    """``<prefix>_<n>`` with the smallest n not used by the library nor by a file in ``directory``."""
    taken = set(taken)
    number = 1
    while True:
        name = f"{prefix}_{number}"
        if name not in taken and not (directory is not None and (directory / f"{name}.npz").exists()):
            return name
        number += 1
