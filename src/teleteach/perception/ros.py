"""ROS layer of perception: the ``teleteach/scene`` MarkerArray of an observed scene, and the static_scene node.

robot_sim and static_scene publish the message; its format is in teleteach.perception.observed.
"""

from typing import Iterable

import rospy
from std_msgs.msg import Header
from visualization_msgs.msg import Marker, MarkerArray

from teleteach.perception.observed import GAPS, PRODUCTS, TABLES, WORLD_FRAME, ObservedScene, gap_box

PRODUCT_COLOUR = (0.8, 0.2, 0.2, 1.0)
GAP_COLOUR = (0.1, 0.8, 0.1, 0.5)
TABLE_COLOUR = (0.5, 0.5, 0.5, 1.0)


def box_marker(header, namespace, marker_id, position, quaternion, size, colour, text) -> Marker:
    """A CUBE marker: centre [m], (x, y, z, w) quaternion, size [m], RGBA colour, name in text."""
    marker = Marker(header=header, ns=namespace, id=marker_id, type=Marker.CUBE, action=Marker.ADD, text=text)
    marker.pose.position.x, marker.pose.position.y, marker.pose.position.z = (float(v) for v in position)
    orientation = marker.pose.orientation
    orientation.x, orientation.y, orientation.z, orientation.w = (float(v) for v in quaternion)
    marker.scale.x, marker.scale.y, marker.scale.z = (float(v) for v in size)
    marker.color.r, marker.color.g, marker.color.b, marker.color.a = colour
    return marker


def scene_markers(observed: ObservedScene, stamp: float, extras: Iterable[Marker] = ()) -> MarkerArray:
    """The ``teleteach/scene`` message of an observed scene, stamped stamp [s], after the extras (RViz only)."""
    header = Header(stamp=rospy.Time.from_sec(stamp), frame_id=WORLD_FRAME)
    markers = list(extras)
    for index, table in enumerate(observed.tables.values()):
        markers.append(
            box_marker(header, TABLES, index, table.position, table.quaternion, table.size, TABLE_COLOUR, table.name)
        )
    for index, gap in enumerate(observed.gaps.values()):
        markers.append(box_marker(header, GAPS, index, *gap_box(gap), GAP_COLOUR, gap.name))
    for index, product in enumerate(observed.products.values()):
        markers.append(
            box_marker(
                header,
                PRODUCTS,
                index,
                product.position,
                product.quaternion,
                product.size,
                PRODUCT_COLOUR,
                product.name,
            )
        )
    return MarkerArray(markers=markers)
