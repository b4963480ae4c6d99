"""convert, wrap, unwrap, undo and redo on the thesis tree, without ROS: each edit, its undo, the running leaf kept
running, decorators changing who is asked for help, the history saved with the tree, and every bad request."""

import json
import math
import re

import py_trees
import pytest
from bt_support import CONFIG, THESIS_SEQUENCE, SkillWorld, leaf_names, status_of, thesis_tree
from conftest import ROOT
from py_trees.common import Status

from teleteach.bt.editor import HISTORY_LIMIT, EditRequest, snapshot
from teleteach.bt.library import SkillEntry, SkillLibrary
from teleteach.bt.repairs import RepairMemory
from teleteach.bt.teaching import TeachingTree, TreeStore
from teleteach.bt.tree import describe, load_tree, parse_tree

GROCERIES = {
    "execution": "BehaviorExecution",
    "root": {
        "type": "selector",
        "name": "Root",
        "children": [
            {"type": "pause", "name": "PauseCondition"},
            {
                "type": "sequence",
                "name": "BehaviorExecution",
                "children": [
                    {"type": "sequence", "name": "Fetch", "children": ["LookToShelf", "PickItem"]},
                    "MoveBase",
                    "PlaceItem",
                ],
            },
        ],
    },
}


def groceries_tree(world):
    py_trees.blackboard.Blackboard.clear()
    library = SkillLibrary.load(CONFIG / "skills.yaml")
    return TeachingTree(parse_tree(GROCERIES, library), library, world.make_leaf)


def run(tree, ticks=300):
    for _ in range(ticks):
        if tree.completed or tree.help_request is not None:
            return
        tree.tick()


def structure(tree):
    return describe(tree.root)


def test_convert_keeps_children_and_order_and_undo_restores_the_type():
    tree = groceries_tree(SkillWorld())
    before = structure(tree)
    result = tree.change("Fetch", "convert", node_type="selector")
    # Expect Fetch a selector (its default memory) with the same children in the same order, the index updated
    assert result.success, result.message
    assert result.message == "converted 'Fetch' from a sequence to a selector"
    fetch = tree.editor.nodes["Fetch"]
    assert isinstance(fetch, py_trees.composites.Selector) and leaf_names(fetch) == ["LookToShelf", "PickItem"]
    assert all(child.parent is fetch for child in fetch.children) and fetch.parent is tree.execution
    assert tree.change("Fetch", "convert", node_type="parallel").success
    assert isinstance(tree.editor.nodes["Fetch"], py_trees.composites.Parallel)
    # Expect two undos to give back exactly the tree before, and a redo to re-apply the first conversion
    assert tree.change("", "undo").success and tree.change("", "undo").success
    assert structure(tree) == before
    redone = tree.change("", "redo")
    assert redone.success and redone.message == "redo: converted 'Fetch' from a sequence to a selector"
    assert isinstance(tree.editor.nodes["Fetch"], py_trees.composites.Selector)


def test_a_selector_with_a_first_choice_runs_only_what_is_needed():
    # an operator turning Fetch into "look, else pick": LookToShelf succeeds, so PickItem never starts
    world = SkillWorld()
    tree = groceries_tree(world)
    assert tree.change("Fetch", "convert", node_type="selector").success
    run(tree)
    assert tree.completed
    assert world.names("start") == ["LookToShelf", "MoveBase", "PlaceItem"]


def test_converting_the_execution_composite_keeps_it_the_default_parent():
    tree = groceries_tree(SkillWorld())
    assert tree.change("BehaviorExecution", "convert", node_type="parallel").success
    # Expect the default parent of add to be the converted node, still found by name
    assert isinstance(tree.execution, py_trees.composites.Parallel)
    added = tree.change("Idle", "add")
    assert added.success and leaf_names(tree.execution)[-1] == "Idle"


def test_wrap_in_retry_retries_the_failing_skill_before_asking_the_operator():
    world = SkillWorld(failures={"PickItem": ["no product", "no product", "no product", "no product"]})
    tree = groceries_tree(world)
    wrapped = tree.change("PickItem", "wrap", node_type="retry", parameter=3)
    assert wrapped.success, wrapped.message
    assert wrapped.new_node_name == "RetryPickItem"
    assert wrapped.message == "wrapped 'PickItem' in the retry 'RetryPickItem', attempts 3"
    retry = tree.editor.nodes["RetryPickItem"]
    assert retry.parent is tree.editor.nodes["Fetch"] and leaf_names(retry) == ["PickItem"]
    run(tree)
    # Expect three attempts, then (the last one failing) a help request naming the leaf and its reason
    assert world.names("start").count("PickItem") == 3
    assert tree.help_request is not None and tree.help_request.node_name == "PickItem"
    assert tree.help_request.reason == "no product"
    # Expect the operator's resume to try once more: this time it succeeds and the tree completes
    tree.set_pause(False)
    world.failures["PickItem"] = []
    run(tree)
    assert tree.completed and world.names("start").count("PickItem") == 4


def test_retry_with_attempts_to_spare_needs_no_operator():
    world = SkillWorld(failures={"PickItem": ["slipped"]})
    tree = groceries_tree(world)
    assert tree.change("PickItem", "wrap", node_type="retry", parameter=2).success
    run(tree)
    # Expect one failure absorbed by the retry and the whole tree done without a help request
    assert tree.completed and tree.help_request is None
    assert world.names("fail") == ["PickItem"] and world.names("start").count("PickItem") == 2


def test_inverter_turns_a_failure_into_success_without_help():
    world = SkillWorld(failures={"LookToShelf": ["shelf empty"]})
    tree = groceries_tree(world)
    assert tree.change("LookToShelf", "wrap", node_type="inverter").success
    run(tree)
    assert tree.completed and tree.help_request is None


def test_a_timeout_that_fires_asks_the_operator_about_the_decorator():
    world = SkillWorld(durations={"MoveBase": 10**6})
    tree = groceries_tree(world)
    wrapped = tree.change("MoveBase", "wrap", node_type="timeout", parameter=0.05)
    assert wrapped.success and wrapped.message.endswith("seconds 0.05")
    for _ in range(10**5):
        tree.tick()
        if tree.help_request is not None:
            break
    # Expect the skill cancelled by the timeout and a help request saying what failed and what resuming does
    assert world.names("cancel") == ["MoveBase"]
    assert tree.help_request.node_name == "TimeoutMoveBase" and tree.paused
    assert tree.help_request.reason == (
        "timed out; 'BehaviorExecution' failed and starts again from its first node on resume"
    )


def test_wrap_and_unwrap_a_running_leaf_keep_its_skill_running():
    world = SkillWorld(ticks=2, durations={"MoveBase": 30})
    tree = thesis_tree(world)
    for _ in range(100):
        if status_of(tree, "MoveBase") == Status.RUNNING:
            break
        tree.tick()
    leaf = tree.editor.nodes["MoveBase"]
    assert tree.change("MoveBase", "wrap", node_type="retry", parameter=2).success
    # Expect the sequence to remember the decorator in the leaf's place, and the leaf to go on
    assert tree.execution.current_child is tree.editor.nodes["RetryMoveBase"]
    for _ in range(3):
        tree.tick()
    assert leaf.status == Status.RUNNING and leaf.parent.name == "RetryMoveBase"
    unwrapped = tree.change("RetryMoveBase", "unwrap")
    assert unwrapped.message == "unwrapped 'MoveBase' from the retry 'RetryMoveBase'"
    assert tree.execution.current_child is leaf and leaf.parent is tree.execution
    run(tree, 1000)
    # Expect MoveBase started once, never cancelled, and the tree done in the thesis order
    assert tree.completed and world.names("cancel") == []
    assert world.names("start") == THESIS_SEQUENCE


def test_undo_and_redo_every_kind_of_edit_restore_the_exact_tree():
    tree = thesis_tree(SkillWorld())
    states = [structure(tree)]
    for request in [
        ("PlaceItem", "remove"),
        ("PlaceItem", "add"),
        ("Idle", "prepend"),
        ("PickItem", "insert", 3),
        ("PickItem", "wrap", 0, "", "retry", 3),
        ("PickItem_2", "wrap", 0, "", "timeout", 12.5),
        ("TimeoutPickItem_2", "wrap", 0, "", "inverter"),
        ("RetryPickItem", "unwrap"),
        ("BehaviorExecution", "convert", 0, "", "selector"),
    ]:
        result = tree.change(*request)
        assert result.success, (request, result.message)
        states.append(structure(tree))
    # Expect each undo to give back the tree before that edit (names, types, parameters and order)
    for expected in reversed(states[:-1]):
        assert tree.change("", "undo").success
        assert structure(tree) == expected
        assert {node.name: node for node in tree.root.iterate()} == tree.editor.nodes
    nothing = tree.change("", "undo")
    assert (nothing.success, nothing.message) == (False, "nothing to undo")
    # Expect the redos to walk forward through the same trees
    for expected in states[1:]:
        assert tree.change("", "redo").success
        assert structure(tree) == expected
    assert tree.change("", "redo").message == "nothing to redo"


def test_a_condition_in_front_of_a_pick_keeps_a_second_round_from_picking_twice():
    # the operator's selector(ProductInHand, PickItem), built with wrap and prepend, then copied for a second round
    world = SkillWorld(failures={"ProductInHand": ["no product is in the hand"]})
    tree = groceries_tree(world)
    wrapped = tree.change("PickItem", "wrap", node_type="selector")
    assert wrapped.message == "wrapped 'PickItem' in the selector 'SelectorPickItem'"
    assert tree.change("ProductInHand", "prepend", parent="SelectorPickItem").success
    assert leaf_names(tree.editor.nodes["SelectorPickItem"]) == ["ProductInHand", "PickItem"]
    copy = tree.change("SelectorPickItem", "insert", 2, "Fetch")
    assert copy.new_node_name == "SelectorPickItem_2"
    run(tree)
    # Expect the failed condition to be an answer (no help request): the first round picks, the second does not
    assert tree.completed and tree.help_request is None
    assert world.names("start") == [
        "LookToShelf",
        "ProductInHand",
        "PickItem",
        "ProductInHand_2",
        "MoveBase",
        "PlaceItem",
    ]
    assert world.names("fail") == ["ProductInHand"]


def test_a_condition_that_fails_with_nothing_to_handle_it_asks_the_operator():
    world = SkillWorld(failures={"ProductInGap": ["no product in gap_1 (nearest: ...)"]})
    tree = groceries_tree(world)
    assert tree.change("ProductInGap", "add").success
    run(tree)
    # Expect BehaviorExecution failed by the condition, the help request naming it, the tree paused
    assert tree.help_request.node_name == "ProductInGap" and tree.paused and not tree.completed
    assert tree.help_request.reason.startswith("no product in gap_1 (nearest: ...); 'BehaviorExecution' failed")


def test_wrap_a_running_leaf_in_a_new_sequence_and_unwrap_it_again():
    world = SkillWorld(durations={"PickItem": 20})
    tree = groceries_tree(world)
    for _ in range(100):
        if status_of(tree, "PickItem") == Status.RUNNING:
            break
        tree.tick()
    assert tree.change("PickItem", "wrap", node_type="sequence").success
    assert tree.change("Idle", "add", parent="SequencePickItem").success
    refused = tree.change("SequencePickItem", "unwrap")
    assert refused.message == (
        "cannot unwrap 'SequencePickItem': it is a sequence of 2 children, not a decorator or a composite of one child"
    )
    assert tree.change("", "undo").success and tree.change("", "undo").success
    run(tree)
    # Expect the running pick neither restarted nor cancelled by the new composite around it, and Idle undone
    assert tree.completed and world.names("cancel") == []
    assert world.names("start") == ["LookToShelf", "PickItem", "MoveBase", "PlaceItem"]


def test_a_new_edit_clears_redo_and_the_history_is_bounded():
    tree = thesis_tree(SkillWorld())
    assert tree.change("Idle", "add").success
    assert tree.change("", "undo").success
    assert tree.change("Idle", "prepend").success
    assert tree.change("", "redo").message == "nothing to redo"
    # Expect as many edits kept as the reference promises ("`undo` and `redo` revert ... the last edits ... (up to N,")
    reference = " ".join((ROOT / "docs" / "reference.md").read_text().split())
    promised = [int(number) for number in re.findall(r"`undo` and `redo` revert [^(]*\(up to (\d+),", reference)]
    assert promised == [100]
    for _ in range(promised[0] + 5):
        assert tree.change("Idle", "add").success
    assert len(tree.editor.undo_edits) == HISTORY_LIMIT == promised[0]


def test_history_is_saved_with_the_tree_and_undo_works_after_a_restart(tmp_path):
    tree = thesis_tree(SkillWorld())
    original = structure(tree)
    assert tree.change("PickItem", "wrap", node_type="retry", parameter=4).success
    assert tree.change("MoveBase", "remove").success
    saved = tmp_path / "tree.yaml"
    saved.write_text(tree.tree_yaml())
    library = SkillLibrary.load(CONFIG / "skills.yaml")
    spec = load_tree(saved, library)
    # Expect the saved file to hold the decorator and both edits
    assert [edit["edit"] for edit in spec.history["undo"]] == ["wrap", "remove"]
    py_trees.blackboard.Blackboard.clear()
    restarted = TeachingTree(spec, library, SkillWorld().make_leaf)
    assert isinstance(restarted.editor.nodes["RetryPickItem"], py_trees.decorators.Retry)
    assert restarted.editor.nodes["RetryPickItem"].num_failures == 4
    assert restarted.change("", "undo").success and restarted.change("", "undo").success
    assert structure(restarted) == original
    # and what was undone is redone after another restart
    saved.write_text(restarted.tree_yaml())
    py_trees.blackboard.Blackboard.clear()
    again = TeachingTree(load_tree(saved, library), library, SkillWorld().make_leaf)
    assert again.change("", "redo").message == "redo: wrapped 'PickItem' in the retry 'RetryPickItem', attempts 4"


def test_undo_of_an_addition_that_now_runs_is_refused():
    world = SkillWorld(durations={"Idle": 50})
    tree = thesis_tree(world)
    assert tree.change("Idle", "prepend").success
    for _ in range(5):
        tree.tick()
    assert status_of(tree, "Idle_2") == Status.RUNNING
    before = snapshot(tree.root)
    result = tree.change("", "undo")
    assert result.success is False
    assert result.message == (
        "cannot undo the last edit: cannot remove 'Idle_2': it is running; removing it would abort its skill"
    )
    assert snapshot(tree.root) == before and len(tree.editor.undo_edits) == 1


def test_a_damaged_saved_edit_is_refused_with_what_is_wrong():
    tree = thesis_tree(SkillWorld())
    tree.editor.undo_edits.append({"edit": "wrap", "node": "PickItem"})  # no wrapper: a damaged file
    before = snapshot(tree.root)
    result = tree.change("", "undo")
    assert not result.success and "cannot be applied: KeyError('wrapper')" in result.message
    assert snapshot(tree.root) == before


BAD_REQUESTS = [
    (("PickItem", "convert", 0, "", "selector"), "cannot convert 'PickItem': it is a skill, not a composite"),
    (("PauseCondition", "convert", 0, "", "sequence"), "cannot convert 'PauseCondition': it is a pause"),
    (("Root", "convert", 0, "", "sequence"), "cannot convert 'Root': it is the root of the tree"),
    (
        ("BehaviorExecution", "convert", 0, "", "selector"),
        "cannot convert 'BehaviorExecution' while it runs MoveBase, paused or not (a new selector would start its"
        " children again): convert a composite that does not run, or wrap a node that has not run yet in a selector",
    ),
    (("BehaviorExecution", "convert", 0, "", "sequence"), "'BehaviorExecution' is a sequence already"),
    (("BehaviorExecution", "convert", 0, "", "fallback"), "cannot convert to 'fallback'; expected node_type"),
    (("BehaviorExecution", "convert", 0, "", ""), "cannot convert to ''; expected node_type"),
    (("Shelf", "convert", 0, "", "selector"), "no node named 'Shelf' in the tree"),
    (("Root", "wrap", 0, "", "inverter"), "cannot wrap 'Root' is the root of the tree"),
    (("PauseCondition", "wrap", 0, "", "retry", 2), "cannot wrap 'PauseCondition' is the condition that pauses"),
    (("BehaviorExecution", "wrap", 0, "", "inverter"), "cannot wrap 'BehaviorExecution' is the composite"),
    (
        ("PickItem", "wrap", 0, "", "repeat", 2),
        "cannot wrap in 'repeat'; expected node_type retry | timeout | inverter | selector",
    ),
    (("PickItem", "wrap", 0, "", "retry", 0), "a retry needs attempts, a whole number >= 1, got 0"),
    (("PickItem", "wrap", 0, "", "retry", 2.5), "a retry needs attempts, a whole number >= 1, got 2.5"),
    (("PickItem", "wrap", 0, "", "retry", math.nan), "a retry needs attempts, a whole number >= 1, got nan"),
    (("PickItem", "wrap", 0, "", "timeout", -1), "a timeout needs seconds, a finite number > 0, got -1"),
    (("PickItem", "wrap", 0, "", "timeout", 0), "a timeout needs seconds, a finite number > 0, got 0"),
    (("PickItem", "wrap", 0, "", "timeout", math.inf), "a timeout needs seconds, a finite number > 0, got inf"),
    (("Teleport", "wrap", 0, "", "inverter"), "no node named 'Teleport' in the tree"),
    (("PickItem", "unwrap"), "cannot unwrap 'PickItem': it is a skill, not a decorator or a composite of one child"),
    (("BehaviorExecution", "unwrap"), "cannot unwrap 'BehaviorExecution' is the composite that /change_tree edits"),
    (("Teleport", "unwrap"), "no node named 'Teleport' in the tree"),
    (("", "undo"), "nothing to undo"),
    (("", "redo"), "nothing to redo"),
    (("", "wrap", 0, "", "inverter"), "empty node name"),
    (("Fly", "add"), "'Fly' is neither a node of the tree nor a skill in the library"),
    (("Idle", "insert", 99), "index 99 is out of range for 'BehaviorExecution' (0..10)"),
    (("Idle", "add", 0, "Shelf"), "no composite named 'Shelf' in the tree"),
    (("Idle", "add", 0, "PickItem"), "'PickItem' is not a composite, nodes cannot be added to it"),
    (("BehaviorExecution", "add"), "cannot copy 'BehaviorExecution' is the composite that /change_tree edits"),
    (("PickItem", "remove", 0, "Root"), "'PickItem' is a child of 'BehaviorExecution', not of 'Root'"),
    (("MoveBase", "remove"), "cannot remove 'MoveBase': it is running; removing it would abort its skill"),
    (("PauseCondition", "remove"), "cannot remove 'PauseCondition' is the condition that pauses the tree"),
]


@pytest.mark.parametrize("request_, message", BAD_REQUESTS, ids=[f"{r[1]}-{r[0] or 'empty'}" for r, _ in BAD_REQUESTS])
def test_bad_request_changes_nothing_and_says_what_was_wrong(request_, message):
    world = SkillWorld(durations={"MoveBase": 50})
    tree = thesis_tree(world)
    for _ in range(100):
        if status_of(tree, "MoveBase") == Status.RUNNING:
            break
        tree.tick()
    before, names, revision = snapshot(tree.root), dict(tree.editor.nodes), tree.revision
    text = tree.tree_yaml()
    result = tree.change(*request_)
    # Expect failure, the precise reason, and the tree, its index, its history and its saved text as before
    assert result.success is False
    assert message in result.message
    assert result.new_node_name == ""
    assert snapshot(tree.root) == before and tree.editor.nodes == names and tree.revision == revision
    assert tree.tree_yaml() == text
    assert world.names("cancel") == []
    # and it used up no name: the next copy of Idle is the first one
    assert tree.change("Idle", "add").new_node_name == "Idle_2"


DAMAGED_EDITS = [
    ({"edit": "fly"}, 'unknown edit {"edit": "fly"}'),
    (
        {"edit": "convert", "before": {"type": "sequence", "name": "Shelf"}, "after": {"type": "selector"}},
        "no composite named 'Shelf' in the tree",
    ),
    (
        {
            "edit": "convert",
            "before": {"type": "selector", "name": "BehaviorExecution", "memory": False},
            "after": {"type": "sequence", "name": "BehaviorExecution", "memory": True},
        },
        "'BehaviorExecution' is a sequence, not the selector it was",
    ),
    (
        {"edit": "insert", "parent": "", "index": 0, "node": {"type": "skill", "name": "PickItem", "skill": "Idle"}},
        "cannot insert 'PickItem': the name 'PickItem' is in the tree",
    ),
    (
        {
            "edit": "insert",
            "parent": "",
            "index": 0,
            "node": {
                "type": "sequence",
                "name": "New",
                "memory": True,
                "children": [
                    {"type": "skill", "name": "Fresh", "skill": "Idle"},
                    {"type": "skill", "name": "Idle", "skill": "Idle"},
                ],
            },
        },
        "cannot insert 'New': the name 'Idle' is in the tree",
    ),
    (
        {"edit": "wrap", "node": "PickItem", "wrapper": {"type": "inverter", "name": "MoveBase"}},
        "cannot wrap 'PickItem': the name 'MoveBase' is in the tree",
    ),
    (
        {"edit": "insert", "parent": "", "index": 0, "node": {"type": "skill", "name": "Lost", "skill": "Taught"}},
        "cannot insert 'Lost': skill 'Taught' is unavailable: its file is missing",
    ),
]


def tree_with_an_unavailable_skill():
    """The thesis tree, its library holding Taught, a demonstrated skill whose file is missing."""
    py_trees.blackboard.Blackboard.clear()
    library = SkillLibrary.load(CONFIG / "skills.yaml")
    taught = SkillEntry("Taught", "stiffness", "/nowhere/taught.npz", problem="its file is missing")
    library = SkillLibrary([*library, taught])
    return TeachingTree(load_tree(CONFIG / "tree.yaml", library), library, SkillWorld().make_leaf)


def test_an_unavailable_skill_is_not_added_and_the_refusal_says_why():
    tree = tree_with_an_unavailable_skill()
    before = snapshot(tree.root)
    result = tree.change("Taught", "add")
    assert (result.success, result.message) == (
        False,
        "cannot add 'Taught': skill 'Taught' is unavailable: its file is missing",
    )
    assert snapshot(tree.root) == before


def test_a_copy_is_named_after_its_skill_or_its_original_and_renames_what_it_holds():
    world = SkillWorld()
    tree = groceries_tree(world)
    assert tree.change("PickItem", "wrap", node_type="retry", parameter=2).success
    copy = tree.change("Fetch", "add")
    assert copy.new_node_name == "Fetch_2"
    copied = sorted(node.name for node in tree.editor.nodes["Fetch_2"].iterate())
    assert copied == ["Fetch_2", "LookToShelf_2", "PickItem_2", "RetryPickItem_2"]
    assert tree.change("Fetch_2", "add").new_node_name == "Fetch_3"  # a copy of a copy: after the original
    renamed = parse_tree(
        {
            "execution": "Work",
            "root": {"type": "sequence", "name": "Work", "children": [{"name": "Go", "skill": "MoveBase"}]},
        },
        tree.editor.library,
    )
    py_trees.blackboard.Blackboard.clear()
    other = TeachingTree(renamed, tree.editor.library, world.make_leaf)
    assert other.change("Go", "add").new_node_name == "MoveBase"  # a leaf's copy is named after its skill


def test_a_snapshot_tells_two_leaves_apart_by_their_skill():
    library = SkillLibrary.load(CONFIG / "skills.yaml")

    def tree(skill):
        py_trees.blackboard.Blackboard.clear()
        data = {
            "execution": "W",
            "root": {"type": "sequence", "name": "W", "children": [{"name": "X", "skill": skill}]},
        }
        return TeachingTree(parse_tree(data, library), library, SkillWorld().make_leaf)

    assert snapshot(tree("PickItem").root) != snapshot(tree("PlaceItem").root)


@pytest.mark.parametrize("edit, message", DAMAGED_EDITS, ids=[message for _, message in DAMAGED_EDITS])
def test_a_saved_edit_that_no_longer_fits_the_tree_is_refused_and_changes_nothing(edit, message):
    tree = tree_with_an_unavailable_skill()
    tree.editor.redo_edits.append(edit)  # a hand-edited history, or one saved with another tree
    before = snapshot(tree.root)
    result = tree.change("", "redo")
    assert (result.success, result.message) == (False, f"cannot redo the last edit: {message}")
    assert snapshot(tree.root) == before and tree.editor.redo_edits == [edit]


def test_an_applied_insert_is_remembered_with_where_it_went_and_redone_there():
    tree = thesis_tree(SkillWorld())
    added = tree.change("Idle", "add")
    assert added.message == "add: a copy of 'Idle' as 'Idle_2' in 'BehaviorExecution' at index 10"
    assert tree.editor.undo_edits[-1] == {
        "edit": "insert",
        "parent": "BehaviorExecution",
        "index": 10,
        "node": {"type": "skill", "name": "Idle_2", "skill": "Idle"},
    }
    assert tree.change("", "undo").message == "undo: removed 'Idle_2' from 'BehaviorExecution' (it was at index 10)"
    redone = tree.change("", "redo")
    assert (redone.success, redone.message, redone.new_node_name) == (
        True,
        "redo: inserted 'Idle_2' in 'BehaviorExecution' at index 10",
        "Idle_2",
    )


def test_decorators_are_visible_in_the_ascii_tree_and_the_saved_yaml():
    tree = thesis_tree(SkillWorld())
    assert tree.change("PickItem", "wrap", node_type="retry", parameter=3).success
    text = py_trees.display.ascii_tree(tree.root)
    assert "RetryPickItem" in text and text.index("RetryPickItem") < text.index("PickItem\n")
    saved = tree.tree_yaml()
    assert "type: retry" in saved and "attempts: 3" in saved
    assert json.loads(saved.split("undo:\n    - ")[1].splitlines()[0])["wrapper"]["attempts"] == 3


def test_a_repair_is_remembered_and_suggested_when_the_same_failure_comes_again(tmp_path):
    # session 1: PickItem fails; the operator wraps it in a retry, tries something, undoes it, and resumes
    store = TreeStore(tmp_path / "trees")
    world = SkillWorld(failures={"PickItem": ["product_pick_1 is not on the table"] * 2})
    tree = thesis_tree(world, store=store)
    run(tree)
    assert tree.help_request[:2] == ("PickItem", "product_pick_1 is not on the table")
    assert tree.help_request.suggestion == ()
    assert tree.change("PickItem", "wrap", node_type="retry", parameter=3).success
    assert tree.change("Idle", "prepend").success
    assert tree.change("", "undo").success
    tree.set_pause(False)
    run(tree)
    assert tree.completed and world.names("start").count("PickItem") == 3
    remembered = (EditRequest("PickItem", "wrap", node_type="retry", parameter=3.0),)
    assert tree.repairs.suggestion("PickItem", "product_pick_1 is not on the table") == remembered

    # session 2 (a new tree from the same data directory): the same failure suggests the repair
    repairs, problems = TreeStore(tmp_path / "trees").restore_repairs()
    assert problems == "" and len(repairs) == 1
    world = SkillWorld(failures={"PickItem": ["product_pick_1 is not on the table"] * 2})
    tree = thesis_tree(world, repairs=repairs)
    original = describe(tree.root)
    run(tree)
    assert tree.help_request.suggestion == remembered
    assert remembered[0].describe() == "wrap PickItem in a retry (3)"
    applied = tree.change("PickItem", "repair")
    # Expect the repair applied as one edit that one undo reverts (and a redo re-applies)
    assert applied.success and applied.message == "wrapped 'PickItem' in the retry 'RetryPickItem', attempts 3"
    assert tree.change("", "undo").success and describe(tree.root) == original
    assert tree.change("", "redo").success and "RetryPickItem" in tree.editor.nodes
    tree.set_pause(False)
    run(tree)
    assert tree.completed and world.names("start").count("PickItem") == 3


def test_repair_without_a_suggestion_and_a_repair_that_no_longer_fits_change_nothing():
    world = SkillWorld(failures={"PickItem": ["gone"]})
    repairs = RepairMemory({("PickItem", "gone"): (EditRequest("Idle", "prepend"), EditRequest("Teleport", "remove"))})
    tree = groceries_tree(world)
    assert tree.change("", "repair").message == (
        "there is no remembered repair to apply: the open help request suggests none"
    )
    tree = thesis_tree(world, repairs=repairs)
    run(tree)
    before = snapshot(tree.root)
    result = tree.change("PickItem", "repair")
    assert result.success is False
    assert result.message == (
        "the remembered repair cannot be applied: edit 2 of 2 (remove Teleport) failed: "
        "no node named 'Teleport' in the tree"
    )
    assert snapshot(tree.root) == before and tree.editor.undo_edits == []


def test_a_damaged_repair_memory_is_set_aside_and_an_empty_one_used(tmp_path):
    store = TreeStore(tmp_path / "trees")
    store.repairs_path.write_text("repairs: [{node: PickItem, reason: gone, edits: [{operation: fly}]}]\n")
    repairs, problems = store.restore_repairs()
    assert len(repairs) == 0
    assert "repair 1: an edit is a mapping of" in problems and "moved to repairs.corrupt-" in problems


def test_failures_are_the_same_without_their_measured_values():
    memory = RepairMemory()
    assert memory.remember("PlaceItem", "product_pick_1 ended 15.0 cm from gap_2", [EditRequest("Idle", "prepend")])
    assert memory.suggestion("PlaceItem", "product_pick_1 ended 14.2 cm from gap_2") == (
        EditRequest("Idle", "prepend"),
    )
    assert memory.suggestion("PlaceItem", "product_pick_2 ended 15.0 cm from gap_2") == ()
    assert memory.suggestion("PickItem", "product_pick_1 ended 15.0 cm from gap_2") == ()
    saved = RepairMemory.from_dict(memory.to_dict())
    assert saved.to_dict() == memory.to_dict()
    assert saved.to_dict()["repairs"][0]["reason"] == "product_pick_1 ended 15.0 cm from gap_2"


def test_a_paused_composite_is_still_refused_with_advice_the_operator_can_follow():
    world = SkillWorld(durations={"MoveBase": 50})
    tree = thesis_tree(world)
    while status_of(tree, "MoveBase") != Status.RUNNING:
        tree.tick()
    tree.set_pause(True)
    tree.tick()
    # Expect the pause to leave the sequence holding its suspended skill, so the refusal no longer says "pause first"
    refused = tree.change("BehaviorExecution", "convert", node_type="parallel")
    assert not refused.success and "pause first" not in refused.message
    assert refused.message.startswith("cannot convert 'BehaviorExecution' while it runs MoveBase, paused or not")
    # Expect its advice to work: a node that has not run yet, wrapped in the new type, takes edits and the tree resumes
    wrapped = tree.change("Idle", "wrap", node_type="parallel")
    assert wrapped.success, wrapped.message
    assert tree.change("Idle", "add", parent=wrapped.new_node_name).success
    tree.set_pause(False)
    run(tree)
    assert tree.completed and world.names("start").count("MoveBase") == 1


@pytest.mark.parametrize(
    "requests, message",
    [
        ((), "no edits to apply"),
        ((EditRequest("Idle", "undo"),), "edit 1 of 1 (undo Idle) failed: 'undo' cannot be part of a repair"),
        ((EditRequest("Idle", "prepend"), EditRequest("", "redo")), "edit 2 of 2 (redo ) failed: 'redo' cannot be"),
        ((EditRequest("PickItem", "repair"),), "edit 1 of 1 (repair PickItem) failed: 'repair' cannot be part of"),
        ((EditRequest("PickItem", "swap"),), "edit 1 of 1 (swap PickItem) failed: 'swap' cannot be part of a repair"),
        ((EditRequest("Idle", "prepend"), EditRequest("", "remove")), "edit 2 of 2 (remove ) failed: empty node name"),
    ],
)
def test_a_group_of_edits_that_cannot_all_be_applied_changes_nothing(requests, message):
    tree = thesis_tree(SkillWorld())
    before, names = snapshot(tree.root), dict(tree.editor.nodes)
    result = tree.editor.apply_requests(requests)
    # Expect failure with the exact reason, the tree, its index and its history as before (a first edit undone)
    assert not result.success and result.message.startswith(message), result.message
    assert snapshot(tree.root) == before and tree.editor.nodes == names
    assert tree.editor.undo_edits == [] and tree.editor.redo_edits == []
    # and the undone first edit used up no name: the next copy of Idle is the first one
    assert tree.change("Idle", "add").new_node_name == "Idle_2"


@pytest.mark.parametrize(
    "request_, words",
    [
        (EditRequest("PickItem", "wrap", node_type="retry", parameter=3.0), "wrap PickItem in a retry (3)"),
        (EditRequest("PickItem", "wrap", node_type="timeout", parameter=2.5), "wrap PickItem in a timeout (2.5)"),
        (EditRequest("PickItem", "wrap", node_type="inverter"), "wrap PickItem in an inverter"),
        (EditRequest("PickItem", "wrap", node_type="sequence", parameter=4.0), "wrap PickItem in a sequence"),
        (EditRequest("Shelf", "convert", node_type="selector", parent="Root"), "convert Shelf to a selector in Root"),
        (EditRequest("Idle", "insert", index=3, parent="Shelf"), "insert Idle at index 3 in Shelf"),
        (EditRequest("Idle", "add", index=3, parent="Shelf"), "add Idle in Shelf"),
        (EditRequest("Idle", "prepend"), "prepend Idle"),
        (EditRequest("PickItem", "remove", parent="BehaviorExecution"), "remove PickItem"),
    ],
)
def test_a_request_is_told_to_the_operator_in_one_line(request_, words):
    assert request_.describe() == words
