"""The shared-control MPC loop: constraints never violated, safe fallback on bad input, records complete."""

import math

import numpy as np
import pytest

from teleteach.msg import SharedControlState
from teleteach.shared_control.constraints import Box, StraightEdge, violation
from teleteach.shared_control.loop import DIRECT, FALLBACK, SHARED, UNKNOWN, Mode, SharedControl, SharedControlConfig
from teleteach.shared_control.models import synthetic_commands
from teleteach.shared_control.operators import commands_around_path, lasa_path
from teleteach.shared_control.problems import recency_weights

DT = 0.02
TOLERANCE = 1e-6


@pytest.fixture(scope="module")
def controller():
    return SharedControl(SharedControlConfig.paper(solver="fast"), (0.5, 0.0))


def wave(duration, heading=math.pi, seed=0):
    times = np.arange(0, duration, DT)
    return synthetic_commands("wave", (0.03, 20.0, 0.0), heading, 0.05, times, 0.02, np.random.default_rng(seed))


def test_static_boundary_is_never_crossed_while_direct_control_crosses(controller):
    box = Box(-1.0, -0.06, 1.0, 0.2)
    commands = wave(6.0, heading=math.pi + 0.2)
    direct = np.array([0.5, 0.0]) + np.cumsum(commands, axis=0) * DT
    assert violation(direct.T, box, None) > 0.01  # the operator's input leads across the boundary
    controller.reset((0.5, 0.0))
    controller.set_boundary(box)
    controller.set_obstacle(None)
    records = [controller.step(c) for c in commands]
    states = np.array([r.state for r in records]).T
    assert violation(states, box, None) <= TOLERANCE
    assert sum(r.mode == SHARED for r in records) > 0.9 * (len(records) - 50)
    assert states[1].min() < -0.05  # it did go along the boundary rather than stop early
    for record in records:
        assert record.skill in ("", "wave", "cycloid")
        if record.mode == SHARED:
            assert violation(record.plan, box, None) <= TOLERANCE


def test_a_plan_is_shown_as_the_robot_follows_it_stopped_at_the_constraints():
    # The rostest's run (the node's configuration): a wave drifting up into y = 0.08, then an edge below. One cycle's
    # optimisation stops at its iteration cap with a last iterate 21 mm past the boundary (CI showed such a plan).
    box, edge = Box(-0.25, -0.05, 0.25, 0.08), StraightEdge(0.0, -0.02, math.pi / 2)
    controller = SharedControl(SharedControlConfig.from_yaml(solver="fast"), box=box)
    commands = synthetic_commands("wave", (0.03, 20.0, 0.0), math.pi - 0.5, 0.05, np.arange(0, 5.0, DT))
    margin, worst, planned = controller.config.margin, 0.0, 0
    for k, command in enumerate(commands):
        obstacle = edge if k >= 150 else None
        controller.set_obstacle(obstacle)
        record = controller.step(command)
        if record.plan.size:
            planned += 1
            worst = max(worst, violation(record.plan, box, obstacle, margin))
        assert violation(np.array(record.state), box, obstacle) <= TOLERANCE
    assert planned > 150 and worst <= TOLERANCE


def test_moving_straight_edge_is_never_crossed(controller):
    box = Box(-1.0, -0.08, 1.0, 0.2)
    controller.reset((0.5, 0.0))
    controller.set_boundary(box)
    worst = 0.0
    modes = []
    for k, command in enumerate(wave(6.0, seed=1)):
        # The edge comes down from y = 0.08 to y = 0.01 and back (free side below it).
        edge = StraightEdge(0.0, 0.08 - 0.07 * math.sin(math.pi * k * DT / 6.0), -math.pi / 2)
        controller.set_obstacle(edge)
        record = controller.step(command)
        modes.append(record.mode)
        worst = max(worst, violation(np.array(record.state), box, edge))
    assert worst <= TOLERANCE
    assert modes.count(SHARED) > 0.9 * (len(modes) - 50)
    controller.set_obstacle(None)


def test_non_finite_huge_and_malformed_commands_are_replaced_and_reported(controller):
    box = Box(-1.0, -0.5, 1.0, 0.5)
    controller.reset((0.0, 0.0))
    controller.set_boundary(box)
    controller.set_obstacle(None)
    # Empty window: the first command is NaN, so direct control holds.
    record = controller.step([math.nan, 0.0])
    assert record.mode == DIRECT
    assert record.state == (0.0, 0.0)
    assert "non-finite" in record.message
    record = controller.step([1e9, 0.0])
    assert "clipped" in record.message
    assert violation(np.array(record.state), box, None) <= TOLERANCE
    for bad in (None, "fast", [1.0], [[math.inf, 1.0]]):
        record = controller.step(bad)
        assert "rejected" in record.message
        assert all(math.isfinite(v) for v in record.state)
    # In shared control too: a wave, then garbage, never leaves the box and never raises.
    commands = list(wave(1.5))
    commands[60] = [math.nan, math.inf]
    commands[61] = [1e12, -1e12]
    for command in commands:
        record = controller.step(command)
        assert violation(np.array(record.state), box, None) <= TOLERANCE
        assert all(math.isfinite(v) for v in record.state)


def test_obstacle_covering_the_robot_moves_it_out_without_a_jump(controller):
    box = Box(-1.0, -0.5, 1.0, 0.5)
    controller.reset((0.0, 0.0))
    controller.set_boundary(box)
    controller.set_obstacle(None)
    for command in wave(1.2):
        controller.step(command)
    x, y = controller.state
    edge = StraightEdge(x, y + 0.05, math.pi / 2)  # free side starts 5 cm above the robot: it is covered
    controller.set_obstacle(edge)
    step = controller.config.recovery_speed * DT
    previous = np.array([x, y])
    # Expect: FALLBACK, saying why, moving straight up (towards the nearest point that keeps the margin) by at most
    # recovery_speed x dt each cycle until free: at the edge, 5 cm up.
    cycles = 0
    while violation(previous, box, edge) > 0.0:
        record = controller.step(wave(0.02)[0])
        assert record.mode == FALLBACK
        assert "moving there" in record.message
        assert np.linalg.norm(np.array(record.state) - previous) <= step + 1e-12
        assert record.state[0] == pytest.approx(x, abs=1e-9)
        previous = np.array(record.state)
        cycles += 1
    assert cycles == math.ceil(0.05 / step - 1e-9)
    assert record.state[1] == pytest.approx(y + 0.05, abs=1e-9)
    assert violation(np.array(record.state), box, edge) <= TOLERANCE
    # The loop carries on from there and stays free.
    for command in wave(1.0, seed=2):
        record = controller.step(command)
        assert violation(np.array(record.state), box, edge) <= TOLERANCE
    controller.set_obstacle(None)


def test_obstacle_covering_the_whole_workspace_holds_and_says_so(controller):
    box = Box(-1.0, -0.5, 1.0, 0.5)
    controller.reset((0.0, 0.0))
    controller.set_boundary(box)
    controller.set_obstacle(StraightEdge(5.0, 0.0, 0.0))
    record = controller.step([0.01, 0.0])
    assert record.mode == FALLBACK
    assert "no free state" in record.message
    assert record.state == (0.0, 0.0)
    controller.set_obstacle(None)


def test_a_boundary_tighter_than_the_margin_is_kept_and_the_margin_said_lost(controller):
    controller.reset((0.0, 0.0))
    controller.set_boundary(Box(-1.0, -0.5, 1.0, 0.5))
    controller.set_obstacle(None)
    for command in wave(1.5):
        controller.step(command)
    x, y = controller.state
    # A boundary tighter than the optimisation's margin around the robot: no plan keeps the margin.
    half = controller.config.margin / 2
    box = Box(x - half, y - half, x + half, y + half)
    controller.set_boundary(box)
    for command in wave(1.0, seed=4):
        record = controller.step(command)
        assert record.mode in (SHARED, UNKNOWN, FALLBACK)
        assert "mm margin" in record.message or "no free state exists within the margin" in record.message
        assert violation(np.array(record.state), box, None) <= TOLERANCE


def test_operator_pushing_into_the_boundary_stays_shared_and_slides_along_it():
    # The operator waves towards -x at 5 cm/s and keeps pushing 10 s after meeting the boundary at x = -0.1 m.
    controller = SharedControl(SharedControlConfig.from_yaml(solver="fast"), (0.0, 0.0), Box(-0.1, -0.15, 0.25, 0.15))
    commands = synthetic_commands(
        "wave", (0.015, 14.0, 0.0), math.pi, 0.05, np.arange(0, 12.0, DT), 0.008, np.random.default_rng(3)
    )
    records = [controller.step(command) for command in commands]
    pushing = records[int(3.0 / DT) :]
    # Expect: never outside the boundary, no FALLBACK, the wave kept, the plan's step stopped at the constraint.
    assert max(violation(np.array(r.state), controller.box, None) for r in records) <= TOLERANCE
    assert sum(r.mode == FALLBACK for r in pushing) == 0
    identified = [r.skill for r in pushing if r.mode in (SHARED, UNKNOWN)]
    assert identified.count("wave") >= 0.99 * len(pushing)
    assert min(r.state[0] for r in pushing) < -0.1 + 0.006
    assert any("no plan keeps the 5 mm margin" in r.message for r in pushing)


def cycloid_into_the_top_of_the_boundary():
    """A controller and the commands of a wave, then a cycloid of 11 cm/s that meets the top of its boundary."""
    controller = SharedControl(SharedControlConfig.from_yaml(solver="fast"), (0.0, 0.0), Box(-0.25, -0.15, 0.25, 0.15))
    rng = np.random.default_rng(5)
    times = np.arange(0.0, 4.0, DT)
    commands = np.vstack(
        [synthetic_commands(s, (0.015, 12.0, 0.0), 1.21, 0.05, times, 0.01, rng) for s in ("wave", "cycloid")]
    )
    return controller, commands


def operator_paces(controller, commands) -> np.ndarray:
    """Per cycle, the fastest command of the window up to and including it [m/s]."""
    window, speeds = controller.config.n_window, np.linalg.norm(commands, axis=1)
    return np.array([speeds[max(0, i - window + 1) : i + 1].max() for i in range(len(commands))])


def test_no_executed_step_is_faster_than_the_operator_moved_in_the_window():
    # At the boundary, last iterates at the iteration cap planned loops of up to 7 m/s (the first measured: a 5.5 cm
    # loop at 20 cm/s, first step 1.58 m/s), which the blend with the operator's step made up to 0.6 m/s.
    controller, commands = cycloid_into_the_top_of_the_boundary()
    records = [controller.step(command) for command in commands]
    states = np.array([(0.0, 0.0)] + [r.state for r in records])
    speeds = np.linalg.norm(np.diff(states, axis=0), axis=1) / DT
    paces = operator_paces(controller, commands)
    assert np.all(speeds <= paces + TOLERANCE / DT), f"{np.max(speeds - paces):.3f} m/s above the operator's pace"
    assert any("paced to the operator's" in r.message for r in records), "no step was paced: the case tests nothing"
    assert max(violation(np.array(r.state), controller.box, None) for r in records) <= TOLERANCE


def fail_every_estimation(controller, monkeypatch):
    def crash(*args, **kwargs):
        raise RuntimeError("solver crashed (injected)")

    for estimation in controller.estimations.values():
        monkeypatch.setattr(estimation, "solve", crash)


@pytest.mark.parametrize("cycle", ["late", "failed"])
def test_a_plan_faster_than_the_operator_is_followed_at_the_operators_pace(cycle, monkeypatch):
    # After a cycle whose plan ran away (paced), the next cycle follows that plan without solving: a late cycle
    # (coast) or a failed solve (FALLBACK). Its next state lies a plan's step away, far more than the operator moved.
    controller, commands = cycloid_into_the_top_of_the_boundary()
    paces = operator_paces(controller, commands)
    k = next(i for i, command in enumerate(commands) if "paced to the operator's" in controller.step(command).message)
    before, planned = np.array(controller.state), controller.plan[:, controller.plan_index + 1]
    assert np.linalg.norm(planned - before) > 2 * paces[k + 1] * DT
    if cycle == "late":
        record = controller.coast(commands[k + 1])
    else:
        fail_every_estimation(controller, monkeypatch)
        record = controller.step(commands[k + 1])
        assert record.mode == FALLBACK and "fallback: following the previous plan" in record.message
    # Expect: towards the plan's next state, as fast as the operator's fastest command of the window, said so.
    assert "paced to the operator's" in record.message
    step, towards = np.array(record.state) - before, planned - before
    assert np.linalg.norm(step) == pytest.approx(paces[k + 1] * DT)
    assert step[0] * towards[1] - step[1] * towards[0] == pytest.approx(0.0, abs=1e-12)
    assert np.dot(step, towards) > 0.0


@pytest.mark.slow
def test_a_wave_around_a_turning_human_stroke_is_identified_with_a_free_heading():
    # The LASA stroke "Sine" (one of the sweep's tuned shapes), 40 cm across at 5 cm/s, turns at 0.6 rad/s (median
    # curvature 12.5 1/m); the estimation's Clothoid may bend 0.1 rad/s (2 1/m). With the heading held near the
    # followed skill's (0.001 rad a cycle) the fits lag the turn and the cycloid explains half the windows better.
    path = lasa_path("Sine", 0, DT, 0.4, 0.05)
    wave = ("wave", (0.015, 14.0, 0.0))
    commands = commands_around_path(path, DT, (wave, wave), math.inf, 0.008, np.random.default_rng(1))
    shares = {}
    for heading_continuity in (3.1416, 0.001):
        config = SharedControlConfig.from_yaml(solver="fast", heading_continuity=heading_continuity)
        skills = identified_skills(SharedControl(config), commands)
        shares[heading_continuity] = skills.count("wave") / len(skills)
    assert shares[3.1416] >= 0.85
    assert shares[3.1416] - shares[0.001] >= 0.25


@pytest.mark.parametrize("skill, other", [("wave", "cycloid"), ("cycloid", "wave")])
def test_a_window_alone_is_fitted_best_by_its_own_skill_whatever_came_before(controller, skill, other):
    # The controller has just followed the other pattern: window_fits must not carry its heading or estimates over.
    times = np.arange(0.0, controller.config.window_time, DT)
    rng = np.random.default_rng(4)
    controller.reset((0.5, 0.0))
    for command in synthetic_commands(other, (0.03, 20.0, 0.0), 0.5, 0.05, np.arange(0.0, 2.0, DT), 0.0, rng):
        controller.step(command)
    window = synthetic_commands(skill, (0.02, 15.0, 0.01), 2.5, 0.05, times, 0.005, rng)
    fits = controller.window_fits(window)
    assert set(fits) == {"wave", "cycloid"}
    assert fits[skill] < 0.2 * fits[other]


def test_coasting_follows_the_previous_plan_and_keeps_the_window_on_the_grid():
    controller = SharedControl(SharedControlConfig.from_yaml(solver="fast"), (0.0, 0.0))
    commands = wave(3.0)
    for command in commands[:100]:
        record = controller.step(command)
    assert record.mode == SHARED
    plan, index = controller.plan.copy(), controller.plan_index
    coasted = [controller.coast(command) for command in commands[100:105]]
    # Expect: the next five states of the previous plan, SHARED, said so; the window took the five commands.
    for k, record in enumerate(coasted):
        assert record.mode == SHARED
        assert "late cycle: following the previous plan" in record.message
        assert np.allclose(record.state, plan[:, index + k + 1])
    assert np.allclose(controller.window[-1], commands[104])
    # Solving again carries on from there, still the wave.
    record = controller.step(commands[105])
    assert record.mode == SHARED and record.skill == "wave"
    assert np.linalg.norm(np.array(record.state) - coasted[-1].state) < 0.01


def test_record_has_the_state_message_fields(controller):
    controller.reset((0.1, 0.2))
    controller.set_boundary(None)
    controller.set_obstacle(None)
    records = [controller.step(c) for c in wave(1.2)]
    first, last = records[0], records[-1]
    assert first.mode == DIRECT and first.skill == "" and first.fitting_errors == []
    assert last.mode == SHARED
    assert last.skills == ["wave", "cycloid"]
    assert len(last.fitting_errors) == 2 and len(last.parameters) == 7
    assert last.estimation_time > 0 and last.optimisation_time > 0
    assert last.command == pytest.approx(tuple(wave(1.2)[-1]))
    assert last.plan.shape == (2, 51)
    assert np.allclose(last.plan[:, 1], last.state)


def test_bad_configuration_is_rejected_and_changes_nothing(controller):
    before = controller.box
    with pytest.raises(TypeError):
        controller.set_boundary((0, 0, 1, 1))
    with pytest.raises(TypeError):
        controller.set_obstacle("edge")
    assert controller.box is before
    with pytest.raises(ValueError):
        controller.reset((math.nan, 0.0))
    with pytest.raises(ValueError):
        SharedControl(SharedControlConfig.paper(skills=("spiral",), solver="fast"))


def test_idle_operator_restarts_the_estimation(controller):
    controller.reset((0.0, 0.0))
    controller.set_boundary(None)
    controller.set_obstacle(None)
    for command in wave(1.5):
        controller.step(command)
    records = [controller.step([0.0, 0.0]) for _ in range(60)]
    assert records[-1].mode == DIRECT
    assert any("operator idle" in r.message for r in records)
    # Moving again: direct control for one window, then shared control on the new motion only.
    records = [controller.step(c) for c in wave(1.2, seed=5)]
    assert records[10].mode == DIRECT
    assert records[-1].mode == SHARED and records[-1].skill == "wave"


def test_ros_message_conversions_and_task_plane():
    from geometry_msgs.msg import PoseStamped, TwistStamped, Vector3Stamped
    from sensor_msgs.msg import Joy

    from teleteach.shared_control.plane import TaskPlane
    from teleteach.shared_control.ros import (
        InvalidMessageError,
        command_from_joy,
        command_from_twist,
        command_from_vector,
        obstacle_from_pose,
    )

    vector = Vector3Stamped()
    vector.vector.x, vector.vector.y, vector.vector.z = 0.1, -0.2, 5.0
    assert command_from_vector(vector).tolist() == [0.1, -0.2]
    vector.vector.x = math.nan
    with pytest.raises(InvalidMessageError):
        command_from_vector(vector)
    twist = TwistStamped()
    twist.twist.linear.x, twist.twist.linear.y, twist.twist.linear.z = 0.01, 0.02, 0.03
    projection = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    assert command_from_twist(twist, projection, 2.0) == pytest.approx([0.04, 0.06])
    joy = Joy(axes=[0.5, -1.0, 0.0])
    assert command_from_joy(joy, (0, 1), (0.2, 0.1)) == pytest.approx([0.1, -0.1])
    with pytest.raises(InvalidMessageError):
        command_from_joy(joy, (0, 5), (0.2, 0.1))
    pose = PoseStamped()
    pose.pose.position.x, pose.pose.position.y = 0.1, 0.2
    pose.pose.orientation.z, pose.pose.orientation.w = math.sin(0.3), math.cos(0.3)
    edge = obstacle_from_pose(pose)
    assert (edge.x, edge.y, edge.yaw) == pytest.approx((0.1, 0.2, 0.6))
    pose.pose.orientation.w = pose.pose.orientation.z = 0.0
    with pytest.raises(InvalidMessageError):
        obstacle_from_pose(pose)
    down = (0.0, 0.7071067811865476, 0.0, 0.7071067811865476)
    plane = TaskPlane(origin=(0.5, 0.0, 0.4), x_axis=(0.0, 2.0, 0.0), y_axis=(0.0, 1.0, 1.0), orientation=down)
    assert plane.to_base((0.1, 0.2)) == pytest.approx([0.5, 0.1, 0.6])
    with pytest.raises(ValueError):
        TaskPlane(origin=(0.5, 0.0, 0.4), x_axis=(0.0, 1.0, 0.0), y_axis=(0.0, 2.0, 0.0), orientation=down)


def test_two_clothoid_segments_run_and_keep_the_boundary():
    box = Box(-1.0, -0.06, 1.0, 0.2)
    controller = SharedControl(SharedControlConfig.paper(solver="fast", n_segments=2), (0.5, 0.0), box)
    records = [controller.step(c) for c in wave(2.5, heading=math.pi + 0.2)]
    assert records[-1].mode == SHARED and records[-1].skill == "wave"
    assert len(records[-1].parameters) == 9  # two (phi0, phi1) pairs
    assert violation(np.array([r.state for r in records]).T, box, None) <= TOLERANCE


@pytest.mark.parametrize("skill", ["wave", "cycloid"])
@pytest.mark.slow
def test_start_from_rest_follows_the_operator_at_every_start_timing(controller, skill):
    """Issue 15: after rest, a window half full of zeros made the first heading arbitrary (21 of 50 went backwards)."""
    controller.set_boundary(None)
    controller.set_obstacle(None)
    rng = np.random.default_rng(15)
    wrong = []
    for start in range(25):
        rest = 0.3 + 0.07 * start  # the window restarts every 1 s of rest: every phase of it is covered
        heading = rng.uniform(-math.pi, math.pi)
        times = np.arange(0, 2.5, DT)
        push = synthetic_commands(skill, (0.03, 20.0, 0.0), heading, 0.05, times, 0.005, rng)
        push *= np.minimum(times / 0.3, 1.0)[:, None]  # a human starts gently
        still = 0.001 * rng.standard_normal((int(round(rest / DT)), 2))  # a device at rest is not exactly still
        controller.reset((0.0, 0.0))
        records = [controller.step(c) for c in np.vstack([still, push])]
        moved = np.array(records[-1].state) - np.array(records[len(still)].state)
        along = moved @ np.array([math.cos(heading), math.sin(heading)])
        assert records[-1].mode == SHARED
        if along < 0.5 * 0.05 * times[-1]:
            wrong.append((rest, heading, along))
    assert not wrong, f"went against or short of the operator's push (rest [s], heading [rad], along [m]): {wrong}"


def test_record_velocity_is_the_velocity_of_the_executed_states(controller):
    """The velocity sent as the impedance controller's x_dot_r matches how the executed state really moves."""
    controller.reset((0.0, 0.0))
    controller.set_boundary(None)
    controller.set_obstacle(None)
    records = [controller.step(c) for c in wave(4.0, heading=0.4, seed=3)]
    states = np.array([r.state for r in records])
    velocities = np.array([r.velocity for r in records])
    moved = np.gradient(states, DT, axis=0)
    assert np.allclose(velocities[1:40], np.diff(states, axis=0)[:39] / DT, atol=1e-9)
    shared = [k for k in range(60, len(records) - 1) if records[k].mode == SHARED and records[k + 1].mode == SHARED]
    assert len(shared) > 100
    error = np.linalg.norm(velocities[shared] - moved[shared], axis=1)
    assert np.median(error) < 0.1 * np.median(np.linalg.norm(moved[shared], axis=1))


def zigzag(duration, heading=0.25):
    """Straight strokes alternating +-45 degrees about the heading, 0.5 s each: a pattern no skill has."""
    times = np.arange(0, duration, DT)
    angle = heading + np.where(np.floor(times / 0.5) % 2 == 0, 1.0, -1.0) * math.pi / 4
    return 0.05 * math.sqrt(2) * np.column_stack([np.cos(angle), np.sin(angle)])


def test_authority_follows_confidence_and_the_paper_switch_restores_the_plan_always():
    box = Box(-0.25, -0.15, 0.25, 0.06)
    blended = SharedControl(SharedControlConfig.paper(solver="fast", blend_authority=True))
    paper = SharedControl(SharedControlConfig.paper(solver="fast", blend_authority=False))
    authorities = {}
    for name, controller in (("blended", blended), ("paper", paper)):
        controller.reset((-0.2, 0.0))
        controller.set_boundary(box)
        records = [controller.step(c) for c in zigzag(6.0)]
        assert violation(np.array([r.state for r in records]).T, box, None) <= TOLERANCE
        authorities[name] = np.array([r.authority for r in records if r.mode != DIRECT])
    assert np.all(authorities["paper"] == 1.0)
    assert authorities["blended"].mean() < 0.6  # the zig-zag stays mostly the operator's
    blended.reset((-0.2, 0.0))
    records = [blended.step(c) for c in wave(4.0, heading=0.25)]
    assert np.mean([r.authority for r in records if r.mode != DIRECT]) > 0.6  # a known wave is mostly the plan's


def test_unknown_pattern_executes_the_operators_step_keeping_the_margin():
    box = Box(-0.25, -0.15, 0.25, 0.06)
    # Residual bounds so strict that nothing counts as known: every estimation cycle is UNKNOWN.
    config = SharedControlConfig.paper(solver="fast", blend_authority=True, authority_residual=(1e-9, 2e-9))
    controller = SharedControl(config, (-0.2, 0.0), box)
    commands = zigzag(5.0)
    records = [controller.step(c) for c in commands]
    unknown = [k for k, r in enumerate(records) if r.mode == UNKNOWN]
    assert len(unknown) > 150
    for k in unknown:
        step = np.array(records[k - 1].state) + commands[k] * DT
        expected = step if violation(step, box, None, config.margin) == 0.0 else None
        if expected is not None:
            assert np.allclose(records[k].state, expected)
        assert records[k].authority == 0.0
    assert violation(np.array([r.state for r in records]).T, box, None) <= TOLERANCE
    assert max(r.state[1] for r in records) > 0.05  # it went along the top of the boundary, as the operator pushed


def identified_skills(controller, commands):
    return [r.skill for r in (controller.step(c) for c in commands) if r.mode in (SHARED, UNKNOWN)]


def test_recency_weighting_identifies_a_pattern_change_sooner_than_the_uniform_window():
    rng = np.random.default_rng(2)
    times = np.arange(0.0, 4.0, DT)
    rho = (0.015, 30.0, 0.0)  # small fast loops: the slowest switch of bench/shared_control_sweep.py
    commands = np.vstack([synthetic_commands(s, rho, 0.0, 0.05, times, 0.01, rng) for s in ("cycloid", "wave")])
    delays = {}
    for half_life in (0.4, 0.0):
        controller = SharedControl(
            SharedControlConfig.from_yaml(solver="fast", recency_half_life=half_life), (0.0, 0.0)
        )
        skills = identified_skills(controller, commands)
        switch = len(skills) - len(times)
        found = skills.index("wave", switch)
        # Expect: the cycloid until the operator changes, then only the wave
        assert set(skills[:switch]) == {"cycloid"} and set(skills[found:]) == {"wave"}
        delays[half_life] = (found - switch) * DT
    assert delays[0.4] < delays[0.0]
    assert delays[0.4] <= 0.5


def test_a_skill_in_a_local_minimum_is_reseeded_before_the_identification_leaves_it():
    controller = SharedControl(SharedControlConfig.from_yaml(solver="fast", reseed_period=0.0), (0.0, 0.0))
    commands = synthetic_commands(
        "wave", (0.03, 20.0, 0.0), 0.3, 0.05, np.arange(0, 3, DT), 0.01, np.random.default_rng(3)
    )
    assert set(identified_skills(controller, commands[:100])) == {"wave"}
    # The wave's warm start is pushed into a poor local minimum (as after a change of the operator's pattern).
    layout = controller.estimation_layouts["wave"]
    skill = layout.skill
    stuck = controller.estimates["wave"].copy()
    stuck[layout.i_rho + skill.frequency_index] = skill.rho_upper[skill.frequency_index]
    stuck[layout.i_rho + skill.amplitude_index] = skill.rho_lower[skill.amplitude_index]
    controller.estimates["wave"] = stuck
    # Expect: still a wave (without the check the cycloid took over for 28 cycles)
    assert set(identified_skills(controller, commands[100:])) == {"wave"}


def test_recency_weights_halve_at_the_half_life_and_keep_a_mean_of_one():
    weights = recency_weights(40, DT, 0.4)
    assert weights.mean() == pytest.approx(1.0)
    assert weights[-1] / weights[-21] == pytest.approx(2.0)  # 20 cycles = 0.4 s older: half the weight
    assert np.all(np.diff(weights) > 0)  # the newest command counts most
    assert np.array_equal(recency_weights(40, DT, 0.0), np.ones(40))  # the paper's uniform window


def test_the_modes_are_the_state_message_s_constants():
    assert {mode.name: int(mode) for mode in Mode} == {
        name: getattr(SharedControlState, name) for name in ("DIRECT", "SHARED", "FALLBACK", "UNKNOWN")
    }


@pytest.mark.parametrize("skill", ["wave", "cycloid"])
def test_a_clutch_keeps_the_recognised_pattern_along_the_operators_heading_until_the_operator_commands_again(skill):
    controller = SharedControl(SharedControlConfig.from_yaml(solver="fast"), (0.0, 0.0))
    times = np.arange(0, 7.0, DT)
    commands = synthetic_commands(skill, (0.03, 20.0, 0.0), math.pi, 0.05, times, 0.005, np.random.default_rng(4))
    for command in commands[:150]:  # 3 s: identified well before (the window is 1.5 s)
        controller.step(command)
    states, kept = [], []
    for _ in range(100):  # 2 s clutched: the operator's hand is on the ellipsoid
        record = controller.keep()
        states.append(record.state)
        kept.append(record.command)
    assert record.mode == SHARED and record.skill == skill
    assert record.message.startswith(f"clutch: keeping the {skill}")
    # Expect: the pattern the operator was making, where they were heading, at their speed: what they would have
    # commanded without their noise, within the estimate's error.
    intended = synthetic_commands(skill, (0.03, 20.0, 0.0), math.pi, 0.05, times)
    np.testing.assert_allclose(np.array(kept), intended[150:250], atol=0.02)
    states = np.array(states)
    assert 0.08 < states[0, 0] - states[-1, 0] < 0.12  # 2 s at 0.05 m/s along the heading (-x)
    assert np.ptp(states[:, 1]) > 0.02  # and the pattern's sway across it
    record = controller.step(np.array([0.0, 0.05]))  # released: the operator's command again
    assert not record.message.startswith("clutch") and record.command == (0.0, 0.05)


def test_a_clutch_with_no_pattern_recognised_holds():
    controller = SharedControl(SharedControlConfig.from_yaml(solver="fast"), (0.1, 0.0))
    controller.step(np.array([0.05, 0.0]))
    record = controller.keep()
    assert record.mode == DIRECT and record.command == (0.0, 0.0)
    assert record.message.startswith("clutch: no pattern recognised to keep")
    np.testing.assert_allclose(controller.keep().state, record.state)
