"""A virtual Sigma.7 for people without the device: a small PyQt5 window (the ``virtual`` backend).

Keys: arrows (or a mouse drag) move x/y, Page Up/Down move z, Q/A W/S E/D turn roll/pitch/yaw, Space clicks (a
scripted quick close-and-back of the gripper, detected like a real one), Enter double-clicks (two such flicks
``double_click_gap`` apart: a keyboard's two presses are too slow or too irregular for the GUI's double-click window),
O held down opens the gripper fully, C held down keeps it closed (TELEOP's clutch), 1 draws a wave and 2 a cycloid
(SHARED CONTROL's patterns: keys move in steps, which the shared controller cannot recognise as a pattern) until
pressed again or the handle is moved.

A key's gesture arrives whole on a busy machine too: a flick that a stalled device loop did not read is given to the
loop's click detector afterwards (:meth:`VirtualDevice.missed_gripper`, as the scenario backend does), so a double
click stays two clicks; and the X server's key repeat (a release and a press again, which Qt cannot always tell from
the operator's own when events queue up) does not open a held gripper for an instant, which made clicks of a hold.
:class:`VirtualDevice` holds the state and is read by the device loop's thread; :class:`VirtualDeviceWindow` only
edits it from the Qt thread, under the device's lock.
"""

import functools
import threading
import time as wall_time
from typing import Callable, List, Optional, Tuple

import numpy as np
from PyQt5 import QtCore, QtWidgets

from teleteach.core.rotations import rpy_to_quaternion
from teleteach.haptics.click import flick_gripper_angle
from teleteach.haptics.device import DeviceBackend, DeviceSample

RESTING_GRIPPER = 0.25  # [rad] finger relaxed
OPEN_GRIPPER = 0.5  # [rad] fully open (the GUI's "back to START" gesture needs >= 0.45)
CLOSED_GRIPPER = 0.0  # [rad] held closed (TELEOP's clutch engages after 0.6 s of it)
POSITION_LIMIT = 0.1  # [m] per axis, about the Sigma.7 workspace
ANGLE_LIMIT = 1.0  # [rad] per angle
# The strokes keys 1 and 2 draw, on the device (full.launch's SHARED CONTROL moves the task twice as far: twist_scale):
# a 2 cm wave and 2.5 cm cycloid loops, 20 per metre, at 5 cm/s on the task plane (the controller recognised a 3 cm
# wave this steep in 64 % of its cycles, the 2 cm one in all: test/unit/test_virtual_device_patterns.py)
STROKES = {"wave": (0.01, 40.0), "cycloid": (0.0125, 40.0)}  # amplitude or radius [m], spatial frequency [1/m]
STROKE_SPEED = 0.025  # [m/s] along device x
STROKE_REACH = 0.07  # [m] the stroke turns back at x = +-this (inside the workspace with the pattern's sway)


class VirtualDevice(DeviceBackend):
    """Device state edited by a user interface and read by the device loop (thread-safe).

    A stall of the reading loop must not swallow a click: the flicks between two reads are sampled
    (``flick_samples`` each) and given by :meth:`missed_gripper`.

    Args:
        click_duration: [s] duration of the scripted gripper flick of a click.
        double_click_gap: [s] between the two flicks of a double click.
        clock: [s] wall clock that times the flick.
    """

    def __init__(
        self,
        click_duration: float,
        double_click_gap: float,
        clock: Callable[[], float] = wall_time.monotonic,
    ) -> None:
        self._lock = threading.Lock()
        self._clock = clock
        self._click_duration = click_duration
        self._double_click_gap = double_click_gap
        self._position = np.zeros(3)
        self._rpy = np.zeros(3)
        self._quaternion = np.array([0.0, 0.0, 0.0, 1.0])  # of _rpy, made when it changes, not in each 1 kHz read
        self._held_open = False
        self._held_closed = False
        self._flicks = [-float("inf")]  # start times of the scripted flicks, in order
        self._closed = False
        self._last_read = -float("inf")  # [s] the device clock's time of the last read
        self._missed: List[Tuple[float, float]] = []
        self._stroke: Optional[Tuple[str, float, np.ndarray]] = None  # pattern, start time, handle position then

    flick_samples = 20  # per scripted flick, for the catch-up after a stall
    moves_on_wall_clock = True  # keys, the mouse and the drawn strokes move it in real time

    def move(self, dx: float = 0.0, dy: float = 0.0, dz: float = 0.0) -> None:
        """Moves the end effector by [m], clamped to the workspace; a stroke being drawn stops where it is."""
        with self._lock:
            self._stop_stroke()
            self._position = np.clip(self._position + np.array([dx, dy, dz]), -POSITION_LIMIT, POSITION_LIMIT)

    def draw(self, pattern: str) -> None:
        """Starts drawing ``pattern`` (a key of STROKES) from where the handle is; the same pattern again stops it.

        The handle travels along x at STROKE_SPEED, back and forth within STROKE_REACH, swaying across (wave) or
        looping (cycloid) as the shared controller's skill models describe: a hand's smooth pattern, which single key
        steps cannot make.
        """
        with self._lock:
            drawing = self._stroke[0] if self._stroke else None
            self._stop_stroke()
            if pattern != drawing:
                self._stroke = (pattern, self._clock(), self._position.copy())

    @property
    def drawing(self) -> Optional[str]:
        """The pattern being drawn, None when none is."""
        with self._lock:
            return self._stroke[0] if self._stroke else None

    def _stop_stroke(self) -> None:
        """The handle stays where the stroke took it (lock held)."""
        self._position = self._position_at(self._clock())
        self._stroke = None

    def _position_at(self, moment: float) -> np.ndarray:
        """The handle's position [m] at ``moment``: where it was put, or along the stroke being drawn (lock held)."""
        if self._stroke is None:
            return self._position.copy()
        pattern, started, origin = self._stroke
        size, frequency = STROKES[pattern]
        travelled = STROKE_SPEED * max(moment - started, 0.0)
        lap = (np.clip(origin[0], -STROKE_REACH, STROKE_REACH) + STROKE_REACH + travelled) % (4.0 * STROKE_REACH)
        along = -STROKE_REACH + (lap if lap <= 2.0 * STROKE_REACH else 4.0 * STROKE_REACH - lap)
        angle = 2.0 * np.pi * frequency * travelled
        if pattern == "wave":  # sigma = rho_0 sin(2 pi rho_1 s), across the path (omega = pi / 2)
            sway = np.array([0.0, size * np.sin(angle)])
        else:  # cycloid: sigma = rho_0 turning by omega = 2 pi rho_1 s, from the start point
            sway = size * np.array([np.cos(angle) - 1.0, np.sin(angle)])
        position = np.array([along + sway[0], origin[1] + sway[1], origin[2]])
        return np.clip(position, -POSITION_LIMIT, POSITION_LIMIT)

    def rotate(self, droll: float = 0.0, dpitch: float = 0.0, dyaw: float = 0.0) -> None:
        """Turns roll/pitch/yaw by [rad], each clamped to +-ANGLE_LIMIT."""
        with self._lock:
            self._rpy = np.clip(self._rpy + np.array([droll, dpitch, dyaw]), -ANGLE_LIMIT, ANGLE_LIMIT)
            self._quaternion = rpy_to_quaternion(*self._rpy)

    def click(self) -> None:
        """Starts a quick close-and-back of the gripper (ignored while one is under way)."""
        self._flick(1)

    def double_click(self) -> None:
        """Two flicks ``double_click_gap`` apart: the GUI's double click (ignored while a flick is under way)."""
        self._flick(2)

    def _flick(self, count: int) -> None:
        with self._lock:
            now = self._clock()
            if now - self._flicks[-1] > self._click_duration:
                period = self._click_duration + self._double_click_gap
                self._flicks = [now + index * period for index in range(count)]

    def hold_open(self, held: bool) -> None:
        """Opens the gripper fully while ``held``; back to resting otherwise."""
        with self._lock:
            self._held_open = held

    def hold_closed(self, held: bool) -> None:
        """Keeps the gripper closed while ``held`` (TELEOP's clutch); back to resting otherwise."""
        with self._lock:
            self._held_closed = held

    def close_window(self) -> None:
        """The user closed the window: the device is gone, the loop should end."""
        with self._lock:
            self._closed = True

    def state(self) -> Tuple[np.ndarray, np.ndarray, float]:
        """Position [m], roll/pitch/yaw [rad] and gripper angle [rad] now."""
        with self._lock:
            now = self._clock()
            return self._position_at(now), self._rpy.copy(), self._gripper_at(now)

    def _gripper_at(self, moment: float) -> float:
        """The gripper angle [rad] at ``moment`` of the device clock (the held state, dipped by a flick)."""
        base = OPEN_GRIPPER if self._held_open else CLOSED_GRIPPER if self._held_closed else RESTING_GRIPPER
        started = max((start for start in self._flicks if start <= moment), default=-float("inf"))
        return flick_gripper_angle(base, moment - started, self._click_duration)

    def read(self, time: float) -> DeviceSample:
        """The current state as a device sample (the flick is timed by the device's own wall clock)."""
        with self._lock:
            now = self._clock()
            self._missed = self._flicks_between(self._last_read, now, time)
            self._last_read = now
            sample = DeviceSample(self._position_at(now), self._quaternion.copy(), self._gripper_at(now))
        return sample

    def missed_gripper(self) -> List[Tuple[float, float]]:
        """The flicks' gripper angles between the last two reads, at the loop's times (none without a stall)."""
        with self._lock:
            return self._missed

    def _flicks_between(self, previous: float, now: float, time: float) -> List[Tuple[float, float]]:
        step = self._click_duration / self.flick_samples
        if now - previous <= step:
            return []
        missed = []
        for start in self._flicks:
            if start + self._click_duration > previous and start < now:
                for moment in np.linspace(start, start + self._click_duration, self.flick_samples + 1):
                    if previous < moment < now:
                        missed.append((time - (now - moment), self._gripper_at(moment)))
        return missed

    @property
    def finished(self) -> bool:
        """True once the window has been closed."""
        with self._lock:
            return self._closed


class VirtualDeviceWindow(QtWidgets.QWidget):
    """The window that drives a :class:`VirtualDevice` and shows its current values."""

    POSITION_STEP = 0.005  # [m] per key press
    ANGLE_STEP = 0.05  # [rad] per key press
    DRAG_SCALE = 0.0005  # [m/px] of mouse drag
    RELEASE_DELAY = 80  # [ms] a released O or C lets go after this, unless pressed again: the key repeat's release
    _ROTATION_KEYS = {
        QtCore.Qt.Key_Q: (1, 0, 0),
        QtCore.Qt.Key_A: (-1, 0, 0),
        QtCore.Qt.Key_W: (0, 1, 0),
        QtCore.Qt.Key_S: (0, -1, 0),
        QtCore.Qt.Key_E: (0, 0, 1),
        QtCore.Qt.Key_D: (0, 0, -1),
    }
    _MOVE_KEYS = {
        QtCore.Qt.Key_Right: (1, 0, 0),
        QtCore.Qt.Key_Left: (-1, 0, 0),
        QtCore.Qt.Key_Up: (0, 1, 0),
        QtCore.Qt.Key_Down: (0, -1, 0),
        QtCore.Qt.Key_PageUp: (0, 0, 1),
        QtCore.Qt.Key_PageDown: (0, 0, -1),
    }

    _PATTERN_KEYS = {QtCore.Qt.Key_1: "wave", QtCore.Qt.Key_2: "cycloid"}

    def __init__(self, device: VirtualDevice, refresh_hz: float = 30.0) -> None:
        super().__init__()
        self.device = device
        self.setWindowTitle("teleteach: virtual Sigma.7")
        self.setFocusPolicy(QtCore.Qt.StrongFocus)
        self._drag_origin = None
        self._releases = {}  # O and C: the timer that lets the held gripper go
        for key, hold in ((QtCore.Qt.Key_O, device.hold_open), (QtCore.Qt.Key_C, device.hold_closed)):
            timer = QtCore.QTimer(self)
            timer.setSingleShot(True)
            timer.setInterval(self.RELEASE_DELAY)
            timer.timeout.connect(functools.partial(self._let_go, hold))
            self._releases[key] = timer
        self.values = QtWidgets.QLabel()
        self.values.setTextFormat(QtCore.Qt.PlainText)
        self.values.setStyleSheet("font-family: monospace; font-size: 14px")
        help_text = QtWidgets.QLabel(
            "The device's keys go to this window: click it to type here.\n"
            "arrows / mouse drag: x, y    PgUp / PgDn: z\n"
            "Q/A roll   W/S pitch   E/D yaw\n"
            "Space: click    Enter: double click    O (hold): gripper fully open    C (hold): gripper closed\n"
            "SHARED CONTROL: 1 draws a wave, 2 a cycloid (again: stop)"
        )
        layout = QtWidgets.QVBoxLayout(self)
        layout.addWidget(self.values)
        layout.addWidget(help_text)
        self.setMinimumSize(360, 240)
        self._place_in_corner()
        self._timer = QtCore.QTimer(self)
        self._timer.timeout.connect(self.refresh)
        self._timer.start(int(1000 / refresh_hz))
        self.refresh()

    def _place_in_corner(self) -> None:
        """Bottom right of the screen, not under the GUI at (0, 0) where every window opens without a window manager.

        The keys go to this window: it must be found.
        """
        screen = QtWidgets.QApplication.primaryScreen().availableGeometry()
        size = self.sizeHint().expandedTo(self.minimumSize())
        self.move(screen.right() - size.width(), screen.bottom() - size.height())

    def refresh(self) -> None:
        """Shows the device's current values."""
        position, rpy, gripper = self.device.state()
        self.values.setText(
            f"x {position[0]:+.3f} m   roll  {rpy[0]:+.2f} rad\n"
            f"y {position[1]:+.3f} m   pitch {rpy[1]:+.2f} rad\n"
            f"z {position[2]:+.3f} m   yaw   {rpy[2]:+.2f} rad\n"
            f"gripper {gripper:.2f} rad" + (f"   drawing a {self.device.drawing}" if self.device.drawing else "")
        )

    def keyPressEvent(self, event):  # noqa: N802 (Qt API)
        """Moves, turns, clicks or opens the gripper."""
        key = event.key()
        if key in self._MOVE_KEYS:
            self.device.move(*(self.POSITION_STEP * step for step in self._MOVE_KEYS[key]))
        elif key in self._ROTATION_KEYS:
            self.device.rotate(*(self.ANGLE_STEP * step for step in self._ROTATION_KEYS[key]))
        elif key in self._PATTERN_KEYS and not event.isAutoRepeat():
            self.device.draw(self._PATTERN_KEYS[key])
        elif key == QtCore.Qt.Key_Space and not event.isAutoRepeat():
            self.device.click()
        elif key in (QtCore.Qt.Key_Return, QtCore.Qt.Key_Enter) and not event.isAutoRepeat():
            self.device.double_click()
        elif key == QtCore.Qt.Key_O and not event.isAutoRepeat():
            self._releases[key].stop()
            self.device.hold_open(True)
        elif key == QtCore.Qt.Key_C and not event.isAutoRepeat():
            self._releases[key].stop()
            self.device.hold_closed(True)
        else:
            super().keyPressEvent(event)
            return
        self.refresh()

    def _let_go(self, hold: Callable[[bool], None]) -> None:
        """A released O or C was not pressed again: its hold ends, the gripper goes back to rest."""
        hold(False)
        self.refresh()

    def keyReleaseEvent(self, event):  # noqa: N802 (Qt API)
        """Releasing O or C lets the gripper back to rest ``RELEASE_DELAY`` later, unless the key is pressed again."""
        if event.key() in self._releases and not event.isAutoRepeat():
            self._releases[event.key()].start()
        else:
            super().keyReleaseEvent(event)

    def mousePressEvent(self, event):  # noqa: N802 (Qt API)
        """Starts a drag."""
        if event.button() == QtCore.Qt.LeftButton:
            self._drag_origin = event.pos()

    def mouseMoveEvent(self, event):  # noqa: N802 (Qt API)
        """Dragging right moves +x, dragging up moves +y."""
        if self._drag_origin is None or not event.buttons() & QtCore.Qt.LeftButton:
            return
        delta = event.pos() - self._drag_origin
        self._drag_origin = event.pos()
        self.device.move(dx=delta.x() * self.DRAG_SCALE, dy=-delta.y() * self.DRAG_SCALE)
        self.refresh()

    def mouseReleaseEvent(self, event):  # noqa: N802 (Qt API)
        """Ends a drag."""
        if event.button() == QtCore.Qt.LeftButton:
            self._drag_origin = None

    def closeEvent(self, event):  # noqa: N802 (Qt API)
        """Closing the window ends the device."""
        self.device.close_window()
        super().closeEvent(event)
