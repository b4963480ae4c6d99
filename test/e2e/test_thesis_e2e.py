"""The main job end to end: `run_thesis` plays the thesis experiments (III-B to III-E) headless on the simulated robot
through the real GUI, tree, skills and device nodes; the outcome is checked from the run folder's files themselves
(the saved tree, the taught skill file, the bag), not only from the runner's own summary."""

import json

import numpy as np
import pytest
import yaml
from conftest import ROOT
from main_job import FASTER, run_thesis
from scipy.spatial.transform import Rotation

from teleteach.core import skill_file
from teleteach.core.scene import load_scene
from teleteach.recording.session import read_session
from teleteach.run.pictures import background_colour, rviz_picture


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    data = tmp_path_factory.mktemp("thesis_data")
    result = run_thesis(data)
    folders = sorted((data / "runs").iterdir())
    assert len(folders) == 1, result.stdout + result.stderr
    return result, folders[0]


def scene_products(bag):
    """First and last product poses (centre [m], quaternion) on /teleteach/scene, read with the project's bag reader."""
    products = read_session(bag).products
    first = {name: (series.values[0, :3], series.values[0, 3:]) for name, series in products.items()}
    last = {name: (series.values[-1, :3], series.values[-1, 3:]) for name, series in products.items()}
    return first, last


def test_runner_passes_and_prints_the_summary(run):
    result, folder = run
    assert result.returncode == 0, result.stdout + result.stderr
    assert f"Run folder: {folder}" in result.stdout
    assert "Thesis run: PASSED" in result.stdout
    summary = json.loads((folder / "summary.json").read_text())
    assert summary["passed"] and summary["problems"] == []


def test_live_output_tells_the_operators_steps_before_the_tree_steps_they_explain(run):
    result, _ = run
    lines = [line.split("s  ", 1)[1] for line in result.stdout.splitlines() if line.startswith("run_thesis: t =")]

    def first(start):
        return next(index for index, line in enumerate(lines) if line.startswith(start))

    # Expect III-B's edit, III-C's teaching before DropItem releases what the teaching put in gap_1, III-E's
    # insertion in the summary's words, and III-D's ellipsoid turned 45 degrees
    assert first("operator: tree edit: removed PlaceItem") < first("operator: opened LOW-LEVEL")
    assert first("operator: LOW-LEVEL teaching: recording stopped") < first("DropItem: done released product_pick_1")
    assert first("operator: taught DemonstratedPlace_1") < first("operator: tree edit: inserted DemonstratedPlace_1 at")
    turns = [float(line.split("ellipsoid turned ")[1].split()[0]) for line in lines if "ellipsoid turned" in line]
    assert any(-47.0 <= yaw <= -43.0 for yaw in turns), lines  # the handle's -45 deg, as far as the GUI took it (-44)


def test_tree_after_iii_b_and_iii_e_is_exactly_as_expected(run):
    _, folder = run
    initial = yaml.safe_load((ROOT / "config" / "tree.yaml").read_text())["root"]["children"][1]["children"]
    assert yaml.safe_load((folder / "tree_before.yaml").read_text()) == yaml.safe_load(
        (ROOT / "config" / "tree.yaml").read_text()
    )
    summary = json.loads((folder / "summary.json").read_text())
    taught = summary["taught_skills"][0]["name"]
    after_b = [name for name in initial if name != "PlaceItem"]
    after_e = after_b[:8] + [taught] + after_b[8:]
    # Expect: exactly two edits, III-B's removal then III-E's insertion at the dialled index 8 (after MoveBase2)
    assert summary["tree_changes"] == [initial, after_b, after_e]
    children = [child["name"] for child in yaml.safe_load((folder / "tree_after.yaml").read_text())["children"]]
    assert children == after_e
    # the behaviour tree node's own saved tree (what a restart with resume:=true loads) and its ascii view agree
    saved = yaml.safe_load((folder / "tree_after_saved.yaml").read_text())["root"]["children"][1]["children"]
    assert [child["name"] for child in saved] == after_e
    assert [line.strip(" -") for line in (folder / "tree_after.txt").read_text().strip().splitlines()[3:]] == [
        f"> {name}" for name in after_e
    ]


def test_recorded_stiffness_shows_the_three_phases_of_iii_c(run):
    _, folder = run
    files = sorted((folder / "skills").glob("*.npz"))
    assert len(files) == 1
    skill = skill_file.load(files[0])
    time = skill.time - skill.time[0]
    kx, ky = skill.stiffness[:, 0, 0], skill.stiffness[:, 1, 1]
    approach, alignment, insertion = time < 3.0, (time >= 3.0) & (time < 5.0), time >= 5.0
    # approach: compliant, equal low X and Y stiffness
    assert np.median(kx[approach]) == pytest.approx(np.median(ky[approach]), rel=0.1)
    assert np.median(kx[approach]) < 1000.0
    # alignment: Y at least 3x the approach's; insertion: X at least 3x the approach's
    assert ky[alignment].max() >= 3.0 * np.median(ky[approach])
    assert kx[insertion].max() >= 3.0 * np.median(kx[approach])
    # the equilibrium followed the perpendicular trajectory into the gap: stored in the frame of gap_1 as perception
    # saw it (config/trajectories/perpendicular.yaml's last waypoint), which stood where gap_1 is, give or take
    # perception's error, in front of the base at place_perpendicular
    assert (skill.frame, skill.target.name) == (skill_file.TARGET_FRAME, "gap_1")
    assert skill.equilibrium_pose[-1, :3] == pytest.approx([0.0, 0.0, 0.035], abs=1e-3)
    assert skill.target.pose_in_base[:3] == pytest.approx([0.61, 0.0, 0.72], abs=0.03)


def test_both_products_end_upright_in_their_gaps_and_the_neighbours_stay(run):
    _, folder = run
    scene = load_scene()
    first, last = scene_products(next(folder.glob("*.bag")))
    # Expect, from the scene recorded in the bag: product 1 in gap_1 (the demonstration), product 2 in gap_2 (the
    # taught skill, reused by the tree), both upright; nothing else on the shelves moved by more than 1 cm
    for product, gap in (("product_pick_1", "gap_1"), ("product_pick_2", "gap_2")):
        position, quaternion = last[product]
        horizontal, vertical = scene.gap(gap).distance(position)
        assert horizontal < scene.gap(gap).tolerance and vertical < 0.02, (product, position)
        assert Rotation.from_quat(quaternion).apply([0.0, 0.0, 1.0])[2] > np.cos(np.radians(10.0)), product
    for name in first:
        if name.startswith("product_shelf") or name.startswith("product_low"):
            assert np.linalg.norm(last[name][0] - first[name][0]) < 0.01, name


def test_tree_reuses_the_taught_skill_to_place_the_second_product(run):
    result, folder = run
    summary = json.loads((folder / "summary.json").read_text())
    taught = summary["taught_skills"][0]["name"]
    children = yaml.safe_load((folder / "tree_after.yaml").read_text())["children"]
    leaf = next(child for child in children if child["skill"] == taught)
    assert leaf["status"] == "success", leaf
    assert leaf["message"].startswith(f"replayed {taught} (stiffness)"), leaf
    assert "product_pick_2 released upright in gap_2" in leaf["message"], leaf
    assert all(child["status"] == "success" for child in children), children
    # Expect: the summary's placements, computed from the bag, credit the taught skill with product 2 in gap_2
    by_product = {entry["product"]: entry for entry in summary["placements"]}
    assert by_product["product_pick_1"]["gap"] == "gap_1"
    assert by_product["product_pick_2"]["gap"] == "gap_2" and by_product["product_pick_2"]["by_skill"] == taught
    assert "product product_pick_2: on the shelf in gap_2, upright" in result.stdout
    assert f"put there by {taught}" in result.stdout


def test_run_folder_holds_bag_report_and_screenshots(run):
    _, folder = run
    assert len(list(folder.glob("*.bag"))) == 1
    for figure in ("high_level.png", "stiffness.png", "rotation.png", "summary.md"):
        assert (folder / "report" / figure).stat().st_size > 0, figure
    shots = {path.name for path in folder.glob("*.png")}
    missing = json.loads((folder / "summary.json").read_text())["screenshot_errors"]
    assert {"rviz.png", "gui_final.png"} <= shots, (missing, (folder / "rviz.log").read_text()[-2000:])
    # Expect RViz's own window with the robot and the scene drawn (it showed the GUI, or RViz's splash screen)
    drawn, share, why = rviz_picture(folder / "rviz.png", background_colour(ROOT / "rviz" / "teleteach.rviz"))
    assert drawn, why
    for tab in ("start", "high_level", "low_level"):
        assert any(tab in name for name in shots), (tab, shots)
    for name in ("tree_before.txt", "tree_after.txt", "tree_after_saved.yaml", "summary.md"):
        assert (folder / name).stat().st_size > 0, name


def test_thesis_iii_d_turns_the_ellipsoid_places_at_45_degrees_and_reuses_it(tmp_path):
    result = run_thesis(
        tmp_path, "--scenario", ROOT / "config" / "scenarios" / "thesis_III_D.yaml", "--no-rviz", *FASTER
    )
    assert result.returncode == 0, result.stdout + result.stderr
    folder = next((tmp_path / "runs").iterdir())
    skill = skill_file.load(next((folder / "skills").glob("*.npz")))
    time = skill.time - skill.time[0]
    # stored in gap_1's frame, where the shelf runs along y: the ellipsoid's long axis lies along it
    values, vectors = np.linalg.eigh(skill.stiffness[np.searchsorted(time, 6.9)][:2, :2])
    assert abs(vectors[1, np.argmax(values)]) > np.cos(np.radians(5.0)), vectors
    skill = skill.in_base(skill.target.transform)
    # Expect: after the alignment (3-7 s of angled_45) the stiffest horizontal axis lies along the shelf, i.e. the
    # ellipsoid turned 45 degrees about Z in the rotated base frame; during the approach it was round in X-Y
    values, vectors = np.linalg.eigh(skill.stiffness[np.searchsorted(time, 6.9)][:2, :2])
    major = vectors[:, np.argmax(values)]
    assert abs(abs(np.degrees(np.arctan2(major[1], major[0]))) - 45.0) < 5.0, major
    assert values.max() >= 3.0 * np.median(skill.stiffness[time < 3.0, 0, 0])
    approach = skill.stiffness[np.searchsorted(time, 1.5)]
    assert approach[0, 0] == pytest.approx(approach[1, 1], rel=0.1) and abs(approach[0, 1]) < 1.0
    # and the product it placed stands in gap_1; reused at 45 degrees to gap_2, the taught skill placed the second
    # product there; the neighbours untouched
    scene = load_scene()
    first, last = scene_products(next(folder.glob("*.bag")))
    for product, gap in (("product_pick_1", "gap_1"), ("product_pick_2", "gap_2")):
        horizontal, vertical = scene.gap(gap).distance(last[product][0])
        assert horizontal < 0.02 and vertical < 0.02, (product, last[product])
    for name in first:
        if name.startswith("product_shelf"):
            assert np.linalg.norm(last[name][0] - first[name][0]) < 0.01, name
    summary = json.loads((folder / "summary.json").read_text())
    by_product = {entry["product"]: entry for entry in summary["placements"]}
    assert by_product["product_pick_2"]["by_skill"] == summary["taught_skills"][0]["name"]
