"""ReplaySkill of a skill taught on a surface: the skill server wipes the surface it perceives now, judged by the force
and the TCP, on the real in-process simulation (issue 49: "a wiping skill in the library, which the tree can run on
another surface pose")."""

import dataclasses
import math

import numpy as np
import pytest
import yaml

from teleteach.core import skill_file
from teleteach.core.rotations import yaw_rotation
from teleteach.core.scene import load_scene
from teleteach.core.wiping import load_wiping_config
from teleteach.run.sim_robot import SimRobot
from teleteach.sim.robot_sim import RobotSim
from teleteach.sim.uncertainty import UncertaintySettings
from teleteach.skills.config import load_motion_config
from teleteach.skills.runner import SkillRunner
from teleteach.wiping.ablation import TAUGHT
from teleteach.wiping.trial import SurfaceWiper, wiping_scene

SCENE = load_scene()
CONFIG = load_wiping_config()
BOARD = SCENE.surface("counter_board")
TURNED = dataclasses.replace(BOARD, center=(0.66, 0.98, 0.64), rpy=(0.0, 0.1, BOARD.rpy[2] + 0.3))


class TruthRecordingRobot(SimRobot):
    """The simulated robot, recording after each wait what the world did: the true surface's push along its true
    normal [N] and where the tool's face is in the true surface's frame (u, v, height [m])."""

    def __init__(self, sim, surface):
        super().__init__(sim)
        self.surface, self.truth = surface, []

    def sleep(self, seconds: float) -> None:
        super().sleep(seconds)
        world = self.sim.world
        normal = self.surface.frame.rotation.apply([0.0, 0.0, 1.0])
        push = float(yaw_rotation(world.base_pose[2]).apply(world.external_wrench()[0]) @ normal)
        face = [math.nan] * 3
        if world.tool is not None:
            face = self.surface.frame.inverse().apply_point(np.asarray(world.tool_face()[0]))
        self.truth.append((self.now(), push, *face))


@pytest.fixture(scope="module")
def kinematics():
    from teleteach.control.kinematics import PandaKinematics

    model = PandaKinematics(SCENE.robot.mount_height)
    yield model
    model.close()


def wave(seconds=3.0):
    """A wave across the board's middle, right to left, one target per cycle (u, v) [m]."""
    phase = np.linspace(0.0, 1.0, int(round(seconds / CONFIG.dt)))
    return np.column_stack([0.1 - 0.2 * phase, 0.04 * np.sin(2 * np.pi * 2 * phase)])


def wiping_robot(surface, kinematics, mounted=True, base_pose="wipe_counter"):
    """A robot at base_pose before the surface (exact perception), holding the eraser, and its skill runner."""
    sim = RobotSim(wiping_scene(SCENE, surface), uncertainty=UncertaintySettings.none())
    sim.place_base(SCENE.base_poses[base_pose])
    if mounted:
        sim.world.mount_tool(SCENE.wiping_tool)
    robot = TruthRecordingRobot(sim, surface)
    return robot, SkillRunner(robot, load_motion_config(), sim.scene, kinematics, CONFIG)


@pytest.fixture(scope="module")
def taught(tmp_path_factory, kinematics):
    """A wave taught on the board where it stands, as a skill file in the board's frame."""
    robot, _ = wiping_robot(BOARD, kinematics)
    try:
        skill = SurfaceWiper(robot.sim, kinematics, BOARD, CONFIG).pattern_skill(wave(), TAUGHT, "TaughtWave")
    finally:
        robot.sim.close()
    return skill_file.save(skill, tmp_path_factory.mktemp("skills") / "TaughtWave")


def replay(runner, path, **request):
    return runner.execute("ReplaySkill", yaml.safe_dump({"data_file": str(path), **request}))


def test_a_skill_taught_on_the_board_wipes_it_turned_and_tilted_where_it_was_not_taught(taught, kinematics):
    robot, runner = wiping_robot(TURNED, kinematics)
    try:
        outcome = replay(runner, taught)
        assert outcome.success, outcome.message
        assert "wiped counter_board with TaughtWave" in outcome.message
        # Expect: the world agrees: pressed on the true board for the pattern's length, along the taught wave.
        truth = np.array(robot.truth)
        touching = truth[truth[:, 1] >= CONFIG.contact_threshold]
        assert len(touching) * CONFIG.dt >= 0.95 * 3.0
        assert 4.0 <= float(np.median(touching[:, 1])) <= 16.0  # the 10 N asked for, through the taught stiffness
        assert touching[:, 2].min() < -0.08 and touching[:, 2].max() > 0.08  # swept u across the middle
        assert np.abs(touching[:, 3]).max() < 0.05  # the wave's amplitude, not beyond
        assert robot.sim.manager.running == load_motion_config().position_controller  # handed back
        assert truth[-1, 4] > 0.01  # and the eraser lifted off the board
    finally:
        robot.sim.close()


def test_without_the_tool_the_wipe_fails_saying_what_fell_short(taught, kinematics):
    robot, runner = wiping_robot(BOARD, kinematics, mounted=False)
    try:
        outcome = replay(runner, taught)
        assert not outcome.success
        # Expect: the bare fingertips brush the board now and then, far from a wipe.
        assert "short of the 95% contact" in outcome.message and "is the tool mounted?" in outcome.message
        assert robot.sim.manager.running == load_motion_config().position_controller
    finally:
        robot.sim.close()


def test_a_board_out_of_reach_or_not_perceived_is_refused_before_the_arm_moves(taught, kinematics):
    far = dataclasses.replace(BOARD, center=(BOARD.center[0] + 0.45, *BOARD.center[1:]))
    robot, runner = wiping_robot(far, kinematics)
    try:
        joints = robot.joint_positions()
        outcome = replay(runner, taught)
        assert not outcome.success and "from the arm's shoulder" in outcome.message, outcome.message
        unknown = replay(runner, taught, target="shop_window")
        assert not unknown.success and "perception reports no such surface (it reports counter_board)" in (
            unknown.message
        )
        np.testing.assert_allclose(robot.joint_positions(), joints, atol=1e-3)
    finally:
        robot.sim.close()


def test_place_taught_never_takes_a_wiping_skill_for_a_placement(taught, kinematics):
    robot, runner = wiping_robot(BOARD, kinematics)
    try:
        robot.library.append(("TaughtWave", "stiffness", str(taught)))
        outcome = runner.execute("PlaceTaught")
        assert not outcome.success and "hand holds none" in outcome.message
    finally:
        robot.sim.close()


def test_a_surface_skill_file_keeps_its_target_kind_and_an_older_file_is_a_gap(taught, tmp_path):
    skill = skill_file.load(taught)
    assert skill.target.kind == skill_file.SURFACE and skill.target.name == BOARD.name
    older = dataclasses.replace(skill, target=skill_file.Target(skill.target.name, skill.target.pose_in_base))
    assert skill_file.load(skill_file.save(older, tmp_path / "older")).target.kind == skill_file.GAP
    with pytest.raises(skill_file.SkillFileError, match="unknown target kind 'wall'"):
        dataclasses.replace(skill, target=skill_file.Target("x", skill.target.pose_in_base, "wall"))
    assert math.isclose(skill.duration, 3.0 - CONFIG.dt, rel_tol=1e-9)
