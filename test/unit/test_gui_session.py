"""The teaching session's rules, without Qt: tab changes, recordings and help requests in, the window's actions out."""

import pytest

from teleteach.core.active_tab import Tab
from teleteach.gui.session import Action, Arm, Recording, TeachingSession

A = Action


@pytest.fixture
def session():
    machine = TeachingSession()
    assert machine.tab_changed(Tab.START) == []
    return machine


def test_a_teaching_tab_pauses_the_tree_and_hands_the_arm_to_impedance_control_once_it_is_free(session):
    # Expect: entering LOW-LEVEL starts a session: the tree pauses, the switch waits for the arm to be free
    assert session.tab_changed(Tab.LOW_LEVEL) == [A.ENTER_LOW_LEVEL, A.PAUSE_TREE, A.WAIT_FOR_ARM]
    assert session.arm == Arm.WAITING
    assert session.arm_freed() == [A.IMPEDANCE_CONTROL]
    assert session.arm_freed() == []  # told twice: switched once
    # SHARED CONTROL keeps the session; START ends it, arm first, then the tree
    assert session.tab_changed(Tab.SHARED_CONTROL) == [A.LEAVE_LOW_LEVEL, A.SHARED_CONTROL_ON]
    assert session.tab_changed(Tab.START) == [A.SHARED_CONTROL_OFF, A.POSITION_CONTROL, A.RESUME_TREE]
    assert not session.session
    assert session.tab_changed(Tab.START) == []  # the same tab again: nothing


def test_a_demonstration_is_saved_and_ends_the_session(session):
    session.tab_changed(Tab.LOW_LEVEL)
    session.arm_freed()
    assert session.toggle_stiffness_recording() == [A.START_STIFFNESS_RECORDING]
    assert session.recording == Recording.STIFFNESS
    # Expect: the second double click stops, saves, and gives the arm back to the tree
    stop = [A.STOP_STIFFNESS_RECORDING, A.SAVE_STIFFNESS_SKILL, A.POSITION_CONTROL, A.RESUME_TREE]
    assert session.toggle_stiffness_recording() == stop
    assert session.recording is None and not session.session
    # leaving LOW-LEVEL afterwards has nothing left to end
    assert session.tab_changed(Tab.START) == [A.LEAVE_LOW_LEVEL]


def test_leaving_mid_recording_keeps_what_was_recorded(session):
    session.tab_changed(Tab.LOW_LEVEL)
    session.arm_freed()
    session.toggle_stiffness_recording()
    stop = [A.STOP_STIFFNESS_RECORDING, A.SAVE_STIFFNESS_SKILL, A.POSITION_CONTROL, A.RESUME_TREE]
    assert session.tab_changed(Tab.START) == [A.LEAVE_LOW_LEVEL, *stop]


def test_a_shared_control_recording_goes_on_in_the_tab_and_stops_when_it_is_left(session):
    assert session.tab_changed(Tab.SHARED_CONTROL) == [A.PAUSE_TREE, A.WAIT_FOR_ARM]
    # Expect the MPC to drive only once the impedance controller holds the arm
    assert session.arm_freed() == [A.IMPEDANCE_CONTROL, A.SHARED_CONTROL_ON]
    assert session.toggle_shared_recording() == [A.START_SHARED_RECORDING]
    assert session.toggle_shared_recording() == [A.STOP_SHARED_RECORDING, A.SAVE_SHARED_SKILL]
    assert session.session  # the operator goes on in the tab
    session.toggle_shared_recording()
    # Expect: to LOW-LEVEL, the recording is saved and the session goes on; to START, the session ends too
    stop = [A.SHARED_CONTROL_OFF, A.STOP_SHARED_RECORDING, A.SAVE_SHARED_SKILL]
    assert session.tab_changed(Tab.LOW_LEVEL) == [*stop, A.ENTER_LOW_LEVEL]
    assert session.tab_changed(Tab.SHARED_CONTROL) == [A.LEAVE_LOW_LEVEL, A.SHARED_CONTROL_ON]
    session.toggle_shared_recording()
    assert session.tab_changed(Tab.START) == [*stop, A.POSITION_CONTROL, A.RESUME_TREE]


def test_teleop_moves_the_arm_only_while_the_session_holds_it(session):
    assert session.tab_changed(Tab.TELEOP) == [A.PAUSE_TREE, A.WAIT_FOR_ARM]
    # Expect the device to drive once the impedance controller holds the arm, and to stop first when the tab is left
    assert session.arm_freed() == [A.IMPEDANCE_CONTROL, A.TELEOP_ON]
    assert session.tab_changed(Tab.LOW_LEVEL) == [A.TELEOP_OFF, A.ENTER_LOW_LEVEL]
    assert session.session  # teaching goes on: the stiffness for the pose the operator brought the arm to
    assert session.tab_changed(Tab.TELEOP) == [A.LEAVE_LOW_LEVEL, A.TELEOP_ON]
    assert session.tab_changed(Tab.START) == [A.TELEOP_OFF, A.POSITION_CONTROL, A.RESUME_TREE]
    # leaving before the arm was free: nothing was driven
    session.tab_changed(Tab.TELEOP)
    assert session.tab_changed(Tab.START) == [A.STOP_WAITING_FOR_ARM, A.RESUME_TREE]


def test_a_path_is_recorded_in_teleop_and_the_session_goes_on_to_teach_its_stiffness(session):
    session.tab_changed(Tab.TELEOP)
    assert session.toggle_path_recording() == []  # asked before the arm is free: starts once it is
    assert session.arm_freed() == [A.IMPEDANCE_CONTROL, A.TELEOP_ON, A.START_PATH_RECORDING]
    assert session.toggle_path_recording() == [A.STOP_PATH_RECORDING, A.SAVE_PATH]
    assert session.session and session.recording is None
    session.toggle_path_recording()
    # Expect: to LOW-LEVEL, the path is kept and the session goes on; to START, the session ends too
    stop = [A.TELEOP_OFF, A.STOP_PATH_RECORDING, A.SAVE_PATH]
    assert session.tab_changed(Tab.LOW_LEVEL) == [*stop, A.ENTER_LOW_LEVEL]
    assert session.tab_changed(Tab.TELEOP) == [A.LEAVE_LOW_LEVEL, A.TELEOP_ON]
    session.toggle_path_recording()
    assert session.tab_changed(Tab.START) == [*stop, A.POSITION_CONTROL, A.RESUME_TREE]


def test_recording_from_outside_a_session_starts_one(session):
    # the GUI tests toggle recording directly: the arm must be on impedance control first
    assert session.toggle_stiffness_recording() == [A.PAUSE_TREE, A.WAIT_FOR_ARM]
    assert session.arm_freed() == [A.IMPEDANCE_CONTROL, A.START_STIFFNESS_RECORDING]


def test_a_recording_asked_for_before_the_arm_is_free_starts_when_it_is_or_not_at_all(session):
    session.tab_changed(Tab.LOW_LEVEL)
    # Expect nothing recorded while the tree's skill still drives the arm; a second double click cancels the wish
    assert session.toggle_stiffness_recording() == []
    assert session.toggle_stiffness_recording() == []
    assert session.arm_freed() == [A.IMPEDANCE_CONTROL]
    session.tab_changed(Tab.START)
    session.tab_changed(Tab.LOW_LEVEL)
    session.toggle_stiffness_recording()
    # Expect an arm that never becomes free to leave the session without a switch or a recording, the tree resumed
    assert session.arm_not_freed() == []
    assert session.arm_freed() == []
    assert session.tab_changed(Tab.START) == [A.LEAVE_LOW_LEVEL, A.RESUME_TREE]


def test_leaving_before_the_arm_is_free_stops_waiting_and_switches_nothing(session):
    session.tab_changed(Tab.LOW_LEVEL)
    assert session.tab_changed(Tab.START) == [A.LEAVE_LOW_LEVEL, A.STOP_WAITING_FOR_ARM, A.RESUME_TREE]
    assert session.arm_freed() == []


def test_a_tab_beyond_the_contract_is_one_no_rule_concerns(session):
    # Expect: a tab added after TELEOP (an ABOUT tab) ends a teaching session as START does, and asks for nothing
    extra = len(Tab)
    assert session.tab_changed(extra) == []
    session.tab_changed(Tab.LOW_LEVEL)
    session.arm_freed()
    assert session.tab_changed(extra) == [A.LEAVE_LOW_LEVEL, A.POSITION_CONTROL, A.RESUME_TREE]
    assert session.tab_changed(Tab.START) == []


def test_a_tree_waiting_for_its_start_is_started_only_by_the_start_gesture(session):
    session.tree_state_changed(waiting=True, done=False)
    session.tab_changed(Tab.LOW_LEVEL)
    session.arm_freed()
    # Expect: a teaching session before the start does not start the tree when it ends
    assert session.tab_changed(Tab.START) == [A.LEAVE_LOW_LEVEL, A.POSITION_CONTROL]
    assert session.start_requested() == [A.START_TREE]
    assert session.start_requested() == []  # started once
    session.tree_state_changed(waiting=False, done=False)
    session.tab_changed(Tab.LOW_LEVEL)
    session.arm_freed()
    assert session.tab_changed(Tab.START) == [A.LEAVE_LOW_LEVEL, A.POSITION_CONTROL, A.RESUME_TREE]


def test_the_start_gesture_runs_a_tree_that_is_done_again(session):
    session.tab_changed(Tab.START)
    # Expect: a running tree is not started by the gesture, a done one runs again (once)
    assert session.start_requested() == []
    session.tree_state_changed(waiting=False, done=True)
    assert session.start_requested() == [A.START_TREE]
    assert session.start_requested() == []
    session.tree_state_changed(waiting=False, done=True)
    session.tab_changed(Tab.HIGH_LEVEL)
    assert session.start_requested() == []


def test_the_start_gesture_counts_only_in_start(session):
    session.tree_state_changed(waiting=True, done=False)
    session.tab_changed(Tab.HIGH_LEVEL)
    assert session.start_requested() == []


def test_leaving_high_level_answers_the_help_request(session):
    session.help_requested("PickItem")
    assert session.tab_changed(Tab.HIGH_LEVEL) == [A.RESET_HIGH_LEVEL]
    # Expect: back to START, the operator's edits answer the request and the tree resumes
    assert session.tab_changed(Tab.START) == [A.RESUME_TREE, A.ANNOUNCE_HELP_ANSWERED]
    # to LOW-LEVEL or TELEOP instead, teaching continues the answer: the session pauses the tree
    session.tab_changed(Tab.HIGH_LEVEL)
    assert session.tab_changed(Tab.LOW_LEVEL) == [A.ENTER_LOW_LEVEL, A.PAUSE_TREE, A.WAIT_FOR_ARM]
    session.tab_changed(Tab.HIGH_LEVEL)
    assert session.tab_changed(Tab.TELEOP) == [A.PAUSE_TREE, A.WAIT_FOR_ARM]  # no RESUME_TREE in between
    # a closed request (empty node name) needs no answer
    session.help_requested("")
    session.tab_changed(Tab.HIGH_LEVEL)
    assert session.tab_changed(Tab.START) == []


@pytest.mark.parametrize(
    "steps, expected",
    [
        ([], []),
        ([Tab.LOW_LEVEL], [A.STOP_WAITING_FOR_ARM, A.RESUME_TREE]),
        ([Tab.LOW_LEVEL, "free"], [A.POSITION_CONTROL, A.RESUME_TREE]),
        (
            [Tab.LOW_LEVEL, "free", "record"],
            [A.STOP_STIFFNESS_RECORDING, A.SAVE_STIFFNESS_SKILL, A.POSITION_CONTROL, A.RESUME_TREE],
        ),
        ([Tab.TELEOP, "free"], [A.TELEOP_OFF, A.POSITION_CONTROL, A.RESUME_TREE]),
        (
            [Tab.TELEOP, "free", "record"],
            [A.TELEOP_OFF, A.STOP_PATH_RECORDING, A.SAVE_PATH, A.POSITION_CONTROL, A.RESUME_TREE],
        ),
        (
            [Tab.SHARED_CONTROL, "free", "record"],
            [A.SHARED_CONTROL_OFF, A.STOP_SHARED_RECORDING, A.SAVE_SHARED_SKILL, A.POSITION_CONTROL, A.RESUME_TREE],
        ),
    ],
)
def test_shutdown_saves_and_gives_the_arm_back(session, steps, expected):
    for step in steps:
        if step == "record":
            toggles = {Tab.LOW_LEVEL: session.toggle_stiffness_recording, Tab.TELEOP: session.toggle_path_recording}
            toggles.get(session.tab, session.toggle_shared_recording)()
        elif step == "free":
            session.arm_freed()
        else:
            session.tab_changed(step)
    assert session.shutdown() == expected


def test_every_path_through_the_tabs_gives_the_arm_back():
    """Whatever the operator does, a session that took the arm returns it before the tree resumes."""
    import itertools

    events = [*Tab, "record", "free", "not freed"]
    for path in itertools.product(events, repeat=4):
        machine, actions = TeachingSession(), []
        for event in (Tab.START, *path):
            if event == "record":
                toggle = {
                    Tab.LOW_LEVEL: machine.toggle_stiffness_recording,
                    Tab.SHARED_CONTROL: machine.toggle_shared_recording,
                    Tab.TELEOP: machine.toggle_path_recording,
                }
                actions += toggle[machine.tab]() if machine.tab in toggle else []
            elif event == "free":
                actions += machine.arm_freed()
            elif event == "not freed":
                actions += machine.arm_not_freed()
            else:
                actions += machine.tab_changed(event)
        actions += machine.shutdown()
        assert actions.count(A.IMPEDANCE_CONTROL) == actions.count(A.POSITION_CONTROL), path
        # Expect the MPC (SHARED CONTROL) and the device (TELEOP) to drive only inside their tab's session, one at a
        # time: on and off alternate, off before the arm goes back to the position controller
        drivers = {
            A.SHARED_CONTROL_ON: "mpc",
            A.SHARED_CONTROL_OFF: "mpc",
            A.TELEOP_ON: "device",
            A.TELEOP_OFF: "device",
        }
        driving = None
        for action in actions:
            assert not (action == A.POSITION_CONTROL and driving), path
            if action in (A.SHARED_CONTROL_ON, A.TELEOP_ON):
                assert driving is None, path
                driving = drivers[action]
            elif action in (A.SHARED_CONTROL_OFF, A.TELEOP_OFF):
                assert driving == drivers[action], path
                driving = None
        assert driving is None, path
        starts = sum(
            actions.count(a) for a in (A.START_STIFFNESS_RECORDING, A.START_SHARED_RECORDING, A.START_PATH_RECORDING)
        )
        saves = sum(actions.count(a) for a in (A.SAVE_STIFFNESS_SKILL, A.SAVE_SHARED_SKILL, A.SAVE_PATH))
        assert starts == saves, path
        # Expect a recording only ever while the impedance controller holds the arm
        holding = False
        for action in actions:
            holding = {A.IMPEDANCE_CONTROL: True, A.POSITION_CONTROL: False}.get(action, holding)
            starting = (A.START_STIFFNESS_RECORDING, A.START_SHARED_RECORDING, A.START_PATH_RECORDING)
            if action in (*starting, A.SHARED_CONTROL_ON, A.TELEOP_ON):
                assert holding, path
        assert not machine.session and machine.recording is None and machine.arm == Arm.POSITION, path


def test_tab_ids_and_titles_are_the_contract_of_active_tab():
    assert [(int(tab), tab.title) for tab in Tab] == [
        (0, "START"),
        (1, "HIGH-LEVEL"),
        (2, "LOW-LEVEL"),
        (3, "SHARED CONTROL"),
        (4, "TELEOP"),
    ]
