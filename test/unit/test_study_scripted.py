"""The scripted participant's device input: the study's screens around the task's script, answers the GUI reads back."""

import pathlib

import numpy as np

from teleteach.core.gui_config import GuiConfig
from teleteach.core.study_phase import PHASE_NAMES
from teleteach.gui.device import scale_to_index
from teleteach.haptics.scenario import ScenarioTrajectory, load_scenario, parse_scenario
from teleteach.study.ordering import session_plan
from teleteach.study.schema import load_study
from teleteach.study.scripted import compose, intended_answers, pace, questionnaire_scenario

ROOT = pathlib.Path(__file__).resolve().parents[2]
STUDY = load_study(ROOT / "config" / "studies" / "example.yaml")
RANGE = GuiConfig.load().device_range


def test_a_trial_waits_for_the_instructions_starts_at_the_centre_and_plays_the_task_stretched_by_the_pace():
    step = session_plan(STUDY, "P01")[0]
    trial = compose(STUDY, "P01", step, questionnaire=False, device_range=RANGE, prepare_timeout=120.0)
    scenario = parse_scenario(trial.scenario)
    frames = scenario.keyframes
    assert trial.answers is None
    assert frames[1].wait.study == "INSTRUCTIONS" and frames[1].wait.timeout == 120.0
    start = next(frame for frame in frames if frame.click)
    assert start.position == (0.0, 0.0, 0.0)  # the start gesture: a click at the centre
    running = next(index for index, frame in enumerate(frames) if frame.wait and frame.wait.study == "RUNNING")
    script = load_scenario(STUDY.task(step.task).script).keyframes
    task = frames[running + 1 : running + 1 + len(script)]
    times = np.array([frame.time for frame in task]) - task[0].time
    assert np.allclose(times, pace(STUDY, "P01") * np.array([frame.time for frame in script]), atol=2e-3)
    assert [frame.click for frame in task] == [frame.click for frame in script]
    # Expect the hand to aim off the script by the same offset, at most `aim`, in x and y only
    offsets = {tuple(np.round(np.subtract(a.position, b.position), 5)) for a, b in zip(task, script)}
    (offset,) = offsets
    assert max(abs(offset[0]), abs(offset[1])) <= STUDY.scripted.aim and offset[2] == 0.0
    assert [frame.wait.tab for frame in task if frame.wait] == [1]  # the script's own wait for HIGH-LEVEL
    assert 0.85 <= pace(STUDY, "P01") <= 1.2 and pace(STUDY, "P01") != pace(STUDY, "P02")


def test_the_questionnaire_s_answers_are_where_the_gui_reads_them():
    step = session_plan(STUDY, "P02")[3]
    trial = compose(STUDY, "P02", step, questionnaire=True, device_range=RANGE, prepare_timeout=120.0)
    scenario = parse_scenario(trial.scenario)
    assert trial.answers == intended_answers(STUDY, "P02", step.condition)
    waiting = next(index for index, frame in enumerate(scenario.keyframes) if frame.wait and frame.wait.study)
    asked = [
        index for index, frame in enumerate(scenario.keyframes) if frame.wait and frame.wait.study == "QUESTIONNAIRE"
    ]
    assert waiting < asked[0]
    clicks = [frame for frame in scenario.keyframes[asked[0] :] if frame.click]
    assert len(clicks) == len(STUDY.questionnaire) + 1  # one per item, one to send
    trajectory = ScenarioTrajectory(scenario)
    for item, click in zip(STUDY.questionnaire, clicks):
        # Expect the hand still at the answer when the click registers (the flick's end), read by the GUI's mapping
        for time in (click.time, click.time + scenario.click_duration + 0.05):
            x = trajectory.sample(time).position[0]
            assert item.value(scale_to_index(x, RANGE, item.points)) == trial.answers[item.name]


def test_answers_differ_between_participants_and_conditions_but_not_between_reruns():
    guided, unguided = (intended_answers(STUDY, "P01", condition) for condition in ("guided", "unguided"))
    assert guided != unguided and guided == intended_answers(STUDY, "P01", "guided")
    assert set(guided) == {item.name for item in STUDY.questionnaire}
    text, answers = questionnaire_scenario(STUDY, "P01", session_plan(STUDY, "P01")[4], RANGE)
    assert answers == guided
    phases = {frame.wait.study for frame in parse_scenario(text).keyframes if frame.wait}
    assert phases == {"QUESTIONNAIRE"} and phases <= set(PHASE_NAMES)
