"""The simulated Franka Hand behind franka_gripper's actions: move, grasp, homing and stop, judged from the world.

franka_gripper's semantics (libfranka's ``franka::Gripper``): ``move`` drives the fingers to a width at a speed;
``grasp`` closes (or opens) them at a speed and squeezes with a force, and succeeds only when the fingers stopped at a
width d with width - epsilon.inner <= d <= width + epsilon.outer (a grasp on nothing closes fully and fails); ``homing``
opens fully; ``stop`` halts the fingers and ends the running command. A new command ends the running one. Here the
fingers are pybullet's position motors (teleteach.sim.world); a command ends once the fingers reached the width (move)
or stood still for ``settle_time`` (blocked by a product, or holding it), and is judged by the width they measure.
"""

import math
from dataclasses import dataclass

from teleteach.core.validation import InvalidCommandError

STILL = 2e-4  # [m] finger width changes smaller than this count as standing still


@dataclass
class GripperCommand:
    """One franka_gripper command and how it ended (``done``, ``success``, ``error``, the measured ``final_width``).

    Args:
        kind: move | grasp | homing | stop.
        width: the width asked for [m] (grasp: the expected width of the object).
        inner: grasp tolerance below width [m].
        outer: grasp tolerance above width [m].
    """

    kind: str
    width: float
    inner: float = 0.0
    outer: float = 0.0
    done: bool = False
    success: bool = False
    error: str = ""
    final_width: float = math.nan

    def finish(self, success: bool, final_width: float, error: str = "") -> None:
        """End the command with its outcome."""
        self.done, self.success, self.error, self.final_width = True, success, error, final_width


class SimGripper:
    """The fingers of the simulated hand, commanded like franka_gripper; ``update`` is called every physics step.

    Args:
        world: the pybullet world (its ``set_gripper_width``, ``finger_width`` and ``gripper_width``).
        max_width: the widest opening [m].
        max_speed: fastest opening-width rate a command may ask for [m/s].
        max_force: largest grasp force a command may ask for [N].
        move_force: finger force of move and homing [N].
        settle_time: fingers still this long end a command [s].
        position_tolerance: a move has arrived within this of its width [m].
    """

    def __init__(self, world, max_width, max_speed, max_force, move_force, settle_time, position_tolerance):
        self.world = world
        self.max_width = float(max_width)
        self.max_speed = float(max_speed)
        self.max_force = float(max_force)
        self.move_force = float(move_force)
        self.settle_time = float(settle_time)
        self.position_tolerance = float(position_tolerance)
        self.command = None
        self._last_width = math.nan
        self._still_since = 0.0

    # ----------------------------------------------------------------------------------------------- commands
    def move(self, width, speed, now) -> GripperCommand:
        """franka_gripper/move: the fingers to width [m] at speed [m/s]; InvalidCommandError for a bad goal."""
        width = self._width(width, "width")
        speed = self._speed(speed)
        return self._start(GripperCommand("move", width), width, speed, self.move_force, now)

    def grasp(self, width, inner, outer, speed, force, now) -> GripperCommand:
        """franka_gripper/grasp: close (or open) toward an object of width [m] with force [N] at speed [m/s]."""
        width = self._width(width, "width")
        inner, outer = self._tolerance(inner, "epsilon.inner"), self._tolerance(outer, "epsilon.outer")
        speed = self._speed(speed)
        if not math.isfinite(force) or not 0.0 < force <= self.max_force:
            raise InvalidCommandError(f"grasp force {force} N is outside (0, {self.max_force}] N")
        target = 0.0 if width <= self.world.finger_width() else self.max_width
        return self._start(GripperCommand("grasp", width, inner, outer), target, speed, force, now)

    def homing(self, now) -> GripperCommand:
        """franka_gripper/homing: open fully at the fastest speed."""
        command = GripperCommand("homing", self.max_width)
        return self._start(command, self.max_width, self.max_speed, self.move_force, now)

    def stop(self, now) -> GripperCommand:
        """franka_gripper/stop: hold the fingers where they are and end the running command (unsuccessful)."""
        measured = self.world.finger_width()
        self._end_running(measured, "stopped by a stop command")
        self.world.set_gripper_width(measured, self.max_speed, self.move_force)
        command = GripperCommand("stop", measured)
        command.finish(True, measured)
        return command

    def _start(self, command, target, speed, force, now):
        self._end_running(self.world.finger_width(), f"replaced by a {command.kind} command")
        self.world.set_gripper_width(target, speed, force)
        self.command = command
        self._last_width, self._still_since = self.world.finger_width(), now
        return command

    def _end_running(self, measured, why):
        if self.command is not None and not self.command.done:
            self.command.finish(False, measured, why)
        self.command = None

    # --------------------------------------------------------------------------------------------- validation
    def _width(self, width, what):
        if not math.isfinite(width) or not 0.0 <= width <= self.max_width:
            raise InvalidCommandError(f"{what} {width} m is outside [0, {self.max_width}] m")
        return float(width)

    def _speed(self, speed):
        if not math.isfinite(speed) or not 0.0 < speed <= self.max_speed:
            raise InvalidCommandError(f"speed {speed} m/s is outside (0, {self.max_speed}] m/s")
        return float(speed)

    @staticmethod
    def _tolerance(value, what):
        if not math.isfinite(value) or value < 0.0:
            raise InvalidCommandError(f"{what} {value} m must be finite and >= 0")
        return float(value)

    # -------------------------------------------------------------------------------------------------- update
    def update(self, now) -> None:
        """Follow the running command; end it once the fingers arrived or stood still for settle_time."""
        command = self.command
        if command is None:
            return
        measured = self.world.finger_width()
        if abs(measured - self._last_width) > STILL:
            self._last_width, self._still_since = measured, now
        still = now - self._still_since >= self.settle_time
        if command.kind == "grasp":
            if still:
                self._judge_grasp(command, measured)
        elif abs(measured - command.width) <= self.position_tolerance:
            self._finish(command, True, measured)
        elif still:
            self._finish(
                command, False, measured, f"the fingers stopped at {measured:.4f} m, not {command.width:.4f} m"
            )

    def _judge_grasp(self, command, measured):
        low, high = command.width - command.inner, command.width + command.outer
        if low <= measured <= high:
            self._finish(command, True, measured)
        else:
            self._finish(
                command,
                False,
                measured,
                f"the fingers stopped at {measured:.4f} m, outside [{low:.4f}, {high:.4f}] m: nothing of width "
                f"{command.width:.4f} m between them",
            )

    def _finish(self, command, success, measured, error=""):
        command.finish(success, measured, error)
        self.command = None
