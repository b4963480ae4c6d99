"""The file format of a taught skill: what the GUI records, the BT library accepts and the robot replays.

A skill file is a numpy ``.npz`` archive (no pickles) with, for N samples:

- ``time`` (N,) [s], strictly increasing, starting anywhere;
- ``stiffness`` (N, 3, 3) [N/m], translational stiffness K_T in the skill's frame, SPD;
- ``equilibrium_pose`` (N, 7): commanded reference x_r (x, y, z [m], qx, qy, qz, qw) in the skill's frame;
- ``cartesian_pose`` (N, 7): measured end-effector pose x_a, same layout;
- ``meta``: a JSON string with ``name``, ``kind`` (stiffness | shared_control | dmp),
  ``rotational_stiffness`` [Nm/rad], ``frame`` and free-form provenance.

The skill's frame (``frame``) is ``target``: the frame of the target it was taught at (a shelf gap: origin where the
placed product's centre belongs, x into the shelf, z up; or a surface it wiped: origin at the face's centre, z out of
it), with ``target`` = {``name``, ``pose_in_base`` (the target's pose in base_link when taught, x y z qx qy qz qw),
``kind`` (``gap`` or ``surface``; files without it are gaps)}; the robot replays it relative to where it perceives
such a target now, and the stiffness turns with it. Or ``base_link``: replayed where it was recorded, relative to the
robot's base (files written before skills had a target frame have no ``frame``: they are base_link skills).

:func:`load` validates everything, so a file that loads is safe to execute.
"""

import dataclasses
import io
import json
import pathlib
from typing import Any, Dict, Optional, Tuple, Union

import numpy as np

from teleteach.core.datadir import atomic_write_bytes
from teleteach.core.frames import Transform
from teleteach.core.paths import config_values

KINDS = ("stiffness", "shared_control", "dmp")
BASE_FRAME = "base_link"
TARGET_FRAME = "target"
FRAMES = (BASE_FRAME, TARGET_FRAME)
GAP, SURFACE = "gap", "surface"
TARGET_KINDS = (GAP, SURFACE)  # what a skill's target is: a shelf gap it places into, a surface it wipes


class SkillFileError(ValueError):
    """A skill file is missing, unreadable or describes something unsafe to execute."""


@dataclasses.dataclass(frozen=True)
class Target:
    """What a skill in the target frame was taught at: the target's name, its pose in base_link then, its kind."""

    name: str
    pose_in_base: Tuple[float, ...]
    kind: str = GAP

    @property
    def transform(self) -> Transform:
        """base_link <- target, when taught."""
        return Transform.from_pose(self.pose_in_base)


def shared_rotational_stiffness() -> float:
    """K_R [Nm/rad] the nodes share (config/shared/stiffness.yaml): a skill's when it was given none."""
    return float(config_values("shared/stiffness.yaml")["rotational_stiffness"])


@dataclasses.dataclass
class Skill:
    """A demonstrated (or learned) skill: stiffness and poses over time."""

    name: str
    kind: str
    time: np.ndarray
    stiffness: np.ndarray
    equilibrium_pose: np.ndarray
    cartesian_pose: np.ndarray
    rotational_stiffness: float = dataclasses.field(default_factory=shared_rotational_stiffness)
    provenance: Dict[str, Any] = dataclasses.field(default_factory=dict)
    frame: str = BASE_FRAME
    target: Optional[Target] = None

    def __post_init__(self):
        self.time = np.asarray(self.time, dtype=float)
        self.stiffness = np.asarray(self.stiffness, dtype=float)
        self.equilibrium_pose = np.asarray(self.equilibrium_pose, dtype=float)
        self.cartesian_pose = np.asarray(self.cartesian_pose, dtype=float)
        validate(self)

    @property
    def duration(self) -> float:
        """Length of the demonstration [s]."""
        return float(self.time[-1] - self.time[0])

    def relative_to(self, target: str, target_in_base: Transform, kind: str = GAP) -> "Skill":
        """This base_link skill in the frame of ``target`` (a ``kind``), whose pose in base_link is target_in_base."""
        if self.frame != BASE_FRAME:
            raise SkillFileError(f"skill {self.name} is already relative to {self.target.name}")
        to_target = target_in_base.inverse()
        return dataclasses.replace(
            self,
            stiffness=to_target.turn_stiffness(self.stiffness),
            equilibrium_pose=to_target.apply_poses(self.equilibrium_pose),
            cartesian_pose=to_target.apply_poses(self.cartesian_pose),
            frame=TARGET_FRAME,
            target=Target(target, tuple(float(value) for value in target_in_base.as_pose()), kind),
        )

    def in_base(self, target_in_base: Transform) -> "Skill":
        """This target-frame skill in base_link for a target at target_in_base (a base_link skill: itself)."""
        if self.frame == BASE_FRAME:
            return self
        return dataclasses.replace(
            self,
            stiffness=target_in_base.turn_stiffness(self.stiffness),
            equilibrium_pose=target_in_base.apply_poses(self.equilibrium_pose),
            cartesian_pose=target_in_base.apply_poses(self.cartesian_pose),
            frame=BASE_FRAME,
            target=None,
        )


def validate(skill: Skill) -> None:
    """Raise :class:`SkillFileError` naming the first thing that is wrong with ``skill``."""
    if not skill.name or not skill.name.isidentifier():
        raise SkillFileError(f"skill name {skill.name!r} must be a non-empty identifier (letters, digits, _)")
    if skill.kind not in KINDS:
        raise SkillFileError(f"unknown skill kind {skill.kind!r}; expected one of {', '.join(KINDS)}")
    count = skill.time.shape[0] if skill.time.ndim == 1 else -1
    if count < 2:
        raise SkillFileError(f"time must be a 1-D array of at least 2 samples, got shape {skill.time.shape}")
    expected = {"stiffness": (count, 3, 3), "equilibrium_pose": (count, 7), "cartesian_pose": (count, 7)}
    for field, shape in expected.items():
        value = getattr(skill, field)
        if value.shape != shape:
            raise SkillFileError(f"{field} has shape {value.shape}, expected {shape}")
    for field in ("time", *expected):
        bad = np.flatnonzero(~np.isfinite(getattr(skill, field)).reshape(count, -1).all(axis=1))
        if bad.size:
            raise SkillFileError(f"{field} is not finite (NaN or inf) at sample {bad[0]}")
    steps = np.flatnonzero(np.diff(skill.time) <= 0)
    if steps.size:
        raise SkillFileError(f"time is not strictly increasing at sample {steps[0] + 1}")
    asymmetry = np.abs(skill.stiffness - skill.stiffness.transpose(0, 2, 1)).max(axis=(1, 2))
    bad = np.flatnonzero(asymmetry > 1e-6 * (1.0 + np.abs(skill.stiffness).max()))
    if bad.size:
        raise SkillFileError(f"stiffness is not symmetric at sample {bad[0]}")
    smallest = np.linalg.eigvalsh(skill.stiffness)[:, 0]
    bad = np.flatnonzero(smallest <= 0.0)
    if bad.size:
        raise SkillFileError(
            f"stiffness is not positive definite at sample {bad[0]} (smallest eigenvalue {smallest[bad[0]]:.3g})"
        )
    for field in ("equilibrium_pose", "cartesian_pose"):
        norms = np.linalg.norm(getattr(skill, field)[:, 3:], axis=1)
        bad = np.flatnonzero(np.abs(norms - 1.0) > 1e-3)
        if bad.size:
            raise SkillFileError(f"{field} quaternion is not unit length at sample {bad[0]} (norm {norms[bad[0]]:.4f})")
    if not (np.isfinite(skill.rotational_stiffness) and skill.rotational_stiffness >= 0):
        raise SkillFileError(f"rotational_stiffness must be finite and >= 0, got {skill.rotational_stiffness}")
    if skill.frame not in FRAMES:
        raise SkillFileError(f"unknown frame {skill.frame!r}; expected one of {', '.join(FRAMES)}")
    if (skill.frame == TARGET_FRAME) != (skill.target is not None):
        raise SkillFileError("a skill has a target exactly when its frame is 'target'")
    if skill.target is not None:
        _validate_target(skill.target)


def _validate_target(target: Target) -> None:
    if not isinstance(target.name, str) or not target.name:
        raise SkillFileError(f"target name {target.name!r} must be a non-empty string")
    if target.kind not in TARGET_KINDS:
        raise SkillFileError(f"unknown target kind {target.kind!r}; expected one of {', '.join(TARGET_KINDS)}")
    pose = np.asarray(target.pose_in_base, dtype=float)
    if pose.shape != (7,) or not np.all(np.isfinite(pose)):
        raise SkillFileError(f"target pose_in_base must be 7 finite numbers, got {list(target.pose_in_base)}")
    if abs(np.linalg.norm(pose[3:]) - 1.0) > 1e-3:
        raise SkillFileError(f"target pose_in_base quaternion is not unit length (norm {np.linalg.norm(pose[3:]):.4f})")


def save(skill: Skill, path: Union[str, pathlib.Path]) -> pathlib.Path:
    """Validate ``skill`` and write it atomically to ``path`` (``.npz`` appended if missing)."""
    validate(skill)
    path = pathlib.Path(path)
    if path.suffix != ".npz":
        path = path.with_name(path.name + ".npz")
    meta = {
        "name": skill.name,
        "kind": skill.kind,
        "rotational_stiffness": skill.rotational_stiffness,
        "frame": skill.frame,
        "target": dataclasses.asdict(skill.target) if skill.target else None,
        "provenance": skill.provenance,
    }
    buffer = io.BytesIO()
    np.savez_compressed(
        buffer,
        time=skill.time,
        stiffness=skill.stiffness,
        equilibrium_pose=skill.equilibrium_pose,
        cartesian_pose=skill.cartesian_pose,
        meta=np.array(json.dumps(meta)),
    )
    atomic_write_bytes(path, buffer.getvalue())
    return path


def _target(meta: Optional[Dict[str, Any]]) -> Optional[Target]:
    """The target a file's meta names (None for a base_link skill); files written before surfaces have gaps."""
    if not meta:
        return None
    return Target(str(meta["name"]), tuple(float(v) for v in meta["pose_in_base"]), str(meta.get("kind", GAP)))


def load(path: Union[str, pathlib.Path]) -> Skill:
    """Read and validate a skill file; raise :class:`SkillFileError` saying what is wrong."""
    path = pathlib.Path(path)
    if not path.is_file():
        raise SkillFileError(f"skill file {path} does not exist")
    try:
        with np.load(path, allow_pickle=False) as archive:
            arrays = {key: archive[key] for key in archive.files}
        meta = json.loads(str(arrays.pop("meta")))
    except KeyError as error:
        raise SkillFileError(f"skill file {path} has no {error} entry") from None
    except Exception as error:  # any parse failure is reported the same way
        raise SkillFileError(f"skill file {path} cannot be read: {error}") from None
    missing = {"time", "stiffness", "equilibrium_pose", "cartesian_pose"} - set(arrays)
    if missing:
        raise SkillFileError(f"skill file {path} lacks {', '.join(sorted(missing))}")
    try:
        target, rotational = meta.get("target"), meta.get("rotational_stiffness")
        return Skill(
            name=meta["name"],
            kind=meta["kind"],
            time=arrays["time"],
            stiffness=arrays["stiffness"],
            equilibrium_pose=arrays["equilibrium_pose"],
            cartesian_pose=arrays["cartesian_pose"],
            rotational_stiffness=shared_rotational_stiffness() if rotational is None else float(rotational),
            provenance=meta.get("provenance", {}),
            frame=meta.get("frame", BASE_FRAME),
            target=_target(target),
        )
    except KeyError as error:
        raise SkillFileError(f"skill file {path}: meta lacks {error}") from None
    except SkillFileError as error:
        raise SkillFileError(f"skill file {path}: {error}") from None
    except (TypeError, ValueError) as error:
        raise SkillFileError(f"skill file {path}: meta holds a malformed target ({error})") from None
