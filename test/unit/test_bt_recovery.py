"""State that cannot be lost: every save keeps the previous version; a saved tree or library that does not load is
set aside (never overwritten) and the previous version (or the default) is resumed; a taught skill whose file went
missing or bad stays in the library as unavailable, and /change_tree refuses it while the rest works."""

import numpy as np
import pytest
from bt_support import CONFIG, THESIS_SEQUENCE, SkillWorld, leaf_names, thesis_tree
from py_trees.common import Status

from teleteach.bt.library import SkillEntry, SkillLibrary
from teleteach.bt.ros import ActionClients, ActionSkill, BehaviourTreeConfig
from teleteach.bt.teaching import TeachingTree, TreeStore
from teleteach.bt.tree import create_root, load_tree
from teleteach.core import skill_file

COUNT = 5


def save_skill(path):
    pose = np.tile([0.5, 0.0, 0.4, 0.0, 0.0, 0.0, 1.0], (COUNT, 1))
    stiffness = np.tile(np.eye(3) * 500.0, (COUNT, 1, 1))
    return skill_file.save(skill_file.Skill("Wipe", "stiffness", np.arange(COUNT) * 0.1, stiffness, pose, pose), path)


@pytest.fixture
def predefined():
    return SkillLibrary.load(CONFIG / "skills.yaml")


@pytest.fixture
def default(predefined):
    return load_tree(CONFIG / "tree.yaml", predefined)


def taught(tmp_path):
    """A store with two saves of the tree (Idle added twice) and a taught skill Wipe."""
    store = TreeStore(tmp_path / "trees")
    tree = thesis_tree(SkillWorld(), store=store, data_root=tmp_path)
    save_skill(tmp_path / "skills" / "wipe.npz")
    assert tree.add_skill("Wipe", "stiffness", "skills/wipe.npz")[0]
    assert tree.change("Idle", "add").success
    assert tree.change("Wipe", "insert", 1).success
    return store, tree


def execution_names(root):
    return leaf_names(root.children[1])


def names_in(directory):
    return sorted(path.name for path in directory.iterdir())


def test_every_save_keeps_the_previous_version(tmp_path, predefined):
    store, tree = taught(tmp_path)
    previous = store.directory / "current_tree.previous.yaml"
    # Expect the version before the last edit (Idle_2 added, Wipe not yet inserted) kept beside the current one
    assert execution_names(
        create_root(load_tree(previous, tree.library).root, tree.library, SkillWorld().make_leaf)
    ) == [
        *THESIS_SEQUENCE,
        "Idle_2",
    ]
    assert "Wipe" in execution_names(tree.root)
    assert load_tree(store.tree_path, tree.library).root != load_tree(previous, tree.library).root


@pytest.mark.parametrize("content", [b"root: [unclosed", b"\xff\xfe\x00garbage", b"", b"execution: Nowhere\nroot: 3\n"])
def test_a_corrupt_tree_is_set_aside_and_the_previous_version_resumed(tmp_path, predefined, default, content):
    store, tree = taught(tmp_path)
    store.tree_path.write_bytes(content)
    spec, library, problems = store.restore(default, predefined)
    # Expect the tree before the last edit, the corrupt file kept aside with its content, one line saying so
    root = create_root(spec.root, library, SkillWorld().make_leaf)
    assert execution_names(root) == [*THESIS_SEQUENCE, "Idle_2"]
    corrupt = [name for name in names_in(store.directory) if name.startswith("current_tree.corrupt-")]
    assert len(corrupt) == 1 and (store.directory / corrupt[0]).read_bytes() == content
    assert not store.tree_path.exists()
    assert "current_tree.yaml" in problems and corrupt[0] in problems and "current_tree.previous.yaml" in problems
    assert "\n" not in problems
    # Expect the next save not to touch the corrupt file, and to keep the resumed version as the previous one
    resumed = TeachingTree(spec, library, SkillWorld().make_leaf, store=store, data_root=tmp_path)
    assert resumed.change("MoveBase", "add").success
    assert (store.directory / corrupt[0]).read_bytes() == content
    assert load_tree(store.tree_path, library).root != spec.root


def test_without_a_good_version_the_default_tree_is_used_and_both_files_are_kept(tmp_path, predefined, default):
    store, _ = taught(tmp_path)
    store.tree_path.write_text("root: {type: selector")
    (store.directory / "current_tree.previous.yaml").write_text("{{{")
    spec, _, problems = store.restore(default, predefined)
    # Expect the default tree, both unreadable files set aside under distinct names, the reason given
    assert spec == default
    corrupt = [name for name in names_in(store.directory) if ".corrupt-" in name]
    assert len(corrupt) == 2 and "default tree" in problems
    assert sorted((store.directory / name).read_text() for name in corrupt) == ["root: {type: selector", "{{{"]


def test_a_corrupt_library_resumes_the_previous_library(tmp_path, predefined, default):
    store, tree = taught(tmp_path)
    save_skill(tmp_path / "skills" / "wipe2.npz")
    assert tree.add_skill("Wipe2", "stiffness", "skills/wipe2.npz")[0]  # the library saved twice: Wipe is previous
    store.library_path.write_text("skills: 12\n")
    spec, library, problems = store.restore(default, predefined)
    # Expect the previous library (with Wipe, without Wipe2): the saved tree, which uses only Wipe, still loads
    assert "Wipe" in library and "Wipe2" not in library
    assert "skill_library.yaml" in problems and "skill_library.previous.yaml" in problems
    assert "Wipe" in execution_names(create_root(spec.root, library, SkillWorld().make_leaf))


@pytest.mark.parametrize("damage", ["missing", "truncated", "nan"])
def test_a_skill_whose_file_went_bad_is_unavailable_and_refused(tmp_path, predefined, default, damage):
    store, _ = taught(tmp_path)
    path = tmp_path / "skills" / "wipe.npz"
    if damage == "missing":
        path.unlink()
    elif damage == "truncated":
        path.write_bytes(path.read_bytes()[:100])
    else:
        skill = skill_file.load(path)
        stiffness = skill.stiffness.copy()
        stiffness[2, 0, 0] = np.nan
        np.savez(
            path,
            time=skill.time,
            stiffness=stiffness,
            equilibrium_pose=skill.equilibrium_pose,
            cartesian_pose=skill.cartesian_pose,
            meta=np.array('{"name": "Wipe", "kind": "stiffness"}'),
        )
    spec, library, problems = store.restore(default, predefined)
    # Expect the saved tree and library resumed, Wipe listed but unavailable, the problem naming its file
    assert problems == ""
    entry = library.get("Wipe")
    assert not entry.available and str(path.resolve()) in entry.problem
    assert all(entry.available for entry in library if entry.name != "Wipe")
    tree = TeachingTree(spec, library, SkillWorld().make_leaf, store=store, data_root=tmp_path)
    refused = tree.change("Wipe", "add")
    # Expect /change_tree to refuse the unavailable skill (and a copy of its leaf) with its file named, and to
    # change nothing; the rest of the library still works
    assert not refused.success and str(path.resolve()) in refused.message and "unavailable" in refused.message
    copy = tree.change("Wipe", "add")
    assert not copy.success
    before = execution_names(tree.root)
    assert tree.change("PickItem", "add").success
    assert execution_names(tree.root) == [*before, "PickItem_2"]


def test_a_leaf_of_an_unavailable_skill_fails_at_once_with_the_reason():
    entry = SkillEntry("Wipe", "stiffness", "/data/skills/wipe.npz", problem="skill file /data/skills/wipe.npz gone")
    leaf = ActionSkill("Wipe", entry, ActionClients("/skills"), BehaviourTreeConfig.from_yaml())
    leaf.initialise()
    # Expect a failure naming the file before any goal is sent (no server is asked to replay a missing file)
    assert leaf.update() == Status.FAILURE
    assert "unavailable" in leaf.feedback_message and "/data/skills/wipe.npz" in leaf.feedback_message
    assert leaf.goal_handle is None
