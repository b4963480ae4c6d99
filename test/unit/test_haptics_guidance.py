"""Haptic guidance rendering (teleteach.haptics.guidance) without ROS: the force laws, the caps for any input, the
blend on change, zero when stale or dropped, and every bad guidance refused with its reason."""

import dataclasses
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from teleteach.haptics.guidance import (
    AXES,
    AxisGuidance,
    Guidance,
    GuidanceError,
    GuidanceLimits,
    GuidanceRenderer,
    axis_force,
    render,
)

LIMITS = GuidanceLimits.from_yaml()
IDENTITY = (0.0, 0.0, 0.0, 1.0)
STILL = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))


def guidance(**axes):
    """Free everywhere except the named axes; caps at the node's limits."""
    return Guidance(axes=tuple(axes.get(name, AxisGuidance()) for name in AXES), max_force=4.0, max_torque=0.1)


def test_a_hold_axis_is_a_spring_to_its_centre_with_damping():
    hold = AxisGuidance("hold", centre=0.02, stiffness=100.0, damping=2.0)
    assert axis_force(hold, 0.03, 0.0) == pytest.approx(-1.0)
    assert axis_force(hold, 0.02, 0.5) == pytest.approx(-1.0)
    assert axis_force(AxisGuidance(damping=2.0), 0.5, -1.0) == pytest.approx(2.0)


def test_a_detent_well_pulls_to_the_nearest_position_and_lets_go_at_its_edge():
    detents = AxisGuidance("detents", detents=(-0.05, 0.0, 0.05), stiffness=200.0, width=0.05)
    # Expect: zero on a detent and on the boundary between two, stiffness k near a detent, strongest at w/4
    assert axis_force(detents, 0.0, 0.0) == pytest.approx(0.0)
    assert axis_force(detents, 0.025, 0.0) == pytest.approx(0.0, abs=1e-12)
    assert axis_force(detents, 0.001, 0.0) == pytest.approx(-200.0 * 0.001, rel=5e-3)
    peak = 200.0 * 0.05 / (2.0 * math.pi)
    assert axis_force(detents, 0.0125, 0.0) == pytest.approx(-peak)
    assert axis_force(detents, 0.05 - 0.0125, 0.0) == pytest.approx(peak)
    positions = np.linspace(-0.1, 0.1, 2001)
    forces = np.array([axis_force(detents, q, 0.0) for q in positions])
    assert np.max(np.abs(np.diff(forces))) < 0.1  # continuous: no jump anywhere


def test_rendered_wrench_never_exceeds_the_caps_and_is_finite_for_any_state():
    rng = np.random.default_rng(7)
    for _ in range(500):
        axes = {}
        for name in AXES:
            mode = rng.choice(["free", "hold", "detents"])
            axes[name] = AxisGuidance(
                str(mode),
                centre=float(rng.uniform(-0.2, 0.2)),
                detents=tuple(rng.uniform(-0.2, 0.2, rng.integers(1, 8))),
                stiffness=float(rng.uniform(0.0, 1e5)),
                width=float(rng.uniform(1e-4, 0.2)),
                damping=float(rng.uniform(0.0, 100.0)),
            )
        caps = dict(max_force=float(rng.uniform(0.0, 50.0)), max_torque=float(rng.uniform(0.0, 5.0)))
        gripper = dict(gripper_detent=0.15, gripper_stiffness=float(rng.uniform(0, 1e3)), gripper_width=0.1)
        wanted = Guidance(axes=tuple(axes[name] for name in AXES), **caps, **gripper)
        state = (
            rng.uniform(-0.3, 0.3, 3),
            Rotation.random(random_state=int(rng.integers(1 << 30))).as_quat(),
            rng.uniform(-5.0, 5.0, 3),
            rng.uniform(-20.0, 20.0, 3),
            float(rng.uniform(0.0, 0.6)),
        )
        wrench = render(wanted, LIMITS, *state)
        assert np.all(np.isfinite(wrench.force)) and np.all(np.isfinite(wrench.torque))
        assert np.linalg.norm(wrench.force) <= min(caps["max_force"], LIMITS.max_force) + 1e-9
        assert np.linalg.norm(wrench.torque) <= min(caps["max_torque"], LIMITS.max_torque) + 1e-9
        assert abs(wrench.gripper) <= LIMITS.max_gripper_force + 1e-9


def test_angles_are_the_gui_s_roll_pitch_yaw():
    dial = guidance(roll=AxisGuidance("hold", centre=0.0, stiffness=0.2))
    turned = Rotation.from_euler("ZYX", [0.0, 0.0, 0.3]).as_quat()
    wrench = render(dial, LIMITS, (0.0, 0.0, 0.0), turned, *STILL, 0.25)
    np.testing.assert_allclose(wrench.torque, [-0.06, 0.0, 0.0], atol=1e-9)


def test_new_guidance_blends_in_and_stale_or_dropped_guidance_renders_nothing():
    renderer = GuidanceRenderer(LIMITS)
    hold_y = guidance(y=AxisGuidance("hold", centre=0.0, stiffness=100.0))
    state = ((0.0, 0.01, 0.0), IDENTITY, *STILL, 0.25)
    assert np.all(renderer.wrench(0.0, *state).force == 0.0)
    renderer.set(hold_y, now=10.0)
    # Expect half of the spring's 1 N half way through the 0.2 s ramp, all of it after
    assert renderer.wrench(10.1, *state).force[1] == pytest.approx(-0.5)
    assert renderer.wrench(10.25, *state).force[1] == pytest.approx(-1.0)
    renderer.set(hold_y, now=10.4)  # a refresh: no new ramp
    assert renderer.wrench(10.45, *state).force[1] == pytest.approx(-1.0)
    assert renderer.wrench(10.4 + LIMITS.stale_after + 0.01, *state).force[1] == 0.0
    renderer.set(hold_y, now=20.0)
    renderer.drop()
    assert np.all(renderer.wrench(20.5, *state).force == 0.0) and renderer.guidance is None


def test_a_changed_guidance_blends_from_the_old_one():
    renderer = GuidanceRenderer(LIMITS)
    state = ((0.0, 0.01, 0.0), IDENTITY, *STILL, 0.25)
    renderer.set(guidance(y=AxisGuidance("hold", centre=0.0, stiffness=100.0)), now=0.0)
    renderer.set(guidance(y=AxisGuidance("hold", centre=0.0, stiffness=300.0)), now=1.0)
    assert renderer.wrench(1.1, *state).force[1] == pytest.approx(-2.0)


BAD = [
    ({"mode": "sticky"}, "axis y: unknown mode 'sticky'"),
    ({"mode": "hold", "stiffness": -1.0}, "axis y stiffness must be a finite number >= 0, got -1.0"),
    ({"mode": "hold", "stiffness": math.nan}, "axis y stiffness must be a finite number >= 0, got nan"),
    ({"mode": "hold", "centre": math.inf}, "axis y centre must be finite"),
    ({"mode": "detents", "stiffness": 1.0, "width": 0.01}, "axis y: detents need at least one position"),
    ({"mode": "detents", "detents": (0.0, math.nan), "width": 0.01}, "axis y detents must be finite"),
    ({"damping": -0.1}, "axis y damping must be a finite number >= 0"),
    ({"mode": "detents", "detents": tuple(range(1001)), "width": 0.01}, "axis y: 1001 detents, more than the 1000"),
]


@pytest.mark.parametrize(
    "fields, message", BAD, ids=[message.split(":")[0] + str(i) for i, (_, message) in enumerate(BAD)]
)
def test_bad_guidance_is_refused_with_its_reason(fields, message):
    with pytest.raises(GuidanceError, match=message.replace("(", r"\(").replace(")", r"\)")):
        guidance(y=AxisGuidance(**fields))


def test_bad_caps_and_gripper_are_refused():
    with pytest.raises(GuidanceError, match="max_force must be a finite number >= 0, got -4.0"):
        dataclasses.replace(guidance(), max_force=-4.0)
    with pytest.raises(GuidanceError, match="a gripper detent needs gripper_width > 0"):
        dataclasses.replace(guidance(), gripper_detent=0.1)
    with pytest.raises(GuidanceError, match="guidance needs 6 axes"):
        Guidance(axes=(AxisGuidance(),))
    with pytest.raises(GuidanceError, match="guidance max_force must be a positive number"):
        GuidanceLimits.from_yaml(max_force=0.0)


@pytest.mark.parametrize(
    ("field", "value", "limit"), [("max_force", 25.0, 20.0), ("max_torque", 0.5, 0.4), ("max_gripper_force", 9.0, 8.0)]
)
def test_the_node_s_caps_never_exceed_the_sigma7_s_own_limits(field, value, limit):
    with pytest.raises(GuidanceError, match=f"guidance {field} {value} is above the Sigma.7's own limit of {limit}"):
        GuidanceLimits.from_yaml(**{field: value})
    assert getattr(GuidanceLimits.from_yaml(**{field: limit}), field) == limit


def test_while_the_gripper_is_closed_for_a_click_a_detent_holds_the_device_at_its_well_s_centre():
    wells = AxisGuidance("detents", detents=(0.0, 0.01, 0.02), stiffness=400.0, width=0.01, click_stiffness=1500.0)
    patient = GuidanceLimits.from_yaml(stale_after=100.0)
    renderer = GuidanceRenderer(patient, click_below=0.2)
    renderer.set(guidance(x=wells), now=0.0)

    def force_x(now, x, gripper):
        return renderer.wrench(now, (x, 0.0, 0.0), IDENTITY, *STILL, gripper).force[0]

    # Expect the well's own force while the gripper rests, 1.2 mm off the middle well's centre
    well = axis_force(wells, 0.0112, 0.0)
    assert force_x(1.0, 0.0112, 0.25) == pytest.approx(well)
    # the finger closes the gripper: the hold blends in over 30 ms, then pulls with the click stiffness
    assert force_x(1.001, 0.0112, 0.15) == pytest.approx(well)
    assert force_x(1.016, 0.0112, 0.1) == pytest.approx(0.5 * well + 0.5 * -1.5 * 1.2, rel=1e-6)
    # pushed on into the next well, the hold stays at the centre the click began in (capped at 4 N)
    assert force_x(1.05, 0.0112, 0.0) == pytest.approx(-1.5 * 1.2)
    assert force_x(1.1, 0.0152, 0.05) == pytest.approx(-4.0)
    assert axis_force(wells, 0.0152, 0.0) > 0.0  # the wells alone would pull it on into the next one
    # the gripper back open: the wells again
    assert force_x(1.2, 0.0152, 0.25) == pytest.approx(axis_force(wells, 0.0152, 0.0))
    # a detent without a click stiffness, or a hold, is not changed by a click
    plain = GuidanceRenderer(patient, click_below=0.2)
    plain.set(guidance(x=dataclasses.replace(wells, click_stiffness=0.0)), now=0.0)
    assert plain.wrench(1.0, (0.0112, 0.0, 0.0), IDENTITY, *STILL, 0.0).force[0] == pytest.approx(well)
