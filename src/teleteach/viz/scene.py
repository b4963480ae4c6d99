"""The scene as RViz draws it: ``teleteach/scene``'s shapes without their names, and each object's name as a label.

``teleteach/scene`` (:mod:`teleteach.core.observed`) names each object in its shape marker's ``text``, which RViz
does not draw: its Scene display only warns "Non-empty text is ignored" for every such marker. :func:`rviz_markers`
turns one scene message into what RViz should draw, in the same order:

- every shape marker as it is, with ``text`` empty (a TEXT_VIEW_FACING marker keeps its text);
- after each object of the four classes (products, gaps, tables, surfaces: a marker :func:`scene_objects` takes), a
  TEXT_VIEW_FACING label with its name, centred just above its box's highest point, in the namespace
  ``<class>/names`` with the object's id, its header, lifetime and frame_locked. A gap's box is a thin slab at the
  height of a placed product's centre, between its neighbours, which would hide its label: the label of a gap with
  products beside it (:func:`beside`) stands one line above theirs, where the products' labels leave it readable;
- after a marker of the four classes that takes its label away, the label's removal: a DELETE of the object (a
  DELETE of its label), an ADD that is no object (no name, NaN, ...: a DELETE of the label it may have had), a
  DELETEALL of a class' namespace (a DELETEALL of its labels' namespace, for an RViz that deletes by namespace).

Markers of other namespaces (robot_sim's ``shelf`` boards) are drawn without a label; a DELETEALL without a namespace
passes through and clears the labels with everything else.
"""

import copy
import math
from typing import Iterable, List, Tuple

import numpy as np
from scipy.spatial.transform import Rotation
from visualization_msgs.msg import Marker

from teleteach.core.observed import GAPS, PRODUCTS, SURFACES, TABLES, ObservedBox, scene_objects

SCENE_RVIZ_TOPIC = "teleteach/scene_rviz"  # what RViz's Scene display reads
LABELLED = (PRODUCTS, GAPS, TABLES, SURFACES)
LABEL_HEIGHT = 0.03  # [m] text height (TEXT_VIEW_FACING's scale.z)
LABEL_CLEARANCE = 0.01  # [m] between a box's highest point and its label's lower edge
LABEL_COLOUR = (0.6, 0.9, 1.0, 1.0)  # RGBA: light cyan, readable on RViz's dark grey, unlike any box's colour


def label_namespace(namespace: str) -> str:
    """The namespace of the labels of a class' objects: ``products/names`` for ``products``."""
    return f"{namespace}/names"


def vertical_extent(box: ObservedBox) -> Tuple[float, float]:
    """The heights of the box's lowest and highest corners in world [m]."""
    vertical = Rotation.from_quat(box.quaternion).as_matrix()[2]  # each box axis' share of world z
    half = float(np.abs(vertical) @ np.asarray(box.size) / 2.0)
    return float(box.position[2]) - half, float(box.position[2]) + half


def beside(gap: ObservedBox, product: ObservedBox) -> bool:
    """Whether a product stands beside a gap: it spans the gap's height, near it horizontally.

    Near: its centre no farther from the gap's than half the gap's width (the box's scale.y) and its larger side.
    """
    low, high = vertical_extent(product)
    distance = math.hypot(*(product.position[:2] - gap.position[:2]))
    return low <= gap.position[2] <= high and distance <= gap.size[1] / 2.0 + max(product.size[:2])


def label_marker(marker, box: ObservedBox, base: float) -> Marker:
    """The label of the object a shape marker describes: its name, facing the view, centred over its box.

    Its lower edge is LABEL_CLEARANCE above ``base`` [m], the height of what it stands above.
    """
    label = Marker(
        header=marker.header,
        ns=label_namespace(marker.ns),
        id=marker.id,
        type=Marker.TEXT_VIEW_FACING,
        action=Marker.ADD,
        text=box.name,
        lifetime=marker.lifetime,
        frame_locked=marker.frame_locked,
    )
    label.pose.position.x, label.pose.position.y = (float(value) for value in box.position[:2])
    label.pose.position.z = base + LABEL_CLEARANCE + LABEL_HEIGHT / 2.0
    label.pose.orientation.w = 1.0  # RViz warns about an all-zero quaternion
    label.scale.x = label.scale.y = label.scale.z = LABEL_HEIGHT
    label.color.r, label.color.g, label.color.b, label.color.a = LABEL_COLOUR
    return label


def _label_removal(marker) -> Marker:
    """What takes the label of a marker's object away: a DELETE of the label, or a DELETEALL of its namespace."""
    action = Marker.DELETEALL if marker.action == Marker.DELETEALL else Marker.DELETE
    return Marker(header=marker.header, ns=label_namespace(marker.ns), id=marker.id, action=action)


def rviz_markers(markers: Iterable) -> Tuple[List[Marker], List[str]]:
    """What RViz should draw of a ``teleteach/scene`` message's markers, and why a named object got no label."""
    markers = list(markers)
    objects, rejected = scene_objects(markers)
    boxes = {id(marker): box for marker, box in objects}
    products = [box for marker, box in objects if marker.ns == PRODUCTS]
    drawn: List[Marker] = []
    for marker in markers:
        shape = marker
        if marker.text and marker.type != Marker.TEXT_VIEW_FACING:
            shape = copy.copy(marker)  # shallow: the received message stays as it came, the rest is shared
            shape.text = ""
        drawn.append(shape)
        if marker.ns not in LABELLED:
            continue
        if id(marker) in boxes:
            box = boxes[id(marker)]
            base = vertical_extent(box)[1]
            if marker.ns == GAPS:
                tops = [vertical_extent(product)[1] for product in products if beside(box, product)]
                base = max([base] + [top + LABEL_CLEARANCE + LABEL_HEIGHT for top in tops])
            drawn.append(label_marker(marker, box, base))
        elif marker.action in (Marker.ADD, Marker.DELETE, Marker.DELETEALL):
            drawn.append(_label_removal(marker))
    return drawn, rejected
