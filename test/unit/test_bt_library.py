"""Skill library (predefined + demonstrated, validated) and persistence of the tree and library to the data dir."""

import json
import os
import time

import numpy as np
import pytest
import yaml
from bt_support import CONFIG, THESIS_SEQUENCE, SkillWorld, leaf_names, thesis_tree
from conftest import ROOT

from teleteach.bt.library import CONDITION, PREDEFINED, LibraryError, SkillEntry, SkillLibrary
from teleteach.bt.ros import ActionClients, ActionSkill, BehaviourTreeConfig
from teleteach.bt.teaching import TreeStore
from teleteach.bt.tree import create_root, describe, load_tree
from teleteach.core import skill_file

COUNT = 10


def poses():
    return np.tile([0.5, 0.0, 0.4, 0.0, 0.0, 0.0, 1.0], (COUNT, 1))


def save_skill(path, kind="stiffness"):
    stiffness = np.tile(np.diag([300.0, 800.0, 1500.0]), (COUNT, 1, 1))
    skill = skill_file.Skill("Demo", kind, np.linspace(0.0, 1.0, COUNT), stiffness, poses(), poses())
    return skill_file.save(skill, path)


def save_raw(path, time, stiffness):
    meta = json.dumps({"name": "Raw", "kind": "stiffness"})
    np.savez(
        path, time=time, stiffness=stiffness, equilibrium_pose=poses(), cartesian_pose=poses(), meta=np.array(meta)
    )
    return path


@pytest.fixture
def library():
    return SkillLibrary.load(CONFIG / "skills.yaml")


def test_predefined_library_from_config(library):
    # Expect the ten thesis skills, predefined, then the conditions; no data files, none run through ReplaySkill
    assert [entry.name for entry in library] == [*THESIS_SEQUENCE, "ProductInHand", "ProductInGap"]
    assert [entry.kind for entry in library] == [PREDEFINED] * 10 + [CONDITION] * 2
    assert all(entry.description and not entry.data_file and not entry.demonstrated for entry in library)


def test_demonstrated_skill_is_validated_and_added(library, tmp_path):
    save_skill(tmp_path / "skills" / "place.npz")
    entry = library.add_demonstrated("PlaceStiff", "stiffness", "skills/place.npz", tmp_path)
    # Expect a relative path taken from the data dir and stored absolute
    assert entry == SkillEntry("PlaceStiff", "stiffness", str((tmp_path / "skills" / "place.npz").resolve()))
    assert library.get("PlaceStiff") == entry and entry.demonstrated
    assert [e.name for e in library][-1] == "PlaceStiff"


@pytest.mark.parametrize(
    "name, kind, data_file, message",
    [
        ("", "stiffness", "good.npz", "empty skill name"),
        ("place it", "stiffness", "good.npz", "must be an identifier"),
        ("PlaceItem", "stiffness", "good.npz", "'PlaceItem' is already in the library (predefined)"),
        ("New", "impedance", "good.npz", "unknown skill kind 'impedance'"),
        ("New", "stiffness", "", "empty data file"),
        ("New", "stiffness", "missing.npz", "does not exist"),
        ("New", "stiffness", "garbage.npz", "cannot be read"),
        ("New", "stiffness", "not_spd.npz", "stiffness is not positive definite at sample 3"),
        ("New", "stiffness", "backwards.npz", "time is not strictly increasing at sample 5"),
        ("New", "dmp", "good.npz", "holds a stiffness skill, not a dmp skill"),
    ],
)
def test_bad_demonstrated_skills_are_refused_and_change_nothing(library, tmp_path, name, kind, data_file, message):
    save_skill(tmp_path / "good.npz")
    (tmp_path / "garbage.npz").write_bytes(b"not a zip archive")
    stiffness = np.tile(np.eye(3) * 500.0, (COUNT, 1, 1))
    stiffness[3, 2, 2] = -1.0
    save_raw(tmp_path / "not_spd.npz", np.linspace(0, 1, COUNT), stiffness)
    time = np.linspace(0, 1, COUNT)
    time[5] = time[4]
    save_raw(tmp_path / "backwards.npz", time, np.tile(np.eye(3) * 500.0, (COUNT, 1, 1)))
    before = library.to_dict()
    with pytest.raises(LibraryError) as error:
        library.add_demonstrated(name, kind, data_file, tmp_path)
    # Expect the reason in the message and the library unchanged
    assert message in str(error.value)
    assert library.to_dict() == before


@pytest.mark.parametrize(
    "data, message",
    [
        ({"skills": "LookToShelf"}, "expected a mapping with a 'skills' list"),
        ({"skills": ["A", "A"]}, "skill 'A' is listed twice"),
        ({"skills": [{"name": "A", "kind": "magic"}]}, "unknown kind 'magic'"),
        ({"skills": [{"name": "A", "speed": 1}]}, "unknown fields ['speed']"),
        ({"skills": [{"kind": "stiffness"}]}, "each skill needs a name"),
        ({"skills": ["not an identifier"]}, "must be a non-empty identifier"),
    ],
)
def test_bad_library_files_are_rejected(data, message):
    with pytest.raises(LibraryError) as error:
        SkillLibrary.from_dict(data)
    assert message in str(error.value)


def test_demonstrated_leaf_replays_through_replay_skill(tmp_path):
    path = str(save_skill(tmp_path / "wipe.npz"))
    leaf = ActionSkill(
        "Wipe_2", SkillEntry("Wipe", "stiffness", path), ActionClients("/skills"), BehaviourTreeConfig.from_yaml()
    )
    # Expect the goal of the thesis contract: ReplaySkill, goal.skill = name, parameters = yaml {data_file, kind}
    assert leaf.server == "ReplaySkill" and leaf.goal.skill == "Wipe" and leaf.skill == "Wipe"
    assert yaml.safe_load(leaf.goal.parameters) == {"data_file": path, "kind": "stiffness"}
    predefined = ActionSkill(
        "PlaceItem_2", SkillEntry("PlaceItem"), ActionClients("/skills"), BehaviourTreeConfig.from_yaml()
    )
    assert (
        predefined.server == "PlaceItem" and predefined.goal.skill == "PlaceItem" and predefined.goal.parameters == ""
    )


def test_changes_and_taught_skills_are_saved_and_restored(library, tmp_path):
    store = TreeStore(tmp_path / "trees")
    tree = thesis_tree(SkillWorld(), store=store, data_root=tmp_path)
    save_skill(tmp_path / "skills" / "place.npz")
    assert tree.add_skill("PlaceStiff", "stiffness", "skills/place.npz")[0]
    assert tree.change("PlaceItem", "remove").success
    assert tree.change("PlaceStiff", "insert", 3).success
    assert tree.change("PickItem", "add").new_node_name == "PickItem_2"
    failed = tree.change("Nothing", "add")
    assert not failed.success
    # Expect both files written, and a restart from them to rebuild the edited tree with the taught skill
    assert store.tree_path.is_file() and store.library_path.is_file()
    default = load_tree(CONFIG / "tree.yaml", library)
    spec, restored_library, problems = store.restore(default, SkillLibrary.load(CONFIG / "skills.yaml"))
    assert problems == ""
    assert restored_library.get("PlaceStiff").kind == "stiffness" and restored_library.get("PlaceStiff").available
    root = create_root(spec.root, restored_library, SkillWorld().make_leaf)
    assert describe(root) == describe(tree.root)
    assert leaf_names(root.children[1]) == [
        "LookToShelf",
        "PickItem",
        "MoveBase",
        "PlaceStiff",
        "DropItem",
        "MoveBaseToStart",
        "LookToShelfAgain",
        "PickItem2",
        "MoveBase2",
        "Idle",
        "PickItem_2",
    ]
    assert root.children[1].children[3].data_file == restored_library.get("PlaceStiff").data_file
    # Expect the previous version of the tree kept, and no temporary files left behind by the atomic writes
    assert sorted(p.name for p in store.directory.iterdir()) == [
        "current_tree.previous.yaml",
        "current_tree.yaml",
        "skill_library.yaml",
    ]


def test_restore_without_saved_files_gives_the_defaults(library, tmp_path):
    default = load_tree(CONFIG / "tree.yaml", library)
    spec, restored, problems = TreeStore(tmp_path).restore(default, library)
    assert spec == default and list(restored) == list(library) and problems == ""


def test_refused_skill_is_not_saved(tmp_path):
    store = TreeStore(tmp_path / "trees")
    tree = thesis_tree(SkillWorld(), store=store, data_root=tmp_path)
    success, message = tree.add_skill("Ghost", "stiffness", "skills/ghost.npz")
    assert not success and "does not exist" in message
    assert not store.library_path.exists() and not store.tree_path.exists()


def test_a_burst_of_saves_is_made_durable_by_one_background_fsync(tmp_path, monkeypatch):
    synced = []
    real_fsync = os.fsync

    def recording_fsync(fd):
        path = os.readlink(f"/proc/self/fd/{fd}")
        if path.startswith(str(tmp_path)):  # stores of other tests may still be flushing
            synced.append(path)
        real_fsync(fd)

    monkeypatch.setattr(os, "fsync", recording_fsync)
    store = TreeStore(tmp_path / "trees")
    tree = thesis_tree(SkillWorld(), store=store, data_root=tmp_path)
    for _ in range(5):
        assert tree.change("Idle", "add").success
    # Expect the saved tree and its directory fsynced shortly after the burst, once each, not once per save
    deadline = time.monotonic() + 5.0
    while len(synced) < 2 and time.monotonic() < deadline:
        time.sleep(0.01)
    time.sleep(3 * TreeStore.flush_delay)
    previous = str(store.tree_path.with_name("current_tree.previous.yaml"))
    assert sorted(synced[:-1]) == sorted([str(store.tree_path), previous]) and synced[-1] == str(store.directory)
    assert load_tree(store.tree_path, tree.library).root == describe(tree.root)


def test_a_library_extends_another_and_may_not_extend_itself(tmp_path):
    base = SkillLibrary.load(ROOT / "config" / "skills.yaml")
    extended = SkillLibrary.load(ROOT / "config" / "scenarios" / "teach_placement_skills.yaml")
    # Expect the predefined library's skills, in their order, then PlaceTaught
    assert [entry["name"] for entry in extended.to_dict()["skills"]] == [
        *(entry["name"] for entry in base.to_dict()["skills"]),
        "PlaceTaught",
    ]
    (tmp_path / "a.yaml").write_text("extends: b.yaml\nskills: [LookToShelf]\n")
    (tmp_path / "b.yaml").write_text("extends: a.yaml\nskills: [PickItem]\n")
    with pytest.raises(LibraryError, match="extends itself"):
        SkillLibrary.load(tmp_path / "a.yaml")
    (tmp_path / "c.yaml").write_text("extends: missing.yaml\nskills: []\n")
    with pytest.raises(LibraryError, match="cannot read skill library .*missing.yaml"):
        SkillLibrary.load(tmp_path / "c.yaml")
