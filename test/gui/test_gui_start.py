"""START with the real GUI: a neutral zone in the centre, and the start gesture of a tree that started paused."""

import pytest
from conftest import pump, pump_until, start_bt, stop
from std_msgs.msg import Bool

from teleteach.gui.session import Tab
from teleteach.gui.tabs import StartTab
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
        device.click()
        pump_until(qapp, lambda: window.tabs.currentIndex() == Tab.LOW_LEVEL, 5, "LOW-LEVEL")
        device.set_gripper(0.5)
        pump_until(qapp, lambda: window.tabs.currentIndex() == Tab.START, 5, "back to START")
        device.set_gripper(0.25)
        pump(qapp, 1.0)
        assert execution_log.last().state == TreeExecution.WAITING
        assert all(message.data for _, message in pause_log.messages)
        # the start gesture: centred, click
        device.move(x=0.0)
        pump_until(qapp, lambda: window.start_tab.selected == StartTab.NEUTRAL, 5, "the neutral zone")
        device.click()
        pump_until(qapp, lambda: execution_log.last().state == TreeExecution.RUNNING, 10, "the tree running")
        assert pause_log.last().data is False
        pump_until(qapp, lambda: not window.start_tab.tree_waiting, 5, "START no longer waiting")
        assert window.tabs.currentIndex() == Tab.START
    finally:
        stop(tree)
