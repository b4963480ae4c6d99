"""Parameters of the teaching GUI, validated once so that a wrong value is reported before any window opens."""

import dataclasses
import math
import pathlib
from typing import Any, Dict, Mapping, Tuple

import yaml

from teleteach.paths import config_file
from teleteach.robot_controllers import ControllerNames, ControllerNamesError, controller_names

DEVICE_AXES = ("x", "y", "z", "roll", "pitch", "yaw")
CONFIG_DIR = config_file()


class GuiConfigError(ValueError):
    """A GUI parameter is missing, of the wrong type or out of its allowed range."""


@dataclasses.dataclass(frozen=True)
class GuiConfig:
    """All GUI parameters; units as in ``config/gui.yaml``."""

    device_range: float = 0.1
    device_angle_range: float = 1.0
    reject_position_beyond: float = 0.25
    reject_angle_beyond: float = 3.2
    deadband_position: float = 0.002
    deadband_angle: float = 0.02
    locked_axes: Tuple[str, ...] = ()
    stiffness_per_pixel: float = 5.0
    max_stiffness: float = 3000.0
    min_stiffness: float = 50.0
    initial_stiffness: float = 1525.0
    takeover_tolerance: float = 50.0
    takeover_angle: float = 0.05
    rotational_stiffness: float = 30.0
    rotation_gain: float = 1.0
    double_click_window: float = 0.6
    gripper_open_threshold: float = 0.45
    gripper_rearm_below: float = 0.35
    publish_rate: float = 200.0
    device_ui_rate: float = 60.0
    repaint_rate: float = 30.0
    player_rate: float = 100.0
    service_timeout: float = 5.0
    device_timeout: float = 0.5
    health_rate: float = 5.0
    start_neutral_zone: float = 0.02
    arm_rest_speed: float = 0.05
    arm_free_timeout: float = 20.0
    base_frame: str = "base_link"
    controllers: str = ""
    trajectory: str = "perpendicular"
    skill_prefix: str = "DemonstratedPlace"
    initial_tab: int = 0
    shared_control_node: str = "shared_control"
    shared_control_stiffness: Tuple[float, float, float] = (500.0, 500.0, 500.0)
    shared_skill_prefix: str = "SharedControl"
    shared_trail_length: int = 500
    edit_push: float = 0.05
    page_turn: float = 0.5
    retry_attempts: Tuple[int, ...] = (1, 2, 3, 4, 5)
    timeout_seconds: Tuple[float, ...] = (5.0, 10.0, 20.0, 30.0, 60.0, 120.0)
    guidance: bool = True
    guidance_detent_stiffness: float = 400.0
    guidance_hold_stiffness: float = 100.0
    guidance_angle_detent_stiffness: float = 2.0
    guidance_angle_hold_stiffness: float = 0.5
    guidance_damping: float = 2.0
    guidance_angular_damping: float = 0.01
    guidance_mode_angle_width: float = 0.4
    guidance_mode_angle_stiffness: float = 4.0
    guidance_click_stiffness: float = 1500.0
    guidance_angle_click_stiffness: float = 4.0
    guidance_max_force: float = 3.0
    guidance_max_torque: float = 0.1
    guidance_refresh: float = 0.2
    study_start_radius: float = 0.02

    def __post_init__(self):
        positive = (
            "device_range",
            "device_angle_range",
            "reject_position_beyond",
            "reject_angle_beyond",
            "stiffness_per_pixel",
            "max_stiffness",
            "min_stiffness",
            "double_click_window",
            "gripper_open_threshold",
            "publish_rate",
            "device_ui_rate",
            "repaint_rate",
            "player_rate",
            "service_timeout",
            "device_timeout",
            "health_rate",
            "rotation_gain",
            "edit_push",
            "page_turn",
            "guidance_max_force",
            "guidance_max_torque",
            "guidance_refresh",
            "study_start_radius",
            "guidance_mode_angle_width",
            "takeover_tolerance",
            "takeover_angle",
            "start_neutral_zone",
            "arm_rest_speed",
            "arm_free_timeout",
        )
        for name in positive:
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise GuiConfigError(f"GUI parameter {name} must be a positive number, got {value!r}")
        non_negative = (
            "deadband_position",
            "deadband_angle",
            "rotational_stiffness",
            "gripper_rearm_below",
            "guidance_detent_stiffness",
            "guidance_hold_stiffness",
            "guidance_angle_detent_stiffness",
            "guidance_angle_hold_stiffness",
            "guidance_damping",
            "guidance_angular_damping",
            "guidance_mode_angle_stiffness",
            "guidance_click_stiffness",
            "guidance_angle_click_stiffness",
        )
        for name in non_negative:
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise GuiConfigError(f"GUI parameter {name} must be a number >= 0, got {value!r}")
        if not self.min_stiffness < self.max_stiffness:
            raise GuiConfigError(f"min_stiffness {self.min_stiffness} must be below max_stiffness {self.max_stiffness}")
        if not self.min_stiffness <= self.initial_stiffness <= self.max_stiffness:
            raise GuiConfigError(
                f"initial_stiffness {self.initial_stiffness} must lie in [{self.min_stiffness}, {self.max_stiffness}]"
            )
        if not self.gripper_rearm_below < self.gripper_open_threshold:
            raise GuiConfigError("gripper_rearm_below must be below gripper_open_threshold (hysteresis)")
        unknown = [axis for axis in self.locked_axes if axis not in DEVICE_AXES]
        if unknown:
            raise GuiConfigError(f"locked_axes {unknown} unknown; allowed: {', '.join(DEVICE_AXES)}")
        if self.initial_tab not in (0, 1, 2, 3):
            raise GuiConfigError(
                "initial_tab must be 0 (START), 1 (HIGH-LEVEL), 2 (LOW-LEVEL) or 3 (SHARED CONTROL), "
                f"got {self.initial_tab}"
            )
        for name in ("skill_prefix", "shared_skill_prefix"):
            if not getattr(self, name).isidentifier():
                raise GuiConfigError(f"{name} {getattr(self, name)!r} must be an identifier")
        stiffness = self.shared_control_stiffness
        if len(stiffness) != 3 or not all(
            isinstance(value, (int, float)) and math.isfinite(value) and value > 0 for value in stiffness
        ):
            raise GuiConfigError(f"shared_control_stiffness must be 3 positive numbers [N/m], got {stiffness!r}")
        if not self.start_neutral_zone < self.device_range:
            raise GuiConfigError(
                f"start_neutral_zone {self.start_neutral_zone} must be below device_range {self.device_range}"
            )
        if not self.edit_push < self.device_range:
            raise GuiConfigError(f"edit_push {self.edit_push} must be below device_range {self.device_range}")
        if not self.page_turn < self.device_angle_range:
            raise GuiConfigError(
                f"page_turn {self.page_turn} must be below device_angle_range ({self.device_angle_range})"
            )
        if not self.retry_attempts or not all(
            isinstance(value, int) and not isinstance(value, bool) and value >= 1 for value in self.retry_attempts
        ):
            raise GuiConfigError(f"retry_attempts must be whole numbers >= 1, got {self.retry_attempts!r}")
        if not self.timeout_seconds or not all(
            isinstance(value, (int, float)) and math.isfinite(value) and value > 0 for value in self.timeout_seconds
        ):
            raise GuiConfigError(f"timeout_seconds must be positive numbers [s], got {self.timeout_seconds!r}")
        try:
            self.controller_names  # noqa: B018 - an unknown section is refused before any window opens
        except ControllerNamesError as error:
            raise GuiConfigError(f"GUI parameter {error}") from None
        if not (isinstance(self.shared_trail_length, int) and self.shared_trail_length >= 2):
            raise GuiConfigError(f"shared_trail_length must be an integer >= 2, got {self.shared_trail_length!r}")

    @property
    def controller_names(self) -> ControllerNames:
        """The impedance and position controllers of the ``controllers`` section (config/robot_controllers.yaml)."""
        return controller_names(self.controllers)

    @property
    def max_pixels(self) -> float:
        """Longest semi-axis on screen [px]: max_stiffness / stiffness_per_pixel (600 px in the thesis)."""
        return self.max_stiffness / self.stiffness_per_pixel

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any]) -> "GuiConfig":
        """Build from a dict (a yaml file or the node's private params); unknown keys are an error."""
        names = {field.name for field in dataclasses.fields(cls)}
        unknown = sorted(set(values) - names)
        if unknown:
            raise GuiConfigError(f"unknown GUI parameters: {', '.join(unknown)}")
        values = dict(values)
        if "locked_axes" in values:
            values["locked_axes"] = tuple(values["locked_axes"] or ())
        for name in ("shared_control_stiffness", "retry_attempts", "timeout_seconds"):
            if name in values:
                values[name] = tuple(values[name] or ())
        try:
            return cls(**values)
        except TypeError as error:
            raise GuiConfigError(str(error)) from None

    @classmethod
    def load(cls, path=None, **overrides) -> "GuiConfig":
        """Read ``config/gui.yaml`` (or ``path``) and apply ``overrides``."""
        path = pathlib.Path(path) if path else CONFIG_DIR / "gui.yaml"
        values: Dict[str, Any] = yaml.safe_load(path.read_text()) or {}
        values.update(overrides)
        return cls.from_mapping(values)
