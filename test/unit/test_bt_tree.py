"""The tree from yaml, ticked without ROS: the thesis sequence, pausing that keeps the running skill, help requests."""

import py_trees
import pytest
import yaml
from bt_support import CONFIG, THESIS_SEQUENCE, SkillWorld, leaf_names, status_of, thesis_tree
from py_trees.common import Status

from teleteach.bt.behaviours import EditableSequence, PausableSelector, PauseCondition
from teleteach.bt.editor import snapshot
from teleteach.bt.library import SkillEntry, SkillLibrary
from teleteach.bt.tree import (
    EDIT_KINDS,
    PARALLEL_POLICIES,
    TYPES,
    TreeSpec,
    TreeSpecError,
    create_root,
    describe,
    dump_live_yaml,
    dump_yaml,
    load_tree,
    parse_tree,
)


@pytest.fixture
def library():
    return SkillLibrary.load(CONFIG / "skills.yaml")


def tick_until(tree, condition, limit=200):
    for _ in range(limit):
        if condition():
            return
        tree.tick()
    raise AssertionError(
        f"condition not reached in {limit} ticks:\n{py_trees.display.ascii_tree(tree.root, show_status=True)}"
    )


def test_thesis_tree_from_config(library):
    spec = load_tree(CONFIG / "tree.yaml", library)
    root = create_root(spec.root, library, SkillWorld().make_leaf)
    # Expect Root (fallback, no memory) -> PauseCondition, BehaviorExecution (sequence with memory) -> the ten skills
    assert isinstance(root, PausableSelector) and root.name == "Root" and not root.memory
    pause, execution = root.children
    assert isinstance(pause, PauseCondition) and pause.name == "PauseCondition"
    assert isinstance(execution, EditableSequence) and execution.memory
    assert leaf_names(execution) == THESIS_SEQUENCE
    assert [leaf.skill for leaf in execution.children] == THESIS_SEQUENCE
    assert spec.execution == "BehaviorExecution"


def test_dumped_yaml_loads_back_to_the_same_tree(library):
    data = {
        "execution": "Work",
        "root": {
            "type": "fallback",
            "name": "Top",
            "children": [
                {"type": "pause", "name": "Hold"},
                {
                    "type": "sequence",
                    "name": "Work",
                    "memory": True,
                    "children": [
                        "PickItem",
                        {"name": 'Place "quoted": yes', "skill": "PlaceItem"},
                        {"name": "MoveBase45", "skill": "MoveBase2", "parameters": {"base_pose": "place_45deg"}},
                        {"type": "parallel", "name": "Both", "policy": "success_on_one", "children": ["Idle"]},
                        {"type": "parallel", "name": "Sync", "synchronise": True, "children": []},
                        {"type": "selector", "name": "Choose", "memory": True, "children": ["DropItem"]},
                    ],
                },
            ],
        },
    }
    spec = parse_tree(data, library)
    root = create_root(spec.root, library, SkillWorld().make_leaf)
    text = dump_yaml(TreeSpec(describe(root), spec.execution), header="a header\non two lines")
    # Expect the written yaml to describe exactly the tree that was built, live or from its description
    assert parse_tree(yaml.safe_load(text), library) == spec
    assert dump_live_yaml(root, spec.execution, header="a header\non two lines") == text
    assert describe(create_root(spec.root, library, SkillWorld().make_leaf)) == spec.root
    # and a leaf's parameters reach the leaf that sends the goal
    moved = next(node for node in root.iterate() if node.name == "MoveBase45")
    assert moved.skill == "MoveBase2" and moved.parameters == {"base_pose": "place_45deg"}


def test_every_node_type_and_the_history_are_written_as_yaml_and_read_back(library):
    history = {"undo": [{"edit": "remove", "node": "Idle"}], "redo": [{"edit": "wrap", "node": "PickItem"}]}
    data = {
        "execution": "Work",
        "root": {
            "type": "sequence",
            "name": "Work",
            "memory": False,
            "children": [
                {"type": "retry", "name": "Again", "attempts": 1, "children": ["PickItem"]},
                {"type": "timeout", "name": "Soon", "seconds": 2.5, "children": ["PlaceItem"]},
                {"type": "inverter", "name": "Not", "children": ["Idle"]},
                {"type": "parallel", "name": "Both", "synchronise": False, "children": ["DropItem"]},
                {"type": "sequence", "name": "Empty"},
                {"name": "MoveBase45", "skill": "MoveBase2", "parameters": {"base_pose": "place_45deg", "z": "a"}},
            ],
        },
        "history": history,
    }
    spec = parse_tree(data, library)
    assert spec.history == history
    assert spec.root["children"][4]["children"] == []  # a composite written without children has none
    root = create_root(spec.root, library, SkillWorld().make_leaf)
    text = dump_yaml(TreeSpec(describe(root), spec.execution, spec.history))
    assert parse_tree(yaml.safe_load(text), library) == spec
    assert dump_live_yaml(root, spec.execution, history=spec.history) == text
    # Expect yaml's own words for the flags and JSON for numbers, names and parameters, with no header by default
    lines = text.splitlines()
    assert lines[:2] == ['execution: "Work"', "root:"]
    for line in ("  memory: false", "      seconds: 2.5", "      synchronise: false", "      attempts: 1"):
        assert line in lines, text
    leaf = '{type: skill, name: "MoveBase45", skill: "MoveBase2", parameters: {"base_pose": "place_45deg", "z": "a"}}'
    assert f"    - {leaf}" in lines, text
    assert lines[-5:] == [
        "history:",
        "  undo:",
        '    - {"edit": "remove", "node": "Idle"}',
        "  redo:",
        '    - {"edit": "wrap", "node": "PickItem"}',
    ]
    # a history with only redo edits is written too, an empty list as []
    redo_only = dump_yaml(TreeSpec(spec.root, spec.execution, {"redo": history["redo"]})).splitlines()
    assert redo_only[-4:] == ["history:", "  undo: []", "  redo:", '    - {"edit": "wrap", "node": "PickItem"}']


def test_a_skill_missing_from_the_library_or_a_node_without_a_yaml_form_is_named(library):
    with pytest.raises(TreeSpecError, match="^Gone: skill 'Fly' is not in the skill library$"):
        create_root({"type": "skill", "name": "Gone", "skill": "Fly"}, library, SkillWorld().make_leaf)
    with pytest.raises(TreeSpecError, match="^Done: Success has no yaml form$"):
        describe(py_trees.behaviours.Success("Done"))


def sequence(*children, **fields):
    """A tree whose root and execution is the sequence S of these children."""
    return {"root": {"type": "sequence", "name": "S", "children": list(children), **fields}, "execution": "S"}


def test_parameters_are_refused_for_a_demonstrated_skill(library, tmp_path):
    taught = SkillEntry("PlaceStiff", "stiffness", str(tmp_path / "place.npz"))
    with_taught = SkillLibrary([*library, taught])
    data = sequence({"name": "P", "skill": "PlaceStiff", "parameters": {"base_pose": "start"}})
    with pytest.raises(TreeSpecError, match="^tree: root/S/P: parameters are for predefined skills; 'PlaceStiff' is a"):
        parse_tree(data, with_taught)


def test_a_tree_file_s_problem_is_named_with_its_path(library, tmp_path):
    path = tmp_path / "tree.yaml"
    path.write_text("execution: S\nroot: {type: sequence, name: S, children: [Fly]}\n")
    with pytest.raises(TreeSpecError, match=f"^{path}: root/S/Fly: skill 'Fly' is not in the skill library$"):
        load_tree(path, library)
    with pytest.raises(TreeSpecError, match=f"^cannot read tree {tmp_path / 'none.yaml'}: "):
        load_tree(tmp_path / "none.yaml", library)


@pytest.mark.parametrize(
    "data, message",
    [
        ({"execution": "S"}, "tree: expected a mapping with 'root' (and 'execution')"),
        ({"root": {"type": "sequence", "name": "S"}}, "tree: execution '' must name a composite of the tree"),
        ({**sequence(), "history": []}, "tree: history must be a mapping with 'undo' and 'redo' lists of edits"),
        ({**sequence(), "history": {"undo": [], "later": []}}, "tree: history must be a mapping with 'undo'"),
        (
            {**sequence(), "history": {"redo": [{"edit": "fly"}]}},
            f"tree: history/redo must be a list of edits of kind {', '.join(EDIT_KINDS)}",
        ),
        ({**sequence(), "history": {"undo": {"edit": "remove"}}}, "tree: history/undo must be a list of edits"),
        ({**sequence(), "history": {"undo": ["remove"]}}, "tree: history/undo must be a list of edits"),
        (sequence(5), "tree: root/S: a node is a skill name or a mapping, got 5"),
        (sequence({"name": 5}), "tree: root/S: node without a name: {'name': 5}"),
        (
            {"root": {"type": "loop", "name": "L"}, "execution": "L"},
            f"tree: root/L: unknown type 'loop'; expected one of {', '.join(TYPES)} or fallback",
        ),
        (
            {"root": {"type": "parallel", "name": "P", "policy": "most"}, "execution": "P"},
            f"tree: root/P: unknown policy 'most'; expected one of {', '.join(PARALLEL_POLICIES)}",
        ),
        (
            {"root": {"type": "parallel", "name": "P", "synchronise": "yes"}, "execution": "P"},
            "tree: root/P: synchronise must be true or false, got 'yes'",
        ),
        (sequence(memory="yes"), "tree: root/S: memory must be true or false, got 'yes'"),
        (sequence(children="Idle"), "tree: root/S: children must be a list"),
        (
            sequence({"name": "M", "skill": "MoveBase2", "parameters": {"base_pose": 1}}),
            "tree: root/S/M: parameters must map names to names",
        ),
        (
            sequence({"type": "inverter", "name": "I", "children": ["Idle", "PickItem"]}),
            "tree: root/S/I: a inverter decorates exactly one child, got 2",
        ),
        (
            sequence({"type": "timeout", "name": "T", "seconds": True, "children": ["Idle"]}),
            "tree: root/S/T: a timeout needs seconds, a finite number > 0, got True",
        ),
        (
            sequence({"type": "retry", "name": "R", "attempts": 0, "children": ["Idle"]}),
            "tree: root/S/R: a retry needs attempts, a whole number >= 1, got 0",
        ),
    ],
)
def test_bad_tree_descriptions_are_rejected_with_the_whole_reason(library, data, message):
    with pytest.raises(TreeSpecError) as error:
        parse_tree(data, library)
    assert str(error.value).startswith(message), str(error.value)


@pytest.mark.parametrize(
    "data, message",
    [
        ([], "expected a mapping with 'root'"),
        ({"root": {"type": "sequence", "name": "S", "children": []}, "execution": "X"}, "execution 'X'"),
        ({"root": "PickItem", "execution": "PickItem"}, "the root must be a composite"),
        ({"root": {"type": "loop", "name": "L"}, "execution": "L"}, "unknown type 'loop'"),
        ({"root": {"type": "sequence", "children": []}, "execution": "S"}, "node without a name"),
        ({"root": {"type": "sequence", "name": "S", "children": ["Fly"]}, "execution": "S"}, "skill 'Fly' is not"),
        (
            {"root": {"type": "sequence", "name": "S", "children": ["Idle", "Idle"]}, "execution": "S"},
            "'Idle' is used twice",
        ),
        ({"root": {"type": "sequence", "name": "S", "memory": "yes"}, "execution": "S"}, "memory must be true or"),
        ({"root": {"type": "parallel", "name": "P", "policy": "most"}, "execution": "P"}, "unknown policy 'most'"),
        ({"root": {"type": "sequence", "name": "S", "colour": 1}, "execution": "S"}, "unknown fields ['colour']"),
        ({"root": {"type": "sequence", "name": "S"}, "execution": "S", "extra": 1}, "unknown top-level fields"),
        (
            {
                "root": {"type": "sequence", "name": "S", "children": [{"name": "Idle", "parameters": [1]}]},
                "execution": "S",
            },
            "S/Idle: parameters must map names to names",
        ),
    ],
)
def test_bad_tree_descriptions_are_rejected_with_the_reason(library, data, message):
    with pytest.raises(TreeSpecError, match="") as error:
        parse_tree(data, library)
    assert message in str(error.value)


def test_thesis_sequence_runs_to_completion_and_stops():
    world = SkillWorld(ticks=2)
    tree = thesis_tree(world)
    tree.tick()
    # Expect the first skill running, the pause condition failing (not paused)
    assert status_of(tree, "LookToShelf") == Status.RUNNING
    assert status_of(tree, "PauseCondition") == Status.FAILURE
    tick_until(tree, lambda: tree.completed)
    # Expect every skill run once in the thesis order, and nothing more once complete
    assert world.names("succeed") == THESIS_SEQUENCE
    assert tree.execution.status == Status.SUCCESS
    events = len(world.events)
    for _ in range(5):
        tree.tick()
    assert len(world.events) == events


def test_pause_suspends_the_running_leaf_without_cancelling_and_it_resumes():
    world = SkillWorld(ticks=3)
    tree = thesis_tree(world)
    tick_until(tree, lambda: status_of(tree, "PickItem") == Status.RUNNING)
    leaf = tree.editor.nodes["PickItem"]
    tree.tick()
    remaining = leaf.remaining
    tree.set_pause(True)
    for _ in range(10):
        tree.tick()
    # Expect PauseCondition to win, the leaf still RUNNING and untouched (not polled, not cancelled, not restarted)
    assert tree.root.status == Status.SUCCESS
    assert status_of(tree, "PauseCondition") == Status.SUCCESS
    assert status_of(tree, "PickItem") == Status.RUNNING
    assert tree.execution.status == Status.RUNNING and tree.execution.current_child is leaf
    assert leaf.remaining == remaining
    assert world.names("cancel") == []
    assert leaf.id not in tree.snapshot_visitor.visited
    tree.set_pause(False)
    tick_until(tree, lambda: tree.completed)
    # Expect the same run to finish: PickItem started once, the rest of the sequence after it
    assert world.names("start").count("PickItem") == 1
    assert world.names("succeed") == THESIS_SEQUENCE
    assert world.names("cancel") == []


def test_a_real_preemption_still_cancels_the_running_leaf(library):
    world = SkillWorld(ticks=50)
    root = create_root(
        parse_tree(
            {
                "execution": "Work",
                "root": {
                    "type": "selector",
                    "name": "Top",
                    "memory": False,
                    "children": [
                        {"type": "sequence", "name": "Guard", "children": ["Idle"]},
                        {"type": "sequence", "name": "Work", "children": ["PickItem"]},
                    ],
                },
            },
            library,
        ).root,
        library,
        world.make_leaf,
    )
    world.durations["Idle"] = 1
    world.failures["Idle"] = ["not yet"]
    guard_leaf = root.children[0].children[0]
    guard_leaf.on_failure = None
    root.tick_once()
    # Expect the guard failing once, PickItem running; then the guard succeeds and preempts it (a py_trees selector)
    assert root.children[1].children[0].status == Status.RUNNING
    root.tick_once()
    assert world.names("cancel") == ["PickItem"]
    assert root.children[1].status == Status.INVALID


def test_failure_pauses_and_asks_for_help_then_retries_when_unpaused():
    world = SkillWorld(ticks=1, failures={"PickItem": ["the product is not there"]})
    tree = thesis_tree(world)
    tick_until(tree, lambda: tree.help_request is not None)
    # Expect a help request naming the leaf and the reason, the tree paused, the leaf kept in place (not failed)
    assert tree.help_request[:2] == ("PickItem", "the product is not there") and tree.help_request.suggestion == ()
    assert tree.paused
    tree.tick()
    assert status_of(tree, "PauseCondition") == Status.SUCCESS
    assert tree.execution.current_child.name == "PickItem"
    records = {record.name: record for record in tree.records()[0]}
    assert records["PickItem"].status == Status.FAILURE
    assert "waiting for the operator" in records["PickItem"].message
    for _ in range(5):
        tree.tick()
    assert world.names("start") == ["LookToShelf", "PickItem"]
    tree.set_pause(False)
    assert tree.help_request is None
    tick_until(tree, lambda: tree.completed)
    # Expect the failed skill retried (started twice), then the sequence continued
    assert world.names("start").count("PickItem") == 2
    assert world.names("succeed") == THESIS_SEQUENCE


def test_removing_the_failed_leaf_skips_it():
    world = SkillWorld(ticks=1, failures={"PickItem2": ["product_pick_2 is absent"]})
    tree = thesis_tree(world)
    tick_until(tree, lambda: tree.help_request is not None)
    result = tree.change("PickItem2", "remove")
    assert result.success, result.message
    tree.set_pause(False)
    tick_until(tree, lambda: tree.completed)
    # Expect the sequence to continue with the node after the removed one
    assert world.names("start")[-3:] == ["PickItem2", "MoveBase2", "Idle"]
    assert world.names("start").count("PickItem2") == 1


def test_replacing_the_failed_leaf_runs_the_replacement_in_its_place():
    world = SkillWorld(ticks=1, failures={"PickItem": ["slipped"]})
    tree = thesis_tree(world)
    tick_until(tree, lambda: tree.help_request is not None)
    inserted = tree.change("Idle", "insert", 1)
    assert inserted.success and inserted.new_node_name == "Idle_2"
    assert tree.change("PickItem", "remove").success
    tree.set_pause(False)
    tick_until(tree, lambda: tree.completed)
    # Expect the replacement to run where the failed leaf was, then the rest
    assert world.names("start") == ["LookToShelf", "PickItem", "Idle_2", *THESIS_SEQUENCE[2:]]


def test_inserting_in_front_of_the_failed_leaf_runs_it_first_then_retries():
    world = SkillWorld(ticks=1, failures={"MoveBase": ["blocked"]})
    tree = thesis_tree(world)
    tick_until(tree, lambda: tree.help_request is not None)
    assert tree.change("MoveBaseToStart", "insert", 2).success
    tree.set_pause(False)
    tick_until(tree, lambda: tree.completed)
    # Expect the inserted node first, then the retried MoveBase, then the rest
    starts = world.names("start")
    assert starts[:5] == ["LookToShelf", "PickItem", "MoveBase", "MoveBaseToStart_2", "MoveBase"]
    assert world.names("succeed")[-1] == "Idle"


def test_removing_the_failed_last_leaf_completes_the_sequence():
    world = SkillWorld(ticks=1, failures={"Idle": ["no idle today"]})
    tree = thesis_tree(world)
    tick_until(tree, lambda: tree.help_request is not None)
    assert tree.change("Idle", "remove").success
    tree.set_pause(False)
    tick_until(tree, lambda: tree.completed)
    # Expect completion without re-running anything
    assert world.names("start") == THESIS_SEQUENCE
    assert tree.execution.status == Status.SUCCESS


def test_tick_reports_changes_only_when_something_changed():
    world = SkillWorld(ticks=1)
    tree = thesis_tree(world)
    assert tree.tick()
    tick_until(tree, lambda: tree.completed)
    # Expect a complete tree to report nothing new, until an edit
    assert not tree.tick()
    assert tree.change("Idle", "add").success
    assert tree.tick()
    assert not tree.tick()


class EveryNodeVisitor(py_trees.visitors.VisitorBase):
    """A "full" visitor: py_trees shows it every node of the tree after each tick."""

    def __init__(self):
        super().__init__(full=True)
        self.seen = []

    def run(self, behaviour):
        self.seen.append(behaviour.name)


def run_ticks(use_py_trees_tick, ticks=12):
    """Statuses, visited nodes and tick counts of the thesis tree over ``ticks`` ticks (MoveBase fails once)."""
    tree = thesis_tree(SkillWorld(ticks=2, failures={"MoveBase": ["path blocked"]}))
    if use_py_trees_tick:
        tree.tree = py_trees.trees.BehaviourTree(tree.root)
        tree.tree.visitors.append(tree.snapshot_visitor)
    history = []
    for _ in range(ticks):
        tree.tick()
        visitor = tree.snapshot_visitor
        history.append(
            (
                snapshot(tree.root),
                [(node.name, node.status) for node in visitor.nodes.values()],
                sorted(node.name for node in visitor.active),
                tree.tree.count,
                tree.help_request,
            )
        )
    return history


def test_teaching_tree_ticks_like_py_trees():
    # Expect, tick by tick, the same statuses, visited nodes, tick counts and help request as py_trees' own tick
    ours, reference = run_ticks(False), run_ticks(True)
    assert ours == reference
    assert ours[-1][4] is not None and ours[-1][4].node_name == "MoveBase"
    assert all(sorted(name for name, _ in visited) == active for _, visited, active, _, _ in ours)


def test_full_visitors_still_see_every_node():
    tree = thesis_tree(SkillWorld(ticks=2))
    full = EveryNodeVisitor()
    tree.tree.visitors.append(full)
    for _ in range(3):
        tree.tick()
    # Expect py_trees' contract for a full visitor: every node, after every tick
    assert full.seen == [node.name for node in tree.root.iterate()] * 3
