import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from teleteach.core import skill_file
from teleteach.skills.replay import parse_replay_parameters, plan_replay, principal_axes
from teleteach.skills.robot import SkillError


def rotation_z(angle):
    return Rotation.from_euler("z", angle).as_matrix()


def test_principal_axes_rebuild_the_stiffness_with_a_right_handed_rotation():
    rng = np.random.default_rng(4)
    for _ in range(20):
        axes = Rotation.random(random_state=rng).as_matrix()
        stiffness = axes @ np.diag(rng.uniform(50.0, 3000.0, 3)) @ axes.T
        values, rotation = principal_axes(stiffness)
        np.testing.assert_allclose(rotation @ np.diag(values) @ rotation.T, stiffness, atol=1e-8)
        assert np.linalg.det(rotation) == pytest.approx(1.0)


def test_principal_axes_of_the_45_degree_ellipsoid_point_along_45_degrees():
    # thesis III-D: stiff along the alignment direction, rotated 45 degrees about z
    stiffness = rotation_z(math.pi / 4) @ np.diag([300.0, 1500.0, 1000.0]) @ rotation_z(math.pi / 4).T
    values, rotation = principal_axes(stiffness, previous=rotation_z(math.pi / 4))
    np.testing.assert_allclose(values, [300.0, 1500.0, 1000.0])
    np.testing.assert_allclose(rotation, rotation_z(math.pi / 4), atol=1e-9)


def make_skill(stiffness, positions, times=None, name="placing"):
    count = len(stiffness)
    times = np.linspace(0.0, 1.0, count) if times is None else times
    quaternion = Rotation.from_euler("x", math.pi).as_quat()
    poses = np.hstack([positions, np.tile(quaternion, (count, 1))])
    return skill_file.Skill(name, "stiffness", times, stiffness, poses, poses)


def test_plan_keeps_the_ellipsoid_continuous_when_two_stiffnesses_cross():
    # Kx falls from 1000 to 200 while Ky rises from 200 to 1000: eigh swaps their order half-way
    kx, ky = np.linspace(1000.0, 200.0, 11), np.linspace(200.0, 1000.0, 11)
    stiffness = np.array([np.diag([x, y, 800.0]) for x, y in zip(kx, ky)])
    plan = plan_replay(make_skill(stiffness, np.tile([0.5, 0.0, 0.8], (11, 1))), rate=200.0)
    steps = np.abs(np.diff(plan.eigenvalues, axis=0)).max()
    assert steps < 10.0  # [N/m] per 5 ms sample: no jump when the values cross
    turns = [abs(np.dot(a, b)) for a, b in zip(plan.eigenvectors[:-1], plan.eigenvectors[1:])]
    assert min(turns) > 1.0 - 1e-9  # the axes never rotate
    rebuilt = [
        Rotation.from_quat(quaternion).as_matrix() @ np.diag(values) @ Rotation.from_quat(quaternion).as_matrix().T
        for quaternion, values in zip(plan.eigenvectors, plan.eigenvalues)
    ]
    np.testing.assert_allclose(rebuilt[-1], stiffness[-1], atol=1e-6)
    np.testing.assert_allclose(rebuilt[len(rebuilt) // 2], np.diag([600.0, 600.0, 800.0]), atol=1.0)


def test_plan_resamples_at_the_rate_and_keeps_the_recorded_timing():
    times = np.array([10.0, 10.3, 11.0, 12.5])  # irregular recording
    stiffness = np.array([np.diag([500.0, 500.0, 500.0])] * 4)
    positions = np.array([[0.4, 0.0, 0.8], [0.43, 0.0, 0.8], [0.5, 0.0, 0.8], [0.5, 0.1, 0.8]])
    plan = plan_replay(make_skill(stiffness, positions, times), rate=100.0)
    assert plan.duration == pytest.approx(2.5)
    assert np.diff(plan.times).max() <= 0.01 + 1e-9
    index = int(np.argmin(np.abs(plan.times - 1.0)))  # recorded t = 11.0
    np.testing.assert_allclose(plan.positions[index], [0.5, 0.0, 0.8], atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(plan.orientations, axis=1), 1.0)


@pytest.mark.parametrize(
    ("parameters", "message"),
    [
        ("", "must be yaml {data_file"),
        ("[1, 2]", "must be yaml {data_file"),
        ("{data_file: a.npz, kind: poem}", "unknown skill kind 'poem'"),
        ("{data_file: [", "not valid yaml"),
        ("{data_file: a.npz, target: [gap_1]}", "target must be the name of a gap, got \\['gap_1'\\]"),
    ],
)
def test_bad_replay_parameters_are_refused(parameters, message):
    with pytest.raises(SkillError, match=message):
        parse_replay_parameters(parameters)


def test_replay_parameters_name_the_file_the_kind_and_the_target():
    request = parse_replay_parameters("{data_file: ~/skills/Place.npz, kind: stiffness, target: gap_2}")
    assert request.path.name == "Place.npz" and not str(request.path).startswith("~")
    assert (request.kind, request.target) == ("stiffness", "gap_2")
    assert parse_replay_parameters("{data_file: Place.npz}").target is None
