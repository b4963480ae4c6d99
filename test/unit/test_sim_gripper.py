"""The simulated hand behind franka_gripper's actions (teleteach.sim.gripper): moves, grasps judged by the fingers'
width with franka_gripper's epsilon, homing, stop, and bad goals refused without touching the running command.

Grasps on a real product are in test_world.py (the pick); here the fingers close on air.
"""

import math

import pytest
from sim_support import robot_sim_for_module

from teleteach.core.validation import InvalidCommandError


@pytest.fixture(scope="module")
def robot_sim():
    yield from robot_sim_for_module()


def finish(sim, command, limit=3.0):
    """Step the simulation until the command ends (at most limit [s] of sim time)."""
    for _ in range(int(limit / 0.05)):
        if command.done:
            return command
        sim.run(0.05)
    raise AssertionError(f"{command.kind} did not end within {limit} s")


def fingers(sim):
    positions = sim.world.joint_states()[0]
    return positions[7], positions[8]


def test_move_reaches_the_width_with_both_fingers(robot_sim):
    sim = robot_sim
    command = finish(sim, sim.gripper.move(0.03, 0.1, sim.time))
    # Expect: success, each finger at half the width
    assert command.success and command.error == ""
    assert command.final_width == pytest.approx(0.03, abs=0.002)
    assert fingers(sim) == pytest.approx((0.015, 0.015), abs=0.001)


def test_a_grasp_on_nothing_closes_and_fails_saying_where_the_fingers_stopped(robot_sim):
    sim = robot_sim
    finish(sim, sim.gripper.move(0.08, 0.1, sim.time))
    command = finish(sim, sim.gripper.grasp(0.05, 0.005, 0.005, 0.1, 20.0, sim.time))
    # Expect: the fingers closed fully: outside [0.045, 0.055], so no success
    assert not command.success
    assert command.final_width < 0.005
    assert "outside [0.0450, 0.0550] m" in command.error


def test_homing_opens_fully_and_stop_ends_a_running_move(robot_sim):
    sim = robot_sim
    finish(sim, sim.gripper.move(0.0, 0.1, sim.time))
    homing = finish(sim, sim.gripper.homing(sim.time))
    assert homing.success and homing.final_width == pytest.approx(0.08, abs=0.002)
    move = sim.gripper.move(0.0, 0.02, sim.time)  # slow: 4 s to close
    sim.run(0.5)
    stop = sim.gripper.stop(sim.time)
    held = sim.world.finger_width()
    sim.run(0.5)
    # Expect: the move ended unsuccessfully, the stop succeeded, the fingers stay where they stopped (mid-way)
    assert move.done and not move.success and "stopped" in move.error
    assert stop.done and stop.success
    assert 0.06 < held < 0.075
    assert sim.world.finger_width() == pytest.approx(held, abs=0.001)


def test_a_new_command_replaces_the_running_one(robot_sim):
    sim = robot_sim
    first = sim.gripper.move(0.0, 0.02, sim.time)
    sim.run(0.1)
    second = finish(sim, sim.gripper.move(0.06, 0.1, sim.time))
    assert first.done and not first.success and "replaced by a move command" in first.error
    assert second.success and second.final_width == pytest.approx(0.06, abs=0.002)


@pytest.mark.parametrize(
    ("goal", "reason"),
    [
        (lambda g, t: g.move(math.nan, 0.1, t), "width nan m is outside"),
        (lambda g, t: g.move(0.09, 0.1, t), "width 0.09 m is outside"),
        (lambda g, t: g.move(0.04, 0.0, t), "speed 0.0 m/s is outside"),
        (lambda g, t: g.grasp(0.04, -0.001, 0.005, 0.1, 20.0, t), "epsilon.inner"),
        (lambda g, t: g.grasp(0.04, 0.005, math.inf, 0.1, 20.0, t), "epsilon.outer"),
        (lambda g, t: g.grasp(0.04, 0.005, 0.005, 0.1, 200.0, t), "force 200.0 N is outside"),
    ],
)
def test_bad_goals_are_refused_and_the_running_command_goes_on(robot_sim, goal, reason):
    sim = robot_sim
    running = sim.gripper.move(0.02, 0.02, sim.time)
    with pytest.raises(InvalidCommandError, match=reason):
        goal(sim.gripper, sim.time)
    finish(sim, running, limit=5.0)
    assert running.success and running.final_width == pytest.approx(0.02, abs=0.002)
