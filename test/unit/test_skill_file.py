"""The skill file format: skills relative to the target they were taught at, and older base_link files."""

import io
import json

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from teleteach.core import skill_file
from teleteach.core.frames import Transform

GAP_IN_BASE = Transform.from_planar(0.61, 0.02, 0.3, z=0.72)  # a gap ahead, turned 0.3 rad


def base_link_skill():
    """A short placement in base_link: the hand moving into the gap, stiff along base x at the end."""
    times = np.linspace(0.0, 2.0, 5)
    positions = np.column_stack([np.linspace(0.45, 0.61, 5), np.full(5, 0.02), np.full(5, 0.755)])
    quaternions = np.tile(Rotation.from_euler("xyz", [np.pi, 0.0, 0.3]).as_quat(), (5, 1))
    poses = np.hstack([positions, quaternions])
    stiffness = np.array([np.diag([400.0 + 400.0 * index, 1500.0, 2000.0]) for index in range(5)])
    return skill_file.Skill("Place", "stiffness", times, stiffness, poses, poses)


def test_a_skill_moved_into_its_target_s_frame_and_back_is_unchanged():
    skill = base_link_skill()
    relative = skill.relative_to("gap_1", GAP_IN_BASE)
    assert relative.frame == skill_file.TARGET_FRAME and relative.target.name == "gap_1"
    # Expect: the last reference 0.035 m above the gap's origin along its z; its stiffness turned into the gap's axes
    np.testing.assert_allclose(relative.equilibrium_pose[-1, :3], [0.0, 0.0, 0.035], atol=1e-12)
    rotation = GAP_IN_BASE.rotation.as_matrix()
    np.testing.assert_allclose(relative.stiffness[0], rotation.T @ skill.stiffness[0] @ rotation, atol=1e-9)
    back = relative.in_base(GAP_IN_BASE)
    assert back.frame == skill_file.BASE_FRAME and back.target is None
    np.testing.assert_allclose(back.equilibrium_pose[:, :3], skill.equilibrium_pose[:, :3], atol=1e-12)
    np.testing.assert_allclose(
        np.abs(np.einsum("ij,ij->i", back.equilibrium_pose[:, 3:], skill.equilibrium_pose[:, 3:])), 1.0
    )
    np.testing.assert_allclose(back.stiffness, skill.stiffness, atol=1e-9)


def test_replayed_at_another_gap_the_profile_turns_with_the_gap():
    relative = base_link_skill().relative_to("gap_1", GAP_IN_BASE)
    other = Transform.from_planar(0.55, -0.2, -0.5, z=0.87)  # a held-out gap: elsewhere, higher, turned the other way
    moved = relative.in_base(other)
    # Expect: the end 0.035 m above the other gap's origin; stiff along that gap's x, as it was along gap_1's
    np.testing.assert_allclose(moved.equilibrium_pose[-1, :3], other.apply_point([0.0, 0.0, 0.035]), atol=1e-12)
    along = other.rotation.apply([1.0, 0.0, 0.0])
    taught_along = GAP_IN_BASE.rotation.apply([1.0, 0.0, 0.0])
    base_skill = base_link_skill()
    assert along @ moved.stiffness[-1] @ along == pytest.approx(taught_along @ base_skill.stiffness[-1] @ taught_along)


def test_the_target_survives_a_save_and_load(tmp_path):
    relative = base_link_skill().relative_to("gap_1", GAP_IN_BASE)
    loaded = skill_file.load(skill_file.save(relative, tmp_path / "Place"))
    assert loaded.frame == skill_file.TARGET_FRAME
    assert loaded.target.name == "gap_1"
    np.testing.assert_allclose(loaded.target.pose_in_base, GAP_IN_BASE.as_pose())
    np.testing.assert_allclose(loaded.equilibrium_pose, relative.equilibrium_pose)


def test_a_file_written_before_target_frames_loads_as_a_base_link_skill(tmp_path):
    skill = base_link_skill()
    buffer = io.BytesIO()
    meta = {"name": skill.name, "kind": skill.kind, "rotational_stiffness": 30.0, "provenance": {}}
    np.savez_compressed(
        buffer,
        time=skill.time,
        stiffness=skill.stiffness,
        equilibrium_pose=skill.equilibrium_pose,
        cartesian_pose=skill.cartesian_pose,
        meta=np.array(json.dumps(meta)),
    )
    path = tmp_path / "Old.npz"
    path.write_bytes(buffer.getvalue())
    loaded = skill_file.load(path)
    assert loaded.frame == skill_file.BASE_FRAME and loaded.target is None


@pytest.mark.parametrize(
    "target, said",
    [
        ({"name": "gap_1", "pose_in_base": [0.6, 0.0, 0.7, 0.0, 0.0, 0.0]}, "7 finite numbers"),
        ({"name": "gap_1", "pose_in_base": [0.6, 0.0, 0.7, 0.0, 0.0, 0.0, 2.0]}, "not unit length"),
        ({"name": "", "pose_in_base": [0.6, 0.0, 0.7, 0.0, 0.0, 0.0, 1.0]}, "non-empty string"),
        ({"pose_in_base": [0.6, 0.0, 0.7, 0.0, 0.0, 0.0, 1.0]}, "meta lacks 'name'"),
    ],
)
def test_a_malformed_target_is_refused_naming_the_file(tmp_path, target, said):
    skill = base_link_skill()
    buffer = io.BytesIO()
    meta = {"name": "Place", "kind": "stiffness", "frame": "target", "target": target}
    np.savez_compressed(
        buffer,
        time=skill.time,
        stiffness=skill.stiffness,
        equilibrium_pose=skill.equilibrium_pose,
        cartesian_pose=skill.cartesian_pose,
        meta=np.array(json.dumps(meta)),
    )
    path = tmp_path / "Bad.npz"
    path.write_bytes(buffer.getvalue())
    with pytest.raises(skill_file.SkillFileError, match=f"{path}.*{said}"):
        skill_file.load(path)


def test_a_target_frame_without_a_target_is_refused():
    skill = base_link_skill()
    with pytest.raises(skill_file.SkillFileError, match="exactly when its frame is 'target'"):
        skill_file.Skill(
            "Place",
            "stiffness",
            skill.time,
            skill.stiffness,
            skill.equilibrium_pose,
            skill.cartesian_pose,
            frame="target",
        )
