"""Device input from another program (the ``topic`` backend): the latest pose and gripper angle it sent.

Another input device's driver, a motion capture of a hand, or a closed-loop script (``bench/haptic_guidance.py``
plays an operator who watches the GUI) gives the device's pose and gripper angle; the node's loop reads the latest
of them at its own rate, so the click emulation, the twist, the guidance and the hand model work as with any other
backend (with ``~hand/enabled`` the input is what the operator intends). The ROS layer feeds :meth:`TopicInput.pose`
and :meth:`TopicInput.gripper` from ``sigma7/input/pose`` and ``sigma7/input/gripper_angle``; input with NaN, a
quaternion that is not one, or a negative gripper angle is refused with its reason and the last good input stays.
No input yet, or none for ``timeout``, is a failed read: nothing is published and no force is rendered, as when a
real device is lost.
"""

import math
import threading
import time as wall_time
from typing import Callable, Optional, Sequence

import numpy as np

from teleteach.haptics.device import DeviceBackend, DeviceReadError, DeviceSample


class TopicInput(DeviceBackend):
    """The latest input received (thread-safe: written by ROS callbacks, read by the device loop).

    Args:
        timeout: [s] of wall time without a new pose after which reads fail.
        gripper: [rad] the gripper angle until the first one arrives (a pose-only source: resting, no clicks).
        clock: [s] wall clock that times the input's age.
    """

    def __init__(self, timeout: float, gripper: float, clock: Callable[[], float] = wall_time.monotonic) -> None:
        if not (math.isfinite(timeout) and timeout > 0.0):
            raise ValueError(f"~topic/timeout must be a positive number of seconds, got {timeout}")
        if not (math.isfinite(gripper) and gripper >= 0.0):
            raise ValueError(f"~topic/gripper must be an angle >= 0 rad, got {gripper}")
        self._timeout = timeout
        self._clock = clock
        self._lock = threading.Lock()
        self._position: Optional[np.ndarray] = None
        self._orientation = np.array([0.0, 0.0, 0.0, 1.0])
        self._gripper = gripper
        self._received = -math.inf

    def pose(self, position: Sequence[float], orientation: Sequence[float]) -> None:
        """A new pose: position [m], quaternion (x, y, z, w).

        Raises:
            ValueError: NaN or infinite values, or a quaternion whose norm is not 1 (within 1 %); nothing changes.
        """
        values = np.array([*position, *orientation], dtype=float)
        if values.shape != (7,) or not np.all(np.isfinite(values)):
            raise ValueError(f"input pose must be 7 finite numbers, got {list(values)}")
        norm = float(np.linalg.norm(values[3:]))
        if abs(norm - 1.0) > 0.01:
            raise ValueError(f"input orientation is not a unit quaternion (norm {norm:.3f})")
        with self._lock:
            self._position, self._orientation = values[:3], values[3:] / norm
            self._received = self._clock()

    def gripper(self, angle: float) -> None:
        """A new gripper angle [rad].

        Raises:
            ValueError: NaN, infinite or negative; nothing changes.
        """
        if not (math.isfinite(angle) and angle >= 0.0):
            raise ValueError(f"input gripper angle must be a finite number >= 0 rad, got {angle}")
        with self._lock:
            self._gripper = float(angle)

    def read(self, time: float) -> DeviceSample:
        """The latest input, or a failed read when there is none or it is older than the timeout."""
        with self._lock:
            position, orientation, gripper, received = self._position, self._orientation, self._gripper, self._received
        if position is None:
            raise DeviceReadError("no input on sigma7/input/pose yet")
        age = self._clock() - received
        if age > self._timeout:
            raise DeviceReadError(f"no input on sigma7/input/pose for {age:.2f} s (timeout {self._timeout:g} s)")
        return DeviceSample(position=position.copy(), orientation=orientation.copy(), gripper=gripper)
