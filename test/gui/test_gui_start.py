"""START with the real GUI: a neutral zone in the centre, and the start gesture of a tree that started paused."""

import time

import pytest
from conftest import ROOT, pump, pump_until, start, start_bt, stop
from std_msgs.msg import Bool

from teleteach.core.active_tab import Tab
from teleteach.gui.start.view import StartTab
from teleteach.msg import TreeExecution

pytestmark = pytest.mark.gui


def test_a_centred_handle_selects_no_mode_and_its_click_opens_nothing(qapp, device, make_window):
    window = make_window()
    device.move(x=0.0)
    pump_until(qapp, lambda: window.start_tab.selected == StartTab.NEUTRAL, 5, "the neutral zone")
    device.click()
    pump(qapp, 1.0)
    # Expect START still open: a resting hand that clicks does not enter a teaching mode
    assert window.tabs.currentIndex() == Tab.START
    for x, selected in ((0.015, StartTab.NEUTRAL), (0.03, 1), (-0.03, 0), (-0.015, StartTab.NEUTRAL)):
        device.move(x=x)
        pump_until(qapp, lambda selected=selected: window.start_tab.selected == selected, 5, f"x {x} -> {selected}")
    # Expect a handle on its way down (or up) told how far TELEOP (SHARED CONTROL) still is
    centre = window.start_tab.centre
    device.move(y=-0.03)
    pump_until(qapp, lambda: "handle down 3.0 cm: TELEOP from 5.0 cm" in centre.text(), 5, "the TELEOP cue")
    assert window.start_tab.selected == StartTab.NEUTRAL
    device.move(y=0.04)
    pump_until(qapp, lambda: "handle up 4.0 cm: SHARED CONTROL from 5.0 cm" in centre.text(), 5, "the cue")
    device.move(y=0.01)
    pump_until(qapp, lambda: "cm:" not in centre.text(), 5, "no cue near the centre")


def test_a_tree_that_starts_paused_waits_for_the_start_gesture(
    qapp, ros_master, device, make_window, topic_log, data_root, artifacts_dir
):
    execution_log = topic_log("/behaviour_tree/execution", TreeExecution)
    pause_log = topic_log("/behaviour_tree/pause", Bool)
    tree = start_bt(data_root, start_paused=True)
    try:
        window = make_window()
        device.move(x=0.0)
        pump_until(qapp, lambda: window.start_tab.tree_waiting, 10, "START showing the waiting tree")
        # Expect the operator told, in START and in the status bar, and the tree really waiting
        assert window.start_tab.centre.text().startswith("The robot waits for you.")
        assert "waiting for the operator" in window.tree_label.text()
        assert execution_log.last().state == TreeExecution.WAITING
        pump(qapp, 0.5)
        window.screenshot().save(str(artifacts_dir / "gui_start_tree_waiting.png"))
        # a teaching session before the start does not start the tree when it ends
        device.move(x=0.05)
        pump_until(qapp, lambda: window.start_tab.selected == 1, 5, "LOW-LEVEL selected")
        entered = time.monotonic()  # (an earlier test's window may have left its own pause flag latched)
        device.click()
        pump_until(qapp, lambda: window.tabs.currentIndex() == Tab.LOW_LEVEL, 5, "LOW-LEVEL")
        device.set_gripper(0.5)
        pump_until(qapp, lambda: window.tabs.currentIndex() == Tab.START, 5, "back to START")
        device.set_gripper(0.25)
        pump(qapp, 1.0)
        assert execution_log.last().state == TreeExecution.WAITING
        assert [message.data for message in pause_log.since(entered)] == [True]
        # the start gesture: centred, click
        device.move(x=0.0)
        pump_until(qapp, lambda: window.start_tab.selected == StartTab.NEUTRAL, 5, "the neutral zone")
        device.click()
        pump_until(qapp, lambda: execution_log.last().state == TreeExecution.RUNNING, 10, "the tree running")
        pump_until(qapp, lambda: not window.start_tab.tree_waiting, 5, "START no longer waiting")
        assert window.tabs.currentIndex() == Tab.START
        # the start is an event (behaviour_tree/start), not a "not paused" left latched for the next tree
        assert [message.data for message in pause_log.since(entered)] == [True]
        pump_until(qapp, lambda: "the tree: started" in window.statusBar().currentMessage(), 5, "the status bar")
    finally:
        stop(tree)


EMPTY_TREE = """execution: BehaviorExecution
root:
  type: selector
  name: Root
  memory: false
  children:
    - {type: pause, name: PauseCondition}
    - {type: sequence, name: BehaviorExecution, memory: true, children: []}
"""


def test_a_tree_that_is_done_runs_again_with_the_start_gesture(
    qapp, ros_master, device, make_window, topic_log, data_root, artifacts_dir
):
    """A newcomer still learning the gestures when the tree ends goes on without a relaunch (an empty execution
    composite is done at its first tick: no robot needed)."""
    import rospy

    execution_log = topic_log("/behaviour_tree/execution", TreeExecution)
    tree_file = data_root.parent / "empty_tree.yaml"
    tree_file.write_text(EMPTY_TREE)
    node = str(ROOT / "nodes" / "behaviour_tree")
    # a node name of its own: private parameters stay on the master, and the next test's tree must not read these
    private = [f"_data_dir:={data_root}", f"_tree:={tree_file}", "_startup_timeout:=0", "_start_paused:=false"]
    command = [node, "__name:=behaviour_tree_done", *private]
    tree = start(command, data_root.parent / "behaviour_tree.log")
    try:
        rospy.wait_for_service("/behaviour_tree/start", timeout=60)
        window = make_window()
        device.move(x=0.0)
        pump_until(qapp, lambda: window.start_tab.tree_done, 10, "START showing the tree done")
        # Expect the operator told how to go on, and the gesture to run the tree again
        assert window.start_tab.centre.text().endswith("Handle in the centre, click: run it again.")
        assert execution_log.last().state == TreeExecution.COMPLETED
        window.screenshot().save(str(artifacts_dir / "gui_start_tree_done.png"))
        pump_until(qapp, lambda: window.start_tab.selected == StartTab.NEUTRAL, 5, "the neutral zone")
        device.click()
        pump_until(qapp, lambda: "the tree: runs again" in window.statusBar().currentMessage(), 10, "the status bar")
    finally:
        stop(tree)


def test_a_tree_restarted_under_a_gui_that_said_not_paused_waits_for_the_start_gesture_again(
    qapp, ros_master, device, make_window, topic_log, data_root
):
    """A GUI's latched "not paused" (a teaching session ended) is no start: the tree that restarts after a crash
    (roslaunch respawn) with start_paused waits again, until the operator's gesture."""
    import rospy

    execution_log = topic_log("/behaviour_tree/execution", TreeExecution)
    window = make_window()
    not_paused = rospy.Publisher("/behaviour_tree/pause", Bool, queue_size=1, latch=True)
    not_paused.publish(Bool(False))
    try:
        tree = start_bt(data_root, start_paused=True)
        try:
            device.move(x=0.0)
            pump_until(qapp, lambda: window.start_tab.tree_waiting, 10, "START showing the waiting tree")
            pump(qapp, 2.0)
            # Expect the tree still waiting: it heard "not paused" and did not run
            assert execution_log.last().state == TreeExecution.WAITING
            assert not_paused.get_num_connections() > 0, "the tree heard the latched pause flag"
            pump_until(qapp, lambda: window.start_tab.selected == StartTab.NEUTRAL, 5, "the neutral zone")
            device.click()
            pump_until(qapp, lambda: execution_log.last().state == TreeExecution.RUNNING, 10, "the tree running")
        finally:
            stop(tree)
    finally:
        not_paused.unregister()


def test_while_a_skill_replays_the_clutch_corrects_it_and_start_says_who_leads(
    qapp, ros_master, device, make_window, topic_log, artifacts_dir
):
    """The skill server's side played by the test: skills/authority at 20 Hz, as a replay reports it."""
    import threading

    import rospy
    from geometry_msgs.msg import Vector3Stamped

    from teleteach.msg import SkillAuthority

    corrections = topic_log("/skills/correction", Vector3Stamped)
    authority = rospy.Publisher("/skills/authority", SkillAuthority, queue_size=10)
    window = make_window()
    replaying = threading.Event()
    replaying.set()

    def replay():
        while replaying.is_set() and not rospy.is_shutdown():
            last = corrections.last()
            report = SkillAuthority(skill="PlaceTaught_dmp", confidence=0.25, operator_weight=0.75, max_correction=0.05)
            report.header.frame_id = "base_link"
            if last is not None:  # what the replay applies: the operator's correction, weighted
                report.correction.x, report.correction.y, report.correction.z = (
                    0.75 * last.vector.x,
                    0.75 * last.vector.y,
                    0.75 * last.vector.z,
                )
            authority.publish(report)
            time.sleep(0.05)

    thread = threading.Thread(target=replay, daemon=True)
    thread.start()
    try:
        label = window.start_tab.authority
        replay = "PlaceTaught_dmp"
        pump_until(qapp, lambda: label.isVisible() and replay in label.text(), 10, "START showing the replay")
        assert "you lead (confidence 25 %). Your correction counts 75 %" in label.text()
        assert "hold the gripper closed to correct it" in label.text()
        # Expect the handle alone (clutch released) to correct nothing
        device.move(z=0.03)
        pump(qapp, 1.0)
        assert corrections.last() is not None and abs(corrections.last().vector.z) < 1e-9
        device.move()
        pump(qapp, 0.5)
        device.set_gripper(0.0)
        pump_until(qapp, lambda: "correcting" in label.text(), 5, "the clutch engaged")
        device.move(z=0.03)
        pump_until(qapp, lambda: corrections.last().vector.z > 0.029, 5, "the correction following the handle up")
        last = corrections.last()
        assert last.header.frame_id == "base_link" and abs(last.vector.x) < 1e-6 and abs(last.vector.y) < 1e-6
        pump_until(qapp, lambda: "moves the arm 22 mm" in label.text(), 5, "START showing the weighted correction")
        window.screenshot().save(str(artifacts_dir / "gui_start_correcting_a_replay.png"))
        # Expect the correction to stay within what the replay applies (max_correction, each axis)
        device.move(z=0.06)
        pump(qapp, 1.0)
        device.move(z=0.09)
        pump(qapp, 1.0)
        assert 0.049 < corrections.last().vector.z <= 0.05 + 1e-9
        device.set_gripper(0.25)
    finally:
        replaying.clear()
        thread.join(timeout=2.0)
        authority.unregister()
    count = len(corrections.messages)
    # Expect the line gone and no correction sent once the replay's reports stop
    pump_until(qapp, lambda: not window.start_tab.authority.isVisible(), 5, "the replay's line to go")
    pump(qapp, 0.5)
    assert len(corrections.messages) == count


def test_with_the_virtual_device_start_says_where_its_keys_go(qapp, ros_master, device, make_window, artifacts_dir):
    import rospy

    rospy.set_param("/sigma7_node/backend", "virtual")
    try:
        window = make_window()
    finally:
        rospy.delete_param("/sigma7_node/backend")
    keys = window.start_tab.keys
    pump_until(qapp, keys.isVisible, 5, "the keys shown")
    assert "teleteach: virtual Sigma.7" in keys.text() and "Space: click; Enter: double click" in keys.text()
    window.screenshot().save(str(artifacts_dir / "gui_start_virtual_device.png"))
    # Expect nothing of keys with another device
    assert not make_window().start_tab.keys.isVisible()
