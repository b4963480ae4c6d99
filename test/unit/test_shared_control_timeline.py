"""Commands placed by their stamps: the window the controller sees does not depend on how messages arrive."""

import math

import numpy as np
import pytest

from teleteach.shared_control.loop import SHARED, SharedControl, SharedControlConfig, identification_confidence
from teleteach.shared_control.models import synthetic_commands
from teleteach.shared_control.timeline import CommandTimeline

DT = 0.02
DELAY = 0.02  # config/shared_control.yaml command_delay
TIMEOUT = 0.2  # config/shared_control.yaml command_timeout


def operator(seconds=3.0):
    times = np.arange(0.0, seconds, DT)
    return times, synthetic_commands("wave", (0.03, 20.0, 0.0), 0.4, 0.05, times, 0.005, np.random.default_rng(2))


def windows(times, commands, arrivals, kept=None):
    """What the node samples each cycle (offset from the operator's clock) from messages arriving at ``arrivals``."""
    kept = np.ones(len(times), bool) if kept is None else kept
    order = np.argsort(arrivals, kind="stable")
    timeline = CommandTimeline(TIMEOUT)
    samples, received = [], 0
    for cycle_time in np.arange(0.1, times[-1], DT) + 0.007:
        while received < len(order) and arrivals[order[received]] <= cycle_time:
            index = order[received]
            if kept[index]:
                timeline.add(times[index], commands[index])
            received += 1
        samples.append(timeline.sample(cycle_time - DELAY))
    return np.array(samples)


def test_late_bunched_and_reordered_messages_give_the_same_window():
    times, commands = operator()
    on_time = windows(times, commands, times)
    rng = np.random.default_rng(0)
    late = windows(times, commands, times + rng.uniform(0.0, 0.015, len(times)))  # arrive out of order too
    # Every other message held back 15 ms: it arrives 5 ms before the next one.
    bunched = windows(times, commands, times + np.where(np.arange(len(times)) % 2 == 0, 0.015, 0.0))
    assert np.array_equal(late, on_time)
    assert np.array_equal(bunched, on_time)


def test_a_dropped_message_repeats_its_predecessor():
    times, commands = operator()
    kept = np.ones(len(times), bool)
    kept[10::25] = False
    on_time = windows(times, commands, times)
    dropped = windows(times, commands, times, kept)
    differ = np.flatnonzero(np.any(dropped != on_time, axis=1))
    assert 0 < len(differ) <= np.count_nonzero(~kept)
    for k in differ:
        assert np.array_equal(dropped[k], on_time[k - 1])


def test_silence_means_zero_and_the_last_message_is_held_until_the_timeout():
    timeline = CommandTimeline(TIMEOUT)
    assert np.array_equal(timeline.sample(1.0), np.zeros(2))
    timeline.add(1.0, [0.1, 0.0])
    assert np.array_equal(timeline.sample(0.99), np.zeros(2))  # nothing stamped before it yet
    assert np.allclose(timeline.sample(1.1), [0.1, 0.0])
    assert np.array_equal(timeline.sample(1.0 + TIMEOUT + 0.01), np.zeros(2))
    timeline.add(1.02, [0.0, 0.3])
    timeline.add(1.01, [0.0, 0.2])  # out of order: placed by its stamp
    assert np.allclose(timeline.sample(1.015), [0.0, 0.2])
    with pytest.raises(ValueError):
        CommandTimeline(0.0)


def test_confidence_is_the_normalised_margin_of_the_two_best_errors():
    assert identification_confidence([0.01, 0.04]) == pytest.approx(0.75)
    assert identification_confidence([0.04, 0.01, 0.02]) == pytest.approx(0.5)
    assert identification_confidence([0.02, 0.02]) == 0.0
    assert identification_confidence([0.02, math.inf]) == 1.0
    assert identification_confidence([math.inf, math.inf]) == 0.0


def test_switch_from_wave_to_cycloid_without_flicker_and_within_the_bound():
    config = SharedControlConfig.paper(solver="fast", window_time=0.8)
    controller = SharedControl(config, (0.0, 0.0))
    rng = np.random.default_rng(4)
    times = np.arange(0.0, 4.0, DT)
    first = synthetic_commands("wave", (0.02, 25.0, 0.0), -1.0, 0.05, times, 0.01, rng)
    second = synthetic_commands("cycloid", (0.02, 25.0, 0.0), -1.0, 0.05, times, 0.01, rng)
    records = [controller.step(c) for c in np.vstack([first, second])]
    skills = [r.skill for r in records if r.mode == SHARED]
    changes = [k for k in range(1, len(skills)) if skills[k] != skills[k - 1]]
    assert skills[0] == "wave" and skills[-1] == "cycloid"
    assert len(changes) == 1, f"the identification changed {len(changes)} times"
    detected = next(k for k in range(len(first), len(records)) if records[k].skill == "cycloid")
    assert (detected - len(first)) * DT <= 0.6
    assert all(0.0 <= r.confidence <= 1.0 for r in records)
