"""The hand model (teleteach.haptics.hand): the device follows the intention, balances against the guidance's
force as springs in series do, settles in a detent, trembles with the configured RMS, and wraps any backend."""

import math

import numpy as np
import pytest

from teleteach.haptics.device import DeviceBackend, DeviceSample
from teleteach.haptics.guidance import AXES, AxisGuidance, Guidance, GuidanceLimits, GuidanceRenderer, Wrench
from teleteach.haptics.hand import HandModel, HandModelBackend, HandParameters, Tremor

STILL = np.zeros(6)


def settle(model, intended, renderer=None, seconds=2.0, start=0.0):
    """Run the model at 1 kHz with the guidance's wrench fed back; return the pose at the end."""
    pose = model.step(start, intended, Wrench.zero())
    for step in range(1, int(seconds * 1000) + 1):
        time = start + step / 1000.0
        wrench = Wrench.zero()
        if renderer is not None:
            quaternion = (0.0, 0.0, 0.0, 1.0)
            wrench = renderer.wrench(time, pose[:3], quaternion, np.zeros(3), np.zeros(3), 0.25)
        pose = model.step(time, intended, wrench)
    return pose


def renderer_of(**axes):
    renderer = GuidanceRenderer(GuidanceLimits.from_yaml(max_force=20.0, stale_after=100.0))
    renderer.set(Guidance(axes=tuple(axes.get(name, AxisGuidance()) for name in AXES), max_force=20.0), now=0.0)
    return renderer


def test_without_guidance_the_device_goes_where_the_hand_means():
    model = HandModel(HandParameters.from_yaml())
    model.step(0.0, STILL, Wrench.zero())
    intended = np.array([0.03, -0.02, 0.01, 0.2, 0.0, -0.1])
    np.testing.assert_allclose(settle(model, intended, start=0.001), intended, atol=1e-4)


def test_a_hold_spring_and_the_hand_balance_as_springs_in_series():
    parameters = HandParameters.from_yaml(stiffness=300.0)
    pose = settle(
        HandModel(parameters), np.array([0.02, 0, 0, 0, 0, 0]), renderer_of(x=AxisGuidance("hold", stiffness=100.0))
    )
    # Expect k_hand (0.02 - q) = k_guidance q: q = 0.02 * 300 / 400
    assert pose[0] == pytest.approx(0.015, abs=1e-4)


def test_a_hand_slightly_off_a_detent_settles_nearer_to_it():
    width = 0.2 / 23
    detents = AxisGuidance("detents", detents=(0.0, width, 2 * width), stiffness=400.0, width=width, damping=2.0)
    intended = np.array([width + 0.3 * width, 0, 0, 0, 0, 0])  # 30 % of a button off its centre
    pose = settle(HandModel(HandParameters.from_yaml()), intended, renderer_of(x=detents))
    assert abs(pose[0] - width) < 0.3 * width * 0.6


def test_tremor_has_the_configured_rms_in_its_band_and_is_seeded():
    tremor = Tremor(HandParameters.from_yaml(tremor_rms=0.002, seed=3))
    times = np.arange(0.0, 20.0, 0.001)
    offsets = np.array([tremor.at(time) for time in times])
    rms = np.sqrt(np.mean(offsets**2, axis=0))
    np.testing.assert_allclose(rms, 0.002, rtol=0.15)
    spectrum = np.abs(np.fft.rfft(offsets[:, 0]))
    frequencies = np.fft.rfftfreq(len(times), 0.001)
    peak = frequencies[np.argmax(spectrum)]
    assert 8.0 <= peak <= 12.0
    again = Tremor(HandParameters.from_yaml(tremor_rms=0.002, seed=3))
    assert np.array_equal(again.at(1.234), tremor.at(1.234))
    assert not np.array_equal(Tremor(HandParameters.from_yaml(tremor_rms=0.002, seed=4)).at(1.234), tremor.at(1.234))
    assert np.array_equal(Tremor(HandParameters.from_yaml()).at(5.0), np.zeros(3))


def test_a_stalled_loop_keeps_the_last_force_and_only_a_paused_one_restarts_the_model_at_the_intention():
    model = HandModel(HandParameters.from_yaml(stiffness=300.0))
    intended = np.array([0.02, 0, 0, 0, 0, 0])
    push_back = Wrench(np.array([-1.5, 0.0, 0.0]), np.zeros(3))
    model.step(0.0, intended, push_back)
    for step in range(1, 2001):
        pose = model.step(step / 1000.0, intended, push_back)
    # Expect the hand's 300 N/m against 1.5 N: 5 mm short of the intention, also after a 0.3 s stall of the loop
    assert pose[0] == pytest.approx(0.015, abs=1e-4)
    assert model.step(2.3, intended, push_back)[0] == pytest.approx(0.015, abs=1e-4)
    assert model.step(3.3, intended, push_back)[0] == 0.02  # a second without reads: the model starts afresh


def test_a_stall_while_the_device_moves_is_integrated_as_if_the_loop_had_read_every_millisecond():
    # The device frozen across a gap (or teleported to the intention) would differ from the model read at 1 kHz
    stalled, steady = HandModel(HandParameters.from_yaml()), HandModel(HandParameters.from_yaml())
    push_back = Wrench(np.array([-1.5, 0.0, 0.0]), np.zeros(3))
    for model in (stalled, steady):
        settle(model, STILL)
    intended = np.array([0.02, -0.01, 0, 0.2, 0, 0])
    for step in range(1, 101):
        expected = steady.step(2.0 + step / 1000.0, intended, push_back)
    pose = stalled.step(2.1, intended, push_back)  # a 0.1 s stall just as the hand starts to move
    np.testing.assert_allclose(pose, expected, atol=1e-4)
    # Expect the device moved (not frozen at 0) and the push felt (not teleported to the intention's 0.02 m)
    assert 0.01 < pose[0] < 0.018


def test_a_slow_loop_reads_the_same_trembling_device_as_a_1_khz_one():
    # The tremor held over each gap (evaluated at the read only) shakes a device read at a few hundred Hz harder:
    # the study's resting jitter then left the hand model's own band on a starved machine
    parameters = HandParameters.from_yaml(tremor_rms=0.001, seed=1)
    slow, steady = HandModel(parameters), HandModel(parameters)
    gaps = np.random.default_rng(5).choice([0.004, 0.004, 0.012, 0.05, 0.2], size=300)
    reads = np.round(np.cumsum(gaps), 3)
    expected = {}
    for tick in range(int(reads[-1] * 1000) + 1):
        expected[tick] = steady.step(tick / 1000.0, STILL, Wrench.zero())
    poses = np.array([slow.step(time, STILL, Wrench.zero()) for time in np.concatenate([[0.0], reads])])
    np.testing.assert_allclose(poses[1:], [expected[round(time * 1000)] for time in reads], atol=1e-7)
    assert np.std(poses[len(poses) // 2 :, 0]) > 1e-5  # the device trembles


class Intention(DeviceBackend):
    def __init__(self):
        self.x = 0.0
        self.closed = False
        self.failure = "waited too long"

    def read(self, time):
        return DeviceSample(np.array([self.x, 0.0, 0.0]), np.array([0.0, 0.0, 0.0, 1.0]), 0.3, button=True)

    def missed_gripper(self):
        return [(0.5, 0.0)]

    def close(self):
        self.closed = True


def test_the_backend_wrapper_moves_the_pose_and_passes_the_rest_through():
    inner = Intention()
    backend = HandModelBackend(inner, HandParameters.from_yaml())
    backend.read(0.0)
    inner.x = 0.02
    backend.render(Wrench(np.array([-3.0, 0.0, 0.0]), np.zeros(3)))
    sample = None
    for step in range(1, 2001):
        sample = backend.read(step / 1000.0)
    # Expect the 3 N push balanced by the hand: 0.02 - 3 / 300 = 0.01 m; gripper and button as the inner ones
    assert sample.position[0] == pytest.approx(0.01, abs=1e-4)
    assert (sample.gripper, sample.button) == (0.3, True)
    assert backend.missed_gripper() == [(0.5, 0.0)]  # a stall's flick, for the click detector's catch-up
    assert math.isclose(np.linalg.norm(sample.orientation), 1.0)
    assert backend.failure == "waited too long"
    backend.close()
    assert inner.closed


def test_bad_hand_parameters_are_named():
    with pytest.raises(ValueError, match="hand mass must be a positive number, got 0.0"):
        HandParameters.from_yaml(mass=0.0)
    with pytest.raises(ValueError, match=r"hand tremor_rms must be a number >= 0 \[m\], got -0.001"):
        HandParameters.from_yaml(tremor_rms=-0.001)
