"""The tree policy (teleteach.bt.tree_policy): edits generalised over the failed node, a repair learned from a handful
of scripted demonstrations and proposed where it was not shown, "I don't know" far from every demonstration, and a
saved policy that is corrupt or from another feature set set aside with one line."""

import dataclasses

import numpy as np
import pytest
import yaml

from teleteach.bt.editor import EditRequest
from teleteach.bt.scripted_failures import World, demonstrations, draw_situation, novel_situation, scripted_repair
from teleteach.bt.teaching import TreeStore
from teleteach.bt.tree_policy import (
    FAILED,
    PARENT,
    Demonstration,
    PolicyConfig,
    TreePolicy,
    generalise,
    instantiate,
    policy_yaml,
)

CONFIG = PolicyConfig.from_yaml()
QUICK = dataclasses.replace(CONFIG, model="logistic_regression", calibration="none")  # fits in ms


@pytest.fixture(scope="module")
def world():
    return World.load()


@pytest.fixture(scope="module")
def shown(world):
    """Five demonstrations of each kind of repair, all at gap_1."""
    return demonstrations(world, ["gap_1"], 5, np.random.default_rng(11))


@pytest.fixture(scope="module")
def policy(shown):
    return TreePolicy(CONFIG, [Demonstration(*pair) for pair in shown])


def situation_at(world, rng, skill):
    """A drawn failure of ``skill`` whose library has PlaceTaught."""
    while True:
        situation = draw_situation(world, ["gap_2"], rng)
        if situation.node.skill == skill and "PlaceTaught" in dict(situation.library):
            return situation


def test_an_edit_of_one_node_is_the_same_repair_of_another(world):
    rng = np.random.default_rng(5)
    place, pick = situation_at(world, rng, "PlaceItem"), situation_at(world, rng, "PickItem2")
    edits = (EditRequest("PlaceTaught", "insert", 3, "BehaviorExecution"), EditRequest("PlaceItem", "remove"))
    template = generalise(edits, place.node)
    # Expect: the failed node and its parent named by placeholders, the insert's index relative to the failed node
    assert template == (EditRequest("PlaceTaught", "insert", 0, PARENT), EditRequest(FAILED, "remove", parent=PARENT))
    assert instantiate(template, pick) == (
        EditRequest("PlaceTaught", "insert", pick.node.index),
        EditRequest("PickItem2", "remove"),
    )
    # Expect: an empty parent is the execution composite, as /change_tree reads it
    assert generalise((EditRequest("PlaceTaught", "insert", 3),), place.node) == template[:1]


def test_a_repair_that_adds_a_skill_the_library_lacks_does_not_apply(world):
    rng = np.random.default_rng(6)
    situation = situation_at(world, rng, "PlaceItem")
    template = (EditRequest("NoSuchSkill", "insert", 0, PARENT),)
    assert instantiate(template, situation) is None


def test_the_policy_proposes_the_operators_edit_at_a_gap_it_was_not_shown(world, policy):
    rng = np.random.default_rng(12)
    situations = [draw_situation(world, ["gap_2"], rng) for _ in range(60)]
    right = [generalise(policy.propose(s).edits, s.node) == generalise(scripted_repair(s), s.node) for s in situations]
    acting = [
        generalise(proposal.edits, s.node) == generalise(scripted_repair(s), s.node)
        for s in situations
        for proposal in [policy.propose(s)]
        if proposal.acts(CONFIG.act_confidence)
    ]
    assert np.mean(right) >= 0.8
    assert acting and np.mean(acting) >= 0.9


def test_far_from_every_demonstration_the_policy_is_unsure(world, policy):
    rng = np.random.default_rng(13)
    for _ in range(10):
        situation = novel_situation(world, ["gap_2"], rng)
        proposal = policy.propose(situation)
        # Expect: no confidence, never acting alone, and the reason says what is new
        assert proposal.confidence == 0.0 and not proposal.acts(0.0 + 1e-9)
        assert "no demonstration had a failure like this one (arm_blocked)" in proposal.why or (
            "product:mass_kg" in proposal.why and "beyond the demonstrated" in proposal.why
        )


def test_a_situation_among_the_demonstrations_is_known(shown, policy):
    situation, edits = shown[0]
    assert policy.unknown(situation) == ""
    assert generalise(policy.propose(situation).edits, situation.node) == generalise(edits, situation.node)


def test_with_one_kind_of_repair_it_proposes_it_but_never_acts(world, shown):
    same = [pair for pair in shown if generalise(pair[1], pair[0].node) == generalise(shown[0][1], shown[0][0].node)]
    policy = TreePolicy(QUICK, [Demonstration(*pair) for pair in same])
    proposal = policy.propose(shown[0][0])
    assert proposal.edits == shown[0][1] and proposal.confidence == 0.0
    assert TreePolicy(QUICK).propose(shown[0][0]) == ((), 0.0, "nothing was demonstrated yet")


def test_an_answer_without_edits_is_not_learned(shown):
    policy = TreePolicy(QUICK)
    assert not policy.learn(shown[0][0], ())
    assert policy.learn(*shown[0]) and len(policy) == 1


def test_the_deciding_features_are_features_of_the_situations(policy):
    deciding = policy.deciding_features()
    assert deciding and all(weight > 0.0 for _, weight in deciding)
    assert {name.split("=")[0] for name, _ in deciding} <= set(policy.demonstrations[0].situation.features()) | {
        name for situation, _ in policy.demonstrations for name in situation.features()
    }


def test_a_bad_configuration_is_refused():
    with pytest.raises(ValueError, match="unknown model 'oracle'"):
        PolicyConfig("oracle", "none", 3.0, 0.9, 5.0)
    with pytest.raises(ValueError, match="act_confidence"):
        PolicyConfig("random_forest", "none", 3.0, 1.5, 5.0)
    with pytest.raises(ValueError, match="veto_window"):
        PolicyConfig("random_forest", "none", 3.0, 0.9, -1.0)


def test_a_saved_policy_proposes_as_the_one_it_was_saved_from(tmp_path, world, policy):
    store = TreeStore(tmp_path)
    store.save_policy(policy)
    restored, problems = store.restore_policy(CONFIG)
    assert problems == "" and len(restored) == len(policy)
    rng = np.random.default_rng(14)
    for _ in range(10):
        situation = draw_situation(world, ["gap_2"], rng)
        assert restored.propose(situation) == policy.propose(situation)


@pytest.mark.parametrize(
    "text, said",
    [
        ("demonstrations: [unclosed", "while parsing"),
        ("- just a list\n", "expected a mapping with a 'demonstrations' list"),
        (None, "saved with feature set 'older'"),
        ("feature_set: {current}\ndemonstrations: [{{situation: {{node: 3}}, edits: []}}]\n", "demonstration 1"),
    ],
)
def test_a_corrupt_or_incompatible_policy_is_set_aside_in_one_line(tmp_path, policy, text, said):
    store = TreeStore(tmp_path)
    if text is None:
        saved = yaml.safe_load(policy_yaml(policy))
        text = yaml.safe_dump({**saved, "feature_set": "older"})
    store.policy_path.write_text(text.format(current=yaml.safe_load(policy_yaml(policy))["feature_set"]))
    restored, problems = store.restore_policy(CONFIG)
    # Expect: an empty policy (the tree asks as it did), the file moved aside, one line saying why
    assert len(restored) == 0 and restored.propose(policy.demonstrations[0].situation).edits == ()
    assert said in problems and "\n" not in problems and problems.startswith("tree policy: ")
    assert not store.policy_path.exists()
    assert len(list(tmp_path.glob("tree_policy.corrupt-*.yaml"))) == 1


def test_a_policy_that_does_not_load_resumes_from_its_previous_version(tmp_path, shown):
    store = TreeStore(tmp_path)
    store.save_policy(TreePolicy(QUICK, [Demonstration(*shown[0])]))
    store.save_policy(TreePolicy(QUICK, [Demonstration(*pair) for pair in shown[:2]]))
    store.policy_path.write_text("{")
    restored, problems = store.restore_policy(QUICK)
    assert len(restored) == 1 and "resumed from tree_policy.previous.yaml" in problems
