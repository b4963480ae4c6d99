"""Teleoperating the arm with the device: a clutch on the gripper, the handle's motion moving the equilibrium pose.

While the operator holds the gripper closed (longer than a click: ``clutch_hold``), the equilibrium pose x_r of the
impedance controller (thesis eq. 5) follows the handle: the handle's displacement since the clutch engaged, turned
from the operator frame (x right, y away, z up: what /sigma7/pose reports) into the robot's base frame and scaled,
is added to where the equilibrium was at that moment; so is its rotation. Releasing the gripper holds the pose, and
the next clutch starts from there (indexing, as with a mouse lifted off the table). The equilibrium moves no faster
than ``max_speed`` (and ``max_angular_speed``) and stays in the ``workspace`` box (an arm outside it may only
come back in); a device pose that is not a pose
(NaN, not a rotation), that jumped beyond ``max_device_jump`` since the last one, or that stopped coming
(``device_timeout``) holds the pose and releases the clutch, with a one-line reason.

Pure: times come in with the samples (the GUI gives ROS time), so the rules are tested without ROS or Qt.
"""

import dataclasses
import enum
import math
from typing import Callable, Optional, Sequence, Tuple

import numpy as np
from scipy.spatial.transform import Rotation

from teleteach.core.validation import InvalidCommandError, finite_vector, rotation_matrix, validate_quaternion


class TeleopParametersError(ValueError):
    """A teleoperation parameter is out of its range; the message names it."""


@dataclasses.dataclass(frozen=True)
class AssistanceParameters:
    """The ``teleop/assistance`` section of config/gui.yaml: shared control in the placement.

    Its rules are teleteach.shared_control.placement's; a Teleoperation applies them through ``update(constrain=)``.
    """

    enabled: bool
    margin: float
    capture: float
    front_margin: float
    reach: float

    def __post_init__(self):
        if not isinstance(self.enabled, bool):
            raise TeleopParametersError(f"teleop/assistance/enabled must be true or false, got {self.enabled!r}")
        for name in ("margin", "capture", "front_margin", "reach"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0.0):
                raise TeleopParametersError(f"teleop/assistance/{name} must be a number >= 0 [m], got {value!r}")


@dataclasses.dataclass(frozen=True)
class TeleopParameters:
    """The ``teleop`` section of config/gui.yaml, where each value's unit and meaning is written."""

    scale: float
    rotation_scale: float
    operator_to_base: Tuple[Tuple[float, ...], ...]
    clutch_below: float
    clutch_release_above: float
    clutch_hold: float
    max_speed: float
    max_angular_speed: float
    max_device_jump: float
    workspace_low: Tuple[float, ...]
    workspace_high: Tuple[float, ...]
    assistance: AssistanceParameters

    def __post_init__(self):
        for name in (
            "scale",
            "clutch_hold",
            "max_speed",
            "max_angular_speed",
            "max_device_jump",
            "clutch_release_above",
        ):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise TeleopParametersError(f"teleop/{name} must be a positive number, got {value!r}")
        if not (isinstance(self.rotation_scale, (int, float)) and 0.0 <= self.rotation_scale < math.inf):
            raise TeleopParametersError(f"teleop/rotation_scale must be a number >= 0, got {self.rotation_scale!r}")
        if not 0.0 <= self.clutch_below < self.clutch_release_above:
            raise TeleopParametersError(
                f"teleop needs 0 <= clutch_below < clutch_release_above (hysteresis), got {self.clutch_below} and "
                f"{self.clutch_release_above} rad"
            )
        try:
            rotation_matrix(self.operator_to_base, "teleop/operator_to_base")
        except InvalidCommandError as error:
            raise TeleopParametersError(str(error)) from None
        box_error = TeleopParametersError(
            f"teleop/workspace_low {self.workspace_low!r} must lie below workspace_high {self.workspace_high!r} "
            "(3 numbers each, base frame [m])"
        )
        try:
            low, high = (np.array(box, dtype=float) for box in (self.workspace_low, self.workspace_high))
        except (TypeError, ValueError):
            raise box_error from None
        if low.shape != (3,) or high.shape != (3,) or not np.all(np.isfinite(low) & np.isfinite(high) & (low < high)):
            raise box_error

    @property
    def rotation(self) -> Rotation:
        """Operator frame -> base frame (``operator_to_base``'s rows are the base frame's axes in operator axes)."""
        return Rotation.from_matrix(np.array(self.operator_to_base, dtype=float))


Constrain = Callable[[np.ndarray, np.ndarray], Tuple[np.ndarray, str]]  # (pose now, position asked) -> (allowed, what
#                                                                        it did)


class Clutch(enum.Enum):
    """The gripper as a clutch."""

    RELEASED = "released"  # the arm holds its equilibrium
    CLOSING = "closing"  # closed, not yet long enough to be more than a click
    ENGAGED = "engaged"  # the equilibrium follows the handle


class GripperClutch:
    """The gripper as a clutch: closed for ``clutch_hold`` engages it, opened releases it.

    Closed is below ``clutch_below``, opened beyond ``clutch_release_above``; after a refusal it engages again only
    once the gripper was opened. One gesture for every clutch of the device: TELEOP's (the arm follows the handle)
    and a wipe's (the handle shapes the stiffness while the shared controller keeps the pattern).
    """

    def __init__(self, parameters: TeleopParameters):
        self.parameters = parameters
        self.state = Clutch.RELEASED
        self._closed_since: Optional[float] = None
        self.must_reopen = False  # released by a refusal: it engages again only after an opening

    def update(self, now: float, gripper: Optional[float]) -> bool:
        """Follow the gripper angle [rad] at ``now`` [s] (None or NaN: open); True when the clutch engaged now."""
        parameters = self.parameters
        if gripper is None or not math.isfinite(gripper) or gripper > parameters.clutch_release_above:
            self.release(must_reopen=False)
            return False
        if self.must_reopen or (gripper >= parameters.clutch_below and self.state is Clutch.RELEASED):
            return False
        if self.state is Clutch.RELEASED:
            self.state, self._closed_since = Clutch.CLOSING, now
        if self.state is Clutch.CLOSING and now - self._closed_since >= parameters.clutch_hold:
            self.state = Clutch.ENGAGED
            return True
        return False

    def release(self, must_reopen: bool) -> None:
        """Released now; with ``must_reopen`` it engages again only after the gripper was opened."""
        self.state, self._closed_since, self.must_reopen = Clutch.RELEASED, None, must_reopen


@dataclasses.dataclass(frozen=True)
class TeleopCommand:
    """What to command now: ``pose`` (x y z qx qy qz qw, base frame; None before the arm's pose is known)."""

    pose: Optional[np.ndarray]
    clutch: Clutch
    reason: str  # why the pose holds or is limited (one line), "" when it follows the handle freely


class Teleoperation:
    """The clutch and the mapping from the handle to the equilibrium pose (see the module docstring)."""

    def __init__(self, parameters: TeleopParameters):
        self.parameters = parameters
        self._turn = parameters.rotation
        self._low = np.array(parameters.workspace_low, dtype=float)
        self._high = np.array(parameters.workspace_high, dtype=float)
        self._pose: Optional[np.ndarray] = None
        self._time: Optional[float] = None
        self._gripper = GripperClutch(parameters)
        self._anchor: Optional[Tuple[np.ndarray, Rotation, np.ndarray, Rotation]] = None
        self._box = (self._low, self._high)
        self._last_device: Optional[np.ndarray] = None

    @property
    def pose(self) -> Optional[np.ndarray]:
        """The equilibrium it holds or moves (x y z qx qy qz qw, base frame), None before the start."""
        return None if self._pose is None else self._pose.copy()

    @property
    def clutch(self) -> Clutch:
        """The clutch's state now."""
        return self._gripper.state

    def start(self, arm_pose: Sequence[float], now: float) -> None:
        """Hold ``arm_pose`` (the arm's measured pose when TELEOP takes it); the clutch starts released."""
        pose = finite_vector(arm_pose, 7, "arm pose")
        pose[3:] = validate_quaternion(pose[3:], "arm orientation")
        self._pose, self._time = pose, now
        self._release(must_reopen=True)
        self._last_device = None

    def stop(self) -> None:
        """Forget the held pose: nothing is commanded until the next start."""
        self._pose = self._time = None
        self._release(must_reopen=True)

    def update(
        self,
        now: float,
        gripper: Optional[float],
        device: Optional[Tuple[Sequence[float], Sequence[float]]],
        device_age: float,
        device_timeout: float,
        constrain: Optional[Constrain] = None,
    ) -> TeleopCommand:
        """The pose to command at ``now`` [s].

        Given the gripper angle [rad], the newest device pose (position, quaternion in the operator frame), how long
        ago [s] it came, and after how long the device counts as lost. ``constrain`` (shared control) turns the
        position the handle asks for, given the equilibrium's pose now, into the one allowed, and says what it did.
        """
        if self._pose is None:
            return TeleopCommand(None, self.clutch, "not started: waiting for the arm's pose")
        dt = max(0.0, now - self._time)
        self._time = now
        if device is None or device_age > device_timeout:
            self._release(must_reopen=True)
            return self._hold(f"device lost (no pose for {device_age:.1f} s): holding the pose")
        try:
            position = finite_vector(device[0], 3, "device position")
            orientation = Rotation.from_quat(validate_quaternion(device[1], "device orientation"))
        except InvalidCommandError as error:
            self._release(must_reopen=True)
            return self._hold(f"device pose refused ({error}): holding the pose")
        jump = math.inf if self._last_device is None else float(np.linalg.norm(position - self._last_device))
        self._last_device = position
        if self.clutch is Clutch.ENGAGED and jump > self.parameters.max_device_jump:
            self._release(must_reopen=True)
            return self._hold(
                f"device pose jumped {jump * 100:.1f} cm (limit {self.parameters.max_device_jump * 100:.1f} cm): "
                "holding; open and close the gripper to go on"
            )
        self._follow_gripper(now, gripper, position, orientation)
        if self.clutch is not Clutch.ENGAGED:
            waiting = "open the gripper, then close it to move the arm" if self._gripper.must_reopen else ""
            return self._hold(waiting)
        return self._follow(position, orientation, dt, constrain)

    def _follow_gripper(self, now: float, gripper: Optional[float], position, orientation: Rotation) -> None:
        """The clutch follows the gripper; as it engages, the handle and the equilibrium are anchored together."""
        if self._gripper.update(now, gripper):
            pose = self._pose
            self._anchor = (position, orientation, pose[:3].copy(), Rotation.from_quat(pose[3:]))
            # an arm already outside the workspace may move back in, never further out
            self._box = (np.minimum(self._low, pose[:3]), np.maximum(self._high, pose[:3]))
        elif self.clutch is not Clutch.ENGAGED:
            self._anchor = None

    def _follow(
        self, position: np.ndarray, orientation: Rotation, dt: float, constrain: Optional[Constrain]
    ) -> TeleopCommand:
        """Move toward where the handle puts the equilibrium, within the assistance, the workspace and the limits."""
        parameters = self.parameters
        device_start, device_turn_start, pose_start, turn_start = self._anchor
        target = pose_start + parameters.scale * self._turn.apply(position - device_start)
        target, said = (target, "") if constrain is None else constrain(self._pose.copy(), target)
        limits = [said] if said else []
        clipped = np.clip(target, *self._box)
        if not np.allclose(clipped, target):
            limits.append("workspace limit")
        turn = orientation * device_turn_start.inv()  # the handle's rotation since the clutch, operator frame
        turn = Rotation.from_rotvec(parameters.rotation_scale * self._turn.apply(turn.as_rotvec()))
        target_turn = turn * turn_start
        step = clipped - self._pose[:3]
        distance = float(np.linalg.norm(step))
        if distance > parameters.max_speed * dt:
            step *= parameters.max_speed * dt / distance
            limits.append(f"speed limit {parameters.max_speed:g} m/s")
        current = Rotation.from_quat(self._pose[3:])
        rotation_step = (target_turn * current.inv()).as_rotvec()
        angle = float(np.linalg.norm(rotation_step))
        if angle > parameters.max_angular_speed * dt:
            rotation_step *= parameters.max_angular_speed * dt / angle
            limits.append(f"angular speed limit {parameters.max_angular_speed:g} rad/s")
        quaternion = (Rotation.from_rotvec(rotation_step) * current).as_quat()
        self._pose = np.concatenate([self._pose[:3] + step, quaternion * (1.0 if quaternion[3] >= 0.0 else -1.0)])
        return TeleopCommand(self._pose.copy(), self.clutch, "; ".join(limits))

    def _hold(self, reason: str) -> TeleopCommand:
        return TeleopCommand(self._pose.copy(), self.clutch, reason)

    def _release(self, must_reopen: bool) -> None:
        self._gripper.release(must_reopen)
        self._anchor = None


ORIGIN = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)


class ReplayCorrection:
    """The operator's correction of a skill the robot replays: TELEOP's clutch and handle moving an offset from zero.

    While a skill replays (the skill server reports who leads it), holding the clutch moves the offset with the
    handle (scaled and turned into the base frame as in TELEOP, with its speed limit) inside a box of
    +-``max_correction``, what the replay applies at most; the replay weighs it by its unsureness there. Each replay
    starts from zero (another skill, or reports that paused for ``REPLAY_GAP``); when the reports stop, it ends.
    """

    REPLAY_GAP = 1.0  # [s] reports further apart belong to two replays

    def __init__(self, parameters: TeleopParameters):
        self.parameters = parameters
        self._teleoperation: Optional[Teleoperation] = None
        self._skill = ""
        self._last = -math.inf

    def update(
        self,
        now: float,
        replaying: str,
        max_correction: float,
        gripper: Optional[float],
        device: Optional[Tuple[Sequence[float], Sequence[float]]],
        device_age: float,
        device_timeout: float,
    ) -> Optional[TeleopCommand]:
        """The correction at ``now`` (``pose[:3]``, base frame [m]); None when no skill replays.

        ``replaying`` names the skill that replays (empty: none); the other arguments are as
        :meth:`Teleoperation.update`'s.
        """
        new_replay = now - self._last > self.REPLAY_GAP
        self._last = now
        if not replaying or not (math.isfinite(max_correction) and max_correction > 0.0):
            self._teleoperation, self._skill = None, ""
            return None
        if replaying != self._skill or new_replay:
            box = dataclasses.replace(
                self.parameters, workspace_low=(-max_correction,) * 3, workspace_high=(max_correction,) * 3
            )
            self._teleoperation, self._skill = Teleoperation(box), replaying
            self._teleoperation.start(ORIGIN, now)
        return self._teleoperation.update(now, gripper, device, device_age, device_timeout)
