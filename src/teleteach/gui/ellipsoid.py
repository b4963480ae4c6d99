"""LOW-LEVEL teaching (thesis II-C, III-A): the stiffness ellipsoid commanded with the device.

Device translation sets the semi-axis lengths in pixels (scaled to the screen), premultiplied by
``stiffness_per_pixel`` [N/(m px)] they are the principal stiffnesses (eq. 1, footnote 2: lengths used directly);
device rotation sets roll, pitch, yaw of the axes with R = Rz(yaw) Ry(pitch) Rx(roll) (eq. 2).
A click cycles the modes ALL -> X -> Y -> Z: X moves only the X length and roll, Y the Y length and pitch,
Z the Z length and yaw.

Soft takeover: an axis that becomes live (entering LOW-LEVEL, or a mode that includes it) keeps its value until the
handle has met it - come within ``takeover_tolerance`` of it or passed it - and follows the handle from then on. So
entering the tab, or changing mode, never makes the stiffness jump to wherever the handle happens to be; a centred
handle meets the initial ellipsoid (``initial_stiffness`` is the centre of the range).
"""

import threading
from typing import Optional, Sequence, Tuple

import numpy as np

from teleteach.control.stiffness import translational_stiffness
from teleteach.core.gui_config import GuiConfig
from teleteach.core.rotations import rpy_to_matrix, rpy_to_quaternion
from teleteach.gui.device import DeviceSample, scale

MODES = ("ALL", "X", "Y", "Z")


class EllipsoidCommand:
    """The commanded ellipsoid; thread-safe, because the worker writes and publishes it while the GUI draws it."""

    def __init__(self, config: GuiConfig, initial: Optional[Sequence[float]] = None):
        """``initial``: the principal stiffnesses to start with [N/m] (default: ``initial_stiffness`` on each axis)."""
        self.config = config
        self._lock = threading.Lock()
        initial = [config.initial_stiffness] * 3 if initial is None else [float(value) for value in initial]
        self._lengths = [value / config.stiffness_per_pixel for value in initial]
        self._angles = [0.0, 0.0, 0.0]
        self._mode = 0
        self.version = 0
        self._taken = [True] * 6  # per length (x, y, z) then angle (roll, pitch, yaw): follows the handle
        self._side = [0.0] * 6  # on which side of the held value the handle was (sign), while not taken
        self._handle = [float("nan")] * 6  # the value the handle maps to, for the display

    def hold(self, handle: Optional[DeviceSample] = None) -> None:
        """Keep every value until the handle meets it (entering LOW-LEVEL).

        ``handle``: where the device is as the tab opens. A value it is already at is taken at once, and one it has
        passed by its next sample counts as met, even when no sample came while it moved (a busy GUI thread).
        """
        with self._lock:
            self._release(range(3))
        if handle is not None:
            self.device(handle)

    def _release(self, axes) -> None:
        for axis in axes:
            for index in (axis, axis + 3):
                self._taken[index] = False
                self._side[index] = 0.0

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
            before = set(self._live_axes())
            self._mode = (self._mode + 1) % len(MODES)
            self._release(set(self._live_axes()) - before)
            self.version += 1
            return MODES[self._mode]

    def _live_axes(self) -> range:
        return range(3) if self._mode == 0 else range(self._mode - 1, self._mode)

    def waiting(self) -> Tuple[Tuple[float, ...], Tuple[float, ...]]:
        """Where the handle points for each live value that waits for it: (stiffnesses [N/m], angles [rad]).

        NaN for a value that follows the handle, or is not live in this mode.
        """
        with self._lock:
            live = self._live_axes()
            pending = [
                self._handle[index] if (index % 3) in live and not self._taken[index] else float("nan")
                for index in range(6)
            ]
        gain = self.config.stiffness_per_pixel
        return tuple(value * gain for value in pending[:3]), tuple(pending[3:])

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
        tolerances = [config.takeover_tolerance / config.stiffness_per_pixel] * 3 + [config.takeover_angle] * 3
        targets = lengths + angles
        with self._lock:
            values = self._lengths + self._angles
            before = tuple(values)
            self._handle = targets
            for axis in self._live_axes():
                for index in (axis, axis + 3):
                    if not self._taken[index]:
                        side = float(np.sign(targets[index] - values[index]))
                        met = abs(targets[index] - values[index]) <= tolerances[index]
                        if not (met or side * self._side[index] < 0.0):
                            self._side[index] = side
                            continue
                        self._taken[index] = True
                    values[index] = targets[index]
            self._lengths, self._angles = values[:3], values[3:]
            changed = before != tuple(values)
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
