"""A learned (DMP) skill places a product like the demonstration it was learned from, through the skill runner's
ReplaySkill on the real in-process simulation (pybullet physics, controller manager), no ROS."""

import numpy as np
import pytest

from teleteach.core import skill_file
from teleteach.learning.skill import learn_skill
from teleteach.learning.synthetic import placement_on_trajectory
from teleteach.sim.robot_sim import TRAJECTORY
from teleteach.skills.robot import Execution


@pytest.mark.slow
def test_a_learned_dmp_skill_places_the_product_like_the_demonstrated_one(sim, runner, tmp_path):
    demo = placement_on_trajectory("perpendicular")
    learned = learn_skill(demo, "place_dmp")
    path = skill_file.save(learned.to_skill(learned.reproduce()), tmp_path / "place_dmp")
    saved = skill_file.load(path)
    assert saved.kind == "dmp" and saved.name == "place_dmp"
    # Expect the learned skill to end where the demonstration ended, with its stiffness
    np.testing.assert_allclose(saved.equilibrium_pose[-1, :3], demo.equilibrium_pose[-1, :3], atol=2e-3)
    np.testing.assert_allclose(saved.stiffness[-1], demo.stiffness[-1], rtol=0.05)
    for name in ("LookToShelf", "PickItem", "MoveBase"):  # product_pick_1 in the hand, in front of gap_1
        assert runner.execute(name).success, name

    phases = []
    outcome = runner.execute(
        "ReplaySkill",
        f"{{data_file: {path}, kind: dmp}}",
        Execution(feedback=lambda progress, phase: phases.append(phase)),
    )
    assert outcome.success, outcome.message
    assert outcome.message.startswith("replayed place_dmp (dmp)")
    assert "product_pick_1 released upright in gap_1" in outcome.message
    assert "replay" in phases and "switch to impedance control" in phases
    # Expect, from the world: the product stands in gap_1, released; the arm back on position control
    position = sim.world.product_poses()["product_pick_1"][0]
    horizontal, vertical = sim.scene.gap("gap_1").distance(position)
    assert horizontal < sim.scene.gap("gap_1").tolerance and vertical < 0.02
    assert sim.world.grasped is None
    assert sim.manager.running == TRAJECTORY


def test_a_learned_skill_is_refused_when_the_goal_asks_for_another_kind(sim, runner, tmp_path):
    learned = learn_skill(placement_on_trajectory("perpendicular"), "place_dmp")
    path = skill_file.save(learned.to_skill(learned.reproduce()), tmp_path / "place_dmp")
    before = np.array(sim.world.read_state().position)
    outcome = runner.execute("ReplaySkill", f"{{data_file: {path}, kind: stiffness}}")
    assert not outcome.success
    assert outcome.message == f"skill file {path} holds a 'dmp' skill, the goal asked for 'stiffness'"
    np.testing.assert_allclose(sim.world.read_state().position, before, atol=1e-3)
    assert sim.manager.running == TRAJECTORY
