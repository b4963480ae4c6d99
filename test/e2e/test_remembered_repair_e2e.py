"""A remembered repair end to end: config/scenarios/remembered_repair.yaml drives the real GUI, tree, skills and
simulated robot (product_pick_1 left out) through full.launch; the outcome is checked from what the run left in the
data directory: the saved tree with its history, the repair memory and the recorded bag."""

import time

import pytest
import yaml
from conftest import ROOT
from main_job import bag_messages, saved_tree

from teleteach.runtime.experiment import Experiment
from teleteach.runtime.processes import full_launch

SCENARIO = ROOT / "config" / "scenarios" / "remembered_repair.yaml"
FAILURE = ("PickItem", "product_pick_1 is not on the table")
RUN_TIMEOUT = 300.0  # [s] wall: start-up, the scenario and its waits


def undone_repair(tree):
    """Whether the saved history ends with the applied repair undone (waiting for redo)."""
    history = (tree or {}).get("history") or {}
    return [edit["edit"] for edit in history.get("redo", [])] == ["group"]


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    data = tmp_path_factory.mktemp("repair_data")
    arguments = {
        "headless": True,
        "device": "scenario",
        "scenario": SCENARIO,
        "absent_products": ["product_pick_1"],
        "record": True,
        "record_prefix": "repair",
        "data_dir": data,
    }
    log = data / "launch.log"
    with Experiment(data, data) as experiment:
        experiment.own_display()
        experiment.own_launch(lambda port: full_launch(arguments, port), log)
        repaired = experiment.wait_until(lambda: undone_repair(saved_tree(data)), RUN_TIMEOUT, poll=0.5)
        assert repaired, f"no undone repair in the saved tree: {log.read_text()[-3000:]}"
        time.sleep(3.0)  # the tree log of the undone tree reaches the bag
    bags = sorted((data / "bags").glob("repair*.bag"))
    assert len(bags) == 1, list((data / "bags").iterdir())
    return data, bags[0]


def test_the_operator_s_wrap_is_in_the_saved_tree_and_the_repair_undone(run):
    data, _ = run
    tree = saved_tree(data)
    execution = tree["root"]["children"][1]
    retry = execution["children"][1]
    # Expect PickItem in the retry the operator made with the dial (2 attempts), the repair's second retry undone
    assert (retry["type"], retry["name"], retry["attempts"]) == ("retry", "RetryPickItem", 2)
    assert [child["name"] for child in retry["children"]] == ["PickItem"]
    assert "RetryPickItem_2" not in str(tree["root"])
    assert [edit["edit"] for edit in tree["history"]["undo"]] == ["wrap"]
    (group,) = tree["history"]["redo"]
    assert [(edit["edit"], edit["node"], edit["wrapper"]["name"]) for edit in group["edits"]] == [
        ("wrap", "PickItem", "RetryPickItem_2")
    ]


def test_the_repair_is_remembered_in_the_data_directory(run):
    data, _ = run
    (repair,) = yaml.safe_load((data / "trees" / "repairs.yaml").read_text())["repairs"]
    assert (repair["node"], repair["reason"]) == FAILURE
    assert [
        (edit["operation"], edit["node_name"], edit["node_type"], edit["parameter"]) for edit in repair["edits"]
    ] == [("wrap", "PickItem", "retry", 2.0)]


def test_the_bag_shows_the_suggestion_and_the_applied_then_undone_repair(run):
    _, bag = run
    requests = [message for _, message in bag_messages(bag, "/behaviour_tree/help_request") if message.node_name]
    # Expect the first help request without a suggestion, the same failure later with the remembered repair
    assert (requests[0].node_name, requests[0].reason, list(requests[0].suggestion)) == (*FAILURE, [])
    suggested = [message for message in requests if list(message.suggestion)]
    assert suggested and (suggested[0].node_name, suggested[0].reason) == FAILURE
    assert list(suggested[0].suggestion) == ["wrap PickItem in a retry (2)"]
    names = [
        {behaviour.name for behaviour in message.behaviours}
        for _, message in bag_messages(bag, "/behaviour_tree/log/tree")
    ]
    applied = [index for index, tree in enumerate(names) if "RetryPickItem_2" in tree]
    # Expect the repair's decorator to appear in the live tree once and be gone again after the undo
    assert applied and "RetryPickItem_2" not in names[-1] and "RetryPickItem" in names[-1]
