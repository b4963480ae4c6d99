"""Recording a stiffness demonstration (thesis II-C, A.2.2) along a teleteach.core.trajectories.Trajectory.

The recorder stores the commanded stiffness, the equilibrium pose and the measured ``/cartesian_pose`` at every sample
(base_link) and turns them into a :class:`teleteach.core.skill_file.Skill`, relative to the target when there is one.
"""

import pathlib
import threading
from typing import Iterable, List, Optional

import numpy as np

from teleteach.core.skill_file import Skill


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


def unique_skill_name(prefix: str, taken: Iterable[str], directory: Optional[pathlib.Path] = None) -> str:
    """``<prefix>_<n>`` with the smallest n not used by the library nor by a file in ``directory``."""
    taken = set(taken)
    number = 1
    while True:
        name = f"{prefix}_{number}"
        if name not in taken and not (directory is not None and (directory / f"{name}.npz").exists()):
            return name
        number += 1
