"""The virtual device window, driven with QTest in the X server that pytest-xvfb starts (no ROS)."""

import numpy as np
import pytest
from PyQt5 import QtCore, QtGui, QtWidgets
from PyQt5.QtTest import QTest
from scipy.spatial.transform import Rotation

from teleteach.haptics.click import ClickDetector, ClickParameters
from teleteach.haptics.loop import DeviceLoop
from teleteach.haptics.twist import TwistEstimator
from teleteach.haptics.virtual import CLOSED_GRIPPER, OPEN_GRIPPER, RESTING_GRIPPER, VirtualDevice, VirtualDeviceWindow

pytestmark = pytest.mark.gui


class Clock:
    def __init__(self):
        self.now = 100.0

    def __call__(self):
        return self.now


@pytest.fixture(scope="module")
def application():
    """One QApplication for the module: one made and dropped per test reconnected to the X server each time, and
    1 in 8 of those connections failed (qt.qpa.xcb: could not connect to display), aborting the process."""
    return QtWidgets.QApplication.instance() or QtWidgets.QApplication([])


@pytest.fixture
def window(application):
    clock = Clock()
    widget = VirtualDeviceWindow(VirtualDevice(click_duration=0.2, double_click_gap=0.1, clock=clock))
    widget.clock = clock
    widget.show()
    QTest.qWaitForWindowExposed(widget)
    yield widget
    widget.close()
    application.processEvents()


def test_the_window_says_the_keys_go_to_it_and_opens_in_the_screen_s_corner(window):
    """Without a window manager every window opens at (0, 0): this one would be under the GUI's."""
    assert "The device's keys go to this window" in window.findChildren(QtWidgets.QLabel)[1].text()
    screen = QtWidgets.QApplication.primaryScreen().availableGeometry()
    assert window.x() > 0 and window.y() > 0
    assert window.x() + window.width() <= screen.right() + 1 and window.y() + window.height() <= screen.bottom() + 1


def test_arrow_and_page_keys_move_the_device(window):
    for key in (QtCore.Qt.Key_Right, QtCore.Qt.Key_Right, QtCore.Qt.Key_Up, QtCore.Qt.Key_PageDown):
        QTest.keyClick(window, key)
    position, _, _ = window.device.state()
    np.testing.assert_allclose(position, [0.01, 0.005, -0.005])
    assert "x +0.010 m" in window.values.text()
    assert "z -0.005 m" in window.values.text()


def test_keys_turn_roll_pitch_yaw(window):
    QTest.keyClick(window, QtCore.Qt.Key_Q)
    QTest.keyClick(window, QtCore.Qt.Key_S)
    for _ in range(4):
        QTest.keyClick(window, QtCore.Qt.Key_E)
    _, rpy, _ = window.device.state()
    np.testing.assert_allclose(rpy, [0.05, -0.05, 0.2])
    sample = window.device.read(0.0)
    np.testing.assert_allclose(Rotation.from_quat(sample.orientation).as_euler("ZYX")[::-1], rpy, atol=1e-12)
    assert "yaw   +0.20 rad" in window.values.text()


def test_position_and_angles_stay_within_the_device_limits(window):
    for _ in range(40):
        QTest.keyClick(window, QtCore.Qt.Key_Left)
        QTest.keyClick(window, QtCore.Qt.Key_D)
    position, rpy, _ = window.device.state()
    assert position[0] == pytest.approx(-0.1)
    assert rpy[2] == pytest.approx(-1.0)


def test_mouse_drag_moves_x_and_y(window):
    def mouse(kind, x, y, buttons):
        event = QtGui.QMouseEvent(kind, QtCore.QPointF(x, y), QtCore.Qt.LeftButton, buttons, QtCore.Qt.NoModifier)
        QtWidgets.QApplication.sendEvent(window, event)

    mouse(QtCore.QEvent.MouseButtonPress, 100, 100, QtCore.Qt.LeftButton)
    mouse(QtCore.QEvent.MouseMove, 140, 100, QtCore.Qt.LeftButton)
    mouse(QtCore.QEvent.MouseMove, 140, 80, QtCore.Qt.LeftButton)  # up the screen = +y
    mouse(QtCore.QEvent.MouseButtonRelease, 140, 80, QtCore.Qt.NoButton)
    mouse(QtCore.QEvent.MouseMove, 300, 300, QtCore.Qt.NoButton)  # no button held: no motion
    position, _, _ = window.device.state()
    np.testing.assert_allclose(position, [40 * 0.0005, 20 * 0.0005, 0.0])


def test_space_is_one_click_for_the_click_detector(window):
    detector = ClickDetector(ClickParameters.from_yaml())
    clock = window.clock

    def run_for(seconds):
        for _ in range(int(round(seconds / 0.001))):
            clock.now += 0.001
            detector.update(clock.now, window.device.read(clock.now).gripper)

    run_for(0.1)
    QTest.keyClick(window, QtCore.Qt.Key_Space)
    run_for(0.1)
    assert window.device.state()[2] < 0.01  # closed in the middle of the flick
    run_for(0.5)
    assert detector.clicks == 1
    assert window.device.state()[2] == pytest.approx(RESTING_GRIPPER)


def let_go(window):
    QTest.qWait(VirtualDeviceWindow.RELEASE_DELAY + 100)


def test_holding_o_opens_the_gripper_fully(window):
    QTest.keyPress(window, QtCore.Qt.Key_O)
    assert window.device.state()[2] == pytest.approx(OPEN_GRIPPER)
    assert "gripper 0.50 rad" in window.values.text()
    QTest.keyRelease(window, QtCore.Qt.Key_O)
    let_go(window)
    assert window.device.state()[2] == pytest.approx(RESTING_GRIPPER)


def test_holding_c_keeps_the_gripper_closed_for_teleop_s_clutch(window):
    QTest.keyPress(window, QtCore.Qt.Key_C)
    assert window.device.state()[2] == pytest.approx(CLOSED_GRIPPER)
    assert "gripper 0.00 rad" in window.values.text()
    QTest.keyRelease(window, QtCore.Qt.Key_C)
    let_go(window)
    assert window.device.state()[2] == pytest.approx(RESTING_GRIPPER)
    assert "gripper 0.25 rad" in window.values.text()


@pytest.mark.parametrize("key", [QtCore.Qt.Key_C, QtCore.Qt.Key_O], ids=["C", "O"])
def test_a_held_key_s_repeat_does_not_let_the_gripper_go_for_an_instant(window, key):
    """The X server repeats a held key as release + press; when Qt cannot tell (events queued on a busy machine),
    both arrive as the operator's own. A hold of C made clicks, and double clicks, of those instants."""
    detector = ClickDetector(ClickParameters.from_yaml())
    clock = window.clock
    QTest.keyPress(window, key)
    held = window.device.state()[2]
    angles = []
    for _ in range(20):  # 25 Hz repeat for 0.8 s
        QTest.keyRelease(window, key)
        for _ in range(40):
            clock.now += 0.001
            angles.append(window.device.read(clock.now).gripper)
            detector.update(clock.now, angles[-1])
        QTest.keyPress(window, key)
    # Expect the gripper held all along: no instant at rest, so no click
    assert set(angles) == {held}
    assert detector.clicks == 0
    QTest.keyRelease(window, key)
    let_go(window)
    assert window.device.state()[2] == pytest.approx(RESTING_GRIPPER)


def test_closing_the_window_finishes_the_device(window):
    assert not window.device.finished
    window.close()
    assert window.device.finished


def test_enter_is_a_double_click_for_the_gui(window):
    """Two Space presses depend on the operator's timing; Enter plays two flicks within the double-click window."""
    from teleteach.core.gui_config import GuiConfig
    from teleteach.gui.device import ClickClassifier, EdgeDetector

    detector, button = ClickDetector(ClickParameters.from_yaml()), EdgeDetector(0.5, 0.5)
    classifier = ClickClassifier(GuiConfig.load().double_click_window)
    clock, kinds = window.clock, []
    QTest.keyClick(window, QtCore.Qt.Key_Return)
    for _ in range(int(round(1.5 / 0.001))):
        clock.now += 0.001
        pressed = detector.update(clock.now, window.device.read(clock.now).gripper)
        if button.update(1.0 if pressed else 0.0):
            kinds.append(classifier.click(clock.now))
        kinds.append(classifier.poll(clock.now))
    assert detector.clicks == 2
    assert [kind for kind in kinds if kind] == [ClickClassifier.DOUBLE]


def loop_of(device, clock):
    """The node's device loop over the virtual device; returns it and the stamps of the published button presses."""
    presses, previous = [], [False]

    def publish(state):
        if state.button and not previous[0]:
            presses.append(state.stamp)
        previous[0] = state.button

    loop = DeviceLoop(
        device, publish, clock, ClickDetector(ClickParameters.from_yaml()), TwistEstimator(20.0), lambda line: None
    )
    return loop, presses


STALLS = [(0.0, 0.5), (0.0, 0.9), (0.05, 0.2), (0.12, 0.3), (0.15, 0.3), (0.25, 0.12), (0.3, 0.25), (0.45, 0.3)]


@pytest.mark.parametrize("stall_start, stall", STALLS)
def test_enter_arrives_as_one_double_click_when_the_device_loop_stalls(application, stall_start, stall):
    """A busy core stalls the 1 kHz loop (reads 0.1-0.9 s late): the flicks it did not read are caught up, so the GUI
    still gets two presses within its double-click window, whichever part of the gesture the stall covers. (A stall
    longer than the window's slack, 0.3 s, between the two flicks would part them, as it would a real device's.)"""
    from teleteach.core.gui_config import GuiConfig
    from teleteach.gui.device import ClickClassifier

    clock = Clock()
    device = VirtualDevice(click_duration=0.2, double_click_gap=0.1, clock=clock)
    loop, presses = loop_of(device, clock)
    for _ in range(100):
        clock.now += 0.001
        loop.step()
    device.double_click()
    clock.now += stall_start
    loop.step()
    clock.now += stall  # no read for this long
    for _ in range(1500):
        loop.step()
        clock.now += 0.001
    classifier = ClickClassifier(GuiConfig.load().double_click_window)
    kinds = [classifier.click(stamp) for stamp in presses]
    assert len(presses) == 2, presses
    assert kinds == [None, ClickClassifier.DOUBLE]


def test_keys_1_and_2_draw_shared_control_s_patterns_until_pressed_again_or_moved(window):
    device = window.device
    QTest.keyClick(window, QtCore.Qt.Key_1)
    assert device.drawing == "wave" and "drawing a wave" in window.values.text()
    QTest.keyClick(window, QtCore.Qt.Key_2)
    assert device.drawing == "cycloid"
    QTest.keyClick(window, QtCore.Qt.Key_2)
    assert device.drawing is None
    QTest.keyClick(window, QtCore.Qt.Key_1)
    QTest.keyClick(window, QtCore.Qt.Key_Right)
    # Expect: the arrow moves the handle by hand again
    assert device.drawing is None
    assert "1 draws a wave, 2 a cycloid" in " ".join(label.text() for label in window.findChildren(QtWidgets.QLabel))
