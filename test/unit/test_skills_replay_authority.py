"""A replay on the real in-process simulation (pybullet, controller manager, no ROS) where the same operator correction
moves the held product only as far as the skill is unsure (teleteach.skills.authority)."""

import numpy as np
import pytest
from test_skill_authority import CONFIG, with_path

from teleteach.core import skill_file
from teleteach.learning.synthetic import placement_on_trajectory
from teleteach.run.sim_robot import SimRobot
from teleteach.skills.config import load_motion_config
from teleteach.skills.runner import SkillRunner

LIFT = 0.02  # [m] the operator asks the product to stay this much higher (base_link z)


def replay_with_an_operator_lifting(sim, kinematics, skill, tmp_path):
    """Replay ``skill`` at gap_1 while the operator asks for LIFT from the start; the held product's height (world,
    pybullet) where the replay ends, and the authority reports."""
    heights = []

    def operator(_now):
        heights.append(sim.world.product_poses()["product_pick_1"][0][2])
        return [0.0, 0.0, LIFT]

    robot = SimRobot(sim, operator)
    runner = SkillRunner(robot, load_motion_config(), sim.scene, kinematics)
    for name in ("LookToShelf", "PickItem", "MoveBase"):  # product_pick_1 in the hand, in front of gap_1
        assert runner.execute(name).success, name
    path = skill_file.save(skill, tmp_path / skill.name)
    outcome = runner.execute("ReplaySkill", f"{{data_file: {path}}}")
    assert outcome.success, outcome.message
    return heights[-1], robot.authority_reports, outcome.message


@pytest.mark.slow
def test_a_confident_skill_leads_and_the_operators_correction_moves_nothing(sim, kinematics, tmp_path):
    taught = placement_on_trajectory("perpendicular")
    confident = with_path(taught, 3, [0.0, 0.0], [0.0, taught.duration])  # three demonstrations, no spread
    height, reports, message = replay_with_an_operator_lifting(sim, kinematics, confident, tmp_path)
    gap = sim.scene.gap("gap_1")
    assert abs(height - gap.position[2]) < 0.006  # the product at the board, where the skill puts it
    assert all(report.confidence == pytest.approx(1.0) for report in reports)
    assert all(np.allclose(report.correction, 0.0) for report in reports)
    assert "confidence 1.00-1.00, the operator's correction 0 mm" in message


@pytest.mark.slow
def test_an_unsure_skill_lets_the_operator_lead(sim, kinematics, tmp_path):
    taught = placement_on_trajectory("perpendicular")
    unsure = with_path(taught, 2, [CONFIG.spread_unsure] * 2, [0.0, taught.duration])  # demonstrations far apart
    height, reports, message = replay_with_an_operator_lifting(sim, kinematics, unsure, tmp_path)
    gap = sim.scene.gap("gap_1")
    # Expect, from the world: the product held LIFT higher than the skill alone puts it (the stiffness yields a little)
    assert LIFT - 0.006 < height - gap.position[2] < LIFT + 0.004
    assert all(report.confidence == 0.0 for report in reports)
    assert reports[-1].correction == pytest.approx([0.0, 0.0, LIFT])
    assert reports[-1].operator_weight == 1.0 and reports[-1].spread == pytest.approx(CONFIG.spread_unsure)
    assert "confidence 0.00-0.00, the operator's correction 20 mm" in message
