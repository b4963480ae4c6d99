"""The topic backend's input (teleteach.haptics.topic) without ROS: the latest good pose and gripper angle, bad input
refused with its reason, no input or silent input a failed read (nothing published, no force)."""

import math

import numpy as np
import pytest

from teleteach.haptics.device import DeviceReadError
from teleteach.haptics.guidance import Wrench
from teleteach.haptics.hand import HandModelBackend, HandParameters
from teleteach.haptics.topic import TopicInput

IDENTITY = (0.0, 0.0, 0.0, 1.0)


class Clock:
    def __init__(self):
        self.now = 100.0

    def __call__(self):
        return self.now


def test_reads_the_latest_input_and_fails_without_any_or_when_it_is_stale():
    clock = Clock()
    device = TopicInput(timeout=0.5, gripper=0.25, clock=clock)
    with pytest.raises(DeviceReadError, match="no input on sigma7/input/pose yet"):
        device.read(0.0)
    device.pose((0.01, -0.02, 0.03), (0.0, 0.0, math.sin(0.25), math.cos(0.25)))
    sample = device.read(0.0)
    np.testing.assert_allclose(sample.position, [0.01, -0.02, 0.03])
    assert sample.gripper == 0.25 and sample.button is None  # the gripper as configured until one arrives
    device.gripper(0.1)
    clock.now += 0.4
    assert device.read(0.0).gripper == 0.1
    clock.now += 0.2  # 0.6 s after the last pose
    with pytest.raises(DeviceReadError, match=r"no input on sigma7/input/pose for 0.60 s \(timeout 0.5 s\)"):
        device.read(0.0)
    device.pose((0.0, 0.0, 0.0), IDENTITY)
    np.testing.assert_allclose(device.read(0.0).position, [0.0, 0.0, 0.0])


@pytest.mark.parametrize(
    ("position", "orientation", "message"),
    [
        ((0.0, math.nan, 0.0), IDENTITY, "input pose must be 7 finite numbers"),
        ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 0.0), r"input orientation is not a unit quaternion \(norm 0.000\)"),
        ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 2.0), r"input orientation is not a unit quaternion \(norm 2.000\)"),
        ((0.0, 0.0), IDENTITY, "input pose must be 7 finite numbers"),
    ],
)
def test_a_bad_pose_is_refused_and_the_last_good_one_stays(position, orientation, message):
    device = TopicInput(timeout=0.5, gripper=0.25, clock=Clock())
    device.pose((0.05, 0.0, 0.0), IDENTITY)
    with pytest.raises(ValueError, match=message):
        device.pose(position, orientation)
    with pytest.raises(ValueError, match="input gripper angle must be a finite number >= 0 rad, got -0.1"):
        device.gripper(-0.1)
    sample = device.read(0.0)
    np.testing.assert_allclose(sample.position, [0.05, 0.0, 0.0])
    assert sample.gripper == 0.25


def test_bad_settings_are_refused():
    with pytest.raises(ValueError, match="~topic/timeout must be a positive number of seconds"):
        TopicInput(timeout=0.0, gripper=0.25)
    with pytest.raises(ValueError, match="~topic/gripper must be an angle >= 0 rad"):
        TopicInput(timeout=0.5, gripper=math.nan)


def test_with_the_hand_model_the_input_is_the_intention():
    clock = Clock()
    device = TopicInput(timeout=10.0, gripper=0.25, clock=clock)
    device.pose((0.04, 0.0, 0.0), IDENTITY)
    hand = HandModelBackend(device, HandParameters.from_yaml())
    hand.read(0.0)
    device.pose((0.0, 0.0, 0.0), IDENTITY)  # the operator means to move back to the origin
    hand.render(Wrench.zero())
    positions = [hand.read(step / 1000.0).position[0] for step in range(1, 2001)]
    # Expect the device to follow the intention with the hand's dynamics: not at once, there after 2 s
    assert positions[0] > 0.039 and abs(positions[-1]) < 1e-4
