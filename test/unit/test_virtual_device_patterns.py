"""The virtual device's keys 1 and 2 draw a wave and a cycloid that the shared controller recognises, through the
device's own twist estimate and the node's twist input (config/device.yaml, config/shared_control.yaml); the arrow
keys' steps never made a pattern (issue 54: the mode stayed UNKNOWN)."""

import numpy as np
import pytest
import yaml
from conftest import ROOT
from geometry_msgs.msg import TwistStamped

from teleteach.haptics.twist import TwistEstimator
from teleteach.haptics.virtual import VirtualDevice
from teleteach.shared_control.loop import SHARED, SharedControl, SharedControlConfig
from teleteach.shared_control.ros import command_from_twist

DEVICE_RATE = 200.0  # [Hz] the device node's publish rate (config/device.yaml)
CONTROL_RATE = 50.0  # [Hz] the shared controller's (config/shared_control.yaml)


class Clock:
    def __init__(self):
        self.now = 10.0

    def __call__(self):
        return self.now


def identified(draw, seconds=6.0):
    """The shared controller's (mode, skill) per cycle while ``draw`` moves the virtual device, through its twist."""
    node = yaml.safe_load((ROOT / "config" / "shared_control.yaml").read_text())
    cutoff = yaml.safe_load((ROOT / "config" / "device.yaml").read_text())["twist"]["cutoff_frequency"]
    clock = Clock()
    device = VirtualDevice(click_duration=0.2, double_click_gap=0.1, clock=clock)
    estimator = TwistEstimator(cutoff)
    controller = SharedControl(SharedControlConfig.from_yaml(solver="fast"))
    projection = np.asarray(node["twist_projection"], dtype=float)
    records, twist = [], TwistStamped()
    per_cycle = int(DEVICE_RATE / CONTROL_RATE)
    for step in range(int(seconds * DEVICE_RATE)):
        draw(device, step / DEVICE_RATE)
        sample = device.read(clock.now)
        linear, _ = estimator.update(clock.now, sample.position, sample.orientation)
        if step % per_cycle == 0:
            twist.twist.linear.x, twist.twist.linear.y, twist.twist.linear.z = linear
            command = command_from_twist(twist, projection, node["twist_scale"], node["twist_deadband"])
            record = controller.step(command)
            records.append((record.mode, record.skill))
        clock.now += 1.0 / DEVICE_RATE
    return records[len(records) // 2 :]  # the second half: after the window filled and the identification settled


@pytest.mark.parametrize("pattern", ["wave", "cycloid"])
def test_a_drawn_pattern_is_recognised_by_the_shared_controller(pattern):
    def press_once(device, time):
        if time == 0.0:
            device.draw(pattern)  # the key pressed once

    records = identified(press_once)
    # Expect: SHARED control of the drawn pattern in most cycles of the second half
    kept = sum(mode == SHARED and skill == pattern for mode, skill in records)
    assert kept >= 0.8 * len(records), records


def test_arrow_key_steps_make_no_pattern():
    def arrow_keys(device, time):
        step = round(time * DEVICE_RATE)
        if step % 20 == 0:  # a key press every 0.1 s: right, then up or down in turn (a hand trying a wave)
            device.move(dx=0.005, dy=0.005 if (step // 20) % 4 < 2 else -0.005)

    records = identified(arrow_keys)
    assert sum(mode == SHARED for mode, _ in records) < 0.5 * len(records)


def test_the_same_key_again_stops_the_stroke_where_the_handle_is():
    clock = Clock()
    device = VirtualDevice(click_duration=0.2, double_click_gap=0.1, clock=clock)
    device.draw("wave")
    clock.now += 1.3
    position, _, _ = device.state()
    device.draw("wave")
    assert device.drawing is None
    clock.now += 1.0
    # Expect: no jump when the stroke stops, and the handle still once it has
    np.testing.assert_allclose(device.state()[0], position)
    assert position[0] == pytest.approx(0.025 * 1.3)  # STROKE_SPEED along x
