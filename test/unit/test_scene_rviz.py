"""teleteach.viz.scene: what RViz draws of teleteach/scene. No shape keeps a name in its text (RViz warns "Non-empty
text is ignored"); each object of the four classes gets one label with its name just above its box, in a namespace of
its own; deletions reach the labels; markers of other namespaces are drawn without a label."""

import itertools
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from std_msgs.msg import Header
from visualization_msgs.msg import Marker

from teleteach.core.observed import (
    GAPS,
    PRODUCTS,
    SURFACES,
    TABLES,
    box_marker,
    observed_from_markers,
    observed_from_scene,
    scene_markers,
)
from teleteach.core.scene import load_objects
from teleteach.viz.scene import LABEL_CLEARANCE, LABEL_HEIGHT, rviz_markers

CLASSES = (PRODUCTS, GAPS, TABLES, SURFACES)


def supermarket():
    """The scene file's teleteach/scene as robot_sim sends it: shelf boards first (RViz only), then the objects."""
    header = Header(frame_id="world")
    shelf = [
        box_marker(
            header, "shelf", 0, (2.175, 0.0, 0.29), (0, 0, 0, 1), (0.35, 1.2, 0.02), (0.5, 0.4, 0.2, 1), "board"
        ),
        box_marker(
            header, "shelf", 1, (2.36, 0.0, 0.575), (0, 0, 0, 1), (0.02, 1.24, 1.15), (0.5, 0.4, 0.2, 1), "back"
        ),
    ]
    return scene_markers(observed_from_scene(load_objects()), 3.0, shelf).markers


def highest_corner(marker):
    """The world height of the highest of the box's eight corners [m], from the corners themselves."""
    half = np.array([marker.scale.x, marker.scale.y, marker.scale.z]) / 2.0
    o = marker.pose.orientation
    rotation = Rotation.from_quat([o.x, o.y, o.z, o.w])
    corners = [rotation.apply(half * np.array(signs))[2] for signs in itertools.product((-1, 1), repeat=3)]
    return marker.pose.position.z + max(corners)


def horizontal_distance(one, other):
    return math.hypot(one.pose.position.x - other.pose.position.x, one.pose.position.y - other.pose.position.y)


def test_the_shapes_lose_their_text_and_each_object_gets_its_name_above_its_box():
    sent = supermarket()
    drawn, rejected = rviz_markers(sent)
    shapes = [marker for marker in drawn if marker.type != Marker.TEXT_VIEW_FACING]
    labels = [marker for marker in drawn if marker.type == Marker.TEXT_VIEW_FACING]
    # Expect every marker sent drawn as it was but without text, in the same order; the message sent unchanged
    assert rejected == []
    assert [marker.text for marker in shapes] == [""] * len(sent)
    assert [(m.ns, m.id, m.type, m.pose, m.scale, m.color) for m in shapes] == [
        (m.ns, m.id, m.type, m.pose, m.scale, m.color) for m in sent
    ]
    assert all(marker.text for marker in sent)
    # Expect one label per object of the four classes, named as it is, right after its box, in <class>/names
    objects = [marker for marker in sent if marker.ns in CLASSES]
    assert len(objects) > 40 and {marker.ns for marker in objects} == set(CLASSES)
    assert len(labels) == len(objects)
    place = {id(shape): index for index, shape in enumerate(drawn)}
    products = [marker for marker in sent if marker.ns == PRODUCTS]
    for marker, shape in zip(sent, shapes):
        if marker.ns not in CLASSES:
            continue
        label = drawn[place[id(shape)] + 1]
        assert (label.type, label.ns, label.id, label.text) == (
            Marker.TEXT_VIEW_FACING,
            f"{marker.ns}/names",
            marker.id,
            marker.text,
        )
        # just above the box: centred over it, its lower edge LABEL_CLEARANCE above the highest corner
        assert (label.pose.position.x, label.pose.position.y) == pytest.approx(
            (marker.pose.position.x, marker.pose.position.y)
        )
        lower_edge = label.pose.position.z - label.scale.z / 2.0
        if marker.ns == GAPS:  # above the labels of the slot's neighbours (the two products nearest)
            nearest = sorted(products, key=lambda product: horizontal_distance(product, marker))[:2]
            neighbours = max(highest_corner(product) for product in nearest)
            assert neighbours > highest_corner(marker) + 0.05
            assert lower_edge == pytest.approx(neighbours + 2 * LABEL_CLEARANCE + LABEL_HEIGHT)
        else:
            assert lower_edge == pytest.approx(highest_corner(marker) + LABEL_CLEARANCE)
        assert label.scale.z == LABEL_HEIGHT <= 0.03  # small: the shelf's products stand 7-11 cm apart
        assert label.header.frame_id == "world" and label.action == Marker.ADD
        assert label.pose.orientation.w == 1.0  # RViz warns about an uninitialised (all-zero) quaternion
        assert label.color.a == 1.0 and min(label.color.g, label.color.b) >= 0.8  # light, opaque: readable on grey
    # Expect the ids of the labels never to collide with each other or with a shape's
    keys = [(marker.ns, marker.id) for marker in drawn]
    assert len(set(keys)) == len(keys)
    # Expect the shelf's boards drawn without a label, and read back as no object
    assert [m.ns for m in drawn if m.ns.startswith("shelf")] == ["shelf", "shelf"]
    assert observed_from_markers(drawn)[0].products == {}  # what RViz gets is no scene for the skills


def test_a_tilted_surface_s_label_stands_above_its_highest_corner():
    header = Header(frame_id="world")
    tilted = Rotation.from_euler("y", math.radians(30.0)).as_quat()
    board = box_marker(header, SURFACES, 4, (1.0, 0.5, 0.8), tilted, (0.4, 0.3, 0.02), (1, 1, 1, 0.6), "board")
    drawn, _ = rviz_markers([board])
    # Expect: 0.8 m + half of 0.4 m x sin 30 + half of 0.02 m x cos 30, then the clearance and half the text height
    top = 0.8 + 0.2 * 0.5 + 0.01 * math.cos(math.radians(30.0))
    assert drawn[1].pose.position.z == pytest.approx(top + LABEL_CLEARANCE + LABEL_HEIGHT / 2.0)
    assert drawn[1].pose.position.z == pytest.approx(highest_corner(board) + LABEL_CLEARANCE + LABEL_HEIGHT / 2.0)


def test_a_gap_s_label_stands_above_the_products_beside_it_only():
    header = Header(frame_id="world")
    red = (1, 0, 0, 1)
    gap = box_marker(header, GAPS, 0, (2.0, 0.0, 0.72), (0, 0, 0, 1), (0.02, 0.06, 0.002), (0, 1, 0, 0.5), "gap_1")
    alone, _ = rviz_markers([gap])
    # Expect a gap with nothing beside it labelled just above its slab (0.721 m)
    assert alone[1].pose.position.z == pytest.approx(0.721 + LABEL_CLEARANCE + LABEL_HEIGHT / 2.0)
    # Expect a taller product beside it (0.03 + 0.06 from its centre, spanning 0.72 m) to lift it above its label; one
    # on the board above (not spanning the gap's height) and one 0.3 m away not to
    neighbour = box_marker(header, PRODUCTS, 0, (2.0, 0.09, 0.75), (0, 0, 0, 1), (0.06, 0.05, 0.2), red, "tall")
    above = box_marker(header, PRODUCTS, 1, (2.0, 0.0, 1.0), (0, 0, 0, 1), (0.06, 0.05, 0.2), red, "above")
    far = box_marker(header, PRODUCTS, 2, (2.0, 0.3, 0.72), (0, 0, 0, 1), (0.06, 0.05, 0.6), red, "far")
    drawn, _ = rviz_markers([far, above, gap, neighbour])
    label = next(marker for marker in drawn if marker.ns == "gaps/names")
    assert label.pose.position.z == pytest.approx(0.85 + 2 * LABEL_CLEARANCE + 1.5 * LABEL_HEIGHT)
    # the products' own labels stand above their own boxes: far, above, (the gap's), tall
    lower_edges = [m.pose.position.z - LABEL_HEIGHT / 2.0 for m in drawn if m.text]
    assert lower_edges == pytest.approx([1.03, 1.11, 0.87 + LABEL_HEIGHT, 0.86])


def test_deletions_pass_through_and_take_the_labels_with_them():
    header = Header(frame_id="world")
    gone = Marker(header=header, ns=PRODUCTS, id=7, action=Marker.DELETE)
    clear_gaps = Marker(header=header, ns=GAPS, action=Marker.DELETEALL)
    clear_all = Marker(header=header, action=Marker.DELETEALL)
    shelf_gone = Marker(header=header, ns="shelf", id=2, action=Marker.DELETE)
    drawn, rejected = rviz_markers([clear_all, gone, clear_gaps, shelf_gone])
    # Expect each deletion as it came, a product's followed by its label's, the gaps' by their labels' namespace;
    # a DELETEALL without a namespace (it clears the labels too) and the shelf's alone
    assert [(m.ns, m.id, m.action) for m in drawn] == [
        ("", 0, Marker.DELETEALL),
        (PRODUCTS, 7, Marker.DELETE),
        ("products/names", 7, Marker.DELETE),
        (GAPS, 0, Marker.DELETEALL),
        ("gaps/names", 0, Marker.DELETEALL),
        ("shelf", 2, Marker.DELETE),
    ]
    assert drawn[0] is clear_all and drawn[1] is gone and rejected == []


def test_a_marker_that_is_no_object_is_drawn_without_a_label_and_its_old_label_goes():
    header = Header(frame_id="world")
    good = box_marker(header, PRODUCTS, 0, (0.6, 0.0, 0.5), (0, 0, 0, 1), (0.06, 0.05, 0.14), (1, 0, 0, 1), "kept")
    broken = box_marker(header, PRODUCTS, 1, (math.nan, 0.0, 0.5), (0, 0, 0, 1), (0.06, 0.05, 0.14), (1, 0, 0, 1), "x")
    nameless = box_marker(header, TABLES, 0, (0.6, 0.0, 0.2), (0, 0, 0, 1), (0.6, 0.8, 0.4), (0.5, 0.5, 0.5, 1), "")
    twin = box_marker(header, PRODUCTS, 2, (0.7, 0.0, 0.5), (0, 0, 0, 1), (0.06, 0.05, 0.14), (1, 0, 0, 1), "kept")
    drawn, rejected = rviz_markers([good, broken, nameless, twin])
    # Expect every shape drawn without text; a label only for the first "kept"; the others' labels deleted
    assert [(m.ns, m.id, m.type, m.action, m.text) for m in drawn] == [
        (PRODUCTS, 0, Marker.CUBE, Marker.ADD, ""),
        ("products/names", 0, Marker.TEXT_VIEW_FACING, Marker.ADD, "kept"),
        (PRODUCTS, 1, Marker.CUBE, Marker.ADD, ""),
        ("products/names", 1, Marker.ARROW, Marker.DELETE, ""),
        (TABLES, 0, Marker.CUBE, Marker.ADD, ""),
        ("tables/names", 0, Marker.ARROW, Marker.DELETE, ""),
        (PRODUCTS, 2, Marker.CUBE, Marker.ADD, ""),
        ("products/names", 2, Marker.ARROW, Marker.DELETE, ""),
    ]
    assert len(rejected) == 3 and "products marker 'x': position" in rejected[0]
    assert "name is taken" in rejected[2]


def test_a_text_marker_of_the_scene_keeps_its_text():
    header = Header(frame_id="world")
    note = Marker(header=header, ns="notes", id=0, type=Marker.TEXT_VIEW_FACING, text="aisle 3")
    note.pose.orientation.w, note.scale.z = 1.0, 0.1
    drawn, _ = rviz_markers([note])
    assert drawn == [note] and drawn[0].text == "aisle 3"
