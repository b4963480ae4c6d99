"""Parameters of the teaching GUI, validated once so that a wrong value is reported before any window opens."""

import dataclasses
import math
import pathlib
from typing import Any, Dict, Mapping, Tuple

from teleteach.core import parameters
from teleteach.core.paths import config_values
from teleteach.core.robot_controllers import ControllerNames, ControllerNamesError, controller_names
from teleteach.core.teleoperation import TeleopParameters, TeleopParametersError

DEVICE_AXES = ("x", "y", "z", "roll", "pitch", "yaw")


POSITIVE = (
    "device_range",
    "device_angle_range",
    "reject_position_beyond",
    "reject_angle_beyond",
    "stiffness_per_pixel",
    "max_stiffness",
    "min_stiffness",
    "initial_stiffness",
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
    "taught_path_approach",
)
"""The GUI parameters that must be numbers > 0."""
NON_NEGATIVE = (
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
"""The GUI parameters that must be numbers >= 0."""
TEXT = ("base_frame", "controllers", "trajectory", "data_dir", "skill_prefix", "shared_skill_prefix", "path_prefix")
"""The GUI parameters that are text (a yaml key left empty, ``null``, is refused by name, not met later as None)."""


class GuiConfigError(ValueError):
    """A GUI parameter is missing, of the wrong type or out of its allowed range."""


@dataclasses.dataclass(frozen=True)
class GuiConfig:
    """All GUI parameters; their values and units are in ``config/gui.yaml``, the one place of their defaults."""

    device_range: float
    device_angle_range: float
    reject_position_beyond: float
    reject_angle_beyond: float
    deadband_position: float
    deadband_angle: float
    locked_axes: Tuple[str, ...]
    stiffness_per_pixel: float
    max_stiffness: float
    min_stiffness: float
    initial_stiffness: float
    takeover_tolerance: float
    takeover_angle: float
    rotational_stiffness: float
    rotation_gain: float
    double_click_window: float
    gripper_open_threshold: float
    gripper_rearm_below: float
    publish_rate: float
    device_ui_rate: float
    repaint_rate: float
    player_rate: float
    service_timeout: float
    device_timeout: float
    health_rate: float
    start_neutral_zone: float
    arm_rest_speed: float
    arm_free_timeout: float
    base_frame: str
    controllers: str
    trajectory: str
    skill_prefix: str
    initial_tab: int
    data_dir: str
    shared_control_stiffness: Tuple[float, float, float]
    shared_skill_prefix: str
    shared_trail_length: int
    edit_push: float
    page_turn: float
    retry_attempts: Tuple[int, ...]
    timeout_seconds: Tuple[float, ...]
    guidance: bool
    guidance_detent_stiffness: float
    guidance_hold_stiffness: float
    guidance_angle_detent_stiffness: float
    guidance_angle_hold_stiffness: float
    guidance_damping: float
    guidance_angular_damping: float
    guidance_mode_angle_width: float
    guidance_mode_angle_stiffness: float
    guidance_click_stiffness: float
    guidance_angle_click_stiffness: float
    guidance_max_force: float
    guidance_max_torque: float
    guidance_refresh: float
    study_start_radius: float
    teleop: TeleopParameters
    taught_path_approach: float
    path_prefix: str

    def __post_init__(self):
        self._check_numbers()
        self._check_orderings()
        self._check_choices()

    def _check_numbers(self) -> None:
        """Each of POSITIVE > 0, each of NON_NEGATIVE >= 0, all finite."""
        for name in POSITIVE:
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise GuiConfigError(f"GUI parameter {name} must be a positive number, got {value!r}")
        for name in NON_NEGATIVE:
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise GuiConfigError(f"GUI parameter {name} must be a number >= 0, got {value!r}")

    def _check_orderings(self) -> None:
        """Values that must lie below (or between) others: stiffness limits, hysteresis, zones within the range."""
        if not self.min_stiffness < self.max_stiffness:
            raise GuiConfigError(f"min_stiffness {self.min_stiffness} must be below max_stiffness {self.max_stiffness}")
        if not self.min_stiffness <= self.initial_stiffness <= self.max_stiffness:
            raise GuiConfigError(
                f"initial_stiffness {self.initial_stiffness} must lie in [{self.min_stiffness}, {self.max_stiffness}]"
            )
        if not self.gripper_rearm_below < self.gripper_open_threshold:
            raise GuiConfigError("gripper_rearm_below must be below gripper_open_threshold (hysteresis)")
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

    def _check_choices(self) -> None:
        """Names, lists and choices: locked axes, the first tab, prefixes, the dials' values, the controllers."""
        for name in TEXT:
            if not isinstance(getattr(self, name), str):
                raise GuiConfigError(f"GUI parameter {name} must be text, got {getattr(self, name)!r}")
        if not isinstance(self.guidance, bool):
            raise GuiConfigError(f"GUI parameter guidance must be true or false, got {self.guidance!r}")
        unknown = [axis for axis in self.locked_axes if axis not in DEVICE_AXES]
        if unknown:
            raise GuiConfigError(f"locked_axes {unknown} unknown; allowed: {', '.join(DEVICE_AXES)}")
        if self.initial_tab not in (0, 1, 2, 3, 4):
            raise GuiConfigError(
                "initial_tab must be 0 (START), 1 (HIGH-LEVEL), 2 (LOW-LEVEL), 3 (SHARED CONTROL) or 4 (TELEOP), "
                f"got {self.initial_tab}"
            )
        for name in ("skill_prefix", "shared_skill_prefix", "path_prefix"):
            if not getattr(self, name).isidentifier():
                raise GuiConfigError(f"{name} {getattr(self, name)!r} must be an identifier")
        if len(self.shared_control_stiffness) != 3 or not _positive_numbers(self.shared_control_stiffness):
            raise GuiConfigError(
                f"shared_control_stiffness must be 3 positive numbers [N/m], got {self.shared_control_stiffness!r}"
            )
        if not self.retry_attempts or not all(
            isinstance(value, int) and not isinstance(value, bool) and value >= 1 for value in self.retry_attempts
        ):
            raise GuiConfigError(f"retry_attempts must be whole numbers >= 1, got {self.retry_attempts!r}")
        if not self.timeout_seconds or not _positive_numbers(self.timeout_seconds):
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
        """Build from a dict (a yaml file or the node's private params); a missing or unknown key is an error."""
        values = dict(values)
        for name in ("locked_axes", "shared_control_stiffness", "retry_attempts", "timeout_seconds"):
            if name in values and values[name] is None:
                values[name] = ()  # a yaml key left empty: an empty list (lists become tuples in from_mapping)
        try:
            return parameters.from_mapping(cls, values, "GUI parameters (config/gui.yaml)", GuiConfigError)
        except TeleopParametersError as error:
            raise GuiConfigError(f"GUI parameter {error}") from None

    @classmethod
    def load(cls, path=None, **overrides) -> "GuiConfig":
        """Read ``config/gui.yaml`` (or ``path``) and apply ``overrides``.

        A section's override (``teleop``) changes the keys it names and keeps the others, as the parameter server
        merges a launch's value into the yaml.
        """
        values = config_values(pathlib.Path(path) if path else "gui.yaml")
        return cls.from_mapping(_merged(values, overrides))


def _merged(base: Mapping[str, Any], overrides: Mapping[str, Any]) -> Dict[str, Any]:
    """``base`` with ``overrides`` applied, mappings merged key by key."""
    merged = dict(base)
    for key, value in overrides.items():
        both = isinstance(value, Mapping) and isinstance(merged.get(key), Mapping)
        merged[key] = _merged(merged[key], value) if both else value
    return merged


def _positive_numbers(values) -> bool:
    return all(isinstance(value, (int, float)) and math.isfinite(value) and value > 0 for value in values)
