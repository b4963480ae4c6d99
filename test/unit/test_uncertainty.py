"""What the simulated robot gets wrong: base error and perception noise (teleteach.sim.uncertainty)."""

import dataclasses
import math
import re

import numpy as np
import pytest
import yaml
from scipy.spatial.transform import Rotation

from teleteach.core.observed import observed_from_scene
from teleteach.core.scene import load_scene
from teleteach.sim.robot_sim import RobotSim
from teleteach.sim.uncertainty import (
    DEFAULT_UNCERTAINTY_FILE,
    BaseError,
    PerceptionNoise,
    UncertaintyError,
    UncertaintySettings,
    base_stream,
    load_uncertainty,
)


def with_value(path, value):
    """The default settings with one field (a dotted path) replaced."""
    values = yaml.safe_load(DEFAULT_UNCERTAINTY_FILE.read_text())
    *parents, key = path.split(".")
    node = values
    for parent in parents:
        node = node[parent]
    node[key] = value
    return values


def test_the_default_file_turns_both_on_with_a_localised_base_s_figures():
    settings = load_uncertainty()
    assert settings.base_error.enabled and settings.perception.enabled
    assert settings.base_error.position_std == pytest.approx(0.01)
    assert math.degrees(settings.base_error.yaw_std) == pytest.approx(1.0, abs=0.01)


@pytest.mark.parametrize(
    "path, value, said",
    [
        ("base_error.position_std", -0.01, "base_error.position_std: -0.01 must be finite, >= 0"),
        ("base_error.yaw_std", float("nan"), "base_error.yaw_std: nan must be finite"),
        ("base_error.max_position", 3.0, "base_error.max_position: 3.0 must be finite, >= 0 and <= 0.5"),
        ("perception.gaps.position_bias_std", [0.001, 0.002], "perception.gaps.position_bias_std: expected [x, y, z]"),
        ("perception.products.yaw_noise_std", "a lot", "perception.products.yaw_noise_std: not a number"),
        ("perception.enabled", "yes", "perception.enabled: expected true or false"),
        ("seed", -1, "seed: expected an integer >= 0"),
    ],
)
def test_a_wrong_value_is_named_in_one_line(path, value, said):
    with pytest.raises(UncertaintyError, match=re.escape(said)):
        UncertaintySettings.from_mapping(with_value(path, value))


def test_the_file_s_path_is_named_too(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(with_value("base_error.position_std", -1.0)))
    with pytest.raises(UncertaintyError, match=f"{path}: uncertainty base_error.position_std"):
        load_uncertainty(str(path))


def test_base_errors_are_seeded_normal_and_never_beyond_the_limits():
    settings = load_uncertainty().base_error
    first = BaseError(settings, base_stream(3)).draw()
    draws = BaseError(settings, base_stream(3))
    errors = np.array([draws.draw() for _ in range(4000)])
    # Expect: the same seed, the same first error; the spread of the settings; nothing beyond the limits
    np.testing.assert_array_equal(first, errors[0])
    assert np.std(errors[:, :2]) == pytest.approx(0.01, rel=0.1)
    assert np.std(errors[:, 2]) == pytest.approx(math.radians(1.0), rel=0.1)
    assert np.linalg.norm(errors[:, :2], axis=1).max() <= settings.max_position
    assert np.abs(errors[:, 2]).max() <= settings.max_yaw


def test_switching_perception_off_leaves_the_base_s_draws_as_they_were():
    scene = load_scene()
    on = RobotSim(scene, uncertainty=load_uncertainty())
    off = RobotSim(scene, uncertainty=load_uncertainty().with_overrides(perception_noise=False))
    try:
        for sim in (on, off):
            sim.perceived_scene()  # perception draws (or not) before the base goal
            sim.command_base_goal("world", [0.5, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0])
        np.testing.assert_array_equal(on.base_error.last, off.base_error.last)
        assert np.linalg.norm(on.base_error.last[:2]) > 0.0
        # Expect: the base drives to where the error put it, and its TF (the world's base pose) says so
        on.run(2.0)
        np.testing.assert_allclose(on.world.base_pose, np.array([0.5, 0.0, 0.0]) + on.base_error.last, atol=1e-9)
    finally:
        on.close()
        off.close()


def test_perception_errs_by_a_bias_per_viewpoint_plus_noise_and_the_truth_stays_true():
    scene = load_scene()
    truth = observed_from_scene(scene)
    noise = PerceptionNoise(load_uncertainty().perception, 0)
    views = [noise.perceive(truth) for _ in range(400)]
    true_gap = np.array(truth.gaps["gap_1"].position)
    offsets = np.array([view.gaps["gap_1"].position for view in views]) - true_gap
    bias = noise.bias("gaps", "gap_1")
    # Expect: the messages scatter by the noise around the truth plus this viewpoint's bias (gap_1's x is world x)
    np.testing.assert_allclose(offsets.mean(axis=0), bias.position, atol=2e-4)
    assert offsets.std(axis=0) == pytest.approx([0.0005] * 3, rel=0.2)
    assert truth.gaps["gap_1"].position == scene.gap("gap_1").position
    noise.new_viewpoint()
    assert not np.allclose(noise.bias("gaps", "gap_1").position, bias.position)


def test_perception_off_reports_the_truth_itself():
    truth = observed_from_scene(load_scene())
    settings = load_uncertainty().with_overrides(perception_noise=False)
    assert PerceptionNoise(settings.perception, 0).perceive(truth) is truth


def test_a_bias_depends_on_the_seed_the_viewpoint_and_the_object_not_on_how_many_messages_came_before():
    truth = observed_from_scene(load_scene())
    settings = load_uncertainty().perception
    quiet, busy = PerceptionNoise(settings, 7), PerceptionNoise(settings, 7)
    for _ in range(25):
        busy.perceive(truth)  # messages published before the robot arrived
    for noise in (quiet, busy):
        noise.new_viewpoint()
    np.testing.assert_array_equal(quiet.bias("gaps", "gap_1").position, busy.bias("gaps", "gap_1").position)
    assert not np.allclose(quiet.bias("gaps", "gap_1").position, quiet.bias("gaps", "gap_2").position)
    assert not np.allclose(
        quiet.bias("gaps", "gap_1").position, PerceptionNoise(settings, 8).bias("gaps", "gap_1").position
    )


def test_perception_errs_in_each_objects_own_frame_at_a_turned_frame():
    # Expect: gap_1 and a product turned 90 degrees about the vertical (and the product tilted) err along their own
    # axes: an error along the object's x shows along world y, its yaw adds to the object's (in world axes it would not)
    scene = load_scene()
    truth = observed_from_scene(scene)
    turned_gap = dataclasses.replace(truth.gaps["gap_1"], yaw=truth.gaps["gap_1"].yaw + math.pi / 2)
    box = truth.products["product_pick_1"]
    tilted = Rotation.from_euler("zx", [90.0, 20.0], degrees=True)
    turned_box = dataclasses.replace(box, quaternion=tilted.as_quat())
    turned = dataclasses.replace(
        truth, gaps={"gap_1": turned_gap}, products={"product_pick_1": turned_box}, surfaces={}
    )
    noise = PerceptionNoise(load_uncertainty().perception, 3)
    views = [noise.perceive(turned) for _ in range(400)]
    gap_bias, box_bias = noise.bias("gaps", "gap_1"), noise.bias("products", "product_pick_1")
    gap_offsets = np.array([view.gaps["gap_1"].position for view in views]) - np.array(turned_gap.position)
    expected = Rotation.from_euler("z", turned_gap.yaw).apply(gap_bias.position)
    # 400 looks: the mean's standard error is 0.025 mm, so 0.1 mm tells the frames apart (they differ by 0.5 mm here)
    np.testing.assert_allclose(gap_offsets.mean(axis=0), expected, atol=1e-4)
    assert np.max(np.abs(expected - gap_bias.position)) > 3e-4
    box_offsets = np.array([view.products["product_pick_1"].position for view in views]) - np.array(box.position)
    np.testing.assert_allclose(box_offsets.mean(axis=0), tilted.apply(box_bias.position), atol=1e-4)
    assert np.max(np.abs(tilted.apply(box_bias.position) - box_bias.position)) > 3e-4
    yaws = [view.gaps["gap_1"].yaw - turned_gap.yaw for view in views]
    assert float(np.mean(yaws)) == pytest.approx(gap_bias.yaw, abs=2e-3)
