"""The one small interface every device backend implements, and the errors it may raise.

A backend reads the device: ``read(time)`` returns the current pose, orientation and gripper angle (a
:class:`DeviceSample`) or raises :class:`DeviceReadError`; a force-feedback device also renders the guidance's
wrench (``render``). Click emulation, twist estimation, guidance, rate keeping and publishing live elsewhere
(:mod:`teleteach.haptics.loop`), so every backend gets them the same way.
"""

import abc
import dataclasses
from typing import Optional, Sequence, Tuple

import numpy as np

from teleteach.haptics.guidance import Wrench


class DeviceError(Exception):
    """Base class of the errors a haptic device backend raises."""


class DeviceUnavailableError(DeviceError):
    """The device cannot be used at all (library or device missing); the message names what is missing."""


class DeviceReadError(DeviceError):
    """One read failed; the caller may try again on the next cycle."""


@dataclasses.dataclass
class DeviceSample:
    """What a device reports at one instant, in the device frame ``sigma7``.

    Attributes:
        position: end-effector position [m], shape (3,).
        orientation: end-effector orientation as a unit quaternion (x, y, z, w), shape (4,).
        gripper: gripper opening angle [rad], 0 = closed.
        button: the device's own (native) button state, or None when the click must be emulated from the gripper.
    """

    position: np.ndarray
    orientation: np.ndarray
    gripper: float
    button: Optional[bool] = None


class DeviceBackend(abc.ABC):
    """A source of device samples (real device, scripted scenario or virtual window)."""

    moves_on_wall_clock = False
    """Whether a hand moves it on the wall clock (the Sigma.7, the virtual window), whatever clock ROS runs on; a
    scenario is evaluated at the loop's stamps instead. The loop differentiates a hand's pose over the stamp clock as a
    line of the wall clock (:class:`teleteach.haptics.twist.StampOnWall`), not over the late, uneven ticks."""

    @abc.abstractmethod
    def read(self, time: float) -> DeviceSample:
        """Returns the sample at ``time`` [s], the instant the loop stamps it with (now).

        Real devices simply read their current state; time-driven backends (a scenario) evaluate themselves at
        ``time``, so the stamp and the data always belong together.

        Raises:
            DeviceReadError: this read failed (the next one may succeed).
        """

    def missed_gripper(self) -> Sequence[Tuple[float, float]]:
        """(time [s], gripper angle [rad]) samples between the last two reads that a stalled loop did not take.

        Only a backend that knows its past can tell (a scripted scenario); a real device cannot, and gives none.
        """
        return ()

    def render(self, wrench: Wrench) -> None:  # noqa: B027 (optional hook: only force-feedback devices render)
        """Renders a force on the operator's hand; backends without force feedback ignore it.

        Raises:
            DeviceReadError: the device did not take it (the next cycle tries again).
        """

    @property
    def finished(self) -> bool:
        """True when the backend has nothing more to give (a scenario played to its end); devices never finish."""
        return False

    def close(self) -> None:  # noqa: B027 (optional hook: most backends have nothing to release)
        """Releases the device; the default has nothing to release."""
