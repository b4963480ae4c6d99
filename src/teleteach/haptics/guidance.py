"""Haptic guidance: the forces that keep the operator's hand where the GUI needs it (issue: haptic guidance).

The thesis names the device's sensitivity as its main usability problem: selecting with X, the hand drifts in Y.
The GUI says per device axis (x, y, z [m]; roll, pitch, yaw [rad]) what it wants: ``free``; ``hold`` (a spring
toward a centre); or ``detents`` (a well around each position a slider or dial can stop at); plus damping, an
optional detent on the gripper, and caps. :class:`GuidanceRenderer` turns that into a force and torque for the
current device state, in the device loop (1 kHz), without ROS:

- a hold axis pulls with ``-k (q - centre)``;
- a detents axis pulls toward the nearest detent with ``-k w / (2 pi) sin(2 pi d / w)`` for ``|d| <= w / 2``
  (``d`` the distance to it, ``w`` the well's width): stiffness ``k`` at the detent, zero at the well's edge, so
  the hand clicks from one position into the next without a jump;
- damping ``-b q_dot`` on every axis that has it;
- while the gripper is closed for a click (below the click's ``release_threshold``), a detents axis with a
  ``click_stiffness`` holds the device at the centre of the well it is in, that stiff (engaging over
  ``CLICK_HOLD_BLEND``): closing the gripper with a finger pushes the hand (the "Heisenberg effect" of selecting
  with a tracked device), and a well soft enough to glide through cannot resist that push; the hold keeps the
  selection the click confirms;
- force and torque saturated (their norms) at the guidance's caps and the node's own, the gripper force at its cap;
- a new guidance blends in from the previous one over ``ramp_time``; stale guidance (no refresh for
  ``stale_after``), a dropped one (bad message, device lost) and none give exactly zero.
"""

import dataclasses
import math
from typing import Optional, Sequence, Tuple

import numpy as np

from teleteach.core.rotations import quaternion_to_rpy

AXES = ("x", "y", "z", "roll", "pitch", "yaw")
MODES = ("free", "hold", "detents")
# The Sigma.7's own continuous limits (Force Dimension's specification): no cap of the node may exceed them.
SIGMA7_MAX_FORCE = 20.0  # [N]
SIGMA7_MAX_TORQUE = 0.4  # [Nm]
SIGMA7_MAX_GRIPPER_FORCE = 8.0  # [N]
# More positions on one axis than any slider or dial offers: refused, so a message cannot slow the 1 kHz loop.
MAX_DETENTS = 1000
CLICK_HOLD_BLEND = 0.03  # [s] a click's hold engages over this: firm before the finger's push builds up, no step


class GuidanceError(ValueError):
    """A guidance cannot be rendered; the message says which field and why."""


@dataclasses.dataclass(frozen=True)
class AxisGuidance:
    """What one device axis does: ``mode`` free | hold | detents; units [m] or [rad] (stiffness [N/m] or [Nm/rad])."""

    mode: str = "free"
    centre: float = 0.0
    detents: Tuple[float, ...] = ()
    stiffness: float = 0.0
    width: float = 0.0
    damping: float = 0.0
    click_stiffness: float = 0.0  # detents: while clicking, a hold at the well's centre this stiff (0: none)


@dataclasses.dataclass(frozen=True)
class Guidance:
    """The guidance of all six axes and the gripper, with caps [N], [Nm] (see ``msg/HapticGuidance.msg``)."""

    axes: Tuple[AxisGuidance, ...] = tuple(AxisGuidance() for _ in AXES)
    gripper_detent: Optional[float] = None
    gripper_stiffness: float = 0.0
    gripper_width: float = 0.0
    max_force: float = 0.0
    max_torque: float = 0.0

    def __post_init__(self):
        if len(self.axes) != len(AXES):
            raise GuidanceError(f"guidance needs {len(AXES)} axes ({', '.join(AXES)}), got {len(self.axes)}")
        for name, axis in zip(AXES, self.axes):
            _check_axis(name, axis)
        numbers = {
            "max_force": self.max_force,
            "max_torque": self.max_torque,
            "gripper_stiffness": self.gripper_stiffness,
            "gripper_width": self.gripper_width,
        }
        for field, value in numbers.items():
            _non_negative(field, value)
        if self.gripper_detent is not None:
            if not math.isfinite(self.gripper_detent):
                raise GuidanceError(f"gripper_detent must be finite, got {self.gripper_detent}")
            if not self.gripper_width > 0.0:
                raise GuidanceError("a gripper detent needs gripper_width > 0")


def _non_negative(field: str, value: float) -> None:
    if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0.0):
        raise GuidanceError(f"{field} must be a finite number >= 0, got {value}")


def _check_axis(name: str, axis: AxisGuidance) -> None:
    if axis.mode not in MODES:
        raise GuidanceError(f"axis {name}: unknown mode {axis.mode!r}; expected one of {', '.join(MODES)}")
    for field in ("stiffness", "width", "damping", "click_stiffness"):
        _non_negative(f"axis {name} {field}", getattr(axis, field))
    if not math.isfinite(axis.centre):
        raise GuidanceError(f"axis {name} centre must be finite, got {axis.centre}")
    if len(axis.detents) > MAX_DETENTS:
        raise GuidanceError(f"axis {name}: {len(axis.detents)} detents, more than the {MAX_DETENTS} allowed")
    if not all(math.isfinite(position) for position in axis.detents):
        raise GuidanceError(f"axis {name} detents must be finite, got {list(axis.detents)}")
    if axis.mode == "detents" and not (axis.detents and axis.width > 0.0):
        raise GuidanceError(f"axis {name}: detents need at least one position and a width > 0")


@dataclasses.dataclass(frozen=True)
class Wrench:
    """What the device is told to render: force [N] and torque [Nm], gripper force [N].

    The guidance computes it in the operator frame; the device loop turns it into the device's (haptics.axes).
    """

    force: np.ndarray
    torque: np.ndarray
    gripper: float = 0.0

    @classmethod
    def zero(cls) -> "Wrench":
        """No force at all."""
        return cls(np.zeros(3), np.zeros(3), 0.0)

    def blend(self, other: "Wrench", weight: float) -> "Wrench":
        """``(1 - weight) self + weight other``."""
        return Wrench(
            (1.0 - weight) * self.force + weight * other.force,
            (1.0 - weight) * self.torque + weight * other.torque,
            (1.0 - weight) * self.gripper + weight * other.gripper,
        )


@dataclasses.dataclass(frozen=True)
class GuidanceLimits:
    """The node's own bounds (``config/device.yaml`` ``guidance``), never above the Sigma.7's."""

    max_force: float  # [N]
    max_torque: float  # [Nm]
    max_gripper_force: float  # [N]
    ramp_time: float  # [s]
    stale_after: float  # [s]

    def __post_init__(self):
        for field in dataclasses.fields(self):
            value = getattr(self, field.name)
            if not (math.isfinite(value) and value > 0.0):
                raise GuidanceError(f"guidance {field.name} must be a positive number, got {value}")
        device_limits = {
            "max_force": SIGMA7_MAX_FORCE,
            "max_torque": SIGMA7_MAX_TORQUE,
            "max_gripper_force": SIGMA7_MAX_GRIPPER_FORCE,
        }
        for field, limit in device_limits.items():
            if getattr(self, field) > limit:
                raise GuidanceError(
                    f"guidance {field} {getattr(self, field)} is above the Sigma.7's own limit of {limit}"
                )

    @classmethod
    def from_yaml(cls, **changes: float) -> "GuidanceLimits":
        """config/device.yaml's ``guidance`` section, the one place of its values, with ``changes``."""
        from teleteach.core.paths import config_values

        values = config_values("device.yaml", "guidance")
        return cls(**{**values, **changes})


def _nearest(detents: Sequence[float], position: float) -> float:
    return min(detents, key=lambda detent: abs(position - detent))


def _angles(orientation: Sequence[float]) -> Tuple[float, float, float]:
    return tuple(quaternion_to_rpy(orientation))


def axis_force(axis: AxisGuidance, position: float, velocity: float) -> float:
    """The force (or torque) one axis renders at ``position`` moving at ``velocity``."""
    force = -axis.damping * velocity
    if axis.mode == "hold":
        force -= axis.stiffness * (position - axis.centre)
    elif axis.mode == "detents":
        offset = position - _nearest(axis.detents, position)
        if abs(offset) <= axis.width / 2.0:
            force -= axis.stiffness * axis.width / (2.0 * math.pi) * math.sin(2.0 * math.pi * offset / axis.width)
    return force


def _saturate(vector: np.ndarray, limit: float) -> np.ndarray:
    norm = math.hypot(*vector)  # no overflow for huge components: they are scaled down to the cap like any other
    return vector * (limit / norm) if norm > limit else vector


def render(
    guidance: Guidance,
    limits: GuidanceLimits,
    position: Sequence[float],
    orientation: Sequence[float],
    linear_velocity: Sequence[float],
    angular_velocity: Sequence[float],
    gripper: float,
) -> Wrench:
    """The capped wrench of ``guidance`` at a device state (position [m], quaternion xyzw, velocities, gripper [rad]).

    Angles are the GUI's roll, pitch, yaw (R = Rz Ry Rx); the torque of each angle's axis is applied about the device
    axis of the same name, which is what they are for the small turns a dial or a held wrist makes.
    """
    turned = any(axis.mode != "free" for axis in guidance.axes[3:])  # the angles cost a conversion: only if used
    angles = quaternion_to_rpy(orientation) if turned else (0.0, 0.0, 0.0)
    coordinates = (*position, *angles)
    velocities = (*linear_velocity, *angular_velocity)
    values = [axis_force(axis, q, v) for axis, q, v in zip(guidance.axes, coordinates, velocities)]
    if not all(math.isfinite(value) for value in values):
        return Wrench.zero()
    force = _saturate(np.array(values[:3]), min(guidance.max_force, limits.max_force))
    torque = _saturate(np.array(values[3:]), min(guidance.max_torque, limits.max_torque))
    gripper_force = 0.0
    if guidance.gripper_detent is not None:
        detent = AxisGuidance("detents", detents=(guidance.gripper_detent,), stiffness=guidance.gripper_stiffness)
        detent = dataclasses.replace(detent, width=guidance.gripper_width)
        cap = min(guidance.max_force, limits.max_gripper_force)
        gripper_force = float(np.clip(axis_force(detent, gripper, 0.0), -cap, cap))
    return Wrench(force, torque, gripper_force)


class GuidanceRenderer:
    """The guidance in force now: set by messages, blended in on change, dropped when stale or bad.

    Times are wall-clock seconds (the device loop's clock), so a stopped simulation clock cannot keep a force on.
    """

    def __init__(self, limits: GuidanceLimits, click_below: float = 0.0) -> None:
        self.limits = limits
        self.click_below = click_below  # [rad] a gripper closed below this is clicking (the click's release threshold)
        self._guidance: Optional[Guidance] = None
        self._previous: Optional[Guidance] = None
        self._since = -math.inf  # when the current guidance was set (its ramp started)
        self._refreshed = -math.inf  # when it was last received
        self._held: Optional[Guidance] = None  # the current guidance with its click holds, while a click lasts
        self._held_for: Optional[Guidance] = None  # the guidance those holds were made from
        self._held_since = -math.inf

    @property
    def guidance(self) -> Optional[Guidance]:
        """The guidance being rendered (None: none)."""
        return self._guidance

    def set(self, guidance: Guidance, now: float) -> None:
        """A (valid) guidance arrived: a refresh of the current one, or a new one that blends in."""
        self._refreshed = now
        if guidance == self._guidance:
            return
        self._previous = self._guidance if self._active(now) else None
        self._guidance, self._since = guidance, now

    def drop(self) -> None:
        """Render nothing until the next valid guidance (a bad message, the device lost, shutdown)."""
        self._guidance = self._previous = self._held = None

    def _active(self, now: float) -> bool:
        return self._guidance is not None and now - self._refreshed <= self.limits.stale_after

    def wrench(
        self,
        now: float,
        position: Sequence[float],
        orientation: Sequence[float],
        linear_velocity: Sequence[float],
        angular_velocity: Sequence[float],
        gripper: float,
    ) -> Wrench:
        """The wrench to render at this device state: zero without fresh guidance."""
        if not self._active(now):
            return Wrench.zero()
        state = (position, orientation, linear_velocity, angular_velocity, gripper)
        target = render(self._guidance, self.limits, *state)
        if gripper < self.click_below:
            target = self._click_hold(now, position, orientation, target, state)
        else:
            self._held = None
        weight = min(1.0, (now - self._since) / self.limits.ramp_time)
        if weight >= 1.0:
            self._previous = None
            return target
        start = Wrench.zero() if self._previous is None else render(self._previous, self.limits, *state)
        return start.blend(target, weight)

    def _click_hold(self, now: float, position, orientation, free: Wrench, state) -> Wrench:
        """While clicking: detents axes with a click stiffness held at the centre of the well they were in.

        The holds are made when the click begins (or the guidance changes during it) and blend in from the wells
        over CLICK_HOLD_BLEND.
        """
        guidance = self._guidance
        if not any(axis.mode == "detents" and axis.click_stiffness > 0.0 for axis in guidance.axes):
            return free
        if self._held is None or self._held_for is not guidance:
            coordinates = (*position, *_angles(orientation))
            axes = tuple(
                AxisGuidance(
                    "hold", centre=_nearest(axis.detents, q), stiffness=axis.click_stiffness, damping=axis.damping
                )
                if axis.mode == "detents" and axis.click_stiffness > 0.0
                else axis
                for axis, q in zip(guidance.axes, coordinates)
            )
            self._held, self._held_for, self._held_since = dataclasses.replace(guidance, axes=axes), guidance, now
        held = render(self._held, self.limits, *state)
        return free.blend(held, min(1.0, (now - self._held_since) / CLICK_HOLD_BLEND))
