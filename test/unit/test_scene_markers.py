"""teleteach/scene, the perception interface: an observed scene written as markers reads back the same; markers that
cannot be an object are left out with their reason; and the distance of a product from a gap."""

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from visualization_msgs.msg import Marker

from teleteach.core.observed import (
    GAPS,
    PRODUCTS,
    TABLES,
    observed_from_markers,
    observed_from_scene,
    product_positions,
    scene_markers,
    table_on,
)
from teleteach.core.scene import load_objects, load_scene


def marker(ns, text, xyz, frame="world", quaternion=(0.0, 0.0, 0.0, 1.0), scale=(0.06, 0.05, 0.14)):
    message = Marker(ns=ns, text=text)
    message.header.frame_id = frame
    message.pose.position.x, message.pose.position.y, message.pose.position.z = xyz
    o = message.pose.orientation
    o.x, o.y, o.z, o.w = quaternion
    message.scale.x, message.scale.y, message.scale.z = scale
    return message


def test_the_scene_file_read_back_from_its_markers_is_the_same():
    objects = load_objects()
    sent = observed_from_scene(objects, stamp=12.5)
    received, rejected = observed_from_markers(scene_markers(sent, 12.5).markers)
    # Expect: every product (pose and size), gap (target, yaw, width, tolerance) and table, and the stamp
    assert rejected == []
    assert received.stamp == pytest.approx(12.5)
    assert sorted(received.products) == sorted(product.name for product in objects.products)
    for name, box in sent.products.items():
        np.testing.assert_allclose(received.products[name].position, box.position)
        np.testing.assert_allclose(received.products[name].quaternion, box.quaternion, atol=1e-12)
        assert received.products[name].size == pytest.approx(box.size)
    assert received.gaps.keys() == objects.gaps.keys()
    for name, gap in objects.gaps.items():
        got = received.gap(name)
        assert got.position == pytest.approx(gap.position)
        assert (got.yaw, got.width, got.tolerance) == pytest.approx((gap.yaw, gap.width, gap.tolerance))
    assert list(received.tables) == ["pick_table"]
    assert received.tables["pick_table"].size == pytest.approx(objects.pick_table.size)
    board = objects.surfaces["counter_board"]  # a surface keeps its whole orientation, not only its yaw
    assert list(received.surfaces) == ["counter_board"]
    np.testing.assert_allclose(received.surfaces["counter_board"].position, board.center)
    seen = Rotation.from_quat(received.surfaces["counter_board"].quaternion)
    assert (seen.inv() * board.frame.rotation).magnitude() < 1e-9
    # the pick products stand on the table, the shelf's do not
    assert table_on(received, received.product("product_pick_1"), 0.02) == "pick_table"
    assert table_on(received, received.product("product_shelf_1"), 0.02) is None


def test_a_gap_turned_about_z_keeps_its_yaw():
    turned = marker(GAPS, "gap_9", (2.0, 0.5, 0.72), quaternion=(0.0, 0.0, math.sin(0.3), math.cos(0.3)))
    turned.scale.x, turned.scale.y = 0.04, 0.12
    gap = observed_from_markers([turned])[0].gap("gap_9")
    assert (gap.yaw, gap.width, gap.tolerance) == pytest.approx((0.6, 0.12, 0.02))


def test_markers_that_cannot_be_objects_are_left_out_saying_why():
    markers = [
        marker(PRODUCTS, "product_pick_1", (1.0, 2.0, 3.0)),
        marker(PRODUCTS, "product_shelf_1", (0.5, 0.0, 1.2), frame="/world"),
        marker("shelf", "board_low", (9.0, 9.0, 9.0)),  # another namespace: for RViz, not an object
        marker(PRODUCTS, "", (7.0, 7.0, 7.0)),
        marker(PRODUCTS, "elsewhere", (7.0, 7.0, 7.0), frame="base_link"),
        marker(PRODUCTS, "nan", (math.nan, 0.0, 0.0)),
        marker(PRODUCTS, "zero", (1.0, 0.0, 0.0), quaternion=(0.0, 0.0, 0.0, 0.0)),
        marker(PRODUCTS, "flat", (1.0, 0.0, 0.0), scale=(0.06, 0.0, 0.14)),
        marker(PRODUCTS, "product_pick_1", (5.0, 5.0, 5.0)),
        marker(GAPS, "tilted", (2.0, 0.0, 0.7), quaternion=(0.7071068, 0.0, 0.0, 0.7071068)),
        marker(TABLES, "pick_table", (0.6, 0.0, 0.2), scale=(0.4, 0.6, 0.43)),
    ]
    deleted = marker(PRODUCTS, "gone", (1.0, 1.0, 1.0))
    deleted.action = Marker.DELETE
    scene, rejected = observed_from_markers([*markers, deleted])
    # Expect the two products in the world frame and the table, by name; one reason per other marker of a known class
    assert sorted(scene.products) == ["product_pick_1", "product_shelf_1"]
    np.testing.assert_allclose(scene.product("product_pick_1").position, [1.0, 2.0, 3.0])
    assert list(scene.tables) == ["pick_table"] and scene.gaps == {}
    assert len(rejected) == 7, rejected
    for reason in (
        "products marker '': no name",
        "products marker 'elsewhere': frame 'base_link' is not 'world'",
        "products marker 'nan': position contains NaN",
        "products marker 'zero': orientation is zero",
        "products marker 'flat': scale must be > 0",
        "products marker 'product_pick_1': the name is taken",
        "gaps marker 'tilted': orientation must be a rotation about z only",
    ):
        assert any(line.startswith(reason) for line in rejected), (reason, rejected)
    assert sorted(product_positions(markers)) == ["product_pick_1", "product_shelf_1"]


def test_gap_distance_is_horizontal_and_vertical():
    gap = load_scene().gap("gap_1")
    horizontal, vertical = gap.distance(np.add(gap.position, (0.03, 0.04, -0.02)))
    assert horizontal == pytest.approx(0.05) and vertical == pytest.approx(0.02)
