"""Scenario files: validation with line/field messages, interpolation, scripted clicks, playback against a clock."""

import math
import pathlib
import textwrap

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from teleteach.haptics.click import ClickDetector, ClickParameters
from teleteach.haptics.scenario import (
    ScenarioBackend,
    ScenarioError,
    ScenarioTrajectory,
    check_clicks,
    load_scenario,
    parse_scenario,
)

ROOT = pathlib.Path(__file__).resolve().parents[2]

LINEAR = """\
interpolation: linear
keyframes:
  - {t: 0.0, position: [0.0, 0.0, 0.0], rpy: [0.0, 0.0, 0.0], gripper: 0.25}
  - {t: 1.0, position: [0.04, -0.02, 0.01], rpy: [0.0, 0.0, 0.8], gripper: 0.25, click: true}
  - {t: 3.0, position: [0.08, 0.02, -0.03], rpy: [0.3, -0.2, 0.8], gripper: 0.5}
"""


def rotation_matrix(roll, pitch, yaw):
    """R = Rz(yaw) Ry(pitch) Rx(roll), written out independently of scipy's euler conventions."""
    cr, sr, cp, sp, cy, sy = (
        math.cos(roll),
        math.sin(roll),
        math.cos(pitch),
        math.sin(pitch),
        math.cos(yaw),
        math.sin(yaw),
    )
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    return rz @ ry @ rx


def error_of(text):
    with pytest.raises(ScenarioError) as caught:
        parse_scenario(textwrap.dedent(text), source="bad.yaml")
    message = str(caught.value)
    assert "\n" not in message
    return message


# --- interpolation -----------------------------------------------------------------------------


def test_keyframes_are_hit_exactly():
    scenario = parse_scenario(LINEAR)
    trajectory = ScenarioTrajectory(scenario)
    for keyframe in scenario.keyframes:
        sample = trajectory.sample(keyframe.time)
        np.testing.assert_allclose(sample.position, keyframe.position, atol=1e-12)
        np.testing.assert_allclose(
            Rotation.from_quat(sample.orientation).as_matrix(), rotation_matrix(*keyframe.rpy), atol=1e-12
        )
        assert sample.gripper == pytest.approx(keyframe.gripper)


def test_linear_position_and_gripper_between_keyframes():
    trajectory = ScenarioTrajectory(parse_scenario(LINEAR))
    sample = trajectory.sample(2.5)  # 3/4 of the way from keyframe 1 to 2
    np.testing.assert_allclose(sample.position, [0.07, 0.01, -0.02], atol=1e-12)
    assert sample.gripper == pytest.approx(0.25 + 0.75 * 0.25)


def test_orientation_is_slerped_at_constant_angular_velocity():
    trajectory = ScenarioTrajectory(parse_scenario(LINEAR))
    # Between keyframes 0 and 1 only yaw changes (0 -> 0.8 rad in 1 s): at t the yaw is 0.8 t
    for time in (0.1, 0.25, 0.5, 0.9):
        matrix = Rotation.from_quat(trajectory.sample(time).orientation).as_matrix()
        np.testing.assert_allclose(matrix, rotation_matrix(0.0, 0.0, 0.8 * time), atol=1e-12)
    # Between keyframes 1 and 2 the rotation angle from keyframe 1 grows linearly
    start, end = rotation_matrix(0.0, 0.0, 0.8), rotation_matrix(0.3, -0.2, 0.8)
    total = Rotation.from_matrix(end @ start.T).magnitude()
    for fraction in (0.25, 0.5, 0.75):
        matrix = Rotation.from_quat(trajectory.sample(1.0 + 2.0 * fraction).orientation).as_matrix()
        assert Rotation.from_matrix(matrix @ start.T).magnitude() == pytest.approx(fraction * total, abs=1e-9)


def test_smooth_interpolation_hits_keyframes_is_continuous_and_never_overshoots():
    scenario = parse_scenario(LINEAR.replace("linear", "smooth"))
    trajectory = ScenarioTrajectory(scenario)
    times = np.arange(0.0, 3.0, 0.001)
    positions = np.array([trajectory.sample(time).position for time in times])
    for keyframe in scenario.keyframes:
        np.testing.assert_allclose(trajectory.sample(keyframe.time).position, keyframe.position, atol=1e-12)
    keyed = np.array([keyframe.position for keyframe in scenario.keyframes])
    assert (positions >= keyed.min(axis=0) - 1e-12).all() and (positions <= keyed.max(axis=0) + 1e-12).all()
    velocity = np.diff(positions, axis=0) / 0.001
    # Continuous velocity: no jump between successive steps (the linear version jumps at t = 1 s)
    assert np.abs(np.diff(velocity, axis=0)).max() < 0.01
    linear = ScenarioTrajectory(parse_scenario(LINEAR))
    linear_velocity = np.diff([linear.sample(time).position for time in times], axis=0) / 0.001
    assert np.abs(np.diff(linear_velocity, axis=0)).max() > 0.01


def test_holds_before_the_first_and_after_the_last_keyframe():
    scenario = parse_scenario(LINEAR)
    trajectory = ScenarioTrajectory(scenario)
    np.testing.assert_allclose(trajectory.sample(-2.0).position, scenario.keyframes[0].position)
    np.testing.assert_allclose(trajectory.sample(100.0).position, scenario.keyframes[-1].position)
    assert trajectory.sample(100.0).gripper == pytest.approx(0.5)


def test_a_single_keyframe_is_a_still_device():
    scenario = parse_scenario("keyframes:\n  - {t: 0, position: [0.01, 0.02, 0.03], rpy: [0, 0, 0], gripper: 0.3}\n")
    sample = ScenarioTrajectory(scenario).sample(5.0)
    np.testing.assert_allclose(sample.position, [0.01, 0.02, 0.03])


def test_click_flicks_the_gripper_and_is_detected_once():
    scenario = parse_scenario(LINEAR)
    trajectory = ScenarioTrajectory(scenario)
    times = np.arange(0.0, 3.0, 0.001)
    angles = [trajectory.gripper(time) for time in times]
    assert min(angles[1000:1200]) == pytest.approx(0.0, abs=1e-5)  # closed in the middle of the flick
    after = 1.0 + scenario.click_duration + 0.001
    assert trajectory.gripper(after) == pytest.approx(0.25 + 0.125 * (after - 1.0))  # back on the keyframe line
    detector = ClickDetector(ClickParameters.from_yaml())
    for time, angle in zip(times, angles):
        detector.update(time, angle)
    assert detector.clicks == 1


# --- validation --------------------------------------------------------------------------------


def test_missing_field_names_line_keyframe_and_field():
    message = error_of(
        """\
        keyframes:
          - {t: 0.0, position: [0, 0, 0], rpy: [0, 0, 0], gripper: 0.25}
          - t: 1.0
            position: [0, 0, 0]
            rpy: [0, 0, 0]
        """
    )
    assert message == "bad.yaml:3: keyframes[1]: missing field 'gripper'"


def test_non_monotonic_times_are_refused():
    message = error_of(
        """\
        keyframes:
          - {t: 0.0, position: [0, 0, 0], rpy: [0, 0, 0], gripper: 0.25}
          - {t: 2.0, position: [0, 0, 0], rpy: [0, 0, 0], gripper: 0.25}
          - {t: 2.0, position: [0, 0, 0], rpy: [0, 0, 0], gripper: 0.25}
        """
    )
    assert message.startswith("bad.yaml:4: keyframes[2].t: times must increase strictly")


def test_nan_is_refused_with_its_field_line():
    message = error_of(
        """\
        keyframes:
          - {t: 0.0, position: [0, 0, 0], rpy: [0, 0, 0], gripper: 0.25}
          - t: 1.0
            position: [0, 0, 0]
            rpy: [0, .nan, 0]
            gripper: 0.25
        """
    )
    assert message == "bad.yaml:5: keyframes[1].rpy: must be finite, got [0, nan, 0]"


@pytest.mark.parametrize(
    ("keyframe", "expected"),
    [
        ("{t: .inf, position: [0, 0, 0], rpy: [0, 0, 0], gripper: 0.25}", "keyframes[1].t: must be finite"),
        ("{t: 1, position: [0, 0], rpy: [0, 0, 0], gripper: 0.25}", "keyframes[1].position: must be a list of 3"),
        ("{t: 1, position: [0, 0, x], rpy: [0, 0, 0], gripper: 0.25}", "keyframes[1].position: must be a list of 3"),
        ("{t: 1, position: [0, 0, 0], rpy: [0, 0, 0], gripper: -0.1}", "keyframes[1].gripper: must be >= 0"),
        ("{t: 1, position: [0, 0, 0], rpy: [0, 0, 0], gripper: .nan}", "keyframes[1].gripper: must be finite"),
        ("{t: 1, position: [0, 0, 0], rpy: [0, 0, 0], gripper: 0.2, click: 1}", "keyframes[1].click: must be true"),
        ("{t: 1, position: [0, 0, 0], rpy: [0, 0, 0], grip: 0.2}", "keyframes[1]: unknown field 'grip'"),
        ("{t: -1, position: [0, 0, 0], rpy: [0, 0, 0], gripper: 0.2}", "keyframes[1].t: must be >= 0"),
        ("[1, 2, 3]", "keyframes[1]: a keyframe is a mapping"),
    ],
)
def test_bad_keyframe_fields(keyframe, expected):
    message = error_of(
        f"keyframes:\n  - {{t: 0, position: [0, 0, 0], rpy: [0, 0, 0], gripper: 0.25}}\n  - {keyframe}\n"
    )
    assert message.startswith("bad.yaml:3: "), message
    assert expected in message


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("keyframes: [\n", "bad.yaml:2: not valid YAML"),
        ("- 1\n- 2\n", "a scenario is a mapping"),
        ("keyframes: []\n", "bad.yaml:1: field 'keyframes' must be a non-empty list"),
        (
            "interpolation: cubic\nkeyframes: [{t: 0, position: [0,0,0], rpy: [0,0,0], gripper: 0}]\n",
            "bad.yaml:1: field 'interpolation'",
        ),
        (
            "click_duration: 0\nkeyframes: [{t: 0, position: [0,0,0], rpy: [0,0,0], gripper: 0}]\n",
            "field 'click_duration'",
        ),
        ("keyframe: []\n", "bad.yaml:1: unknown field 'keyframe'"),
    ],
)
def test_bad_files(text, expected):
    assert expected in error_of(text)


def test_overlapping_and_unfinished_clicks_are_refused():
    overlapping = error_of(
        """\
        keyframes:
          - {t: 0.0, position: [0, 0, 0], rpy: [0, 0, 0], gripper: 0.25, click: true}
          - {t: 0.1, position: [0, 0, 0], rpy: [0, 0, 0], gripper: 0.25, click: true}
          - {t: 2.0, position: [0, 0, 0], rpy: [0, 0, 0], gripper: 0.25}
        """
    )
    assert overlapping.startswith("bad.yaml:3: keyframes[1].click: starts at 0.1 s, before the click of keyframes[0]")
    unfinished = error_of(
        """\
        keyframes:
          - {t: 0.0, position: [0, 0, 0], rpy: [0, 0, 0], gripper: 0.25}
          - {t: 1.0, position: [0, 0, 0], rpy: [0, 0, 0], gripper: 0.25, click: true}
        """
    )
    assert unfinished.startswith("bad.yaml:3: keyframes[1].click: the click ends after the last keyframe")


def test_click_with_a_nearly_closed_gripper_is_refused_by_check_clicks():
    scenario = parse_scenario(
        textwrap.dedent(
            """\
            keyframes:
              - {t: 0.0, position: [0, 0, 0], rpy: [0, 0, 0], gripper: 0.15}
              - {t: 1.0, position: [0, 0, 0], rpy: [0, 0, 0], gripper: 0.15, click: true}
              - {t: 2.0, position: [0, 0, 0], rpy: [0, 0, 0], gripper: 0.15}
            """
        ),
        source="low.yaml",
    )
    with pytest.raises(ScenarioError, match=r"^low.yaml:3: keyframes\[1\].click: this flick would not be detected"):
        check_clicks(scenario, ClickParameters.from_yaml())
    check_clicks(scenario, ClickParameters.from_yaml(close_threshold=0.05, release_threshold=0.1))


def test_missing_file_is_a_scenario_error(tmp_path):
    with pytest.raises(ScenarioError, match="cannot read the scenario file"):
        load_scenario(tmp_path / "nope.yaml")


@pytest.mark.parametrize("name", ["example", "click_demo"])
def test_shipped_scenarios_are_valid(name):
    scenario = load_scenario(ROOT / "config" / "scenarios" / f"{name}.yaml")
    check_clicks(scenario, ClickParameters.from_yaml())
    assert scenario.click_times()


def test_click_demo_gives_three_clicks_and_no_click_for_the_slow_grip():
    scenario = load_scenario(ROOT / "config" / "scenarios" / "click_demo.yaml")
    trajectory = ScenarioTrajectory(scenario)
    detector = ClickDetector(ClickParameters.from_yaml())
    for time in np.arange(0.0, scenario.duration + 0.5, 0.001):
        detector.update(time, trajectory.gripper(time))
    assert detector.clicks == 3


# --- playback ----------------------------------------------------------------------------------


def test_backend_plays_against_its_clock_from_the_start_time():
    backend = ScenarioBackend(parse_scenario(LINEAR), start_time=100.0)
    np.testing.assert_allclose(backend.read(100.0).position, [0, 0, 0])
    np.testing.assert_allclose(backend.read(102.5).position, [0.07, 0.01, -0.02], atol=1e-12)
    backend.read(200.0)
    assert not backend.finished  # at_end = hold


def test_backend_finishes_after_the_last_keyframe_when_asked_to_exit():
    backend = ScenarioBackend(parse_scenario(LINEAR), start_time=10.0, at_end="exit")
    backend.read(12.9)
    assert not backend.finished
    backend.read(13.01)
    assert backend.finished


def test_backend_refuses_an_unknown_end_mode():
    with pytest.raises(ValueError, match="at_end"):
        ScenarioBackend(parse_scenario(LINEAR), 0.0, at_end="loop")
