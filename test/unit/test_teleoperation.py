"""Teleoperation's clutch and mapping (teleteach.core.teleoperation), checked against poses worked out by hand."""

import dataclasses
import math
import re

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from teleteach.core.gui_config import GuiConfig
from teleteach.core.teleoperation import (
    AssistanceParameters,
    Clutch,
    GripperClutch,
    ReplayCorrection,
    Teleoperation,
    TeleopParameters,
    TeleopParametersError,
)

# operator x (right) = base -y, operator y (away) = base x, z up in both: the operator stands behind the robot
BEHIND = ((0.0, 1.0, 0.0), (-1.0, 0.0, 0.0), (0.0, 0.0, 1.0))
PARAMETERS = TeleopParameters(
    scale=2.0,
    rotation_scale=0.5,
    operator_to_base=BEHIND,
    clutch_below=0.1,
    clutch_release_above=0.2,
    clutch_hold=0.6,
    max_speed=0.1,
    max_angular_speed=0.5,
    max_device_jump=0.03,
    workspace_low=(0.2, -0.5, 0.1),
    workspace_high=(0.9, 0.5, 1.2),
    assistance=AssistanceParameters(enabled=True, margin=0.001, capture=0.015, front_margin=0.005, reach=0.35),
)
ARM = np.array([0.5, 0.1, 0.6, 1.0, 0.0, 0.0, 0.0])  # hand pointing down (180 degrees about x)
LEVEL = (0.0, 0.0, 0.0, 1.0)
REST, CLOSED, OPEN = 0.25, 0.0, 0.5
DT = 0.005  # [s] the GUI's 200 Hz


class Operator:
    """Drives a Teleoperation tick by tick: a handle position, an orientation and a gripper angle."""

    def __init__(self, parameters=PARAMETERS, arm=ARM):
        self.teleop = Teleoperation(parameters)
        self.now = 10.0
        self.teleop.start(arm, self.now)
        self.position = np.zeros(3)
        self.orientation = LEVEL
        self.gripper = REST
        self.age = 0.0
        self.last = None
        self.hold(DT)  # the gripper resting when TELEOP takes the arm: a closed one must open first

    def hold(self, seconds, **changes):
        """Keep the device as it is (after ``changes``) for ``seconds``, ticking at 200 Hz; the last command."""
        for name, value in changes.items():
            setattr(self, name, np.asarray(value, dtype=float) if name == "position" else value)
        for _ in range(max(1, round(seconds / DT))):
            self.now += DT
            device = (self.position, self.orientation)
            self.last = self.teleop.update(self.now, self.gripper, device, self.age, 0.5)
        return self.last

    def glide(self, to, seconds):
        """Move the handle in a straight line to ``to`` over ``seconds`` (slow enough for the speed limit)."""
        start = self.position.copy()
        steps = round(seconds / DT)
        for step in range(1, steps + 1):
            self.hold(DT, position=start + (np.asarray(to) - start) * step / steps)
        return self.last

    def clutch(self):
        return self.hold(0.7, gripper=CLOSED)


def test_the_yaml_section_is_valid():
    assert isinstance(GuiConfig.load().teleop, TeleopParameters)


def test_a_gripper_closed_when_teleop_starts_must_open_before_the_clutch_engages():
    teleop = Teleoperation(PARAMETERS)
    teleop.start(ARM, 0.0)
    device = (np.zeros(3), LEVEL)
    command = teleop.update(1.0, CLOSED, device, 0.0, 0.5)
    assert command.clutch is Clutch.RELEASED and "open the gripper" in command.reason
    teleop.update(1.1, REST, device, 0.0, 0.5)
    teleop.update(1.2, CLOSED, device, 0.0, 0.5)
    assert teleop.update(1.9, CLOSED, device, 0.0, 0.5).clutch is Clutch.ENGAGED


def test_a_click_never_engages_and_the_arm_holds():
    operator = Operator()
    operator.hold(0.2, gripper=CLOSED)  # a click: closed 0.2 s and back
    command = operator.hold(0.3, gripper=REST, position=(0.02, 0.02, 0.0))
    # Expect the arm's pose held, the clutch released
    assert command.clutch is Clutch.RELEASED
    np.testing.assert_allclose(command.pose, ARM)


def test_the_handle_moves_the_equilibrium_in_the_base_frame_scaled():
    operator = Operator()
    assert operator.clutch().clutch is Clutch.ENGAGED
    command = operator.glide((0.01, 0.02, 0.005), 1.0)  # 2.3 cm in 1 s: under 0.1 m/s at scale 2
    command = operator.hold(0.2)
    # Expect away 2 cm -> base +x 4 cm; right 1 cm -> base -y 2 cm; up 0.5 cm -> up 1 cm (scale 2)
    np.testing.assert_allclose(command.pose[:3], ARM[:3] + [0.04, -0.02, 0.01], atol=1e-9)
    np.testing.assert_allclose(command.pose[3:], ARM[3:], atol=1e-9)
    assert command.reason == ""


def test_releasing_holds_and_the_next_clutch_goes_on_from_there():
    operator = Operator()
    operator.clutch()
    operator.glide((0.0, 0.02, 0.0), 1.0)
    held = operator.hold(0.2).pose
    operator.hold(0.1, gripper=REST)
    command = operator.glide((0.0, -0.03, 0.0), 1.0)  # the hand goes back without the arm
    np.testing.assert_allclose(command.pose, held)
    assert command.clutch is Clutch.RELEASED
    operator.clutch()
    operator.glide((0.0, -0.01, 0.0), 1.0)
    command = operator.hold(0.2)
    # Expect the second stroke (2 cm away -> 4 cm along base x) added to where the first one left the arm
    np.testing.assert_allclose(command.pose[:3], held[:3] + [0.04, 0.0, 0.0], atol=1e-9)


def test_the_equilibrium_moves_no_faster_than_the_speed_limit():
    operator = Operator()
    operator.clutch()
    operator.glide((0.0, 0.02, 0.0), 0.05)  # 4 cm of equilibrium asked for in 50 ms: 0.8 m/s
    command = operator.last
    moved = np.linalg.norm(command.pose[:3] - ARM[:3])
    # Expect 0.1 m/s over the 50 ms: 5 mm, and the limit named
    assert moved == pytest.approx(0.1 * 0.05, rel=0.03)
    assert "speed limit 0.1 m/s" in command.reason
    command = operator.hold(0.5)
    np.testing.assert_allclose(command.pose[:3], ARM[:3] + [0.04, 0.0, 0.0], atol=1e-9)
    assert command.reason == ""


def test_a_paused_clock_moves_nothing_and_divides_by_nothing():
    # Expect: two ticks at the same time (simulated time paused: dt = 0) hold the pose, the handle still or moved
    operator = Operator()
    operator.clutch()
    held = operator.hold(0.2)
    device = (operator.position, operator.orientation)
    again = operator.teleop.update(operator.now, operator.gripper, device, 0.0, 0.5)
    np.testing.assert_array_equal(again.pose, held.pose)
    assert again.reason == ""
    moved = (operator.position + np.array([0.0, 0.005, 0.0]), Rotation.from_euler("z", 0.1).as_quat())
    again = operator.teleop.update(operator.now, operator.gripper, moved, 0.0, 0.5)
    np.testing.assert_array_equal(again.pose, held.pose)
    assert "speed limit" in again.reason and "angular speed limit" in again.reason


def test_the_workspace_bounds_the_equilibrium_and_an_arm_outside_may_only_come_back():
    operator = Operator()
    operator.clutch()
    operator.glide((0.0, 0.0, 0.35), 8.0)  # 70 cm up asked: the box ends at z 1.2
    command = operator.hold(0.2)
    assert command.pose[2] == pytest.approx(1.2)
    assert "workspace limit" in command.reason
    outside = ARM.copy()
    outside[0] = 1.0  # beyond workspace_high x = 0.9
    operator = Operator(arm=outside)
    operator.clutch()
    command = operator.glide((0.0, 0.01, 0.0), 1.0)  # further out: refused
    assert command.pose[0] == pytest.approx(1.0) and "workspace limit" in command.reason
    operator.glide((0.0, -0.03, 0.0), 2.0)  # back in: followed
    assert operator.hold(0.2).pose[0] == pytest.approx(1.0 - 0.06)


def test_the_handle_turns_the_hand_about_base_axes_scaled():
    operator = Operator()
    operator.clutch()
    yaw, roll = 0.4, 0.2
    for fraction in np.linspace(0.0, 1.0, 200):  # 1 s: 0.2 rad/s of equilibrium, under the limit
        operator.hold(DT, orientation=Rotation.from_rotvec([roll * fraction, 0.0, yaw * fraction]).as_quat())
    command = operator.hold(0.2)
    # Expect the handle's rotation vector (0.2, 0, 0.4) in the operator frame = (0, -0.2, 0.4) in the base frame,
    # halved (rotation_scale), applied to the hand's orientation
    expected = Rotation.from_rotvec([0.0, -0.1, 0.2]) * Rotation.from_quat(ARM[3:])
    assert (Rotation.from_quat(command.pose[3:]) * expected.inv()).magnitude() < 1e-6
    np.testing.assert_allclose(command.pose[:3], ARM[:3], atol=1e-9)


def test_a_lost_device_holds_and_releases_the_clutch_until_the_gripper_opens():
    operator = Operator()
    operator.clutch()
    operator.glide((0.0, 0.01, 0.0), 0.5)
    held = operator.hold(0.2).pose
    command = operator.hold(DT, age=0.5)  # a pose exactly device_timeout old (0.5 s) still counts
    assert command.clutch is Clutch.ENGAGED and command.reason == ""
    command = operator.hold(0.1, age=0.6, position=(0.0, 0.05, 0.0))
    assert command.clutch is Clutch.RELEASED and command.reason.startswith("device lost")
    np.testing.assert_allclose(command.pose, held)
    # back, still closed: the clutch waits for the gripper to open first
    command = operator.hold(1.0, age=0.0)
    assert command.clutch is Clutch.RELEASED and "open the gripper" in command.reason
    np.testing.assert_allclose(command.pose, held)
    operator.hold(0.1, gripper=REST)
    assert operator.clutch().clutch is Clutch.ENGAGED


@pytest.mark.parametrize(
    "position, orientation, why",
    [
        ((math.nan, 0.0, 0.0), LEVEL, "NaN"),
        ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 2.0), "not unit"),
        ((0.0, 0.0, 0.0, 0.0), LEVEL, "must have 3 values"),
    ],
)
def test_a_device_pose_that_is_not_a_pose_holds_with_a_reason(position, orientation, why):
    operator = Operator()
    operator.clutch()
    command = operator.hold(DT, position=position[:3] if len(position) == 3 else position, orientation=orientation)
    assert command.clutch is Clutch.RELEASED
    assert command.reason.startswith("device pose refused") and why in command.reason
    np.testing.assert_allclose(command.pose, ARM)


def test_a_jump_of_the_handle_holds_until_the_gripper_opens_again():
    operator = Operator()
    operator.clutch()
    command = operator.hold(DT, position=(0.0, 0.05, 0.0))
    assert command.reason.startswith("device pose jumped 5.0 cm (limit 3.0 cm)")
    assert command.clutch is Clutch.RELEASED
    command = operator.hold(1.0)
    np.testing.assert_allclose(command.pose, ARM)


def test_nothing_is_commanded_before_the_start_or_after_the_stop():
    teleop = Teleoperation(PARAMETERS)
    assert teleop.update(1.0, CLOSED, ((0.0, 0.0, 0.0), LEVEL), 0.0, 0.5).pose is None
    teleop.start(ARM, 1.0)
    teleop.stop()
    assert teleop.update(2.0, CLOSED, ((0.0, 0.0, 0.0), LEVEL), 0.0, 0.5).pose is None


@pytest.mark.parametrize(
    "change, named",
    [
        (
            {"operator_to_base": ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, -1.0))},
            "^teleop/operator_to_base: .* is not a rotation",
        ),
        ({"operator_to_base": ((1.0, 0.0), (0.0, 1.0))}, "^teleop/operator_to_base: a 3x3"),
        ({"workspace_low": (1.0, -0.5, 0.1)}, "workspace_low"),
        ({"workspace_low": ("low", -0.5, 0.1)}, "^teleop/workspace_low .* must lie below workspace_high"),
        ({"workspace_high": None}, "^teleop/workspace_low .* must lie below workspace_high"),
        ({"clutch_below": 0.3}, "hysteresis"),
        ({"max_speed": 0.0}, "max_speed"),
        ({"rotation_scale": -1.0}, "rotation_scale"),
    ],
)
def test_bad_parameters_are_named(change, named):
    with pytest.raises(TeleopParametersError, match=named):
        dataclasses.replace(PARAMETERS, **change)


def test_before_the_start_the_clutch_is_released_and_the_reason_says_what_is_missing():
    teleop = Teleoperation(PARAMETERS)
    assert teleop.clutch is Clutch.RELEASED
    command = teleop.update(1.0, CLOSED, ((0.0, 0.0, 0.0), LEVEL), 0.0, 0.5)
    assert (command.clutch, command.reason) == (Clutch.RELEASED, "not started: waiting for the arm's pose")


def test_an_arm_pose_that_is_not_a_pose_is_refused_by_name():
    teleop = Teleoperation(PARAMETERS)
    with pytest.raises(ValueError, match="arm pose contains NaN"):
        teleop.start([math.nan, 0, 0, 0, 0, 0, 1], 0.0)
    with pytest.raises(ValueError, match="arm orientation is not unit"):
        teleop.start([0, 0, 0, 0, 0, 0, 2], 0.0)


def test_a_short_close_moving_the_handle_moves_nothing_and_a_normal_release_says_nothing():
    operator = Operator()
    operator.hold(DT, gripper=CLOSED)
    operator.glide((0.0, 0.02, 0.0), 0.3)  # closed shorter than clutch_hold, the handle moving
    command = operator.hold(0.3, gripper=REST, position=(0.0, 0.0, 0.0))
    np.testing.assert_allclose(command.pose, ARM)
    assert (command.clutch, command.reason) == (Clutch.RELEASED, "")


def test_the_clutch_keeps_closing_and_stays_engaged_between_the_two_thresholds():
    operator = Operator()
    operator.hold(DT, gripper=0.1)  # at clutch_below: not closed yet
    assert operator.hold(1.0).clutch is Clutch.RELEASED
    operator.hold(0.1, gripper=CLOSED)
    assert operator.hold(0.6, gripper=0.15).clutch is Clutch.ENGAGED  # half open: still closing, then engaged
    assert operator.hold(0.1, gripper=0.2).clutch is Clutch.ENGAGED  # at clutch_release_above: still engaged
    assert operator.hold(DT, gripper=0.21).clutch is Clutch.RELEASED


@pytest.mark.parametrize("gripper", [None, math.nan])
def test_no_gripper_angle_releases_the_clutch(gripper):
    operator = Operator()
    operator.clutch()
    command = operator.hold(DT, gripper=gripper)
    assert (command.clutch, command.reason) == (Clutch.RELEASED, "")


def test_both_limits_are_named_together_and_the_hand_turns_no_faster_than_its_limit():
    operator = Operator(arm=np.array([0.5, 0.1, 1.19, *ARM[3:]]))
    operator.clutch()
    command = operator.hold(DT, position=(0.0, 0.0, 0.03))  # 6 cm up at once: beyond the box's 1.2 m, and fast
    assert command.reason == "workspace limit; speed limit 0.1 m/s"
    operator = Operator()
    operator.clutch()
    turn = Rotation.from_rotvec([0.0, 0.0, 0.6]).as_quat()  # 0.3 rad of hand (rotation_scale 0.5) at once
    command = operator.hold(0.1, orientation=turn)
    turned = (Rotation.from_quat(command.pose[3:]) * Rotation.from_quat(ARM[3:]).inv()).magnitude()
    assert turned == pytest.approx(0.5 * 0.1, rel=0.03)  # 0.5 rad/s for 0.1 s
    assert command.reason == "angular speed limit 0.5 rad/s"
    assert command.pose[6] >= 0.0  # the same rotation written with w >= 0
    command = operator.hold(1.0)
    assert (Rotation.from_quat(command.pose[3:]) * Rotation.from_quat(ARM[3:]).inv()).magnitude() == pytest.approx(0.3)


def test_after_a_refused_pose_or_a_jump_the_gripper_must_open_before_the_arm_follows_again():
    for refused in ((math.nan, 0.0, 0.0), (0.0, 0.05, 0.0)):
        operator = Operator()
        operator.clutch()
        command = operator.hold(DT, position=refused)
        assert command.reason.startswith(("device pose refused (device position contains NaN", "device pose jumped"))
        operator.position = np.zeros(3)
        command = operator.glide((0.0, 0.05, 0.02), 1.5)  # still closed: the handle moves, the arm does not
        np.testing.assert_allclose(command.pose, ARM)
        assert command.reason == "open the gripper, then close it to move the arm"
    assert operator.hold(DT, position=(0.0, 0.0, 0.0), orientation=(0.0, 0.0, 0.0, 2.0)).reason.startswith(
        "device pose refused (device orientation is not unit"
    )


def test_a_jump_is_told_in_centimetres_with_what_to_do():
    operator = Operator()
    operator.clutch()
    command = operator.hold(DT, position=(0.0, 0.05, 0.0))
    assert command.reason == "device pose jumped 5.0 cm (limit 3.0 cm): holding; open and close the gripper to go on"


@pytest.mark.parametrize(
    "change",
    [
        {"rotation_scale": 0.0},  # the hand keeps its orientation
        {"clutch_below": 0.0},
        {
            "operator_to_base": tuple(
                tuple(round(v, 6) for v in row) for row in Rotation.from_euler("z", 0.5).as_matrix()
            )
        },
    ],
)
def test_parameters_at_their_bounds_are_accepted(change):
    dataclasses.replace(PARAMETERS, **change)


@pytest.mark.parametrize(
    "change, named",
    [
        ({"clutch_below": 0.2}, "hysteresis"),
        ({"operator_to_base": "behind"}, "3x3"),
        ({"operator_to_base": ((0.0, 1.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, 1.0))}, "not a rotation"),  # a mirror
        ({"workspace_low": (0.2, -0.5)}, r"workspace_low .* \(3 numbers each, base frame \[m\]\)"),
        ({"workspace_high": (0.9, 0.5, math.nan)}, "workspace_high"),
        ({"workspace_high": (0.9, 0.5, 0.1)}, "workspace_high"),  # an empty box: z from 0.1 to 0.1
        ({"rotation_scale": math.inf}, "rotation_scale"),
    ],
)
def test_more_bad_parameters_are_named(change, named):
    with pytest.raises(TeleopParametersError, match=named):
        dataclasses.replace(PARAMETERS, **change)


def test_the_commanded_orientation_is_written_with_w_at_least_zero():
    operator = Operator()
    operator.clutch()
    for fraction in np.linspace(0.0, 1.0, 200):  # pitch (about the operator's y, away) 0.2 rad: 0.1 about base x
        command = operator.hold(DT, orientation=Rotation.from_rotvec([0.0, 0.2 * fraction, 0.0]).as_quat())
        assert command.pose[6] >= 0.0 and np.linalg.norm(command.pose[3:]) == pytest.approx(1.0)
    expected = Rotation.from_rotvec([0.1, 0.0, 0.0]) * Rotation.from_quat(ARM[3:])
    np.testing.assert_allclose(command.pose[3:], expected.as_quat() * np.sign(expected.as_quat()[3]), atol=1e-9)


def correct(correction, skill, seconds, start, position, gripper, period=0.05, max_correction=0.04):
    """Feed ``correction`` one skill-server report every ``period`` [s] for ``seconds``; the last command."""
    command = None
    for step in range(max(1, round(seconds / period))):
        now = start + (step + 1) * period
        command = correction.update(now, skill, max_correction, gripper, (position, LEVEL), 0.0, 0.5)
    return command, now


def test_a_replay_correction_starts_at_zero_follows_the_clutched_handle_and_stays_in_its_box():
    correction = ReplayCorrection(PARAMETERS)
    up = np.array([0.0, 0.0, 0.01])
    assert correction.update(0.0, "", 0.04, REST, (up, LEVEL), 0.0, 0.5) is None  # nothing replays
    assert correction.update(0.0, "Place", math.nan, REST, (up, LEVEL), 0.0, 0.5) is None  # no box: none
    command, now = correct(correction, "Place", 1.0, 0.0, up, REST)
    np.testing.assert_allclose(command.pose, [0, 0, 0, 0, 0, 0, 1])  # the handle alone corrects nothing
    command, now = correct(correction, "Place", 1.0, now, up, CLOSED)
    assert command.clutch is Clutch.ENGAGED
    # 2 cm up the handle, scale 2: 4 cm up, at 0.1 m/s (0.4 s)
    command, now = correct(correction, "Place", 0.5, now, up + np.array([0.0, 0.0, 0.02]), CLOSED)
    np.testing.assert_allclose(command.pose[:3], [0.0, 0.0, 0.04], atol=1e-9)
    # farther: held at the box of max_correction, away (operator y) turning into base x
    command, now = correct(correction, "Place", 1.0, now, up + np.array([0.0, 0.02, 0.03]), CLOSED)
    np.testing.assert_allclose(command.pose[:3], [0.04, 0.0, 0.04], atol=1e-9)
    assert command.reason == "workspace limit"
    command, now = correct(correction, "Place", 0.2, now, up + np.array([0.0, 0.02, 0.03]), REST)
    np.testing.assert_allclose(command.pose[:3], [0.04, 0.0, 0.04], atol=1e-9)  # released: held
    # another skill, or the same after a pause in the reports: a new replay, from zero
    command, later = correct(correction, "Other", 0.05, now, up, REST)
    np.testing.assert_allclose(command.pose[:3], 0.0)
    correct(correction, "Other", 1.0, later, up, CLOSED)
    command, now = correct(correction, "Other", 0.5, later + 1.0, up + np.array([0.0, 0.0, 0.01]), CLOSED)
    np.testing.assert_allclose(command.pose[:3], [0.0, 0.0, 0.02], atol=1e-9)
    command, _ = correct(correction, "Other", 0.05, now + ReplayCorrection.REPLAY_GAP + 0.01, up, REST)
    np.testing.assert_allclose(command.pose[:3], 0.0)


@pytest.mark.parametrize("box", [math.inf, 0.0, -0.01, math.nan])
def test_a_replay_correction_needs_a_box_it_can_move_in(box):
    correction = ReplayCorrection(PARAMETERS)
    assert correction.update(1.0, "Place", box, REST, (np.zeros(3), LEVEL), 0.0, 0.5) is None


def test_reports_exactly_the_replay_gap_apart_belong_to_one_replay():
    correction = ReplayCorrection(PARAMETERS)
    up = np.zeros(3)
    _, now = correct(correction, "Place", 0.1, 0.0, up, REST)
    _, now = correct(correction, "Place", 1.0, now, up, CLOSED)
    command, now = correct(correction, "Place", 0.5, now, up + np.array([0.0, 0.0, 0.01]), CLOSED)
    np.testing.assert_allclose(command.pose[:3], [0.0, 0.0, 0.02], atol=1e-9)
    now = float(np.round(now))  # a time the gap adds to exactly
    correction.update(now, "Place", 0.04, CLOSED, (up + np.array([0.0, 0.0, 0.01]), LEVEL), 0.0, 0.5)
    command = correction.update(
        now + ReplayCorrection.REPLAY_GAP, "Place", 0.04, CLOSED, (up + np.array([0.0, 0.0, 0.01]), LEVEL), 0.0, 0.5
    )
    np.testing.assert_allclose(command.pose[:3], [0.0, 0.0, 0.02], atol=1e-9)


@pytest.mark.parametrize(
    "change, named",
    [
        ({"enabled": 1}, "teleop/assistance/enabled must be true or false, got 1"),
        ({"margin": -0.001}, "teleop/assistance/margin must be a number >= 0 [m], got -0.001"),
        ({"capture": math.nan}, "teleop/assistance/capture must be a number >= 0 [m], got nan"),
        ({"reach": "far"}, "teleop/assistance/reach must be a number >= 0 [m], got 'far'"),
    ],
)
def test_bad_assistance_parameters_are_named(change, named):
    with pytest.raises(TeleopParametersError, match=re.escape(named)):
        dataclasses.replace(PARAMETERS.assistance, **change)


def test_assistance_parameters_of_zero_are_accepted():
    assert dataclasses.replace(PARAMETERS.assistance, margin=0.0, front_margin=0.0).margin == 0.0


def test_a_constraint_turns_the_target_the_handle_asks_for_and_says_so():
    asked = []

    def keep_below(pose_now, target):
        asked.append((pose_now.copy(), target.copy()))
        return np.minimum(target, ARM[:3] + [1.0, 1.0, 0.01]), "held in the corridor"

    operator = Operator()
    operator.clutch()
    operator.teleop.update(operator.now + DT, CLOSED, (np.zeros(3), LEVEL), 0.0, 0.5, keep_below)
    operator.now += DT
    np.testing.assert_allclose(asked[-1][0], ARM)  # what the constraint is given: the pose now, then the target
    command = None
    for step in range(1, 201):
        operator.now += DT
        device = (np.array([0.0, 0.0, 0.02]) * min(1.0, step / 100), LEVEL)
        command = operator.teleop.update(operator.now, CLOSED, device, 0.0, 0.5, keep_below)
    # Expect the handle's 4 cm up (scale 2) turned into the 1 cm the constraint allows, and the reason said
    np.testing.assert_allclose(asked[-1][1], ARM[:3] + [0.0, 0.0, 0.04], atol=1e-9)
    np.testing.assert_allclose(command.pose[:3], ARM[:3] + [0.0, 0.0, 0.01], atol=1e-9)
    assert command.reason == "held in the corridor"
    quiet = Operator()  # a constraint that says nothing adds nothing to the reason
    quiet.clutch()
    quiet.now += DT
    said = quiet.teleop.update(quiet.now, CLOSED, (np.array([0.0, 0.0, 0.0001]), LEVEL), 0.0, 0.5, lambda p, t: (t, ""))
    assert said.reason == ""
    fast = quiet.teleop.update(
        quiet.now + DT, CLOSED, (np.array([0.0, 0.0, 0.02]), LEVEL), 0.0, 0.5, lambda p, t: (t, "")
    )
    assert fast.reason == "speed limit 0.1 m/s"
    np.testing.assert_allclose(asked[-1][0][:3], command.pose[:3], atol=1e-9)


def test_the_gripper_clutch_engages_exactly_after_clutch_hold_closed_and_says_so_once():
    clutch = GripperClutch(PARAMETERS)
    # Expect: a fresh clutch needs no opening first; closed at 1.0 s, engaged at exactly 1.6 s, reported once
    assert clutch.update(1.0, CLOSED) is False and clutch.state is Clutch.CLOSING
    assert clutch.update(1.0 + 0.5 * PARAMETERS.clutch_hold, CLOSED) is False
    assert clutch.update(0.0 + PARAMETERS.clutch_hold + 1.0, CLOSED) is True and clutch.state is Clutch.ENGAGED
    assert clutch.update(2.0, CLOSED) is False and clutch.state is Clutch.ENGAGED
    # between the closing and the opening angles it holds; opened beyond clutch_release_above it releases
    assert clutch.update(2.1, 0.15) is False and clutch.state is Clutch.ENGAGED
    assert clutch.update(2.2, OPEN) is False and clutch.state is Clutch.RELEASED
    assert clutch.update(2.3, 0.15) is False and clutch.state is Clutch.RELEASED  # half-closed: no clutch
    fresh = GripperClutch(PARAMETERS)
    fresh.update(0.0, CLOSED)
    assert fresh.update(PARAMETERS.clutch_hold, CLOSED) is True  # a hold of exactly clutch_hold engages


def test_after_a_refusal_the_gripper_clutch_engages_only_once_the_gripper_was_opened():
    clutch = GripperClutch(PARAMETERS)
    clutch.release(must_reopen=True)
    for time in (0.0, 1.0, 2.0):  # held closed: never
        assert clutch.update(time, CLOSED) is False and clutch.state is Clutch.RELEASED
    assert clutch.update(2.1, OPEN) is False and not clutch.must_reopen
    clutch.update(2.2, CLOSED)
    assert clutch.update(2.2 + PARAMETERS.clutch_hold, CLOSED) is True
    assert clutch.update(3.5, float("nan")) is False and clutch.state is Clutch.RELEASED  # a lost reading opens it
