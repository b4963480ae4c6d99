"""Shared control of high-level decisions (teleteach.bt.decisions in the teaching tree, without ROS): unsure, the help
request carries the policy's proposal and a confirmed one is learned and saved; confident, the tree applies it after
the tick and goes on after the veto window; an undo in the window restores the tree; a refused proposal or answer
changes nothing and teaches nothing; the task around a failure (product, gap, base) from the configured scene."""

import dataclasses

import yaml
from bt_support import SkillWorld, thesis_tree
from test_bt_tree import tick_until

from teleteach.bt.decisions import TaskKnowledge, advise
from teleteach.bt.editor import EditRequest
from teleteach.bt.situations import describe, product_features, target_features
from teleteach.bt.teaching import TreeStore
from teleteach.bt.tree import describe as describe_tree
from teleteach.bt.tree_policy import PolicyConfig, TreePolicy
from teleteach.core.paths import config_values
from teleteach.core.scene import load_scene

MISSING = "product_pick_1 is not on the table"
BASE = "the base did not reach (1.00, 0.00, 0.00) within 30 s: 0.300 m, 0.100 rad away"
MISSED = "product_pick_1 ended 3.0 cm from gap_1 (0.2 cm in height)"
WINDOW = 5.0  # [s]


class Clock:
    """The tree's monotonic clock, moved by the test."""

    def __init__(self):
        self.now = 100.0

    def __call__(self):
        return self.now


def policy_tree(world, store=None, act_confidence=0.8, clock=None):
    config = dataclasses.replace(PolicyConfig.from_yaml(), act_confidence=act_confidence, veto_window=WINDOW)
    return thesis_tree(world, store=store, policy=TreePolicy(config), clock=clock or Clock())


def asked(tree):
    """Tick until the tree asks; one more tick (a confident proposal is applied after the tick that asked)."""
    tick_until(tree, lambda: tree.help_request is not None)
    tree.tick()
    return tree.help_request


def taught_three_repairs(tree):
    """The operator removes a missing product's pick, confirms the proposal to remove the failed drive, and replaces
    the failed placement by a look: two kinds of repair, three demonstrations (the sequence of the rostest)."""
    assert asked(tree).proposal == ()
    assert tree.change("PickItem", "remove").success
    tree.set_pause(False)
    proposal = asked(tree)
    assert tree.change("MoveBase", "repair").success
    tree.set_pause(False)
    asked(tree)
    assert tree.change("LookToShelf", "insert", 1).success and tree.change("PlaceItem", "remove").success
    tree.set_pause(False)
    tick_until(tree, lambda: tree.completed, 400)
    return proposal


def failing_again(tree):
    """The pick put back where it was and the tree run again: the same failure comes at a node the policy knows."""
    assert tree.change("PickItem", "insert", 1).success
    assert tree.start()[0]
    return asked(tree)


def test_unsure_it_asks_with_its_proposal_and_the_confirmed_proposal_is_learned_and_saved(tmp_path):
    world = SkillWorld(ticks=1, failures={"PickItem": [MISSING], "MoveBase": [BASE], "PlaceItem": [MISSED]})
    store = TreeStore(tmp_path)
    tree = policy_tree(world, store)
    proposal = taught_three_repairs(tree)
    # Expect: the drive's failure was never demonstrated, so the proposal was suggested with confidence 0, not applied
    assert proposal.proposal == (EditRequest("MoveBase", "remove"),) and proposal.suggestion == ()
    assert proposal.confidence == 0.0 and not proposal.applied and "base_not_reached" in proposal.why
    # Expect: the confirmed proposal removed the drive; three demonstrations learned and saved
    assert "MoveBase" not in tree.editor.nodes and len(tree.policy) == 3
    saved = yaml.safe_load(store.policy_path.read_text())["demonstrations"]
    assert [entry["edits"][-1]["node_name"] for entry in saved] == ["PickItem", "MoveBase", "PlaceItem"]


def test_confident_it_applies_the_proposal_waits_out_the_veto_window_and_goes_on():
    clock = Clock()
    world = SkillWorld(ticks=1, failures={"PickItem": [MISSING] * 2, "MoveBase": [BASE], "PlaceItem": [MISSED]})
    tree = policy_tree(world, clock=clock)
    taught_three_repairs(tree)
    applied = failing_again(tree)
    # Expect: the pick removed by the robot, announced with its confidence, the tree paused for the window
    assert applied.applied and applied.proposal == (EditRequest("PickItem", "remove"),) and applied.confidence >= 0.8
    assert applied.veto_window == WINDOW and "PickItem" not in tree.editor.nodes and tree.paused
    assert "an undo vetoes it" in tree.execution_state().message
    clock.now += WINDOW - 0.1
    tree.tick()
    assert tree.paused and tree.help_request == applied
    clock.now += 0.2
    tree.tick()
    # Expect: nobody vetoed: the tree goes on by itself and completes; the robot's own edit is no demonstration
    assert not tree.paused and tree.help_request is None
    tick_until(tree, lambda: tree.completed, 400)
    assert len(tree.policy) == 3


def test_an_undo_in_the_veto_window_restores_the_tree_and_the_operators_answer_is_learned():
    clock = Clock()
    world = SkillWorld(ticks=1, failures={"PickItem": [MISSING] * 2, "MoveBase": [BASE], "PlaceItem": [MISSED]})
    tree = policy_tree(world, clock=clock)
    taught_three_repairs(tree)
    tree.change("PickItem", "insert", 1)
    before = describe_tree(tree.root)
    tree.start()
    assert asked(tree).applied
    clock.now += 1.0
    assert tree.change("", "undo").success
    # Expect: the tree as before the proposal, the help request open again, asking, the window closed
    assert describe_tree(tree.root) == before and tree.paused
    vetoed = tree.help_request
    assert not vetoed.applied and vetoed.veto_window == 0.0 and vetoed.why.startswith("vetoed by the operator")
    clock.now += 2 * WINDOW
    tree.tick()
    assert tree.paused and tree.help_request == vetoed
    # Expect: the operator's own answer (a look instead of the pick) becomes the fourth demonstration
    assert tree.change("LookToShelf", "insert", 1).success and tree.change("PickItem", "remove").success
    tree.set_pause(False)
    assert len(tree.policy) == 4 and tree.policy.demonstrations[-1].edits[0].operation == "insert"


def test_a_proposal_naming_a_node_no_longer_in_the_tree_changes_nothing_and_is_only_suggested():
    world = SkillWorld(ticks=1, failures={"PickItem": [MISSING]})
    tree = policy_tree(world, act_confidence=0.0)
    library = [(entry.name, entry.kind) for entry in tree.library]
    situation = describe(describe_tree(tree.root), tree.execution.name, "PickItem", MISSING, library)
    tree.policy.learn(situation, [EditRequest("MoveBase", "remove")])  # an edit of another node: kept by name
    assert tree.change("MoveBase", "remove").success
    before = describe_tree(tree.root)
    asked_now = asked(tree)
    # Expect: the proposal refused by the tree, nothing changed, the operator asked with the reason
    assert describe_tree(tree.root) == before and tree.paused and not asked_now.applied
    assert "not applied, the tree refused it" in asked_now.why and "no node named 'MoveBase'" in asked_now.why
    result = tree.change("PickItem", "repair")
    assert not result.success and result.message.startswith("the proposal cannot be applied")
    assert describe_tree(tree.root) == before


def test_an_edit_the_tree_refused_is_not_learned(tmp_path):
    world = SkillWorld(ticks=1, failures={"PickItem": [MISSING]})
    store = TreeStore(tmp_path)
    tree = policy_tree(world, store)
    asked(tree)
    assert not tree.change("NoSuchSkill", "insert", 1).success
    tree.set_pause(False)
    # Expect: no demonstration, no saved policy
    assert len(tree.policy) == 0 and not store.policy_path.exists()


def test_a_remembered_repair_stays_the_suggestion_beside_the_proposal_and_repair_applies_it_first():
    world = SkillWorld(ticks=1, failures={"PickItem": [MISSING, MISSING]})
    tree = policy_tree(world)
    asked(tree)
    look = EditRequest("LookToShelf", "insert", 1)
    assert tree.change(*look).success  # a look in front of the pick, which then runs again
    tree.set_pause(False)
    again = asked(tree)
    # Expect: the remembered look as the suggestion, the policy's proposal beside it, unsure; repair applies the look
    assert again.suggestion == (look,) and again.proposal and again.confidence == 0.0 and not again.applied
    assert again.repair == again.suggestion
    assert tree.change("PickItem", "repair").success and tree.execution.children[1].name == "LookToShelf_3"
    assert advise(None, None).proposal == ()


def knowledge():
    return TaskKnowledge(load_scene(), config_values("skills_motion.yaml", "skills"))


def thesis_description(tree):
    return describe_tree(tree.root), tree.execution.name, [(entry.name, entry.kind) for entry in tree.library]


def test_the_task_around_a_failed_placement_is_the_product_picked_before_its_gap_and_the_drive_there():
    tree = thesis_tree(SkillWorld())
    root, execution, library = thesis_description(tree)
    scene = load_scene()
    situation = knowledge().situation(root, execution, "PlaceItem", MISSED, library)
    # Expect: product_pick_1 (PickItem's), gap_1 (PlaceItem's), met from place_perpendicular (MoveBase's)
    assert situation.product == product_features(scene.product("product_pick_1"))
    gap, base = scene.gap("gap_1"), scene.base_poses["place_perpendicular"]
    assert situation.target == target_features(gap, situation.product.width_m, base)
    # Expect: a drive's own pose and the next placement's gap; the second pick's own product, and no gap after it
    assert knowledge().situation(root, execution, "MoveBase", BASE, library).target == situation.target
    second = knowledge().situation(root, execution, "PickItem2", MISSING, library)
    assert second.product.name == "product_pick_2" and second.target is None


def test_a_leaf_s_parameters_override_its_skill_s_and_names_the_scene_lacks_are_left_out():
    tree = thesis_tree(SkillWorld())
    root, execution, library = thesis_description(tree)
    place = next(child for child in root["children"][1]["children"] if child["name"] == "PlaceItem")
    place["parameters"] = {"gap": "gap_2"}
    assert knowledge().situation(root, execution, "PlaceItem", MISSED, library).target.name == "gap_2"
    place["parameters"] = {"gap": "no_such_gap"}
    situation = knowledge().situation(root, execution, "PlaceItem", MISSED, library)
    assert situation.target is None and situation.product.name == "product_pick_1"
    # Expect: a failed composite has no product or gap of its own
    composite = knowledge().situation(root, execution, "BehaviorExecution", "failed", library)
    assert composite.product is None and composite.target is None


def test_a_pause_in_the_veto_window_keeps_the_tree_paused_and_a_later_undo_is_still_a_veto():
    clock = Clock()
    world = SkillWorld(ticks=1, failures={"PickItem": [MISSING] * 2, "MoveBase": [BASE], "PlaceItem": [MISSED]})
    tree = policy_tree(world, clock=clock)
    taught_three_repairs(tree)
    assert failing_again(tree).applied
    tree.set_pause(True)  # e.g. the operator enters LOW-LEVEL: the GUI pauses the tree
    clock.now += 2 * WINDOW
    tree.tick()
    # Expect: the window closed, no going on by itself; an undo still restores the pick and is a veto
    assert tree.paused and tree.help_request.applied and tree.help_request.veto_window == 0.0
    assert tree.change("", "undo").success and "PickItem" in tree.editor.nodes
    assert not tree.help_request.applied and tree.help_request.why.startswith("vetoed")


def test_a_corrupt_policy_file_is_set_aside_in_one_line_and_the_tree_asks_as_without_a_policy(tmp_path):
    store = TreeStore(tmp_path)
    store.policy_path.write_text("demonstrations: [{situation: {node: 3}, edits: []}]\n")
    policy, problems = store.restore_policy(dataclasses.replace(PolicyConfig.from_yaml(), act_confidence=0.0))
    # Expect: one line naming the file and where it was moved; an empty policy; the tree asks with nothing proposed
    assert "\n" not in problems and str(store.policy_path) in problems and "moved to tree_policy.corrupt-" in problems
    assert len(policy) == 0 and not store.policy_path.exists()
    tree = thesis_tree(SkillWorld(ticks=1, failures={"PickItem": [MISSING]}), store=store, policy=policy)
    asking = asked(tree)
    assert (asking.proposal, asking.applied, tree.paused) == ((), False, True)
