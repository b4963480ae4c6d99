"""The robot's proposal in the GUI, without a display: teleteach.gui.proposal and its preselection (issue 52)."""

from teleteach.bt.decisions import VETOED
from teleteach.bt.editor import EditRequest
from teleteach.core.gui_config import GuiConfig
from teleteach.gui.device import DeviceSample
from teleteach.gui.guidance import GuidanceDesigner
from teleteach.gui.proposal import HelpRequestView, Offer
from teleteach.gui.selection import REPAIR_CHOICE, SelectionFlow, Step

CONFIG = GuiConfig.load()
CHOICES = ["LookToShelf", "PickItem", "MoveBase", "PlaceItem", "ProductInHand"]
UNSURE = HelpRequestView("PickItem", "product_pick_1 is not on the table", (), ("remove PickItem",), 0.62, "remove")


def at(x, z=0.0):
    return DeviceSample(x, 0.0, z, 0.0, 0.0, 0.0)


def button(index, count=None):
    """The device's X in the middle of button ``index`` (of ``count``, else of CHOICES)."""
    count = count or len(CHOICES)
    return -CONFIG.device_range + (index + 0.5) * 2 * CONFIG.device_range / count


def flow_with(offer):
    flow = SelectionFlow(CONFIG)
    flow.set_choices(CHOICES, len(CHOICES) + 1)
    flow.set_offer(offer)
    return flow


def test_nothing_remembered_one_click_sends_repair_which_applies_the_proposal():
    # Expect the edit shown, a repair of the failed node sent, the confidence in the words
    shown, sent = EditRequest("PickItem", "remove"), EditRequest("PickItem", "repair")
    assert UNSURE.offer() == Offer(shown, sent, "remove PickItem, 62 % sure")


def test_a_remembered_repair_that_is_the_proposal_is_confirmed_by_repair_too():
    same = UNSURE._replace(suggestion=("remove PickItem",))
    assert same.offer().request == EditRequest("PickItem", "repair")


def test_beside_another_remembered_repair_the_proposal_is_sent_as_its_edit():
    # Expect: repair would apply the remembered inverter, so the click sends the removal itself
    other = UNSURE._replace(suggestion=("wrap PickItem in an inverter",))
    assert other.offer().request == EditRequest("PickItem", "remove")


def test_what_one_request_cannot_confirm_is_not_offered():
    two_edits = ("insert LookToShelf at index 1", "remove PickItem")
    beside_another = UNSURE._replace(suggestion=("wrap PickItem in an inverter",), proposal=two_edits)
    assert beside_another.offer() is None
    assert beside_another._replace(suggestion=()).offer().request == EditRequest("PickItem", "repair")
    assert UNSURE._replace(applied=True).offer() is None  # applied already: vetoed, not confirmed
    assert UNSURE._replace(why=f"{VETOED} (the tree is as before): remove").offer() is None  # just said no to it
    assert UNSURE._replace(proposal=()).offer() is None
    assert UNSURE._replace(node_name="").offer() is None  # answered


def test_the_banner_says_what_the_robot_proposes_or_did_and_counts_the_veto_window_down():
    assert "The robot proposes: remove PickItem, 62 % sure (remove). HIGH-LEVEL: it is preselected" in UNSURE.banner(0)
    applied = UNSURE._replace(confidence=0.98, applied=True, veto_left=5.0)
    # Expect the seconds left rounded up, and no countdown once the window is over
    assert "applied its proposal: remove PickItem, 98 % sure" in applied.banner(4.2)
    assert "Undo within 5 s to veto" in applied.banner(4.2)
    assert "Undo within 1 s to veto" in applied.banner(0.3)
    assert "Undo within" not in applied.banner(0.0)
    assert UNSURE._replace(node_name="").banner(0.0) == ""


def test_an_offer_is_preselected_and_one_click_sends_it():
    flow = flow_with(UNSURE.offer())
    # Expect the proposal's node and operation chosen before the handle moves
    assert (flow.step, flow.selected_node, flow.selected_operation) == (Step.PROPOSAL, "PickItem", "remove")
    flow.device(at(button(3)))  # wherever the handle is when the preselection is first felt
    flow.device(at(button(3) + 0.001))  # a tremor within that button
    assert flow.step is Step.PROPOSAL and flow.selected_node == "PickItem"
    assert flow.confirmation() == ("proposal", "repair PickItem")
    assert flow.click() == EditRequest("PickItem", "repair")
    # Expect: answered, the same offer (the help request published again) is not preselected a second time
    flow.answered(True, "repaired")
    flow.set_offer(UNSURE.offer())
    flow.reset()
    assert flow.step is Step.NODE


def test_moving_to_another_button_leaves_the_preselection_and_selects_as_ever():
    flow = flow_with(UNSURE.offer())
    flow.device(at(button(3)))
    flow.device(at(button(0)))
    # Expect step 1 as without a proposal: the handle's button selected, a click confirms the node
    assert (flow.step, flow.selected_node) == (Step.NODE, "LookToShelf")
    assert flow.confirmation() == ("node", "LookToShelf")
    # Expect: entering HIGH-LEVEL again offers it again, as long as the request carries it
    flow.reset()
    assert (flow.step, flow.selected_node) == (Step.PROPOSAL, "PickItem")


def test_the_undo_gesture_works_while_a_proposal_is_preselected():
    flow = flow_with(UNSURE.offer())
    flow.device(at(button(1), z=-1.5 * CONFIG.edit_push))
    assert flow.click() == EditRequest("", "undo")


def test_an_insert_is_preselected_on_the_library_button_at_its_index():
    flow = SelectionFlow(CONFIG)
    flow.set_choices([*CHOICES, "LookToShelf", "PickItem"], len(CHOICES) + 1)  # the tree's nodes, then the library
    flow.set_offer(UNSURE._replace(proposal=("insert LookToShelf at index 2",)).offer())
    assert (flow.node_index, flow.selected_operation, flow.index) == (len(CHOICES), "insert", 2)


def test_a_wrap_is_preselected_on_the_second_page_with_its_value():
    flow = flow_with(UNSURE._replace(proposal=("wrap PickItem in a retry (3)",)).offer())
    assert (flow.page, flow.selected_operation) == (1, "wrap retry")


def test_a_withdrawn_offer_and_a_remembered_repair_leave_the_repair_button_where_it_was():
    flow = flow_with(UNSURE.offer())
    flow.set_offer(None)
    assert flow.step is Step.NODE
    flow.repair_node = "PickItem"
    flow.set_choices([REPAIR_CHOICE, *CHOICES], len(CHOICES) + 1)
    flow.device(at(button(0, len(CHOICES) + 1)))
    assert flow.confirmation() == ("repair", "PickItem")


def test_the_preselection_feels_like_step_one():
    designer = GuidanceDesigner(CONFIG)
    flow = flow_with(UNSURE.offer())
    preselected = designer.high_level(flow)
    flow.set_offer(None)
    assert preselected == designer.high_level(flow)


def test_the_remembered_repair_scenario_still_clicks_its_repair_button():
    # config/scenarios/remembered_repair.yaml's second request: the proposal is the remembered repair; the script
    # enters HIGH-LEVEL at x = -0.05, moves to x = -0.098 (button 0 of 25) and clicks
    remembered = ("wrap PickItem in a retry (2)",)
    request = HelpRequestView("PickItem", "product_pick_1 is not on the table", remembered, remembered, 0.0)
    flow = SelectionFlow(CONFIG)
    flow.repair_node = "PickItem"
    flow.set_choices([REPAIR_CHOICE, *(f"Node{index}" for index in range(24))], 10)
    flow.set_offer(request.offer())
    flow.reset()  # entering the tab
    for x in (-0.05, -0.07, -0.098):
        flow.device(at(x))
    assert flow.confirmation() == ("repair", "PickItem")
