"""Click emulation from the gripper angle: a quick close-and-back is one click, anything else is not."""

import numpy as np
import pytest

from teleteach.haptics.click import ClickDetector, ClickParameters, flick_gripper_angle

PARAMETERS = ClickParameters(close_threshold=0.1, release_threshold=0.2, max_duration=0.5, pulse_duration=0.1)
STEP = 0.001  # [s] 1 kHz like the node


def run(angles, parameters=PARAMETERS, start=0.0):
    """Feeds angles at 1 kHz; returns the detector and the button states."""
    detector = ClickDetector(parameters)
    states = [detector.update(start + index * STEP, angle) for index, angle in enumerate(angles)]
    return detector, np.array(states)


def rising_edges(states):
    return int(np.count_nonzero(states[1:] & ~states[:-1]) + (1 if states[0] else 0))


def segment(start, end, duration):
    return list(np.linspace(start, end, int(round(duration / STEP)), endpoint=False))


def test_quick_close_and_back_is_one_click():
    angles = [0.25] * 100 + segment(0.25, 0.0, 0.1) + segment(0.0, 0.25, 0.1) + [0.25] * 300
    detector, states = run(angles)
    # Expect one click, one rising edge, pressed for pulse_duration
    assert detector.clicks == 1
    assert rising_edges(states) == 1
    assert np.count_nonzero(states) == pytest.approx(PARAMETERS.pulse_duration / STEP, abs=1)


def test_button_goes_up_when_the_gripper_is_back_open():
    angles = [0.25] * 100 + segment(0.25, 0.0, 0.1) + segment(0.0, 0.25, 0.1) + [0.25] * 300
    _, states = run(angles)
    first_pressed = int(np.argmax(states))
    assert angles[first_pressed] > PARAMETERS.release_threshold
    assert angles[first_pressed - 1] <= PARAMETERS.release_threshold


def test_slow_close_and_back_is_not_a_click():
    # Closed for 1 s (a grip): longer than max_duration
    angles = [0.25] * 100 + segment(0.25, 0.0, 0.5) + [0.0] * 1000 + segment(0.0, 0.25, 0.5) + [0.25] * 200
    detector, states = run(angles)
    assert detector.clicks == 0
    assert not states.any()


def test_close_just_longer_than_max_duration_is_not_a_click_and_just_shorter_is():
    for closed_time, expected in ((0.45, 1), (0.55, 0)):
        angles = [0.25] * 50 + [0.05] * int(round(closed_time / STEP)) + [0.25] * 50
        detector, _ = run(angles)
        assert detector.clicks == expected, closed_time


def test_a_slow_close_does_not_block_the_next_click():
    slow = [0.25] * 50 + [0.0] * 800 + [0.25] * 50
    quick = [0.0] * 100 + [0.25] * 200
    detector, states = run(slow + quick)
    assert detector.clicks == 1
    assert rising_edges(states) == 1


def test_noise_around_the_close_threshold_while_held_is_one_gesture():
    rng = np.random.default_rng(1)
    held = list(0.1 + rng.uniform(-0.03, 0.03, 300))  # dips in and out of "closed", never back open
    angles = [0.25] * 50 + held + [0.25] * 200
    detector, states = run(angles)
    # Expect: one gesture (first dip -> release within 0.5 s) = exactly one click, no chatter
    assert detector.clicks == 1
    assert rising_edges(states) == 1


def test_noise_around_the_release_threshold_at_rest_is_no_click():
    rng = np.random.default_rng(2)
    angles = list(0.2 + rng.uniform(-0.05, 0.05, 3000))  # never below the close threshold
    detector, states = run(angles)
    assert detector.clicks == 0
    assert not states.any()


def test_noise_around_the_release_threshold_while_reopening_gives_one_click():
    rng = np.random.default_rng(3)
    reopening = list(0.2 + rng.uniform(-0.04, 0.04, 200))  # chatters across release, stays above close
    angles = [0.25] * 50 + [0.0] * 100 + reopening + [0.25] * 200
    detector, states = run(angles)
    assert detector.clicks == 1
    assert rising_edges(states) == 1


def test_starting_closed_is_not_a_click():
    angles = [0.0] * 100 + [0.25] * 200
    detector, _ = run(angles)
    assert detector.clicks == 0


def test_reset_forgets_a_close_in_progress():
    detector = ClickDetector(PARAMETERS)
    for index in range(50):
        detector.update(index * STEP, 0.25)
    detector.update(0.05, 0.0)
    detector.reset()
    assert not detector.update(0.06, 0.25)
    assert detector.clicks == 0


def test_scripted_flick_is_detected_as_exactly_one_click():
    times = np.arange(0.0, 1.0, STEP)
    angles = [flick_gripper_angle(0.25, time - 0.3, 0.2) for time in times]
    detector, states = run(angles)
    assert detector.clicks == 1
    assert rising_edges(states) == 1
    assert min(angles) == pytest.approx(0.0, abs=1e-6)
    assert angles[0] == angles[-1] == 0.25


def test_two_flicks_are_two_clicks():
    times = np.arange(0.0, 1.5, STEP)
    angles = [
        flick_gripper_angle(0.25, time - 0.2, 0.2) + flick_gripper_angle(0.25, time - 0.9, 0.2) - 0.25 for time in times
    ]
    detector, states = run(angles)
    assert detector.clicks == 2
    assert rising_edges(states) == 2


@pytest.mark.parametrize(
    "arguments, said",
    [
        ({"close_threshold": 0.2, "release_threshold": 0.1}, "need 0 <= close_threshold < release_threshold"),
        ({"close_threshold": 0.2, "release_threshold": 0.2}, "need 0 <= close_threshold < release_threshold"),
        ({"close_threshold": -0.1}, "got close -0.1 rad, release 0.2 rad"),
        ({"max_duration": 0.0}, "durations must be positive, got max_duration 0.0 s"),
        ({"pulse_duration": 0.0}, "pulse_duration 0.0 s"),
        ({"pulse_duration": -1.0}, "pulse_duration -1.0 s"),
        ({"release_threshold": float("nan")}, "must be finite numbers"),
    ],
)
def test_bad_parameters_are_refused_saying_why(arguments, said):
    with pytest.raises(ValueError, match=said):
        ClickParameters.from_yaml(**arguments)


def test_a_fully_closed_threshold_is_allowed():
    assert ClickParameters.from_yaml(close_threshold=0.0).close_threshold == 0.0


# Exact binary times and angles: each threshold and duration hit exactly
EXACT = ClickParameters(close_threshold=0.125, release_threshold=0.25, max_duration=0.5, pulse_duration=0.125)


def feed(samples):
    detector = ClickDetector(EXACT)
    return detector, [detector.update(time, angle) for time, angle in samples]


def test_the_thresholds_must_be_crossed_not_reached():
    # at exactly the release threshold the gripper is not open yet: it cannot arm, so the quick close is no click
    detector, _ = feed([(0.0, 0.25), (0.125, 0.0), (0.25, 0.5)])
    assert detector.clicks == 0
    # at exactly the close threshold the gripper is not closed yet
    detector, _ = feed([(0.0, 0.5), (0.125, 0.125), (0.25, 0.5)])
    assert detector.clicks == 0


def test_a_release_exactly_max_duration_after_the_close_is_a_click_pressed_for_exactly_pulse_duration():
    # closed at 0.25 s, between the thresholds at 0.75 s (not yet too long), released at 0.75 s
    detector, states = feed([(0.0, 0.5), (0.25, 0.0), (0.75, 0.2), (0.75, 0.5), (0.874, 0.5), (0.875, 0.5)])
    assert detector.clicks == 1
    assert states == [False, False, False, True, True, False]


def test_queued_clicks_are_pressed_one_release_pulse_apart():
    detector = ClickDetector(EXACT)
    double_click = [(0.0, 0.5), (0.125, 0.0), (0.25, 0.5), (0.375, 0.0), (0.5, 0.5)]
    detector.catch_up(double_click, now=1.0)
    # Expect: pressed from 1.0 to 1.125 s, released for one pulse, pressed again from 1.25 s
    states = [detector.update(time, 0.5) for time in (1.0, 1.124, 1.125, 1.249, 1.25, 1.374, 1.375)]
    assert detector.clicks == 2
    assert states == [True, True, False, False, True, True, False]


def test_clicks_of_a_second_stall_wait_for_those_still_pressed():
    detector = ClickDetector(EXACT)
    detector.catch_up([(0.0, 0.5), (0.125, 0.0), (0.25, 0.5), (0.375, 0.0), (0.5, 0.5)], now=1.0)
    # a second stall, over another double click, ends while the first click is still pressed
    detector.catch_up([(1.01, 0.0), (1.02, 0.5), (1.03, 0.0), (1.04, 0.5)], now=1.0625)
    times = np.arange(1.0625, 3.0, 0.001)
    states = np.array([True] + [detector.update(time, 0.5) for time in times[1:]])
    # Expect: four clicks, four presses of a pulse each, a pulse of release between them
    assert detector.clicks == 4
    assert rising_edges(states) == 4
    assert np.count_nonzero(states) == pytest.approx(4 * 125 - 62, abs=4)


def test_a_stall_s_click_found_during_a_press_or_its_release_gets_its_own_rising_edge():
    for stall_ends in (0.6, 0.7):  # during the press (0.5-0.625 s), during the release after it (0.625-0.75 s)
        detector, states = feed([(0.0, 0.5), (0.25, 0.0), (0.5, 0.5)])
        assert states[-1] and detector.clicks == 1
        detector.catch_up([(0.52, 0.0), (0.54, 0.5)], now=stall_ends)
        times = np.arange(stall_ends, 2.0, 0.001)
        states = np.array([detector.update(time, 0.5) for time in times])
        # Expect: the second click pressed for a pulse after a release of one pulse, not merged into the first
        assert detector.clicks == 2
        assert not states[(times > 0.626) & (times < 0.749)].any()
        assert states[(times > 0.751) & (times < 0.874)].all() and not states[times > 0.876].any()


def test_a_click_completed_while_the_last_one_is_pressed_gets_its_own_rising_edge():
    """A stall's catch-up pressed the first click late; the second completes, read live, while it is pressed."""
    detector = ClickDetector(EXACT)
    detector.catch_up([(0.0, 0.5), (0.125, 0.0), (0.25, 0.5)], now=0.5)
    times = np.arange(0.5, 1.5, 0.001)
    angles = [0.0 if 0.52 <= time < 0.56 else 0.5 for time in times]  # the second flick, released at 0.56 s
    states = np.array([detector.update(time, angle) for time, angle in zip(times, angles)])
    # Expect: two presses, the second after a release of one pulse, not one press stretched over both
    assert detector.clicks == 2
    assert rising_edges(states) == 2
    assert not states[(times > 0.626) & (times < 0.749)].any()


def test_a_queued_click_waits_until_a_release_was_returned():
    """A press was returned, then the loop stalled past its release and over another click: the button must be seen
    released once before the next press, or the reader sees one long press."""
    detector = ClickDetector(EXACT)
    assert detector.update(0.0, 0.5) is False
    detector.catch_up([(0.0, 0.5), (0.05, 0.0), (0.1, 0.5)], now=0.1)
    assert detector.update(0.1, 0.5) is True
    detector.catch_up([(0.5, 0.0), (0.55, 0.5)], now=2.0)  # a stall of 1.9 s
    # Expect: released at the first read after the stall, pressed again at the next
    assert [detector.update(time, 0.5) for time in (2.0, 2.001, 2.125, 2.126)] == [False, True, True, False]
    assert detector.clicks == 2
