"""The device loop without ROS: publishing, read errors (no stale data, throttled logs, recovery), rate keeping, and
the guidance's wrench rendered every cycle (zero once the device is lost)."""

import numpy as np
import pytest

from teleteach.haptics.click import ClickDetector, ClickParameters
from teleteach.haptics.device import DeviceBackend, DeviceReadError, DeviceSample
from teleteach.haptics.guidance import AxisGuidance, Guidance, GuidanceLimits, GuidanceRenderer
from teleteach.haptics.loop import Decimated, DeviceLoop, DeviceState, ThrottledLog, WallRate
from teleteach.haptics.scenario import ScenarioBackend, parse_scenario
from teleteach.haptics.twist import TwistEstimator


class Clock:
    def __init__(self, now=0.0):
        self.now = now

    def __call__(self):
        return self.now


class FlakyDevice(DeviceBackend):
    """A device whose reads fail while `failing` is set (a cable pulled out, say)."""

    def __init__(self):
        self.failing = False
        self.gripper = 0.25
        self.x = 0.0

    def read(self, time):
        if self.failing:
            raise DeviceReadError("USB transfer failed")
        return DeviceSample(np.array([self.x, 0.0, 0.0]), np.array([0.0, 0.0, 0.0, 1.0]), self.gripper)


def make_loop(backend, clock, wall_clock):
    published, errors, infos = [], [], []
    loop = DeviceLoop(
        backend,
        published.append,
        clock,
        ClickDetector(ClickParameters.from_yaml()),
        TwistEstimator(20.0),
        errors.append,
        infos.append,
        error_log_period=1.0,
        wall_clock=wall_clock,
    )
    return loop, published, errors, infos


def test_each_step_publishes_a_stamped_state():
    clock = Clock(5.0)
    device = FlakyDevice()
    loop, published, _, _ = make_loop(device, clock, clock)
    for index in range(100):
        clock.now = 5.0 + index * 0.001
        device.x = 0.02 * index * 0.001
        assert loop.step()
    assert len(published) == 100
    assert published[-1].stamp == pytest.approx(5.099)
    assert published[-1].linear_velocity[0] == pytest.approx(0.02, rel=0.01)
    assert published[-1].button is False
    assert loop.achieved_rate == pytest.approx(1000.0)


def test_decimated_publishing_passes_every_nth_cycle_and_each_button_change_at_once():
    published = []
    decimated = Decimated(published.append, 5)
    pressed = set(range(12, 14))  # a click's pulse of two cycles, between two published cycles
    for cycle in range(1, 21):
        decimated(
            DeviceState(
                cycle * 0.001, np.zeros(3), np.array([0, 0, 0, 1.0]), np.zeros(3), np.zeros(3), 0.25, cycle in pressed
            )
        )
    # Expect the first cycle (the button's first state), every fifth, the press and the release
    assert [round(state.stamp * 1000) for state in published] == [1, 5, 10, 12, 14, 15, 20]
    assert [state.button for state in published] == [False, False, False, True, False, False, False]


def test_read_errors_stop_publishing_are_logged_once_per_second_and_the_loop_recovers():
    clock = Clock(0.0)
    device = FlakyDevice()
    loop, published, errors, infos = make_loop(device, clock, clock)
    for index in range(10):
        clock.now = index * 0.001
        loop.step()
    device.failing = True
    for index in range(10, 2510):  # 2.5 s of failing reads at 1 kHz
        clock.now = index * 0.001
        assert not loop.step()
    # Expect: nothing published while failing, one report per second, each naming the error
    assert len(published) == 10
    assert len(errors) == 3
    assert all("USB transfer failed" in message for message in errors)
    assert "999 more times" in errors[1]
    device.failing = False
    clock.now = 2.6
    assert loop.step()
    assert len(published) == 11
    assert infos == ["device reads recovered after 2500 failures"]
    # The first state after the gap starts afresh: no velocity spike across the gap
    np.testing.assert_allclose(published[-1].linear_velocity, 0.0)


def test_a_click_interrupted_by_a_read_error_does_not_count():
    clock = Clock(0.0)
    device = FlakyDevice()
    loop, published, _, _ = make_loop(device, clock, clock)
    timeline = [(0.25, False)] * 50 + [(0.0, False)] * 50 + [(0.0, True)] * 20 + [(0.25, False)] * 50
    for index, (gripper, failing) in enumerate(timeline):
        clock.now = index * 0.001
        device.gripper, device.failing = gripper, failing
        loop.step()
    assert not any(state.button for state in published)


def test_a_native_button_is_passed_through():
    class NativeButton(FlakyDevice):
        def read(self, time):
            sample = super().read(time)
            sample.button = True
            return sample

    clock = Clock(0.0)
    loop, published, _, _ = make_loop(NativeButton(), clock, clock)
    loop.step()
    assert published[0].button is True


def test_run_stops_when_a_scenario_that_should_exit_has_played():
    clock = Clock(0.0)
    scenario = parse_scenario(
        "keyframes:\n  - {t: 0, position: [0,0,0], rpy: [0,0,0], gripper: 0.25}\n"
        "  - {t: 0.05, position: [0.01,0,0], rpy: [0,0,0], gripper: 0.25}\n"
    )
    backend = ScenarioBackend(scenario, start_time=0.0, at_end="exit")
    loop, published, _, _ = make_loop(backend, clock, clock)

    def advance(delay):
        clock.now += delay

    loop.run(WallRate(1000.0, clock=clock, sleep=advance), should_stop=lambda: False)
    # Expect: the whole scenario played at 1 kHz, then the loop ended by itself past the last keyframe
    assert len(published) in (51, 52)
    assert published[-1].stamp > 0.05
    np.testing.assert_allclose(published[-1].position, [0.01, 0, 0], atol=1e-12)


def test_wall_rate_keeps_absolute_deadlines():
    clock = Clock(0.0)
    sleeps = []

    def sleep(delay):
        sleeps.append(delay)
        clock.now += delay

    rate = WallRate(1000.0, clock=clock, sleep=sleep)
    for work in (0.0003, 0.0006, 0.0002, 0.0009):
        clock.now += work
        rate.sleep()
    # Expect: each sleep ends exactly on the next millisecond, whatever the work took (no drift)
    assert clock.now == pytest.approx(0.004)
    np.testing.assert_allclose(sleeps, [0.0007, 0.0004, 0.0008, 0.0001], atol=1e-12)


def test_wall_rate_catches_up_after_a_late_cycle_and_drops_a_long_stall():
    clock = Clock(0.0)
    sleeps = []

    def sleep(delay):
        sleeps.append(delay)
        clock.now += delay

    rate = WallRate(1000.0, max_lag=0.1, clock=clock, sleep=sleep)
    clock.now += 0.0035  # one cycle 3.5 ms late
    for _ in range(4):
        rate.sleep()
    # Expect: three cycles without sleeping, then back on the 1 ms grid
    assert sleeps == [pytest.approx(0.0005)]
    assert clock.now == pytest.approx(0.004)
    clock.now += 0.5  # a stall: 500 missed cycles are dropped, not published in a burst
    rate.sleep()
    assert rate.overruns == 1
    rate.sleep()
    assert clock.now == pytest.approx(0.505)


def test_throttled_log_counts_what_it_suppressed():
    clock = Clock(0.0)
    messages = []
    log = ThrottledLog(messages.append, period=1.0, clock=clock)
    for index in range(30):
        clock.now = index * 0.1
        log("problem")
    assert messages == [
        "problem",
        "problem (and 9 more times since the last report)",
        "problem (and 9 more times since the last report)",
    ]


def test_bad_rate_is_refused():
    with pytest.raises(ValueError):
        WallRate(0.0)


class ForceRecordingDevice(FlakyDevice):
    """A flaky device that also keeps every wrench the loop asks it to render."""

    def __init__(self):
        super().__init__()
        self.rendered = []

    def render(self, wrench):
        self.rendered.append(wrench)


def test_the_loop_renders_guidance_and_zero_once_the_device_is_lost():
    clock = Clock(0.0)
    device = ForceRecordingDevice()
    renderer = GuidanceRenderer(GuidanceLimits.from_yaml())
    published_wrenches = []
    loop = DeviceLoop(
        device,
        lambda state: None,
        clock,
        ClickDetector(ClickParameters.from_yaml()),
        TwistEstimator(20.0),
        lambda message: None,
        wall_clock=clock,
        guidance=renderer,
        publish_wrench=published_wrenches.append,
    )
    hold_x = AxisGuidance("hold", centre=0.0, stiffness=100.0)
    renderer.set(Guidance(axes=(hold_x, *[AxisGuidance()] * 5), max_force=4.0, max_torque=0.1), now=0.0)
    device.x = 0.01
    for step in range(400):
        clock.now = step * 0.001
        loop.step()
    # Expect the spring's 1 N back toward x = 0 once the 0.2 s ramp is over, every cycle rendered and reported
    assert device.rendered[-1].force[0] == pytest.approx(-1.0) and len(published_wrenches) == 400
    assert device.rendered[100].force[0] == pytest.approx(-0.5, abs=0.01)
    device.failing = True
    loop.step()
    # Expect a lost device to be sent zero and the guidance dropped: nothing comes back with the device
    assert np.all(device.rendered[-1].force == 0.0) and renderer.guidance is None
    device.failing = False
    loop.step()
    assert np.all(device.rendered[-1].force == 0.0)
