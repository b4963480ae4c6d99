"""The study's screens in the GUI, without Qt: which page, the start gesture, the questionnaire with the device."""

import pytest

from teleteach.core.gui_config import GuiConfig
from teleteach.core.questionnaire import NASA_TLX, Item
from teleteach.core.study_phase import Phase, StudyView
from teleteach.gui.device import DeviceSample
from teleteach.gui.selection import SelectionFlow, Step
from teleteach.gui.study import Page, StudyScreen, Submission

CONFIG = GuiConfig.load()
LIKERT = Item("in_control", "Control", "I felt in control.", "Strongly disagree", "Strongly agree", 7, 1.0, 7.0)
ITEMS = (NASA_TLX[0], LIKERT)


def at(x=0.0, y=0.0, z=0.0):
    return DeviceSample(x, y, z, 0.0, 0.0, 0.0)


@pytest.fixture
def screen():
    return StudyScreen(CONFIG)


def test_the_study_s_page_shows_between_trials_and_the_tabs_while_one_runs(screen):
    assert screen.page is Page.TABS  # no study: the GUI as always
    for phase, page in (
        (Phase.PREPARING, Page.STUDY),
        (Phase.INSTRUCTIONS, Page.STUDY),
        (Phase.RUNNING, Page.TABS),
        (Phase.DONE, Page.STUDY),
        (Phase.QUESTIONNAIRE, Page.STUDY),
        (Phase.FINISHED, Page.STUDY),
    ):
        screen.on_status(StudyView(phase))
        assert screen.page is page, phase
    running = StudyView(
        Phase.RUNNING,
        trial=3,
        trials=8,
        title="Remove PlaceItem",
        elapsed=75.4,
        timeout=90.0,
        status="PlaceItem is there",
    )
    screen.on_status(running)
    assert screen.banner() == "Trial 3 of 8: Remove PlaceItem   1:15 of 1:30\nPlaceItem is there"


def test_the_start_gesture_is_a_click_with_the_handle_at_the_centre(screen):
    screen.on_status(StudyView(Phase.INSTRUCTIONS, trial=1))
    screen.on_device(at(0.05, 0.0, 0.0))
    assert screen.on_click() is None
    assert screen.message == "Bring the handle to the centre (the dot into the ring), then click."
    screen.on_device(at(0.015, -0.019, 0.01))
    assert screen.centred and screen.message == ""
    assert screen.on_click() == Submission("start")
    assert screen.on_click() is None  # sent once, while the answer is awaited
    screen.answered(False, "no trial waits for its start (phase PREPARING)")
    assert screen.message == "not taken: no trial waits for its start (phase PREPARING)"


def test_the_questionnaire_is_answered_with_device_x_and_clicks_and_one_item_back(screen):
    screen.on_status(StudyView(Phase.QUESTIONNAIRE, items=ITEMS))
    assert (screen.item_index, screen.item) == (0, NASA_TLX[0])
    screen.on_device(at(x=-0.1))
    assert screen.position == 0
    screen.on_device(at(x=0.1))
    assert screen.position == 20
    screen.on_device(at(x=-0.1 + 13.5 * 0.2 / 21))  # the 14th of 21 bins: 65
    assert screen.on_click() is None
    assert (screen.item_index, screen.item) == (1, LIKERT)
    screen.on_device(at(x=-0.1 + 1.5 * 0.2 / 7))  # the second of 7 bins: 2
    screen.on_click()
    assert screen.reviewing and screen.summary() == [("Mental Demand", 65.0), ("Control", 2.0)]
    # handle pushed down + click: back to the Likert item, which is answered again
    screen.on_device(at(x=0.0, z=-0.07))
    assert screen.on_click() is None and screen.item is LIKERT
    screen.on_device(at(x=0.1))
    screen.on_click()
    assert screen.summary() == [("Mental Demand", 65.0), ("Control", 7.0)]
    screen.on_device(at(0.0))
    assert screen.on_click() == Submission("questionnaire", ("mental_demand", "in_control"), (65.0, 7.0))
    screen.answered(True, "2 answers taken")
    assert screen.sent and screen.message == "Thank you." and screen.on_click() is None


def test_a_new_questionnaire_starts_at_its_first_item(screen):
    screen.on_status(StudyView(Phase.QUESTIONNAIRE, items=ITEMS))
    screen.on_click()
    screen.on_status(StudyView(Phase.QUESTIONNAIRE, items=ITEMS))  # the same state again: nothing changes
    assert screen.item_index == 1
    screen.on_status(StudyView(Phase.PREPARING))
    screen.on_status(StudyView(Phase.QUESTIONNAIRE, items=ITEMS))
    assert screen.item_index == 0 and screen.answers == [None, None]


def test_a_selection_flow_says_what_each_click_confirms():
    flow = SelectionFlow(CONFIG)
    assert flow.confirmation() is None  # no buttons yet
    flow.set_choices(["PauseCondition", "LookToShelf", "PlaceItem"], 3)
    flow.device(at(x=0.09))
    assert flow.confirmation() == ("node", "PlaceItem")
    flow.click()
    flow.device(at(y=-0.09))
    assert flow.confirmation() == ("operation", "remove")
    flow.device(at(y=-0.09, z=-0.07))
    assert flow.confirmation() == ("undo", "")
    flow.device(at(y=-0.03))
    assert flow.confirmation() == ("operation", "insert")
    flow.click()
    # Expect: the dial begins at the handle's roll (0 rad: the middle of three slots), what a click then confirms
    assert flow.step is Step.INDEX and flow.confirmation() == ("index", "1")
