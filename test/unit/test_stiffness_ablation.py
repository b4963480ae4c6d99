"""The logic of bench/stiffness_ablation.py: the sampled base errors and the three stiffness profiles it compares."""

import importlib.util
import math
import pathlib

import numpy as np
import pytest

from teleteach import skill_file
from teleteach.sim.scene import BasePose

BENCH_FILE = pathlib.Path(__file__).resolve().parents[2] / "bench" / "stiffness_ablation.py"


@pytest.fixture(scope="module")
def ablation():
    spec = importlib.util.spec_from_file_location("stiffness_ablation", BENCH_FILE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def taught_skill():
    """Compliant start, then Y and X stiffened: a variable profile like a demonstration's."""
    count = 30
    diagonal = np.tile([400.0, 430.0, 2000.0], (count, 1))
    diagonal[10:, 1] = 1900.0
    diagonal[20:, 0] = 1900.0
    poses = np.tile([0.3, 0.0, 0.88, 1.0, 0.0, 0.0, 0.0], (count, 1))
    poses[:, 0] = np.linspace(0.3, 0.61, count)
    stiffness = np.array([np.diag(row) for row in diagonal])
    return skill_file.Skill("DemonstratedPlace_1", "stiffness", np.linspace(0.0, 11.0, count), stiffness, poses, poses)


def test_errors_are_reproducible_and_within_the_limits(ablation):
    errors = ablation.base_pose_errors(200, seed=3)
    np.testing.assert_array_equal(errors, ablation.base_pose_errors(200, seed=3))
    assert np.abs(errors[:, :2]).max() <= 0.01 and np.abs(errors[:, 2]).max() <= math.radians(2.0)
    # Expect: both signs and most of the range used on every axis
    assert (errors.min(axis=0) < -0.8 * errors.max(axis=0)).all()


def test_the_profiles_change_only_the_stiffness(ablation):
    taught = taught_skill()
    profiles = ablation.stiffness_profiles(taught)
    assert list(profiles) == ["constant_low", "constant_high", "taught"]
    for name, skill in profiles.items():
        skill_file.validate(skill)
        assert skill.name == f"DemonstratedPlace_1_{name}"
        np.testing.assert_array_equal(skill.time, taught.time)
        np.testing.assert_array_equal(skill.equilibrium_pose, taught.equilibrium_pose)
        assert skill.rotational_stiffness == taught.rotational_stiffness
    # Expect: low = the approach preset throughout, high = 3000 N/m on every axis, taught unchanged
    np.testing.assert_array_equal(
        profiles["constant_low"].stiffness, np.tile(np.diag([400.0, 430.0, 2000.0]), (30, 1, 1))
    )
    np.testing.assert_array_equal(profiles["constant_high"].stiffness, np.tile(3000.0 * np.eye(3), (30, 1, 1)))
    np.testing.assert_array_equal(profiles["taught"].stiffness, taught.stiffness)


def test_aim_offset_is_the_end_of_the_trajectory_seen_from_the_gap(ablation):
    scene = ablation.load_scene(str(ablation.SCENE_FILE))
    taught = scene.base_poses["place_perpendicular"]
    end = [0.61, 0.0, 0.755]  # the recorded skill's last reference in base_link: gap_1's target below the TCP
    np.testing.assert_allclose(ablation.aim_offset(taught, scene, end), [0.0, 0.0], atol=1e-9)
    shifted = BasePose(taught.x - 0.004, taught.y + 0.01, taught.yaw)
    np.testing.assert_allclose(ablation.aim_offset(shifted, scene, end), [-0.004, 0.01], atol=1e-9)
    # 2 degrees of yaw swing the end 0.61 m ahead sideways by 0.61 sin(2 deg)
    turned = BasePose(taught.x, taught.y, taught.yaw + math.radians(2.0))
    lateral = ablation.aim_offset(turned, scene, end)[1]
    assert lateral == pytest.approx(0.61 * math.sin(math.radians(2.0)))
