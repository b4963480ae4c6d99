"""The scripted participant: the device input of one trial (and the questionnaire after it) as a scenario file.

For each trial the scripted participant rests with the handle at the centre, waits for the instructions
(``wait: {study: INSTRUCTIONS}``), reads for a while, makes the start gesture (a click at the centre), waits until
the trial runs, then plays the task's own script (``script:`` of the task, a scenario file whose times count from the
start), stretched by the participant's pace. When the condition's questionnaire follows, it waits for it, moves the
slider of each item to its answer (device X, one scale position per bin of the GUI's ``device_range``) and clicks,
and clicks once more to submit. Pace, reading time and answers are drawn from seeded generators, so that simulated
participants differ and a rerun of the same participant is the same: the pace, the reading time, where the hand
aims (off the script's positions by up to ``aim`` in x and y, per trial) and the answers; the hand model's tremor
(seeded per participant) adds the rest.
"""

import dataclasses
import random
from typing import Dict, List, Optional, Tuple

import yaml

from teleteach.core.questionnaire import Item
from teleteach.haptics.scenario import TABS, Keyframe, load_scenario, parse_scenario
from teleteach.study.ordering import Step
from teleteach.study.schema import Study

REST = [0.0, 0.0, 0.0]
LEVEL = [0.0, 0.0, 0.0]
GRIPPER = 0.25  # [rad] a relaxed finger
CLICK_DURATION = 0.3  # [s]


class ScriptError(ValueError):
    """A trial the scripted participant cannot play (no script for its task)."""


@dataclasses.dataclass(frozen=True)
class ScriptedTrial:
    """A trial's scenario file text, and the answers the scripted participant means to give (if asked)."""

    scenario: str
    answers: Optional[Dict[str, float]] = None


def generator(study: Study, participant: str, what: str) -> random.Random:
    """A generator seeded by the study's seed, the participant and what it draws."""
    return random.Random(f"{study.order.seed}/{participant}/{what}")


def pace(study: Study, participant: str) -> float:
    """The participant's time scale of the task scripts (1: as written)."""
    return generator(study, participant, "pace").uniform(*study.scripted.speed)


def intended_answers(study: Study, participant: str, condition: str) -> Dict[str, float]:
    """The answers the scripted participant gives after ``condition`` (a position of each item's scale)."""
    draw = generator(study, participant, f"answers/{condition}")
    return {item.name: item.value(draw.randrange(item.points)) for item in study.questionnaire}


def slider_x(item: Item, value: float, device_range: float) -> float:
    """[m] the device X at the centre of the bin of ``value`` on ``item``'s slider."""
    width = 2.0 * device_range / item.points
    return -device_range + (item.position(value) + 0.5) * width


def _frame(time: float, position, rpy=LEVEL, gripper: float = GRIPPER, **extra) -> dict:
    frame = {"t": round(time, 3), "position": [round(float(value), 5) for value in position]}
    frame.update(rpy=[round(float(value), 5) for value in rpy], gripper=round(float(gripper), 4), **extra)
    return frame


def compose(
    study: Study,
    participant: str,
    step: Step,
    questionnaire: bool,
    device_range: float,
    prepare_timeout: float,
) -> ScriptedTrial:
    """The scenario of ``step`` (a trial), followed by its condition's questionnaire when ``questionnaire``.

    Raises:
        ScriptError: the task has no script.
    """
    task = study.task(step.task)
    if task.script is None:
        raise ScriptError(f"task {task.name} has no script: the scripted participant cannot do it (add script:)")
    script = load_scenario(task.script)
    scale = pace(study, participant)
    reading = generator(study, participant, f"reading/{step.key}").uniform(*study.scripted.reading_time)
    frames: List[dict] = [_frame(0.0, REST)]
    frames.append(_frame(0.5, REST, wait={"study": "INSTRUCTIONS"}, timeout=prepare_timeout))
    time = 0.5 + reading
    frames.append(_frame(time, REST, click=True))
    time += CLICK_DURATION + 0.2
    frames.append(_frame(time, REST, wait={"study": "RUNNING"}, timeout=30.0))
    start = time + 1.0
    offset = [generator(study, participant, f"aim/{step.key}").uniform(-1.0, 1.0) * study.scripted.aim for _ in "xy"]
    for keyframe in script.keyframes:
        extra = {"click": True} if keyframe.click else {}
        if keyframe.wait is not None:
            wait = {name: value for name, value in _wait_fields(keyframe.wait).items() if value is not None}
            extra.update(wait=wait, timeout=keyframe.wait.timeout)
        position = [keyframe.position[0] + offset[0], keyframe.position[1] + offset[1], keyframe.position[2]]
        frames.append(_frame(start + scale * keyframe.time, position, keyframe.rpy, keyframe.gripper, **extra))
    time = start + scale * script.duration
    answers = None
    last = dataclasses.replace(script.keyframes[-1], position=tuple(frames[-1]["position"]))
    if questionnaire and study.questionnaire:
        timeout = task.timeout + prepare_timeout
        answering, time, answers = _answering(study, participant, step.condition, time, last, device_range, timeout)
        frames += answering
        frames.append(_frame(time + 1.0, REST))
    else:
        frames.append(_frame(time + 1.0, last.position, last.rpy, last.gripper))  # the task's end, held
    description = (
        f"scripted participant {participant}: {step.key} (pace {scale:.2f}, reading {reading:.1f} s, "
        f"aim off by {1000 * offset[0]:+.1f}, {1000 * offset[1]:+.1f} mm)"
    )
    text = _scenario_text(description, script.interpolation, max(script.click_duration, CLICK_DURATION), frames)
    return ScriptedTrial(text, answers)


def questionnaire_scenario(
    study: Study, participant: str, step: Step, device_range: float
) -> Tuple[str, Dict[str, float]]:
    """The scripted participant answering ``step``'s questionnaire alone (its trials were done before a crash)."""
    rest = Keyframe(0.0, tuple(REST), tuple(LEVEL), GRIPPER)
    frames = [_frame(0.0, REST)]
    answering, time, answers = _answering(study, participant, step.condition, 0.5, rest, device_range, 600.0)
    frames += answering
    frames.append(_frame(time + 1.0, REST))
    text = _scenario_text(f"scripted participant {participant}: {step.key}", "smooth", CLICK_DURATION, frames)
    return text, answers


def _answering(
    study: Study,
    participant: str,
    condition: str,
    time: float,
    last: Keyframe,
    device_range: float,
    wait_timeout: float,
) -> Tuple[List[dict], float, Dict[str, float]]:
    """Keyframes from ``time`` on: wait for the questionnaire holding ``last``, answer every item, submit."""
    answers = intended_answers(study, participant, condition)
    time += 0.5
    wait = {"study": "QUESTIONNAIRE"}
    frames = [_frame(time, last.position, last.rpy, last.gripper, wait=wait, timeout=wait_timeout)]
    for item in study.questionnaire:
        position = [slider_x(item, answers[item.name], device_range), 0.0, 0.0]
        time += 1.2
        frames.append(_frame(time, position))
        time += 0.4
        frames.append(_frame(time, position, click=True))
        time += CLICK_DURATION + 0.3  # the hand stays until the click has registered (at the flick's end)
        frames.append(_frame(time, position))
    time += 1.0
    frames.append(_frame(time, REST))
    time += 0.4
    frames.append(_frame(time, REST, click=True))  # submit
    return frames, time, answers


def _scenario_text(description: str, interpolation: str, click_duration: float, frames: List[dict]) -> str:
    """The scenario file, checked the way the device node will check it."""
    document = {
        "description": description,
        "interpolation": interpolation,
        "click_duration": click_duration,
        "keyframes": frames,
    }
    text = yaml.safe_dump(document, sort_keys=False, default_flow_style=None, width=160)
    parse_scenario(text, source=f"<{description}>")
    return text


def _wait_fields(wait) -> dict:
    fields = {
        "tab": TABS[wait.tab] if wait.tab is not None else None,
        "tree_running": wait.tree_running,
        "recording": wait.recording,
        "help_request": wait.help_request,
        "study": wait.study,
    }
    return fields
