"""Haptic guidance felt by a modelled hand: the real sigma7 node plays test/data/guided_selection.yaml through its
hand model (2 mm tremor), the real GUI sends its guidance, and the hand that aims off PlaceItem's centre settles on
its detent, so the click confirms PlaceItem."""

import pytest
from conftest import ROOT, pump_until, start, stop

from teleteach.gui.selection import Step

pytestmark = pytest.mark.gui
SCENARIO = ROOT / "test" / "data" / "guided_selection.yaml"


def test_a_trembling_hand_settles_on_the_button_s_detent_and_confirms_it(
    qapp, bt_node, make_window, topic_log, data_root
):
    from geometry_msgs.msg import PoseStamped, WrenchStamped

    window = make_window()
    flow = window.high_level.flow
    pump_until(qapp, lambda: len(flow.choices) == 23, 20, "the 23 buttons the scenario was written for")
    assert flow.choices.index("PlaceItem") == 4
    poses = topic_log("/sigma7/pose", PoseStamped)
    forces = topic_log("/sigma7/force", WrenchStamped)
    arguments = ["backend:=scenario", f"scenario:={SCENARIO}", "hand_model:=true", "tremor:=0.002"]
    device = start(["roslaunch", "teleteach", "device.launch", *arguments], data_root.parent / "guided_hand.log")
    try:
        pump_until(qapp, lambda: flow.step is Step.OPERATION, 40, "the click confirming a node")
        # Expect the node the hand meant, pulled there by the detent (the guidance's force was felt)
        assert flow.selected_node == "PlaceItem", flow.selected_node
        assert any(abs(message.wrench.force.x) > 0.05 for message in forces.since(0))
        centre = -0.1 + 4.5 * 0.2 / 23
        settled = [message.pose.position.x for message in poses.since(0)][-200:]
        assert abs(sum(settled) / len(settled) - centre) < abs(-0.0574 - centre)
    finally:
        stop(device)
