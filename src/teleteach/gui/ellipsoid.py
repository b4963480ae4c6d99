"""LOW-LEVEL teaching (thesis II-C, III-A): the stiffness ellipsoid commanded with the device.

Device translation sets the semi-axis lengths in pixels (scaled to the screen), premultiplied by
``stiffness_per_pixel`` [N/(m px)] they are the principal stiffnesses (eq. 1, footnote 2: lengths used directly);
device rotation sets roll, pitch, yaw of the axes with R = Rz(yaw) Ry(pitch) Rx(roll) (eq. 2).
A click cycles the modes ALL -> X -> Y -> Z: X moves only the X length and roll, Y the Y length and pitch,
Z the Z length and yaw.
"""

import threading
from typing import Tuple

import numpy as np

from teleteach.control.stiffness import translational_stiffness
from teleteach.gui.config import GuiConfig
from teleteach.gui.device import DeviceSample, scale
from teleteach.rotations import rpy_to_matrix, rpy_to_quaternion

MODES = ("ALL", "X", "Y", "Z")


class EllipsoidCommand:
    """The commanded ellipsoid; thread-safe, because the worker writes and publishes it while the GUI draws it."""

    def __init__(self, config: GuiConfig):
        self.config = config
        self._lock = threading.Lock()
        initial = config.initial_stiffness / config.stiffness_per_pixel
        self._lengths = [initial] * 3
        self._angles = [0.0, 0.0, 0.0]
        self._mode = 0
        self.version = 0

    @property
    def min_pixels(self) -> float:
        """Shortest semi-axis [px]: the stiffness never drops below ``min_stiffness``."""
        return self.config.min_stiffness / self.config.stiffness_per_pixel

    @property
    def mode(self) -> str:
        """ALL, X, Y or Z."""
        return MODES[self._mode]

    def next_mode(self) -> str:
        """Cycle the mode (one click) and return the new one."""
        with self._lock:
            self._mode = (self._mode + 1) % len(MODES)
            self.version += 1
            return MODES[self._mode]

    def device(self, sample: DeviceSample) -> bool:
        """Apply a (filtered) device sample according to the mode; True when the ellipsoid changed."""
        config = self.config
        lengths = [
            scale(value, config.device_range, self.min_pixels, config.max_pixels)
            for value in (sample.x, sample.y, sample.z)
        ]
        limit = np.pi
        angles = [
            float(np.clip(config.rotation_gain * value, -limit, limit))
            for value in (sample.roll, sample.pitch, sample.yaw)
        ]
        axes = range(3) if self._mode == 0 else (self._mode - 1,)
        with self._lock:
            before = (tuple(self._lengths), tuple(self._angles))
            for axis in axes:
                self._lengths[axis] = lengths[axis]
                self._angles[axis] = angles[axis]
            changed = before != (tuple(self._lengths), tuple(self._angles))
            if changed:
                self.version += 1
            return changed

    def state(self) -> Tuple[np.ndarray, np.ndarray, str, int]:
        """Semi-axis lengths [px], (roll, pitch, yaw) [rad], mode and version, read consistently."""
        with self._lock:
            return np.array(self._lengths), np.array(self._angles), MODES[self._mode], self.version

    def stiffness(self) -> Tuple[np.ndarray, Tuple[float, float, float, float]]:
        """Principal stiffnesses [N/m] and the quaternion (x, y, z, w) of their axes in the base frame."""
        lengths, angles, _, _ = self.state()
        return lengths * self.config.stiffness_per_pixel, tuple(rpy_to_quaternion(*angles))

    def stiffness_matrix(self) -> np.ndarray:
        """Translational stiffness K_T = V Sigma V^T [N/m] (thesis eq. 1)."""
        lengths, angles, _, _ = self.state()
        return translational_stiffness(lengths * self.config.stiffness_per_pixel, rpy_to_matrix(*angles))
