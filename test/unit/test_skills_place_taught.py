"""PlaceTaught on the real in-process simulation (pybullet, controller manager, no ROS): it places with what the
operator taught for the gap in front of the robot, judged from the world, and says what to teach when nothing was."""

import dataclasses

import numpy as np
import pytest

from teleteach.core import skill_file
from teleteach.core.frames import Transform
from teleteach.learning.synthetic import placement_on_trajectory
from teleteach.sim.robot_sim import IMPEDANCE, TRAJECTORY


def in_front_of_gap_1(runner):
    for name in ("LookToShelf", "PickItem", "MoveBase"):  # product_pick_1 in the hand, in front of gap_1
        assert runner.execute(name).success, name


def stands_in(sim, product, gap):
    horizontal, vertical = sim.scene.gap(gap).distance(sim.world.product_poses()[product][0])
    return horizontal < sim.scene.gap(gap).tolerance and vertical < 0.02


def test_with_nothing_taught_for_the_gap_it_fails_before_moving_and_says_what_to_teach(
    sim, sim_robot, runner, tmp_path
):
    in_front_of_gap_1(runner)
    taught = placement_on_trajectory("perpendicular")
    in_base = skill_file.save(taught.in_base(taught.target.transform), tmp_path / "InBase")  # no target frame
    sim_robot.library = [
        ("PickItem", "predefined", ""),
        ("InBase", "stiffness", str(in_base)),
        ("Gone", "dmp", str(tmp_path / "Gone.npz")),  # its file is missing
    ]
    joints = sim_robot.joint_positions()
    outcome = runner.execute("PlaceTaught")
    assert not outcome.success
    assert outcome.message.startswith("no taught skill places at gap_1: teach one (TELEOP"), outcome.message
    # Expect nothing moved: the product still in the hand, the arm where it was
    assert sim.world.grasped == "product_pick_1"
    assert np.abs(sim_robot.joint_positions() - joints).max() < 0.01


@pytest.mark.slow
def test_it_places_with_the_taught_skill_the_learned_one_first(sim, sim_robot, runner, tmp_path):
    in_front_of_gap_1(runner)
    taught = placement_on_trajectory("perpendicular")
    demonstration = skill_file.save(taught, tmp_path / "DemonstratedPlace_1")
    learned = skill_file.save(dataclasses.replace(taught, name="DemonstratedPlace_1_dmp", kind="dmp"), tmp_path / "L")
    sim_robot.library = [
        ("DemonstratedPlace_1_dmp", "dmp", str(learned)),
        ("DemonstratedPlace_1", "stiffness", str(demonstration)),
    ]
    outcome = runner.execute("PlaceTaught")
    assert outcome.success, outcome.message
    assert outcome.message.startswith("with DemonstratedPlace_1_dmp: replayed DemonstratedPlace_1_dmp (dmp) relative")
    # Expect, from the world: product_pick_1 released upright in gap_1
    assert sim.world.grasped is None
    assert stands_in(sim, "product_pick_1", "gap_1")


@pytest.mark.slow
def test_a_product_the_operator_set_down_in_the_gap_is_only_let_go(sim, sim_robot, runner):
    in_front_of_gap_1(runner)
    # the operator's demonstration: the taught reference and stiffness played on the impedance controller, the
    # product left in the fingers, and the arm back on position control (LOW-LEVEL left)
    taught = placement_on_trajectory("perpendicular")
    played = taught.in_base(Transform.from_planar(*sim_robot.base_pose()).inverse() * sim.scene.gap("gap_1").frame)
    sim_robot.command_stiffness([400.0, 400.0, 2000.0], [0.0, 0.0, 0.0, 1.0], sim.time)
    sim_robot.command_equilibrium(*sim_robot.cartesian_pose(), sim.time)
    sim_robot.switch_controllers([IMPEDANCE], [TRAJECTORY])
    start = sim.time
    for t, pose in zip(played.time - played.time[0], played.equilibrium_pose):
        sim.run(max(0.0, start + t - sim.time) or sim.world.time_step)
        sim_robot.command_equilibrium(pose[:3], pose[3:], sim.time)
    sim.run(0.5)
    sim_robot.switch_controllers([TRAJECTORY], [IMPEDANCE])
    assert sim.world.grasped == "product_pick_1" and stands_in(sim, "product_pick_1", "gap_1")
    outcome = runner.execute("PlaceTaught")  # nothing in the library: it needs none
    assert outcome.success, outcome.message
    assert outcome.message.startswith("product_pick_1 already stood in gap_1 (set down while the operator taught)")
    assert sim.world.grasped is None and stands_in(sim, "product_pick_1", "gap_1")
