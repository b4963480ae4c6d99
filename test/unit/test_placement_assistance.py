"""Shared control in the placement (teleteach.shared_control.placement): the opening from perception, and what the
assistance lets the held product do there, checked against geometry worked out by hand."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from teleteach.core.frames import Transform
from teleteach.core.observed import ObservedBox, ObservedScene
from teleteach.core.scene import Gap
from teleteach.core.teleoperation import AssistanceParameters
from teleteach.shared_control.placement import Opening, assist

PARAMETERS = AssistanceParameters(enabled=True, margin=0.001, capture=0.015, front_margin=0.005, reach=0.35)
YAW = 0.3  # the gap's direction into the shelf in world [rad]
GAP = Gap("gap_9", (2.0, 0.5, 0.7), YAW, 0.06, 0.01)  # 6 cm free between the neighbours
BASE = Transform.from_planar(1.4, 0.3, 0.2)  # base_link in world
HAND_IN_GAP = np.array([-0.2, 0.01, 0.035])  # the TCP 20 cm in front of the gap, 1 cm aside, above the product
UPRIGHT = Rotation.from_euler("z", YAW)
DOWN = Rotation.from_euler("x", np.pi)  # the hand pointing down, in the gap's axes


def box(name, in_gap, size, yaw=0.0):
    """A perceived product at ``in_gap`` (gap frame), turned ``yaw`` from the gap's axes."""
    world = GAP.frame.apply_point(in_gap)
    return ObservedBox(name, world, (Rotation.from_euler("z", yaw) * UPRIGHT).as_quat(), size)


def scene(held=True):
    products = {
        "left": box("left", [0.01, 0.06, 0.0], (0.08, 0.06, 0.14)),  # its front at 0.01 - 0.04 = -0.03
        "right": box("right", [0.0, -0.06, 0.0], (0.08, 0.06, 0.14)),  # its front at -0.04
        "far": box("far", [0.0, 0.5, 0.0], (0.08, 0.06, 0.14)),  # beyond the band: not a neighbour
    }
    if held:  # the product in the hand, turned 90 degrees: 5 cm across the gap, 7 cm deep
        products["held"] = box("held", HAND_IN_GAP - [0.0, 0.002, 0.035], (0.05, 0.07, 0.13), yaw=np.pi / 2)
    return ObservedScene(products, {GAP.name: GAP}, {})


def hand_in_base(in_gap, turn=DOWN):
    """The hand's pose in the base frame, from its position and turn in the gap's frame."""
    return (BASE.inverse() * GAP.frame * Transform(np.asarray(in_gap, dtype=float), turn)).as_pose()


def opening():
    result, why = Opening.perceived(scene(), "gap_9", BASE, hand_in_base(HAND_IN_GAP), 0.035)
    assert result is not None, why
    return result


def test_the_opening_holds_the_gap_its_neighbours_fronts_and_the_product_in_the_hand():
    found = opening()
    # Expect: the nearer neighbour's front (0 - 4 cm); the held product where the grasp holds it, 3.5 cm beyond the
    # TCP along the hand's z (perception's 2 mm to the side is not believed), turned as perceived
    assert (found.gap, found.width, found.fronts) == ("gap_9", 0.06, pytest.approx(-0.04))
    np.testing.assert_allclose(found.in_hand.position, [0.0, 0.0, 0.035], atol=1e-12)
    turned = DOWN.inv() * Rotation.from_euler("z", np.pi / 2)  # the product in the hand's axes
    assert (found.in_hand.rotation * turned.inv()).magnitude() < 1e-9
    np.testing.assert_allclose(found.frame.as_pose(), (BASE.inverse() * GAP.frame).as_pose(), atol=1e-12)


def test_no_opening_without_the_gap_or_a_product_in_the_hand():
    assert Opening.perceived(scene(), "gap_1", BASE, hand_in_base(HAND_IN_GAP), 0.035) == (
        None,
        "perception reports no gap_1",
    )
    assert Opening.perceived(scene(held=False), "gap_9", BASE, hand_in_base(HAND_IN_GAP), 0.035) == (
        None,
        "no perceived product in the hand",
    )


def assisted(now, asked, turn=DOWN):
    """(allowed hand position in the gap's frame, what the assistance said) for hand positions in the gap's frame."""
    found = opening()
    allowed, said = assist(found, hand_in_base(now, turn), hand_in_base(asked)[:3], PARAMETERS)
    return GAP.frame.inverse().apply_point(BASE.apply_point(allowed)), said


def test_in_front_of_the_opening_the_operator_is_free():
    allowed, said = assisted([-0.2, 0.01, 0.035], [-0.1, 0.05, 0.1])
    np.testing.assert_allclose(allowed, [-0.1, 0.05, 0.1], atol=1e-12)
    assert said == ""


def test_pushed_in_beside_the_corridor_the_product_is_guided_into_it():
    # the product's centre (below the hand) asked 1.4 cm aside: beyond the corridor (4 mm), within its capture
    allowed, said = assisted([-0.1, 0.014, 0.035], [-0.05, 0.014, 0.035])
    # Expect: the corridor: 3 cm - 2.5 cm (half the held product across) - 1 mm; the product's centre, and the hand,
    # at its edge; the depth asked
    np.testing.assert_allclose(allowed, [-0.05, 0.004, 0.035], atol=1e-12)
    assert said == "guided into gap_9's opening"


def test_pushed_in_far_aside_the_shelf_front_holds_it():
    allowed, said = assisted([-0.1, 0.032, 0.035], [-0.05, 0.032, 0.035])  # product 3.2 cm aside: 2.8 cm off
    # Expect: held where its front meets the nearer neighbour's (-4 cm less its half depth 3.5 cm, less the front
    # margin), free across
    np.testing.assert_allclose(allowed, [-0.08, 0.032, 0.035], atol=1e-12)
    assert said == "held at gap_9's front: 2.8 cm beside its opening"


def test_past_the_front_the_product_stays_in_the_corridor_and_above_the_board():
    allowed, said = assisted([-0.03, 0.0, 0.05], [0.01, -0.02, -0.01])
    # Expect: across clipped to the corridor (-4 mm), down to the board (the product's centre at z 0)
    np.testing.assert_allclose(allowed, [0.01, -0.004, 0.035], atol=1e-12)
    assert said == "kept in gap_9's opening"
    allowed, said = assisted([-0.03, 0.0, 0.05], [0.01, 0.003, 0.04])
    np.testing.assert_allclose(allowed, [0.01, 0.003, 0.04], atol=1e-12)
    assert said == ""


def test_the_product_turns_with_the_hand():
    # the hand turned a quarter about the vertical since the product was seen: the product now lies 7 cm across the
    # gap (more than its 6 cm)
    turned = Rotation.from_euler("z", np.pi / 2) * DOWN
    allowed, said = assisted([-0.03, 0.0, 0.05], [0.0, 0.01, 0.05], turn=turned)
    # Expect: no corridor left (3 cm - 3.5 cm - 1 mm: none), so the product's centre kept on the gap's centre line,
    # and the hand above it
    np.testing.assert_allclose(allowed[1], 0.0, atol=1e-12)
    assert said == "kept in gap_9's opening"


def test_the_held_product_is_the_nearest_and_the_neighbours_those_within_the_band():
    products = dict(scene().products)
    # a product 14 cm from the hand (10 cm aside, 10 cm up): within reach of it, but not the nearest
    products["decoy"] = box("decoy", HAND_IN_GAP + np.array([0.0, 0.1, 0.1]), (0.08, 0.08, 0.08))
    # neighbours that would stand in front of the nearer neighbour's front (-4 cm), at the band's edges: across, just
    # inside it (counts); deeper than it, higher than it (do not count)
    products["inside"] = box("inside", [0.0, 0.175, 0.0], (0.1, 0.06, 0.14))  # front at -0.05
    products["deep"] = box("deep", [0.27, 0.0, 0.0], (0.7, 0.06, 0.14))  # front at -0.08, but 27 cm deep
    products["high"] = box("high", [0.0, -0.06, 0.12], (0.2, 0.06, 0.14))  # front at -0.1, but 12 cm up
    products["aside"] = box("aside", [0.0, 0.19, 0.0], (0.14, 0.06, 0.14))  # front at -0.07, but 1 cm beyond the band
    # and one as far from the hand as can be, on the far side of the world's origin
    hand_world = (BASE * Transform.from_pose(hand_in_base(HAND_IN_GAP))).position
    products["far"] = ObservedBox("far", -hand_world, UPRIGHT.as_quat(), (0.08, 0.06, 0.14))
    found, why = Opening.perceived(
        ObservedScene(products, {GAP.name: GAP}, {}), "gap_9", BASE, hand_in_base(HAND_IN_GAP), 0.035
    )
    assert why == ""
    np.testing.assert_allclose(found.size, [0.05, 0.07, 0.13])
    assert found.fronts == pytest.approx(-0.05)


def test_without_neighbours_the_front_is_the_gap_s_centre_and_without_products_nothing_is_held():
    alone = {"held": scene().products["held"]}
    found, why = Opening.perceived(
        ObservedScene(alone, {GAP.name: GAP}, {}), "gap_9", BASE, hand_in_base(HAND_IN_GAP), 0.035
    )
    assert (found.fronts, why) == (0.0, "")
    empty = ObservedScene({}, {GAP.name: GAP}, {})
    assert Opening.perceived(empty, "gap_9", BASE, hand_in_base(HAND_IN_GAP), 0.035) == (
        None,
        "no perceived product in the hand",
    )


def test_guided_from_either_side_and_silent_when_already_in_line():
    allowed, said = assisted([-0.1, -0.014, 0.035], [-0.05, -0.014, 0.035])
    np.testing.assert_allclose(allowed, [-0.05, -0.004, 0.035], atol=1e-12)
    assert said == "guided into gap_9's opening"
    allowed, said = assisted([-0.1, 0.002, 0.035], [-0.05, 0.002, 0.035])
    np.testing.assert_allclose(allowed, [-0.05, 0.002, 0.035], atol=1e-12)
    assert said == ""


def test_a_tilted_hand_carries_the_product_past_the_front_before_itself():
    # the hand pitched 30 degrees: the product, 3.5 cm along the hand's axis, lies 1.75 cm deeper than the hand, and
    # reaches 6.3 cm ahead of its centre (0.5 (0.07 cos 30 + 0.13 sin 30)): the front it may pass is at -10.8 cm
    tilted = Rotation.from_euler("y", -np.pi / 6) * DOWN
    allowed, said = assisted([-0.115, 0.02, 0.05], [-0.11, 0.02, 0.05], turn=tilted)
    # Expect: the product's centre at -9.75 cm, past that front although the hand is not: kept in the corridor across
    # (its centre at 4 mm, and the hand above it), not held at the front
    assert said == "kept in gap_9's opening"
    assert allowed[1] == pytest.approx(0.004, abs=1e-9)
