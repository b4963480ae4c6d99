"""Placement trials in-process (teleteach.run.trials) and the friction grasp they rest on: the real simulation, the
real controllers and ReplaySkill, judged from the true world."""

import numpy as np
import pybullet
import pytest
from scipy.spatial.transform import Rotation

from teleteach.control import panda
from teleteach.control.kinematics import PandaKinematics
from teleteach.core import skill_file
from teleteach.core.scene import load_scene
from teleteach.learning.synthetic import placement_on_trajectory
from teleteach.run.sim_robot import SimRobot
from teleteach.run.trials import TrialJob, TrialSetup, hold_product, run_trial, run_trials, scene_around
from teleteach.sim.robot_sim import RobotSim
from teleteach.sim.uncertainty import DEFAULT_UNCERTAINTY_FILE, UncertaintyError, load_uncertainty
from teleteach.skills.config import load_motion_config
from teleteach.skills.runner import SkillRunner


@pytest.fixture(scope="module")
def kinematics():
    model = PandaKinematics(0.40)
    yield model
    model.close()


def in_hand(sim, product="product_pick_1"):
    """The product's centre [m] and orientation in the TCP's frame, from the true world."""
    link = pybullet.getLinkState(sim.world.robot, panda.TCP_LINK, physicsClientId=sim.world.client)
    hand = Rotation.from_quat(link[5])
    position, quaternion = sim.world.product_poses()[product]
    return hand.inv().apply(position - np.array(link[4])), hand.inv() * Rotation.from_quat(quaternion)


def lowered(skill, drop):
    """The skill with its reference dropped by drop [m] from the alignment on: the product meets the shelf's lip."""
    poses = skill.equilibrium_pose.copy()
    poses[skill.time - skill.time[0] > 3.5, 2] -= drop
    return skill_file.Skill(
        "Low", "stiffness", skill.time, skill.stiffness, poses, poses, frame=skill.frame, target=skill.target
    )


def test_a_held_product_stays_put_in_the_fingers_and_slips_when_pushed_hard(kinematics, tmp_path):
    config = load_motion_config()
    sim = RobotSim(scene_around(load_scene(), "gap_1", "product_pick_1"))
    try:
        hold_product(sim, config, "product_pick_1", "place_perpendicular", np.zeros(4))
        assert sim.world.grasped == "product_pick_1"
        start, turned = in_hand(sim)
        # Expect: held where the grasp put it, 3.5 cm below the TCP, by friction alone
        assert start == pytest.approx([0.0, 0.0, config.grasp.height_above_center], abs=0.002)
        worst = {"shift": 0.0, "turn": 0.0, "calm": 0.0}
        tick = sim.tick

        def watched():
            tick()
            if sim.world.ticks % 20 == 0 and sim.world.finger_width() < 0.065:
                position, rotation = in_hand(sim)
                worst["shift"] = max(worst["shift"], float(np.linalg.norm(position - start)))
                worst["turn"] = max(worst["turn"], float(np.degrees((rotation * turned.inv()).magnitude())))
                if sim.time < 4.0:  # the approach: the hand turns 90 degrees and descends, nothing touched
                    worst["calm"] = max(worst["calm"], worst["shift"])

        sim.tick = watched
        path = skill_file.save(lowered(placement_on_trajectory("perpendicular"), 0.03), tmp_path / "Low")
        runner = SkillRunner(SimRobot(sim), config, sim.scene, kinematics)
        outcome = runner.execute("ReplaySkill", f"{{data_file: {path}, target: gap_1}}")
        # Expect: carried without creeping; then the product's bottom, 1 cm below the lip's top, catches it and the
        # insertion (2100 N/m along it) pushes on: the product slips and turns in the fingers; the world says it is
        # not in the gap, and so does the skill
        assert worst["calm"] < 0.001, worst
        assert worst["shift"] > 0.01 or worst["turn"] > 10.0, worst
        assert not outcome.success
        position = sim.world.product_poses()["product_pick_1"][0]
        assert sim.scene.gap("gap_1").distance(position)[0] > sim.scene.gap("gap_1").tolerance
    finally:
        sim.close()


@pytest.mark.slow
def test_a_trial_places_relative_to_the_perceived_gap_and_is_judged_from_the_world(kinematics, tmp_path):
    path = skill_file.save(placement_on_trajectory("perpendicular"), tmp_path / "Place")
    scene = load_scene()
    result = run_trial(
        scene,
        load_motion_config(),
        kinematics,
        load_uncertainty(),
        TrialSetup("product_pick_1", "gap_2", "place_perpendicular_2", seed=5),
        path,
    )
    # Expect: the base stopped off its goal and perception was off, yet the skill found gap_2 (not named) and the
    # true world has the product there, released, upright, its neighbours in place
    assert np.linalg.norm(result["base_error"][:2]) > 0.001
    assert np.linalg.norm(result["gap_perception_error"][:3]) > 0.0005
    assert result["held_at_start"]
    assert "relative to gap_2 (taught at gap_1)" in result["message"], result["message"]
    assert result["success"] and result["skill_success"], result["message"]
    assert np.hypot(result["lateral_m"], result["depth_m"]) == pytest.approx(result["distance_m"], abs=1e-6)
    assert result["distance_m"] < scene.gap("gap_2").tolerance
    assert result["neighbour_max_move_m"] < 0.01
    assert 0.0 < result["peak_force_n"] < 60.0
    assert result["sim_s"] > 11.0


@pytest.mark.slow
def test_a_trial_that_pushes_a_neighbour_fails_in_the_world_whatever_the_skill_says(kinematics, tmp_path):
    """A skill aimed 2 cm beside the gap: the product meets a neighbour; the world's verdict is a failure."""
    taught = placement_on_trajectory("perpendicular")
    aside = taught.equilibrium_pose.copy()
    aside[:, 1] += 0.02
    shifted = skill_file.Skill(
        "Aside", "stiffness", taught.time, taught.stiffness, aside, aside, frame=taught.frame, target=taught.target
    )
    path = skill_file.save(shifted, tmp_path / "Aside")
    result = run_trial(
        load_scene(),
        load_motion_config(),
        kinematics,
        load_uncertainty().with_overrides(base_error=False, perception_noise=False),
        TrialSetup("product_pick_1", "gap_1", "place_perpendicular", seed=0),
        path,
        target="gap_1",
    )
    assert not result["success"]
    assert result["peak_neighbour_force_n"] > 1.0


@pytest.mark.slow
def test_the_trials_processes_meet_the_uncertainty_file_they_are_given(tmp_path):
    """bench/stiffness_ablation.py --uncertainty: the file reaches every simulation process, a bad one stops all."""
    exact = tmp_path / "exact.yaml"
    text = DEFAULT_UNCERTAINTY_FILE.read_text()
    exact.write_text(text.replace("  enabled: true ", "  enabled: false"))
    assert exact.read_text().count("enabled: false") == 2  # MoveBase and perception
    skill = skill_file.save(placement_on_trajectory("perpendicular"), tmp_path / "Place")
    job = TrialJob("place", TrialSetup("product_pick_1", "gap_2", "place_perpendicular_2", seed=5), str(skill))
    results = run_trials([job], 1, progress=lambda line: None, uncertainty_file=str(exact))
    (result,) = results["place"]
    # Expect: the base stopped on its goal and perception saw the gap where it is: nothing left of the default errors
    assert np.linalg.norm(result["base_error"]) == 0.0
    assert np.linalg.norm(result["gap_perception_error"]) == 0.0
    assert result["success"], result["message"]
    broken = tmp_path / "broken.yaml"
    broken.write_text("seed: -1\n")
    with pytest.raises(UncertaintyError, match=str(broken)):
        run_trials([job], 1, progress=lambda line: None, uncertainty_file=str(broken))
