"""ChangeTree semantics on the thesis tree, without ROS: every operation, running leaves kept running, bad requests."""

import py_trees
import pytest
from bt_support import CONFIG, THESIS_SEQUENCE, SkillWorld, leaf_names, status_of, thesis_tree
from py_trees.common import Status

from teleteach.bt.editor import OPERATIONS, EditRequest, TreeEditor, snapshot
from teleteach.bt.library import SkillLibrary
from teleteach.bt.tree import create_root, parse_tree


def running_tree(world, leaf="MoveBase"):
    tree = thesis_tree(world)
    for _ in range(100):
        if status_of(tree, leaf) == Status.RUNNING:
            return tree
        tree.tick()
    raise AssertionError(f"{leaf} never ran")


def assert_index_consistent(tree):
    assert {node.name: node for node in tree.root.iterate()} == tree.editor.nodes


def test_remove_a_leaf_gives_thesis_fig_b1_bottom():
    tree = thesis_tree(SkillWorld())
    result = tree.change("PlaceItem", "remove")
    # Expect the thesis experiment III-B result
    assert result.success and "removed 'PlaceItem'" in result.message
    assert leaf_names(tree.execution) == [name for name in THESIS_SEQUENCE if name != "PlaceItem"]
    assert leaf_names(tree.root) == ["PauseCondition", "BehaviorExecution"]
    assert_index_consistent(tree)


def test_add_prepend_insert_a_library_skill_and_copies_with_unique_names():
    tree = thesis_tree(SkillWorld())
    assert tree.change("PlaceItem", "remove").success
    added = tree.change("PlaceItem", "add")
    # Expect a library skill no longer in the tree to come back under its own name, at the end
    assert (added.success, added.new_node_name) == (True, "PlaceItem")
    assert leaf_names(tree.execution)[-1] == "PlaceItem"
    prepended = tree.change("PlaceItem", "prepend")
    assert (prepended.success, prepended.new_node_name) == (True, "PlaceItem_2")
    assert leaf_names(tree.execution)[0] == "PlaceItem_2"
    inserted = tree.change("PlaceItem_2", "insert", 3)
    assert (inserted.success, inserted.new_node_name) == (True, "PlaceItem_3")
    assert leaf_names(tree.execution)[3] == "PlaceItem_3"
    assert tree.editor.nodes["PlaceItem_3"].skill == "PlaceItem"
    at_end = tree.change("Idle", "insert", len(tree.execution.children))
    assert at_end.success and leaf_names(tree.execution)[-1] == "Idle_2"
    assert len(set(leaf_names(tree.execution))) == len(tree.execution.children)
    assert_index_consistent(tree)


def test_index_is_ignored_by_add_and_prepend():
    tree = thesis_tree(SkillWorld())
    assert tree.change("Idle", "add", 99).success
    assert tree.change("Idle", "prepend", -5).success
    assert leaf_names(tree.execution)[0] == "Idle_3" and leaf_names(tree.execution)[-1] == "Idle_2"


def test_edits_in_another_parent_and_copies_of_subtrees():
    library = SkillLibrary.load(CONFIG / "skills.yaml")
    py_trees.blackboard.Blackboard.clear()
    spec = parse_tree(
        {
            "execution": "Work",
            "root": {
                "type": "selector",
                "name": "Root",
                "memory": False,
                "children": [
                    {"type": "pause", "name": "PauseCondition"},
                    {
                        "type": "sequence",
                        "name": "Work",
                        "children": [
                            {"type": "sequence", "name": "Fetch", "children": ["LookToShelf", "PickItem"]},
                            {"type": "parallel", "name": "Both", "children": ["MoveBase"]},
                        ],
                    },
                ],
            },
        },
        library,
    )
    world = SkillWorld()
    editor = TreeEditor(create_root(spec.root, library, world.make_leaf), "Work", library, world.make_leaf)
    # Expect a named parent to receive the node, anywhere in the tree
    assert editor.change("DropItem", "insert", 1, "Fetch").success
    assert leaf_names(editor.nodes["Fetch"]) == ["LookToShelf", "DropItem", "PickItem"]
    assert editor.change("Idle", "add", 0, "Both").success
    assert leaf_names(editor.nodes["Both"]) == ["MoveBase", "Idle"]
    # Expect a copied composite to get unique names for itself and all its nodes
    copy = editor.change("Fetch", "add")
    assert copy.success and copy.new_node_name == "Fetch_2"
    assert leaf_names(editor.nodes["Fetch_2"]) == ["LookToShelf_2", "DropItem_2", "PickItem_2"]
    assert editor.change("Fetch_2", "add").new_node_name == "Fetch_3"
    assert leaf_names(editor.nodes["Work"]) == ["Fetch", "Both", "Fetch_2", "Fetch_3"]
    # Expect a composite to be removable with everything under it
    assert editor.change("Fetch_2", "remove", parent="Work").success
    assert "LookToShelf_2" not in editor.nodes and "Fetch_2" not in editor.nodes
    assert editor.change("Both", "remove").success
    assert {node.name: node for node in editor.root.iterate()} == editor.nodes


def test_removing_a_composite_that_holds_the_running_leaf_is_refused():
    library = SkillLibrary.load(CONFIG / "skills.yaml")
    py_trees.blackboard.Blackboard.clear()
    spec = parse_tree(
        {
            "execution": "Work",
            "root": {
                "type": "sequence",
                "name": "Work",
                "children": [{"type": "sequence", "name": "Fetch", "children": ["LookToShelf", "PickItem"]}],
            },
        },
        library,
    )
    world = SkillWorld(ticks=10)
    editor = TreeEditor(create_root(spec.root, library, world.make_leaf), "Work", library, world.make_leaf)
    editor.root.tick_once()
    before = snapshot(editor.root)
    result = editor.change("Fetch", "remove")
    # Expect a refusal naming the running leaf inside, nothing changed, nothing cancelled
    assert result.success is False
    assert result.message == (
        "cannot remove 'Fetch': it holds the running leaf 'LookToShelf'; removing it would abort its skill"
    )
    assert snapshot(editor.root) == before and world.names("cancel") == []


def test_running_leaf_keeps_running_while_siblings_change_around_it():
    world = SkillWorld(ticks=2, durations={"MoveBase": 20})
    tree = running_tree(world, "MoveBase")
    leaf = tree.editor.nodes["MoveBase"]
    # Expect every edit before and after the running leaf to leave it running and remembered by the sequence
    for request in [
        ("DropItem", "prepend"),
        ("LookToShelf", "remove"),
        ("Idle", "insert", 1),
        ("PickItem", "remove"),
        ("Idle", "add"),
        ("PlaceItem", "remove"),
        ("LookToShelfAgain", "insert", 4),
    ]:
        result = tree.change(*request)
        assert result.success, result.message
        assert leaf.status == Status.RUNNING and tree.execution.current_child is leaf, request
        tree.tick()
    for _ in range(200):
        if tree.completed:
            break
        tree.tick()
    # Expect MoveBase never restarted or cancelled, nodes inserted before it skipped, the rest run in order
    starts = world.names("start")
    assert starts.count("MoveBase") == 1 and world.names("cancel") == []
    assert starts == [
        "LookToShelf",
        "PickItem",
        "MoveBase",
        "DropItem",
        "LookToShelfAgain_2",
        "MoveBaseToStart",
        "LookToShelfAgain",
        "PickItem2",
        "MoveBase2",
        "Idle",
        "Idle_3",
    ]


def test_removing_the_running_leaf_or_its_composite_is_refused():
    world = SkillWorld(ticks=50)
    tree = running_tree(world, "PickItem")
    before = snapshot(tree.root)
    result = tree.change("PickItem", "remove")
    # Expect a refusal that says why, and nothing changed
    assert result.success is False
    assert result.message == "cannot remove 'PickItem': it is running; removing it would abort its skill"
    assert snapshot(tree.root) == before
    assert world.names("cancel") == []


def test_every_operation_is_known():
    assert OPERATIONS == ("remove", "add", "prepend", "insert", "convert", "wrap", "unwrap", "undo", "redo", "repair")


BAD_REQUESTS = [
    (
        ("PickItem", "swap"),
        "unknown operation 'swap'; expected one of remove, add, prepend, insert, convert, wrap, unwrap, undo, redo",
    ),
    (("PickItem", ""), "unknown operation ''; expected one of remove, add, prepend, insert, convert"),
    (("PickItem", "Remove"), "unknown operation 'Remove'"),
    (("", "remove"), "empty node name"),
    (("", "add"), "empty node name"),
    (("Teleport", "remove"), "no node named 'Teleport' in the tree"),
    (("Teleport", "add"), "'Teleport' is neither a node of the tree nor a skill in the library"),
    (("Teleport", "insert", 2), "'Teleport' is neither a node of the tree nor a skill in the library"),
    (("Idle", "insert", 11), "index 11 is out of range for 'BehaviorExecution' (0..10)"),
    (("Idle", "insert", -1), "index -1 is out of range for 'BehaviorExecution' (0..10)"),
    (("Idle", "insert", 3, "Root"), "index 3 is out of range for 'Root' (0..2)"),
    (("Idle", "add", 0, "PickItem"), "'PickItem' is not a composite, nodes cannot be added to it"),
    (("Idle", "add", 0, "PauseCondition"), "'PauseCondition' is not a composite, nodes cannot be added to it"),
    (("Idle", "insert", 0, "Shelf"), "no composite named 'Shelf' in the tree"),
    (("Root", "remove"), "cannot remove 'Root' is the root of the tree"),
    (("PauseCondition", "remove"), "cannot remove 'PauseCondition' is the condition that pauses the tree"),
    (("BehaviorExecution", "remove"), "cannot remove 'BehaviorExecution' is the composite that /change_tree edits"),
    (("MoveBase", "remove"), "cannot remove 'MoveBase': it is running; removing it would abort its skill"),
    (("PickItem", "remove", 0, "Root"), "'PickItem' is a child of 'BehaviorExecution', not of 'Root'"),
    (("Root", "add"), "cannot copy 'Root' is the root of the tree"),
    (("BehaviorExecution", "insert", 1), "cannot copy 'BehaviorExecution' is the composite"),
    (("PauseCondition", "prepend"), "cannot copy 'PauseCondition' is the condition that pauses the tree"),
]


@pytest.mark.parametrize(
    "request_, message", BAD_REQUESTS, ids=[f"{r[1] or 'empty'}-{r[0] or 'empty'}" for r, _ in BAD_REQUESTS]
)
def test_bad_request_changes_nothing_and_says_what_was_wrong(request_, message):
    world = SkillWorld(ticks=50)
    tree = running_tree(world, "MoveBase")
    before = snapshot(tree.root)
    names = dict(tree.editor.nodes)
    revision = tree.revision
    result = tree.change(*request_)
    # Expect failure, the precise reason, and the tree exactly as before (structure, statuses, memory, names)
    assert result.success is False
    assert message in result.message
    assert result.new_node_name == ""
    assert snapshot(tree.root) == before
    assert tree.editor.nodes == names
    assert tree.revision == revision
    assert world.names("cancel") == []


@pytest.mark.parametrize(
    "request_",
    [
        EditRequest("PickItem", "remove"),
        EditRequest("PickItem", "wrap", node_type="retry", parameter=3.0),
        EditRequest("PlaceItem", "wrap", node_type="timeout", parameter=2.5),
        EditRequest("LookToShelf", "wrap", node_type="inverter"),
        EditRequest("SelectorPickItem", "convert", node_type="sequence"),
        EditRequest("LookToShelf", "insert", 4, parent="SelectorPickItem"),
        EditRequest("ProductInHand", "prepend", parent="SelectorPickItem"),
        EditRequest("PickItem2", "add"),
        EditRequest("InverterLookToShelf", "unwrap"),
    ],
)
def test_a_described_request_is_read_back_from_its_line(request_):
    # Expect the line a help request carries to give back the request it was written for
    assert EditRequest.from_line(request_.describe()) == request_


def test_a_line_no_request_wrote_is_no_request():
    assert EditRequest.from_line("the robot is confused") is None
