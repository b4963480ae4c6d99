"""Scenario keyframes that wait for the system (a patient scripted operator): parsing, holding, timing out."""

import pathlib

import numpy as np
import pytest
import yaml

from teleteach.haptics.click import ClickDetector, ClickParameters
from teleteach.haptics.loop import DeviceLoop
from teleteach.haptics.scenario import (
    TABS,
    ScenarioBackend,
    ScenarioError,
    SystemState,
    Wait,
    parse_scenario,
    unmet,
)
from teleteach.haptics.twist import TwistEstimator

CONFIG = pathlib.Path(__file__).resolve().parents[2] / "config"
WAITING = """
keyframes:
  - {t: 0.0, position: [0.0, 0.0, 0.0], rpy: [0.0, 0.0, 0.0], gripper: 0.25}
  - {t: 1.0, position: [0.05, 0.0, 0.0], rpy: [0.0, 0.0, 0.0], gripper: 0.25, click: true,
     wait: {tab: LOW_LEVEL, tree_running: PickItem2}, timeout: 5.0}
  - {t: 2.0, position: [0.05, 0.05, 0.0], rpy: [0.0, 0.0, 0.0], gripper: 0.25}
"""


DOUBLE_CLICKING = """
click_duration: 0.3
keyframes:
  - {t: 0.0, position: [0.0, 0.0, 0.0], rpy: [0.0, 0.0, 0.0], gripper: 0.25}
  - {t: 1.0, position: [0.05, 0.0, 0.0], rpy: [0.0, 0.0, 0.0], gripper: 0.25, click: true}
  - {t: 1.35, position: [0.05, 0.0, 0.0], rpy: [0.0, 0.0, 0.0], gripper: 0.25, click: true}
  - {t: 2.0, position: [0.05, 0.05, 0.0], rpy: [0.0, 0.0, 0.0], gripper: 0.25}
"""

CLICKING = """
keyframes:
  - {t: 0.0, position: [0.0, 0.0, 0.0], rpy: [0.0, 0.0, 0.0], gripper: 0.25}
  - {t: 1.0, position: [0.05, 0.0, 0.0], rpy: [0.0, 0.0, 0.0], gripper: 0.25, click: true}
  - {t: 2.0, position: [0.05, 0.05, 0.0], rpy: [0.0, 0.0, 0.0], gripper: 0.25}
"""


def test_a_wait_is_parsed_with_its_timeout():
    scenario = parse_scenario(WAITING)
    # Expect the tab by name as its index, the tree node, the timeout; the other keyframes wait for nothing
    assert scenario.keyframes[1].wait == Wait(tab=2, tree_running="PickItem2", timeout=5.0)
    assert scenario.keyframes[0].wait is None and scenario.waits


@pytest.mark.parametrize(
    "keyframe, message",
    [
        ("wait: {tab: LOWLEVEL}", "tab must be one of START, HIGH_LEVEL, LOW_LEVEL, SHARED_CONTROL"),
        ("wait: {recording: yes please}", "recording must be true or false"),
        ("wait: {colour: red}", "unknown condition 'colour'"),
        ("wait: {}", "must be a mapping of one or more of"),
        ("wait: {help_request: true}, timeout: -1", "keyframes[1].timeout: must be a positive number"),
        ("timeout: 3", "only a keyframe that waits has a timeout"),
        ("wait: {study: STARTED}", "study must be one of PREPARING, INSTRUCTIONS, RUNNING, DONE, QUESTIONNAIRE"),
    ],
)
def test_bad_waits_name_the_line_and_field(keyframe, message):
    text = (
        "keyframes:\n"
        "  - {t: 0.0, position: [0, 0, 0], rpy: [0, 0, 0], gripper: 0.25}\n"
        f"  - {{t: 1.0, position: [0, 0, 0], rpy: [0, 0, 0], gripper: 0.25, {keyframe}}}\n"
    )
    with pytest.raises(ScenarioError) as caught:
        parse_scenario(text, source="s.yaml")
    assert str(caught.value).startswith("s.yaml:3: keyframes[1]") and message in str(caught.value)


def test_a_scripted_participant_waits_for_a_study_s_phase():
    text = WAITING.replace("wait: {tab: LOW_LEVEL, tree_running: PickItem2}", "wait: {study: QUESTIONNAIRE}")
    wait = parse_scenario(text).keyframes[1].wait
    assert wait == Wait(study="QUESTIONNAIRE", timeout=5.0)
    assert unmet(wait, SystemState(study="DONE")) == ["study QUESTIONNAIRE (seen DONE)"]
    assert unmet(wait, SystemState(study="QUESTIONNAIRE")) == []


def test_unmet_says_what_was_seen():
    wait = Wait(tab=2, tree_running="PickItem2", recording=True, help_request=False)
    state = SystemState(tab=0, running=frozenset({"Root", "MoveBase"}), recording=False, help_request=False)
    # Expect each unmet condition with what the system showed instead
    assert unmet(wait, state) == [
        "tab LOW_LEVEL (seen START)",
        "tree_running PickItem2 (running: MoveBase, Root)",
        "recording true (seen False)",
    ]
    assert unmet(wait, SystemState(2, frozenset({"PickItem2"}), True, False)) == []


def test_a_tree_node_to_wait_for_may_be_a_pattern():
    # The GUI names a taught skill DemonstratedPlace_<n> after those already in the data directory: a demo run a second
    # time teaches DemonstratedPlace_2, which the scripted operator must wait for as well
    wait = Wait(tree_running="DemonstratedPlace_*")
    assert unmet(wait, SystemState(running=frozenset({"Root", "DemonstratedPlace_2"}))) == []
    assert unmet(wait, SystemState(running=frozenset({"Root", "DemonstratedPlace"}))) == [
        "tree_running DemonstratedPlace_* (running: DemonstratedPlace, Root)"
    ]
    assert unmet(Wait(tree_running="PickItem"), SystemState(running=frozenset({"PickItem2"}))) != []


def test_the_device_holds_the_waiting_keyframe_until_the_system_is_ready():
    state = {"now": SystemState(tab=0)}
    backend = ScenarioBackend(parse_scenario(WAITING), start_time=100.0, system=lambda: state["now"])
    # Expect the motion up to the keyframe, then the device held there while the GUI is elsewhere
    assert backend.read(100.5).position[0] == pytest.approx(0.025)
    for time in (101.0, 101.5, 103.0):
        assert np.allclose(backend.read(time).position, [0.05, 0.0, 0.0])
        assert backend.read(time).gripper == pytest.approx(0.25)  # the keyframe's click waits too
    state["now"] = SystemState(tab=2, running=frozenset({"PickItem2"}))
    # Expect the scenario to go on from the keyframe (its click first) once the system shows what it waits for
    assert backend.read(103.0).position[0] == pytest.approx(0.05)
    backend.read(103.04)
    assert backend.read(103.08).gripper < 0.2
    assert backend.read(103.5).position[1] == pytest.approx(0.025)
    assert not backend.finished and backend.failure == ""
    # Expect: played only once the last keyframe is reached on the scenario's clock, which stood still 2 s
    assert not backend.played  # at 103.5, 1.5 s of the 2 s scenario
    backend.read(104.1)
    assert backend.played


def test_a_wait_that_times_out_fails_the_scenario_naming_the_keyframe():
    backend = ScenarioBackend(parse_scenario(WAITING, source="s.yaml"), start_time=0.0, system=lambda: SystemState(1))
    backend.read(1.0)
    backend.read(5.9)
    assert not backend.finished
    backend.read(6.1)
    # Expect the backend finished with one message: file, line, keyframe, what it waited for and what it saw
    assert backend.finished
    assert backend.failure.startswith("s.yaml:4: keyframes[1].wait: still waiting after 5 s for tab LOW_LEVEL")
    assert "(seen HIGH_LEVEL)" in backend.failure and "tree_running PickItem2 (running: nothing)" in backend.failure


def presses(backend, times):
    """Stamps of the rising edges of the button the device loop publishes reading ``backend`` at ``times``."""
    clock = {"now": 0.0}
    published = []
    detector = ClickDetector(ClickParameters(**yaml.safe_load((CONFIG / "device.yaml").read_text())["click"]))
    loop = DeviceLoop(backend, published.append, lambda: clock["now"], detector, TwistEstimator(20.0), print)
    for time in times:
        clock["now"] = time
        loop.step()
    pressed = [False] + [state.button for state in published]
    return [state.stamp for state, before in zip(published, pressed) if state.button and not before]


def reads(*spans):
    """Read times every millisecond over each (start, end) span: the loop stalls between spans."""
    return np.concatenate([np.arange(start, end, 0.001) for start, end in spans])


@pytest.mark.parametrize(
    "stop, resume",
    [
        (1.03, 1.15),  # a stall from inside the flick, before the gripper closed, over its closing
        (1.03, 1.6),  # ... and over its end
        (1.04, 2.5),
        (1.09, 1.2),  # closed before the stall, which ends in the flick
        (1.09, 1.8),  # closed before the stall, which ends long after the flick (seen on a loaded fresh machine)
        (1.12, 3.0),
        (0.99, 1.1),  # over the flick's start, (0.99, 1.4) over all of it
        (0.99, 1.4),
        (0.99, 2.5),
    ],
)
def test_a_stall_anywhere_over_a_click_does_not_swallow_it(stop, resume):
    scenario = parse_scenario(CLICKING)
    # Expect the click of keyframe 1 (at 1.0 s, 0.2 s long) pressed exactly once, when steady and when stalled
    assert len(presses(ScenarioBackend(scenario, start_time=0.0), reads((0.0, 3.5)))) == 1
    assert len(presses(ScenarioBackend(scenario, start_time=0.0), reads((0.0, stop), (resume, 3.5)))) == 1


def test_a_double_click_a_stall_jumped_over_stays_a_double_click():
    scenario = parse_scenario(DOUBLE_CLICKING)
    window = yaml.safe_load((CONFIG / "gui.yaml").read_text())["double_click_window"]
    steady = presses(ScenarioBackend(scenario, start_time=0.0), reads((0.0, 3.5)))
    stalled = presses(ScenarioBackend(scenario, start_time=0.0), reads((0.0, 0.99), (2.0, 3.5)))
    # Expect two presses within the GUI's double-click window either way: late after the stall, not lost
    for stamps in (steady, stalled):
        assert len(stamps) == 2 and stamps[1] - stamps[0] < window, stamps
    assert stalled[0] == pytest.approx(2.0)


def test_a_stall_between_clicks_presses_nothing_extra():
    scenario = parse_scenario(CLICKING)
    stamps = presses(ScenarioBackend(scenario, start_time=0.0), reads((0.0, 0.5), (0.9, 3.5)))
    # Expect a stall away from the flick to change nothing: one press, when the flick reopens the gripper
    assert len(stamps) == 1 and 1.1 < stamps[0] < 1.2, stamps
    # Expect the motion to go on as scripted over a stall
    backend = ScenarioBackend(scenario, start_time=0.0)
    backend.read(0.98)
    assert backend.read(1.5).position[1] == pytest.approx(0.025)


def test_every_scenario_going_back_to_start_holds_the_gripper_open_until_start_shows():
    """A gripper opened only for a moment can fall between two reads of a stalled device loop (the player catches up
    on missed clicks, not on the gripper's level): START never comes, and the scenario's wait runs out."""
    threshold = yaml.safe_load((CONFIG / "gui.yaml").read_text())["gripper_open_threshold"]
    checked = 0
    for path in sorted((CONFIG / "scenarios").glob("*.yaml")):
        text = path.read_text()
        if "keyframes:" not in text:
            continue
        for keyframe in parse_scenario(text, str(path)).keyframes:
            if keyframe.wait is not None and keyframe.wait.tab == TABS.index("START"):
                assert keyframe.gripper >= threshold, f"{path.name}:{keyframe.line}: START waited for, gripper closed"
                checked += 1
    assert checked >= 3
