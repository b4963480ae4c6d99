"""The thesis' high-level task (III-B) end to end: the real sigma7 node plays a scenario
(config/scenarios/gui_remove_place_item.yaml) into the real GUI, which edits the real behaviour tree."""

import pytest
from conftest import ROOT, pump_until, start, stop

from teleteach.msg import BehaviourTree

pytestmark = pytest.mark.gui
SCENARIO = ROOT / "config" / "scenarios" / "gui_remove_place_item.yaml"


def test_sigma7_scenario_removes_place_item(qapp, bt_node, make_window, topic_log, data_root, artifacts_dir):
    from std_msgs.msg import Int8

    tree_log = topic_log("/behaviour_tree/log/tree", BehaviourTree)
    tab_log = topic_log("/teleteach/active_tab", Int8)
    window = make_window()
    flow = window.high_level.flow
    pump_until(qapp, lambda: len(flow.choices) == 23, 20, "the 23 buttons the scenario was written for")
    assert flow.choices.index("PlaceItem") == 4, flow.choices

    device = start(
        ["roslaunch", "teleteach", "device.launch", "backend:=scenario", f"scenario:={SCENARIO}", "at_end:=hold"],
        data_root.parent / "sigma7.log",
    )
    try:
        pump_until(qapp, lambda: any(m.data == 1 for m in tab_log.since(0)), 30, "HIGH-LEVEL opened by the device")

        def place_item_gone():
            tree = tree_log.last()
            if tree is None:
                return False
            execution = next(b for b in tree.behaviours if b.name == "BehaviorExecution")
            by_id = {b.own_id: b.name for b in tree.behaviours}
            return "PlaceItem" not in [by_id[child] for child in execution.child_ids]

        pump_until(qapp, lambda: flow.answer.startswith("done"), 20, "the answer on screen")
        window.screenshot().save(str(artifacts_dir / "gui_scenario_removed.png"))
        pump_until(qapp, place_item_gone, 10, "PlaceItem removed through the scenario")
        pump_until(qapp, lambda: window.tabs.currentIndex() == 0, 15, "START after the gripper opened")
    finally:
        stop(device)
