"""Issue 10: a learned (DMP) skill executes on the robot like a demonstrated one, through the skill runner's ReplaySkill
on the real in-process simulation (pybullet physics, controller manager), no ROS."""

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from teleteach import skill_file
from teleteach.learning.skill import learn_skill
from teleteach.sim.kinematics import PandaKinematics
from teleteach.sim.robot_sim import TRAJECTORY, RobotSim
from teleteach.skills.config import load_motion_config
from teleteach.skills.robot import Execution
from teleteach.skills.runner import SkillRunner
from teleteach.skills.sim_robot import SimRobot


@pytest.fixture
def sim():
    simulation = RobotSim()
    yield simulation
    simulation.close()


@pytest.fixture
def runner(sim):
    kinematics = PandaKinematics(0.40)
    yield SkillRunner(SimRobot(sim), load_motion_config(), sim.scene, kinematics)
    kinematics.close()


def demonstration(sim, duration=2.0, step=(0.05, 0.03, 0.0)):
    """A demonstrated stiffness skill from the hand's pose: a short move while the ellipsoid turns 45 degrees."""
    state = sim.world.read_state()
    count = 101
    fractions = np.linspace(0.0, 1.0, count)[:, None]
    smooth = fractions**3 * (10.0 - 15.0 * fractions + 6.0 * fractions**2)  # minimum jerk: the operator's motion
    positions = state.position + smooth * np.array(step)
    poses = np.hstack([positions, np.tile(state.quaternion, (count, 1))])
    rotated = Rotation.from_euler("z", math.pi / 4).as_matrix()
    final = rotated @ np.diag([300.0, 1500.0, 1000.0]) @ rotated.T
    stiffness = np.array([(1 - f) * np.diag([800.0, 800.0, 800.0]) + f * final for f in smooth[:, 0]])
    times = np.linspace(0.0, duration, count)
    return skill_file.Skill("place_45", "stiffness", times, stiffness, poses, poses), final, positions[-1]


def test_a_learned_dmp_skill_replays_on_the_robot_like_the_demonstrated_one(sim, runner, tmp_path):
    demo, final_stiffness, final_position = demonstration(sim)
    learned = learn_skill(demo, "place_45_dmp")
    path = skill_file.save(learned.to_skill(learned.reproduce()), tmp_path / "place_45_dmp")
    saved = skill_file.load(path)
    assert saved.kind == "dmp" and saved.name == "place_45_dmp"
    # Expect the learned skill to end where the demonstration ended, with its stiffness
    np.testing.assert_allclose(saved.equilibrium_pose[-1, :3], final_position, atol=2e-3)
    np.testing.assert_allclose(saved.stiffness[-1], final_stiffness, rtol=0.05)

    phases = []
    outcome = runner.execute(
        "ReplaySkill",
        f"{{data_file: {path}, kind: dmp}}",
        Execution(feedback=lambda progress, phase: phases.append(phase)),
    )
    assert outcome.success, outcome.message
    assert outcome.message.startswith("replayed place_45_dmp (dmp)")
    assert "replay" in phases and "switch to impedance control" in phases
    # Expect: the hand ended at the learned goal under the learned final stiffness, back on position control
    reported = float(outcome.message.rsplit("final end-effector error ", 1)[1].split(" mm")[0])
    assert reported < 10.0  # [mm]
    np.testing.assert_allclose(sim.world.read_state().position, final_position, atol=0.01)
    np.testing.assert_allclose(sim.impedance.stiffness_target[:3, :3], saved.stiffness[-1], atol=1e-6)
    assert sim.manager.running == TRAJECTORY


def test_a_learned_skill_is_refused_when_the_goal_asks_for_another_kind(sim, runner, tmp_path):
    demo, _, _ = demonstration(sim)
    learned = learn_skill(demo, "place_45_dmp")
    path = skill_file.save(learned.to_skill(learned.reproduce()), tmp_path / "place_45_dmp")
    before = np.array(sim.world.read_state().position)
    outcome = runner.execute("ReplaySkill", f"{{data_file: {path}, kind: stiffness}}")
    assert not outcome.success
    assert outcome.message == f"skill file {path} holds a 'dmp' skill, the goal asked for 'stiffness'"
    np.testing.assert_allclose(sim.world.read_state().position, before, atol=1e-3)
    assert sim.manager.running == TRAJECTORY
