"""Situations as features (teleteach.bt.situations): reasons parsed as the skills word them, the tree's shape around a
node, the product and the gap from the scene, and a saved situation read back."""

import math

import numpy as np
import pytest

from teleteach.bt import situations
from teleteach.bt.scripted_failures import World, draw_situation
from teleteach.bt.situations import Situation, describe, node_context, parse_reason, target_features
from teleteach.core.scene import load_scene


@pytest.fixture(scope="module")
def world():
    return World.load()


def test_a_placement_that_missed_and_pushed_gives_both_categories_in_metres():
    # Expect: PlaceItem's problems joined by '; ' (teleteach.core.placement), the first one the category
    failure = parse_reason(
        "product_pick_1 ended 2.4 cm from gap_1 (0.6 cm in height); product_pick_1's neighbour product_shelf_7 moved "
        "1.2 cm; product_pick_1's neighbour product_shelf_8 moved 1.9 cm"
    )
    assert failure.category == "placement_missed"
    assert failure.problems == ("placement_missed", "neighbour_pushed")
    assert failure.measured["placement_error_m"] == pytest.approx(0.024)
    assert failure.measured["height_error_m"] == pytest.approx(0.006)
    assert failure.measured["neighbour_move_m"] == pytest.approx(0.019)  # the larger of the two moves


@pytest.mark.parametrize(
    "reason, category, measured",
    [
        (
            "the grasp of product_pick_2 (52 mm wide) failed: the fingers closed on nothing",
            "grasp_failed",
            {"grasp_width_m": 0.052},
        ),
        (
            "product_pick_1 is not in the gripper after grasping (finger opening 0.004 m, nearest product 0.120 m "
            "from the fingers)",
            "grasp_slipped",
            {"finger_opening_m": 0.004, "product_offset_m": 0.12},
        ),
        ("product_pick_1 is not on the table", "product_missing", {}),
        ("product_pick_1 is not upright (tilted 35 deg)", "product_tilted", {"tilt_deg": 35.0}),
        (
            "the arm did not reach its goal: 0.210 rad off 1.0 s after the trajectory's end (blocked?)",
            "arm_blocked",
            {"joint_error_rad": 0.21},
        ),
        (
            "the base did not reach (1.45, 0.00, 0.00) within 31 s: 0.180 m, 0.050 rad away",
            "base_not_reached",
            {"base_offset_m": 0.18, "base_turn_rad": 0.05},
        ),
        ("the gripper's move to 0.080 m did not finish within 5.0 s", "timed_out", {"timeout_s": 5.0}),
        ("something nobody foresaw", "other", {}),
    ],
)
def test_each_skill_message_gives_its_category_and_values(reason, category, measured):
    failure = parse_reason(reason)
    assert failure.category == category
    assert failure.measured == pytest.approx(measured)


def test_the_node_context_is_read_from_the_thesis_tree(world):
    context = node_context(world.tree, "PlaceItem", world.execution, dict(world.library))
    assert (context.skill, context.kind, context.type) == ("PlaceItem", "predefined", "skill")
    assert (context.parent, context.parent_type, context.in_execution) == ("BehaviorExecution", "sequence", True)
    assert (context.index, context.siblings, context.depth) == (3, 10, 2)
    assert (context.previous, context.next, context.decorator) == ("MoveBase", "DropItem", "")


def test_a_wrapped_node_stands_where_its_decorator_does(world):
    children = world.tree["children"][1]["children"]
    wrapped = [
        {"type": "retry", "name": "Retry", "attempts": 2, "children": [child]}
        if child["name"] == "PlaceItem"
        else child
        for child in children
    ]
    tree = {**world.tree, "children": [world.tree["children"][0], {**world.tree["children"][1], "children": wrapped}]}
    context = node_context(tree, "PlaceItem", world.execution, dict(world.library))
    assert (context.decorator, context.parent, context.index, context.depth) == ("retry", "BehaviorExecution", 3, 2)
    with pytest.raises(KeyError, match="NoSuchNode"):
        node_context(tree, "NoSuchNode", world.execution, {})


def test_the_gap_is_described_as_the_base_meets_it():
    scene = load_scene()
    gap, base = scene.gap("gap_1"), scene.base_poses["place_perpendicular"]
    target = target_features(gap, 0.05, base)
    # Expect: gap_1 is 60 mm wide, 5 mm per side around a 50 mm product, 0.61 m straight ahead, faced squarely
    assert target.clearance_m == pytest.approx(0.005)
    assert target.distance_m == pytest.approx(0.61)
    assert target.bearing_rad == pytest.approx(0.0)
    turned = target_features(gap, 0.05, scene.base_poses["place_45deg"])
    assert turned.facing_rad == pytest.approx(-math.pi / 4, abs=1e-3)


def test_features_hold_numbers_in_their_scales_names_and_categories_as_text(world):
    scene = load_scene()
    situation = describe(
        world.tree,
        world.execution,
        "PlaceItem",
        "product_pick_1 is not upright (tilted 20 deg)",
        world.library,
        scene.product("product_pick_1"),
        scene.gap("gap_2"),
        scene.base_poses["place_perpendicular_2"],
    )
    features = situation.features()
    numbers = {name for name, value in features.items() if not isinstance(value, str)}
    named = {name for name in numbers if not name.startswith(("problem:", "has:"))}
    assert named <= set(situations.SCALES)
    assert {name for name, value in features.items() if isinstance(value, str)} == set(situations.CATEGORIES)
    assert features["product:mass_kg"] == pytest.approx(0.45)
    assert features["failure"] == "product_tilted" and features["measured:tilt_deg"] == 20.0
    assert features["has:PickItem"] == 1.0 and features["library:condition"] == 2.0


def test_a_situation_is_read_back_as_it_was_saved(world):
    rng = np.random.default_rng(3)
    for _ in range(20):
        situation = draw_situation(world, ["gap_1", "gap_2"], rng)
        assert Situation.from_dict(situation.to_dict()) == situation


def test_the_feature_set_changes_with_the_definitions(monkeypatch):
    before = situations.feature_set()
    monkeypatch.setitem(situations.SCALES, "product:mass_kg", 0.3)
    assert situations.feature_set() != before
