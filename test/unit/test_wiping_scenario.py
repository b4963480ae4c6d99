"""run_wipe's measures from the world (teleteach.wiping.scenario) against hand-computed cases, on a turned board."""

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from teleteach.core.frames import Transform
from teleteach.core.wiping import load_wiping_config
from teleteach.shared_control.constraints import Box, StraightEdge
from teleteach.wiping import scenario

CONFIG = load_wiping_config()
BOX = Box(-0.1, -0.05, 0.1, 0.05)
AREA = (-0.12, -0.07, 0.12, 0.07)
FOOTPRINT = (0.05, 0.03)
# A board turned 90 degrees about base_link's z and tilted 10 degrees, 0.5 m ahead: its u is base_link's y
BOARD = Transform(np.array([0.5, 0.0, 0.3]), Rotation.from_euler("zx", [90.0, 10.0], degrees=True))


def on_board(points_uvw):
    """Board-frame points in base_link."""
    return np.array([BOARD.apply_point(point) for point in points_uvw])


def tool_quaternions(yaws):
    """The tool's x along the board's (cos yaw, sin yaw), its z into the board, as base_link quaternions."""
    down = Rotation.from_euler("x", math.pi)
    return [(BOARD.rotation * Rotation.from_euler("z", yaw) * down).as_quat() for yaw in yaws]


def test_a_track_is_the_tcp_and_the_push_on_the_boards_frame():
    times = np.array([0.0, 0.1, 0.2])
    points = np.array([[-0.05, 0.01, 0.04], [0.0, 0.02, 0.04], [0.05, 0.0, 0.05]])
    normal = BOARD.rotation.apply([0.0, 0.0, 1.0])
    along_u = BOARD.rotation.apply([1.0, 0.0, 0.0])
    # the sensor's samples: 12 N along the normal, then 3 N with a push along u, then 0 (off)
    force_times = [-0.01, 0.05, 0.15]
    forces = [12.0 * normal, 3.0 * normal + 5.0 * along_u, np.zeros(3)]
    track = scenario.board_track(
        times, on_board(points), tool_quaternions([0.0, 0.5, -0.5]), force_times, forces, BOARD
    )
    np.testing.assert_allclose(track.positions, points, atol=1e-12)
    np.testing.assert_allclose(track.yaws, [0.0, 0.5, -0.5], atol=1e-9)
    # each pose gets the last force at or before it; only the normal part counts
    np.testing.assert_allclose(track.normal_forces, [12.0, 3.0, 0.0], atol=1e-9)
    with pytest.raises(ValueError, match="need TCP and force samples"):
        scenario.board_track(times, on_board(points), tool_quaternions([0.0] * 3), [], [], BOARD)


def straight_track(us, v=0.0, force=10.0):
    count = len(us)
    positions = np.column_stack([us, np.full(count, v), np.full(count, 0.04)])
    return scenario.Track(np.arange(count) * 0.02, positions, np.zeros(count), np.full(count, force))


def test_a_phase_counts_the_reference_and_the_tool_past_the_boundary_and_the_obstacle():
    us = np.linspace(-0.08, 0.11, 20)  # the tool ends 10 mm past u_max: a violation beyond the 5 mm tolerance
    world = seen = straight_track(us)
    reference = np.column_stack([np.clip(us, None, 0.1005), np.zeros(20)])  # kept within its 1 mm slack
    edge = lambda time: StraightEdge(0.0, 0.03, -0.5 * math.pi)  # noqa: E731 free side below v = 0.03
    figures = scenario.phase_figures(world, seen, CONFIG, BOX, FOOTPRINT, AREA, edge, reference)
    assert figures["reference_boundary_violations"]["count"] == 0
    assert figures["boundary_violations"]["count"] == 1  # only u = 0.11 is more than 5 mm past
    assert figures["boundary_violations"]["worst_m"] == pytest.approx(0.01)
    assert figures["obstacle_violations"] == {"count": 0, "worst_m": 0.0}
    assert figures["contact_fraction"] == 1.0 and figures["force_mean_n"] == pytest.approx(10.0)
    # swept: u from -0.08 - 0.025 to 0.11 + 0.025 (cut at the area's 0.12), v +-0.015 (16 rows of 2 mm cells whose
    # centres fall on the patch: 32 mm), of 0.24 x 0.14
    assert figures["covered_fraction"] == pytest.approx((0.12 + 0.105) * 0.032 / (0.24 * 0.14), rel=0.02)
    above = scenario.phase_figures(straight_track(us, v=0.04), seen, CONFIG, BOX, FOOTPRINT, AREA, edge, reference)
    assert above["obstacle_violations"]["count"] == 0  # counted on the board as seen, where the tool kept below
    past = scenario.phase_figures(world, straight_track(us, v=0.04), CONFIG, BOX, FOOTPRINT, AREA, edge, reference)
    assert past["obstacle_violations"]["count"] == 20 and past["obstacle_violations"]["worst_m"] == pytest.approx(0.01)


def test_pattern_figures_take_one_command_per_stamp_and_count_recognition_after_the_switch():
    times = np.repeat(np.arange(0.0, 4.0, 0.02), 2)  # each command twice: under simulated time stamps repeat
    commands = np.column_stack([np.full(times.size, -0.05), 0.2 * np.cos(2 * np.pi * times)])
    track_times = np.arange(0.0, 4.0, 0.005)
    positions = np.column_stack(
        [-0.05 * track_times, 0.2 / (2 * np.pi) * np.sin(2 * np.pi * track_times), np.zeros(track_times.size)]
    )
    seen = scenario.Track(track_times, positions, np.zeros(track_times.size), np.full(track_times.size, 10.0))
    states = [(t, "wave" if t >= 2.5 else "cycloid") for t in np.arange(0.0, 4.0, 0.02)]
    figures = scenario.pattern_figures("wave", times, commands, seen, states)
    assert figures["F_h"] >= 0 and figures["F_x"] >= 0
    # after SWITCH (2 s): 2.0-2.5 s cycloid, 2.5-4 s wave
    assert figures["recognised_share"] == pytest.approx(75 / 100, abs=0.02)


def passing_phases():
    wipe = {
        "contact_fraction": 0.99,
        "force_mean_n": 10.0,
        "force_spread_n": 1.0,
        "reference_boundary_violations": {"count": 0, "worst_m": 0.0},
        "boundary_violations": {"count": 3, "worst_m": 0.009},
        "recognised_share": 1.0,
    }
    return {
        "wave": dict(wipe),
        "cycloid": {**wipe, "obstacle_violations": {"count": 0, "worst_m": 0.0}},
        "teaching": {**wipe, "clutch_kept_share": 1.0},
        "replay": {**wipe, "status": "SUCCESS", "message": "wiped", "coverage_of_demonstration": 0.95},
    }


def test_checks_pass_only_when_the_world_says_so():
    found = scenario.checks(passing_phases(), CONFIG)
    assert len(found) == 13 and all(check["passed"] for check in found)
    for phase, key, value in (
        ("wave", "contact_fraction", 0.9),
        ("cycloid", "obstacle_violations", {"count": 1, "worst_m": 0.002}),
        ("teaching", "clutch_kept_share", 0.5),
        ("cycloid", "recognised_share", 0.5),
        ("teaching", "reference_boundary_violations", {"count": 2, "worst_m": 0.003}),
        ("replay", "coverage_of_demonstration", 0.85),
        ("replay", "status", "FAILURE"),
    ):
        phases = passing_phases()
        phases[phase][key] = value
        failed = [check["check"] for check in scenario.checks(phases, CONFIG) if not check["passed"]]
        assert len(failed) == 1 and failed[0].startswith(phase), (phase, key, failed)
    # a replay the world saw no pattern of fails, whatever the tree said
    phases = passing_phases()
    phases["replay"] = {"status": "SUCCESS", "message": "wiped"}
    failed = [check["check"] for check in scenario.checks(phases, CONFIG) if not check["passed"]]
    assert failed == ["replay: the learned skill pressed on the board"]
    markdown = scenario.summary_markdown({"passed": False, "checks": found, "phases": {}})
    assert markdown.startswith("# run_wipe: FAILED") and "ok   wave: in contact >= 95%" in markdown


def test_the_scripted_hand_asks_through_a_joystick_or_the_device_what_the_node_reads_back():
    from types import SimpleNamespace

    from teleteach.core.paths import config_values
    from teleteach.shared_control.config import SharedControlNodeConfig
    from teleteach.shared_control.ros import command_from_joy, command_from_twist
    from teleteach.wiping.ros import device_velocity_for, joy_axes_for

    node = SharedControlNodeConfig.from_parameters(config_values("shared_control.yaml"))
    command = np.array([-0.05, 0.12])
    axes = joy_axes_for(command, node.joy_axes, node.joy_scale)
    np.testing.assert_allclose(
        command_from_joy(SimpleNamespace(axes=list(axes)), node.joy_axes, node.joy_scale), command
    )
    # beyond full deflection the stick saturates: the node reads the joystick's most
    fast = joy_axes_for([0.0, 1.0], node.joy_axes, node.joy_scale)
    assert np.all(np.abs(fast) <= 1.0)
    assert command_from_joy(SimpleNamespace(axes=list(fast)), node.joy_axes, node.joy_scale)[1] == abs(
        node.joy_scale[1]
    )
    velocity = device_velocity_for(command, node.twist_projection, node.twist_scale)
    linear = SimpleNamespace(x=velocity[0], y=velocity[1], z=velocity[2])
    twist = SimpleNamespace(twist=SimpleNamespace(linear=linear))
    read = command_from_twist(twist, np.asarray(node.twist_projection, dtype=float), node.twist_scale)
    np.testing.assert_allclose(read, command)
    # a turned projection (the device's plane mapped onto a tilted surface) is inverted too
    turned = np.array([[0.0, 1.0, 0.0], [-0.6, 0.0, 0.8]])
    velocity = device_velocity_for(command, turned, 2.0)
    read = command_from_twist(
        SimpleNamespace(twist=SimpleNamespace(linear=SimpleNamespace(**dict(zip("xyz", velocity))))), turned, 2.0
    )
    np.testing.assert_allclose(read, command)
