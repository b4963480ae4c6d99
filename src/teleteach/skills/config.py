"""The skill server's configuration as validated plain data.

Its parameters (config/skill_server.yaml) and how the predefined skills move (config/skills_motion.yaml).
"""

import pathlib
from dataclasses import dataclass, fields
from typing import Any, Dict, Mapping, Optional, Tuple

import yaml

from teleteach.core.parameters import from_mapping
from teleteach.core.paths import config_file
from teleteach.core.robot_controllers import ControllerNames, ControllerNamesError, controller_names
from teleteach.skills.authority import AuthorityConfig

DEFAULT_MOTION_FILE = config_file("skills_motion.yaml")


class MotionConfigError(ValueError):
    """The motion file is missing a key or holds a wrong value."""


@dataclass(frozen=True)
class SkillServerConfig:
    """The skill server node's parameters: config/skill_server.yaml's keys (the one place of values and meanings)."""

    scene_file: str
    motion_file: str
    controllers: str
    idle_after: float
    action_status_rate: float

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any]) -> "SkillServerConfig":
        """From the yaml's keys, each perhaps overridden; a missing or unknown one is named."""
        return from_mapping(cls, values, "skill_server's parameters (config/skill_server.yaml)")


@dataclass(frozen=True)
class ArmConfig:
    """Arm motion limits and tolerances ([rad/s], [m/s], [s], [rad], [m])."""

    joint_speed: float
    linear_speed: float
    angular_speed: float
    min_duration: float
    sample_period: float
    cartesian_step: float
    goal_tolerance: float
    settle_timeout: float
    ik_tolerance: float
    max_ik_step: float


@dataclass(frozen=True)
class GripperConfig:
    """Finger openings [m], speed [m/s], grasp force [N] and tolerances [m] (franka_gripper's epsilon), timeout [s]."""

    open_width: float
    release_width: float
    speed: float
    grasp_force: float
    grasp_epsilon_inner: float
    grasp_epsilon_outer: float
    timeout: float


@dataclass(frozen=True)
class BaseConfig:
    """Mobile base tolerances [m], [rad] and timeout sizing [m/s], [s]."""

    position_tolerance: float
    yaw_tolerance: float
    expected_speed: float
    timeout: float


@dataclass(frozen=True)
class GraspConfig:
    """Where the TCP holds a product and how it approaches and lifts it [m], [rad]."""

    height_above_center: float
    approach_height: float
    lift_height: float
    yaw: float
    hold_tolerance: float
    table_tolerance: float


@dataclass(frozen=True)
class PlaceConfig:
    """The straight insertion into the gap and the retreat [m]."""

    approach_distance: float
    clearance: float
    release_lift: float
    retreat_distance: float


@dataclass(frozen=True)
class ReplayConfig:
    """Playback of a demonstrated stiffness skill: rate [Hz], approach tolerance [m], settle time [s], target search.

    target_search_radius [m]: how far a perceived gap may lie from where the taught one would be before the skill
    refuses to guess.
    """

    rate: float
    approach_tolerance: float
    settle_time: float
    target_search_radius: float


@dataclass(frozen=True)
class MotionConfig:
    """Everything config/skills_motion.yaml holds."""

    position_controller: str
    impedance_controller: str
    arm: ArmConfig
    gripper: GripperConfig
    base: BaseConfig
    postures: Dict[str, Tuple[float, ...]]
    grasp: GraspConfig
    place: PlaceConfig
    skills: Dict[str, Dict[str, str]]
    replay: ReplayConfig
    authority: AuthorityConfig


def load_motion_config(path: Optional[str] = None, controllers: Optional[str] = None) -> MotionConfig:
    """Read and validate the motion file (default: the package's config/skills_motion.yaml).

    The controllers' names come from config/robot_controllers.yaml, section ``controllers`` (None: its default).

    Raises:
        MotionConfigError: a key is missing or a value is of the wrong kind or out of range.
    """
    path = pathlib.Path(path) if path else DEFAULT_MOTION_FILE
    try:
        names = controller_names(controllers)
    except ControllerNamesError as error:
        raise MotionConfigError(str(error)) from None
    try:
        data = yaml.safe_load(path.read_text())
        return _parse(data, names)
    except (OSError, KeyError, TypeError, ValueError, yaml.YAMLError) as error:
        raise MotionConfigError(f"{path}: {error!r}") from None


def _section(cls, data, positive=(), non_negative=()):
    values = {}
    for field in fields(cls):
        value = float(data[field.name])
        if field.name in positive and not value > 0.0:
            raise ValueError(f"{field.name} must be > 0, got {value}")
        if field.name in non_negative and not value >= 0.0:
            raise ValueError(f"{field.name} must be >= 0, got {value}")
        values[field.name] = value
    return cls(**values)


def _parse(data, names: ControllerNames):
    arm = _section(ArmConfig, data["arm"], positive=[field.name for field in fields(ArmConfig)])
    gripper = _section(
        GripperConfig,
        data["gripper"],
        non_negative=["grasp_epsilon_inner", "grasp_epsilon_outer"],
        positive=["speed", "grasp_force", "timeout"],
    )
    for name in ("open_width", "release_width"):
        if not 0.0 <= getattr(gripper, name) <= 0.08:
            raise ValueError(f"gripper.{name} must be within [0, 0.08] m")
    base = _section(BaseConfig, data["base"], positive=[field.name for field in fields(BaseConfig)])
    postures = {}
    for name, values in data["postures"].items():
        if len(values) != 7:
            raise ValueError(f"posture {name} needs 7 joint positions, got {len(values)}")
        postures[name] = tuple(float(value) for value in values)
    for name in ("look", "carry"):
        if name not in postures:
            raise KeyError(f"postures.{name}")
    grasp = _section(GraspConfig, data["grasp"], positive=["hold_tolerance", "table_tolerance", "approach_height"])
    place = _section(PlaceConfig, data["place"], positive=["approach_distance"])
    replay = _section(ReplayConfig, data["replay"], positive=["approach_tolerance"], non_negative=["settle_time"])
    authority = _section(
        AuthorityConfig,
        data["authority"],
        positive=[field.name for field in fields(AuthorityConfig) if field.name != "spread_unknown"],
        non_negative=["spread_unknown"],
    )
    if replay.rate < 100.0:
        raise ValueError(f"replay.rate must be >= 100 Hz, got {replay.rate}")
    skills = {
        str(name): {str(key): str(value) for key, value in entry.items()} for name, entry in data["skills"].items()
    }
    return MotionConfig(
        position_controller=names.position,
        impedance_controller=names.impedance,
        arm=arm,
        gripper=gripper,
        base=base,
        postures=postures,
        grasp=grasp,
        place=place,
        skills=skills,
        replay=replay,
        authority=authority,
    )
