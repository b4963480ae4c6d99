"""A placement taught from nothing, end to end (issue 34): `run_thesis` plays config/scenarios/teach_placement.yaml
headless through the real GUI, tree, skills, device node and simulated robot. The robot asks for help at gap_1, where
nothing is taught; the operator teleoperates the product in under shared control, records the path, teaches its
stiffness in LOW-LEVEL; the next product, at gap_2, is placed by the robot alone. Checked from the run folder's files
(the bag's true scene, the skill files, the taught path), not only from the runner's summary."""

import json

import numpy as np
import pytest
import yaml
from conftest import ROOT
from main_job import run_thesis

from teleteach.core import skill_file
from teleteach.core.scene import load_scene
from teleteach.recording.session import read_session

SCENARIO = ROOT / "config" / "scenarios" / "teach_placement.yaml"


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    data = tmp_path_factory.mktemp("teach_data")
    result = run_thesis(data, "--scenario", SCENARIO, "--no-rviz")
    folders = sorted((data / "runs").iterdir())
    assert len(folders) == 1, result.stdout + result.stderr
    return data, result, folders[0]


def test_the_run_passes_having_asked_for_help_at_gap_1(run):
    _, result, folder = run
    assert result.returncode == 0, result.stdout + result.stderr
    summary = json.loads((folder / "summary.json").read_text())
    assert summary["passed"] and summary["problems"] == []
    # Expect the tree unchanged: the operator taught, they did not edit
    assert summary["tree_changes"][-1] == summary["tree_initial"]
    asked = {(node, reason.split(":")[0]) for _, node, reason in summary["help_requests"]}
    assert asked == {("PlaceTaught", "no taught skill places at gap_1")}
    # Expect the operator's time reported (the goal, under two minutes: bench/teach_from_nothing.py)
    first_asked = summary["help_requests"][0][0]
    assert summary["help_time_s"] > summary["help_requests"][-1][0] - first_asked > 0.0


def test_the_path_was_taught_in_teleop_relative_to_gap_1_and_the_skill_learned_along_it(run):
    data, _, folder = run
    path = yaml.safe_load((data / "trajectories" / "TaughtPath_1.yaml").read_text())
    assert (path["frame"], path["target"], path["start"]) == ("target", "gap_1", "hand")
    ends = np.array([path["waypoints"][0]["position"], path["waypoints"][-1]["position"]])
    # Expect it from the carry posture, 30 cm before the gap and 16 cm above its target, to the target
    np.testing.assert_allclose(ends[0], [-0.303, 0.0, 0.165], atol=0.02)
    np.testing.assert_allclose(ends[-1], [0.0, 0.0, 0.035], atol=0.01)
    learned = skill_file.load(folder / "skills" / "DemonstratedPlace_1_dmp.npz")
    assert (learned.kind, learned.frame, learned.target.name) == ("dmp", "target", "gap_1")
    assert learned.provenance["path_demonstrations"] == 1
    np.testing.assert_allclose(learned.equilibrium_pose[-1, :3], [0.0, 0.0, 0.035], atol=0.01)


def test_the_products_stand_in_their_gaps_the_second_placed_by_the_robot_with_the_taught_skill(run):
    _, result, folder = run
    summary = json.loads((folder / "summary.json").read_text())
    bag = folder / summary["bag"]
    scene = load_scene()
    session = read_session(bag)
    assert "true_scene" in session.products_from  # judged from the simulation's truth, not from perception
    products = session.products
    for product, gap in (("product_pick_1", "gap_1"), ("product_pick_2", "gap_2")):
        horizontal, vertical = scene.gap(gap).distance(products[product].values[-1, :3])
        assert horizontal < scene.gap(gap).tolerance and vertical < 0.01, (product, horizontal, vertical)
    by = {entry["product"]: entry["by_skill"] for entry in summary["placements"]}
    # product 1 rests where the LOW-LEVEL demonstration set it down, or a few mm on when PlaceTaught let it go
    assert by["product_pick_1"] in ("LOW-LEVEL teaching", "PlaceTaught") and by["product_pick_2"] == "PlaceTaught2"
    assert "PlaceTaught2: done with DemonstratedPlace_1_dmp: replayed DemonstratedPlace_1_dmp (dmp)" in result.stdout
