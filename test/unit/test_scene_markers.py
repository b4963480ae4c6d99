"""The products on /teleteach/scene read back from their markers, and the distance of a product from the gap."""

import numpy as np
import pytest
from visualization_msgs.msg import Marker

from teleteach.sim.scene import PRODUCTS_NAMESPACE, load_scene, product_positions


def marker(ns, text, xyz, frame="world"):
    message = Marker(ns=ns, text=text)
    message.header.frame_id = frame
    message.pose.position.x, message.pose.position.y, message.pose.position.z = xyz
    return message


def test_product_positions_keep_only_named_products_in_world():
    markers = [
        marker(PRODUCTS_NAMESPACE, "product_pick_1", (1.0, 2.0, 3.0)),
        marker(PRODUCTS_NAMESPACE, "product_shelf_1", (0.5, 0.0, 1.2), frame="/world"),
        marker("shelf", "shelf", (9.0, 9.0, 9.0)),
        marker(PRODUCTS_NAMESPACE, "", (7.0, 7.0, 7.0)),
        marker(PRODUCTS_NAMESPACE, "elsewhere", (7.0, 7.0, 7.0), frame="base_link"),
    ]
    positions = product_positions(markers)
    # Expect the two products in the world frame, by name, nothing else
    assert sorted(positions) == ["product_pick_1", "product_shelf_1"]
    np.testing.assert_allclose(positions["product_pick_1"], [1.0, 2.0, 3.0])


def test_gap_distance_is_horizontal_and_vertical():
    gap = load_scene().gap("gap_1")
    horizontal, vertical = gap.distance(np.add(gap.position, (0.03, 0.04, -0.02)))
    assert horizontal == pytest.approx(0.05) and vertical == pytest.approx(0.02)
