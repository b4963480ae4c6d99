"""LOW-LEVEL teaching with the real GUI (thesis II-C, III-C/D): the ellipsoid commanded by the device, over ROS."""

import math
import re

import numpy as np
import pytest
from conftest import pump, pump_until
from geometry_msgs.msg import QuaternionStamped, Vector3Stamped
from scipy.spatial.transform import Rotation
from std_msgs.msg import Bool

from teleteach.core.active_tab import Tab

pytestmark = pytest.mark.gui


def expected_stiffness(position, low=50.0, high=3000.0, half_range=0.1):
    """Independent of the GUI code: device [-0.1, 0.1] m maps linearly onto [50, 3000] N/m."""
    return np.array([low + (value + half_range) / (2 * half_range) * (high - low) for value in position])


def open_low_level(qapp, window, device):
    device.move(x=0.05)
    pump_until(qapp, lambda: window.start_tab.selected == 1, 5, "START to select LOW-LEVEL")
    device.click()
    pump_until(qapp, lambda: window.tabs.currentIndex() == 2, 5, "the LOW-LEVEL tab to open")


def gui_hears(topic):
    """Whether the GUI (this process's node, /gui_test) subscribes ``topic``, as the master sees it."""
    import rosgraph

    _, subscribers, _ = rosgraph.Master("/gui_test").getSystemState()
    return any(name == topic and "/gui_test" in nodes for name, nodes in subscribers)


def test_low_level_publishes_the_commanded_ellipsoid(qapp, device, make_window, topic_log, artifacts_dir):
    values_log = topic_log("/eigenvalues", Vector3Stamped)
    vectors_log = topic_log("/eigenvectors", QuaternionStamped)
    pause_log = topic_log("/behaviour_tree/pause", Bool)
    window = make_window()
    # nothing is commanded outside LOW-LEVEL: checked once this log is connected to the GUI's publishers, so a
    # message sent would have arrived
    pump_until(qapp, lambda: values_log.connected() and vectors_log.connected(), 10, "the logs connected to the GUI")
    pump(qapp, 0.5)
    assert values_log.last() is None and vectors_log.last() is None
    open_low_level(qapp, window, device)
    pump_until(qapp, lambda: pause_log.last() is not None and pause_log.last().data, 5, "the BT paused")
    # Expect the ellipsoid of before (the initial one) commanded, not the handle's X, until the handle meets it
    initial = [window.config.initial_stiffness] * 3
    pump_until(qapp, lambda: values_log.last() is not None, 5, "/eigenvalues")
    device.move(x=0.08)
    pump(qapp, 0.5)
    vector = values_log.last().vector
    assert np.allclose([vector.x, vector.y, vector.z], initial, rtol=0.01)
    assert "waits for the handle (now 2705 N/m)" in window.low_level.axis_labels[0].text()
    device.move(x=0.0)  # the centred handle meets the initial ellipsoid: from now on the device commands it
    pump(qapp, 0.3)

    position, angles = (0.06, -0.03, 0.02), (0.3, -0.2, 0.6)  # roll, pitch, yaw [rad]
    device.move(*position, *angles)
    stiffness = expected_stiffness(position)
    rotation = Rotation.from_euler("ZYX", angles[::-1]).as_matrix()  # R = Rz(yaw) Ry(pitch) Rx(roll)

    def commanded():
        message = values_log.last()
        v = message.vector if message else None
        return v is not None and np.allclose([v.x, v.y, v.z], stiffness, rtol=0.01)

    pump_until(qapp, commanded, 5, f"/eigenvalues = {stiffness}")
    held = len(values_log.messages)
    pump(qapp, 2.0)
    window.screenshot().save(str(artifacts_dir / "gui_low_level_all.png"))
    # Expect the command repeated while the device is still (the controller holds what it last got; the rate is
    # measured by bench/gui_latency.py)
    values = values_log.messages[held:]
    stamps = [message.header.stamp.to_sec() for _, message in values]
    assert len(stamps) >= 2 and all(later > earlier for earlier, later in zip(stamps, stamps[1:]))
    vector = values[-1][1].vector
    assert np.allclose([vector.x, vector.y, vector.z], stiffness, rtol=0.01)
    assert values[-1][1].header.frame_id == "base_link"
    q = vectors_log.last()
    assert q.header.frame_id == "base_link"
    measured = Rotation.from_quat([q.quaternion.x, q.quaternion.y, q.quaternion.z, q.quaternion.w]).as_matrix()
    assert np.abs(measured - rotation).max() < 0.01

    # NaN and out-of-range device data change nothing
    device.raw((math.nan, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
    pump(qapp, 0.3)
    device.raw((0.9, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
    pump(qapp, 0.3)
    vector = values_log.last().vector
    assert np.allclose([vector.x, vector.y, vector.z], stiffness, rtol=0.01)

    # One click: mode X; now only the X length and roll follow the device
    device.move(*position, *angles)
    device.click()
    pump_until(qapp, lambda: window.command.mode == "X", 5, "mode X after one click")
    device.move(-0.08, 0.08, 0.08, -0.4, 0.5, -0.5)
    expected = [expected_stiffness([-0.08])[0], stiffness[1], stiffness[2]]

    def only_x_changed():
        v = values_log.last().vector
        return np.allclose([v.x, v.y, v.z], expected, rtol=0.01)

    pump_until(qapp, only_x_changed, 5, f"/eigenvalues = {expected}")
    q = vectors_log.last().quaternion
    roll, pitch, yaw = Rotation.from_quat([q.x, q.y, q.z, q.w]).as_euler("ZYX")[::-1]
    assert (roll, pitch, yaw) == pytest.approx((-0.4, angles[1], angles[2]), abs=0.01)
    pump(qapp, 0.3)
    window.screenshot().save(str(artifacts_dir / "gui_low_level_mode_x.png"))

    # Back to START with the gripper: stiffness publication stops, the BT runs again
    device.set_gripper(0.5)
    pump_until(qapp, lambda: window.tabs.currentIndex() == 0, 5, "START")
    pump_until(qapp, lambda: not pause_log.last().data, 5, "the BT unpaused")
    count = len(values_log.messages)
    pump(qapp, 0.5)
    assert len(values_log.messages) - count < 5


def test_a_pose_arriving_as_low_level_opens_does_not_take_the_held_ellipsoid(qapp, device, make_window, topic_log):
    # The race a loaded machine hit (a recorded session's X at the handle's 2262 N/m, its replay's at 1525): a device
    # pose handled by the rospy thread while the GUI thread opens LOW-LEVEL, just before the ellipsoid is held
    from geometry_msgs.msg import PoseStamped

    values_log = topic_log("/eigenvalues", Vector3Stamped)
    window = make_window()
    command = window.low_level.command
    hold = command.hold

    def pose_arrives_then_hold(handle=None):
        message = PoseStamped()
        message.pose.position.x, message.pose.orientation.w = 0.05, 1.0
        window.worker._on_pose(message)
        hold(handle)

    command.hold = pose_arrives_then_hold
    open_low_level(qapp, window, device)
    pump_until(qapp, lambda: values_log.last() is not None, 5, "/eigenvalues")
    pump(qapp, 0.5)
    vector = values_log.last().vector
    # Expect the initial ellipsoid kept, X waiting for the handle (at 0.05 m: 2262.5 N/m) to meet it
    assert np.allclose([vector.x, vector.y, vector.z], [window.config.initial_stiffness] * 3, rtol=0.01)
    assert "waits for the handle (now 2263 N/m)" in window.low_level.axis_labels[0].text()


def test_gui_without_the_other_nodes_reports_why(qapp, make_window, device, topic_log, artifacts_dir):
    """No BT node, no controller manager: the status bar says so and the GUI keeps working."""
    recording_log = topic_log("/teleteach/recording", Bool)
    window = make_window(service_timeout=1.0)
    pump_until(qapp, lambda: recording_log.last() is not None and not recording_log.last().data, 5, "not recording")
    pump_until(qapp, lambda: "behaviour_tree" in window.health_label.text(), 5, "the missing BT in the status bar")
    open_low_level(qapp, window, device)
    pump_until(
        qapp,
        lambda: "switch_controller" in window.statusBar().currentMessage(),
        10,
        "the failed controller switch in the status bar",
    )
    window.screenshot().save(str(artifacts_dir / "gui_low_level_no_robot.png"))
    # without perception there is no gap to teach the placement at, and without /cartesian_pose no hand to start
    # from: a double click starts no recording, the GUI says why and stays responsive
    device.click()
    device.click()
    pump_until(
        qapp,
        lambda: "recording not started" in window.statusBar().currentMessage(),
        5,
        "why no recording started",
    )
    assert "no perception yet (teleteach/scene)" in window.statusBar().currentMessage()
    pump(qapp, 0.5)
    assert not window.recorder.active
    assert not recording_log.last().data
    assert window.tabs.currentIndex() == 2  # LOW-LEVEL still open


def test_device_node_killed_while_low_level_is_open(qapp, make_window, topic_log, data_root):
    """SIGKILL of the real sigma7_node in LOW-LEVEL: the GUI says the device is lost, the stiffness stays, and all is
    well again when a new sigma7_node comes up."""
    import os
    import signal
    import time

    from conftest import ROOT, start, stop

    position = (0.06, -0.03, 0.02)
    scenario = data_root / "hold.yaml"
    keyframe = f"position: {list(position)}, rpy: [0.0, 0.0, 0.0], gripper: 0.25"
    centred = "position: [0.0, 0.0, 0.0], rpy: [0.0, 0.0, 0.0], gripper: 0.25"
    # from the centre, where the hand takes the ellipsoid over (it is held at entry), to the position, held there
    # centred for 1.5 s (the GUI connects meanwhile), then a jump (a sweep would stop within the GUI's deadband)
    timeline = ((0.0, centred), (1.5, centred), (1.501, keyframe), (3.0, keyframe))
    keyframes = (f"  - {{t: {t}, {pose}}}\n" for t, pose in timeline)
    scenario.write_text("keyframes:\n" + "".join(keyframes))
    # the second device goes back and forth every 1.5 s for 30 s: once the GUI hears it, it jumps to the position
    # again, however late the GUI connected (on a fresh machine the single jump was missed twice in four runs)
    again = data_root / "again.yaml"
    timeline = [
        point
        for step in range(10)
        for point in (
            (3.0 * step, centred),
            (3.0 * step + 1.5, centred),
            (3.0 * step + 1.501, keyframe),
            (3.0 * step + 2.999, keyframe),
        )
    ]
    again.write_text("keyframes:\n" + "".join(f"  - {{t: {t:.3f}, {pose}}}\n" for t, pose in timeline))
    # a name of its own: private parameters another test's device.launch left on the master (the guided hand's
    # hand/enabled and tremor) would make this held device tremble
    node = "__name:=sigma7_killed_in_low_level"
    command = [str(ROOT / "nodes" / "sigma7_node"), node, "_backend:=scenario", "_rate:=200"]

    def start_device(name, played):
        process = start([*command, f"_scenario:={played}"], data_root.parent / f"{name}.log")
        try:
            pump_until(qapp, lambda: not window.low_level.device_lost_label.isVisible(), 30, f"the {name} device")
        except AssertionError:
            stop(process)  # a device that outlived this test would move the next tests' device
            raise
        return process

    values_log = topic_log("/eigenvalues", Vector3Stamped)
    window = make_window(initial_tab=Tab.LOW_LEVEL, service_timeout=1.0)
    pump_until(qapp, lambda: window.low_level.device_lost_label.isVisible(), 5, "no device yet")
    stiffness = expected_stiffness(position)

    def holds(message):
        v = message.vector
        return np.allclose([v.x, v.y, v.z], stiffness, rtol=0.01)

    device = start_device("first", scenario)
    try:
        pump_until(qapp, lambda: values_log.last() is not None and holds(values_log.last()), 10, f"{stiffness} N/m")
    finally:
        os.killpg(device.pid, signal.SIGKILL)
        device.wait(5)
    killed = time.monotonic()
    # Expect the LOW-LEVEL tab to say so within about a second (the deadline is generous for a loaded machine)
    pump_until(qapp, lambda: window.low_level.device_lost_label.isVisible(), 5, "DEVICE LOST on screen")
    print(f"device lost shown {time.monotonic() - killed:.2f} s after SIGKILL")
    assert "device lost" in window.health_label.text()
    pump(qapp, 1.0)
    # Expect the last valid stiffness still commanded, nothing else
    after = values_log.since(killed)
    assert after and all(holds(message) for message in after)
    device = start_device("second", again)
    try:
        pump_until(qapp, lambda: holds(values_log.last()), 20, f"{stiffness} N/m again")
        assert not window.low_level.device_lost_label.isVisible() and "device" not in window.health_label.text()
    finally:
        stop(device)


def test_an_arm_that_does_not_come_to_rest_is_not_switched_and_the_tab_says_why(qapp, make_window, device):
    """The robot's /joint_states keep moving (a skill outside the tree drives it): after arm_free_timeout the tab says
    why the impedance controller was not started, and nothing was switched."""
    import threading

    import rospy
    from sensor_msgs.msg import JointState

    from teleteach.srv import SwitchController

    switched = []
    service = rospy.Service("/controller_manager/switch_controller", SwitchController, lambda r: switched.append(r))
    joints = rospy.Publisher("/joint_states", JointState, queue_size=10)
    stop = threading.Event()

    def moving_arm():
        while not stop.wait(0.02):
            joints.publish(JointState(name=["panda_joint1"], position=[0.0], velocity=[0.4]))

    thread = threading.Thread(target=moving_arm, daemon=True)
    thread.start()
    try:
        window = make_window(arm_free_timeout=2.0)
        # the arm's joint states (100 Hz in the simulation) cost the GUI nothing outside the tabs that hand it over
        pump(qapp, 0.5)
        assert not gui_hears("/joint_states")
        open_low_level(qapp, window, device)
        label = window.low_level.controller_label
        pump_until(qapp, lambda: "still moves" in label.text(), 5, "the tab saying what it waits for")
        pump_until(qapp, lambda: "was not free within 2 s" in label.text(), 10, "the tab saying it gave up")
        assert (
            "the arm still moves (0.40 rad/s)" in label.text()
            and "impedance controller was not started" in label.text()
        )
        pump(qapp, 0.5)
        # (an earlier test's window, closing, may still be asking for the position controller: only ours count)
        assert [
            request for request in switched if request.start_controllers != ["position_joint_trajectory_controller"]
        ] == []
        # LOW-LEVEL hears TF and the perceived scene (a recording may need its gap); the closed window hears nothing
        heard = ("/tf", "/tf_static", "/teleteach/scene", "/sigma7/pose", "/joint_states")
        assert all(gui_hears(topic) for topic in heard)
        window.close()
        pump_until(
            qapp, lambda: not any(gui_hears(topic) for topic in heard), 5, f"the closed GUI to hear none of {heard}"
        )
    finally:
        stop.set()
        thread.join(2)
        service.shutdown()
        joints.unregister()


def test_two_clicks_too_far_apart_for_a_double_click_are_named(qapp, device, make_window):
    """A double click that came out as two singles (a slow hand, or keys on a busy machine): LOW-LEVEL cycles the
    mode twice, as it should, and the status bar says why no recording started."""
    window = make_window()
    hints = []
    window.low_level.click_hint.connect(hints.append)
    open_low_level(qapp, window, device)
    pump(qapp, 1.0)  # the click that opened the tab is no part of the pair
    device.click()
    pump(qapp, 0.8)
    device.click()
    pump_until(qapp, lambda: hints, 5, "the hint")
    # Expect the gap (0.8 s pumped, more on a loaded machine: 1.02 s on a fresh one) and the window named, in the
    # status bar
    said = re.fullmatch(r"two single clicks (\d+\.\d\d) s apart: a double click needs both within 0.6 s", hints[0])
    assert said and 0.6 < float(said.group(1)) < 3.0, hints[0]
    assert window.statusBar().currentMessage() == hints[0]
    assert window.session.recording is None
