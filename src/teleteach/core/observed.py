"""What the robot sees of the shop: products, free slots (gaps), pick tables and surfaces to wipe, in one message.

The interface is the topic ``teleteach/scene``, a visualization_msgs/MarkerArray in frame ``world``, which a perception
node fills: robot_sim from its world, static_scene from a yaml of a real shelf, or a real detector. One marker per
object (any shape; RViz draws it), ``ns`` its class, ``text`` its name, ``pose`` and ``scale`` its box:

- ns ``products``: a product. Pose: its centre and orientation; scale: its size (x, y, z) [m].
- ns ``gaps``: a free slot. Pose: where a placed product's centre belongs, turned about z only (its x axis points
  into the shelf); scale.y: the free width between the neighbours [m]; scale.x: twice the placement tolerance [m] (a
  product whose centre is that close horizontally counts as placed), so RViz draws the slot's tolerance.
- ns ``tables``: a surface products are picked from. Pose: its box's centre, turned about z only; scale: its size.
- ns ``surfaces``: a surface to wipe. Pose: the centre of its top face, its x and y along the face and z its outward
  normal (any orientation); scale: its size (along x, along y, thickness) [m].

Other namespaces (robot_sim's ``shelf`` boards) are for RViz: the skills ignore them. Each message is the whole scene:
an object it does not name is not seen. A marker that cannot be an object (another frame, no name, NaN, a zero or
non-unit quaternion, a tilted gap or table, a size <= 0, a name already taken in its namespace) is left out, with
the reason in the list :func:`observed_from_markers` returns.
"""

import math
from dataclasses import dataclass, field
from typing import Dict, Iterable, List, Optional, Tuple

import genpy
import numpy as np
from scipy.spatial.transform import Rotation
from std_msgs.msg import Header
from visualization_msgs.msg import Marker, MarkerArray

from teleteach.core.rotations import yaw_quaternion
from teleteach.core.scene import Gap, GapLookup, Scene
from teleteach.core.validation import InvalidCommandError, finite_vector, validate_quaternion

WORLD_FRAME = "world"
SCENE_TOPIC = "teleteach/scene"  # what the robot's perception reports: what the skills act on
TRUE_SCENE_TOPIC = "teleteach/true_scene"  # the world as it is (a simulation's): what judges an outcome
PRODUCTS = "products"
GAPS = "gaps"
TABLES = "tables"
SURFACES = "surfaces"
ADD = 0  # visualization_msgs/Marker.ADD: other actions (DELETE, DELETEALL) carry no object


@dataclass(frozen=True)
class ObservedBox:
    """A product or table as seen: centre [m], (x, y, z, w) quaternion and size (x, y, z) [m] in world."""

    name: str
    position: np.ndarray
    quaternion: np.ndarray
    size: Tuple[float, float, float]

    @property
    def yaw(self) -> float:
        """Rotation of the box's x axis about the vertical [rad]."""
        x_axis = Rotation.from_quat(self.quaternion).apply([1.0, 0.0, 0.0])
        return float(math.atan2(x_axis[1], x_axis[0]))

    def local(self, point) -> np.ndarray:
        """A point [m] of world in the box's frame (origin at its centre)."""
        return Rotation.from_quat(self.quaternion).inv().apply(np.asarray(point, dtype=float) - self.position)


@dataclass(frozen=True)
class ObservedScene(GapLookup):
    """The products, gaps, tables and surfaces of one ``teleteach/scene`` message; ``stamp`` [s] is its newest marker's.

    A surface's box is its frame (origin at the top face's centre, z the outward normal) and its size.
    """

    products: Dict[str, ObservedBox]
    gaps: Dict[str, Gap]
    tables: Dict[str, ObservedBox]
    stamp: float = 0.0
    surfaces: Dict[str, ObservedBox] = field(default_factory=dict)

    def product(self, name) -> ObservedBox:
        """The product called name (KeyError if it is not seen)."""
        return self.products[name]

    def product_poses(self) -> Dict[str, Tuple[np.ndarray, np.ndarray]]:
        """Name -> (centre [m], quaternion (x, y, z, w)) of every product, in world."""
        return {name: (box.position.copy(), box.quaternion.copy()) for name, box in self.products.items()}


def observed_from_scene(scene: Scene, product_poses=None, stamp: float = 0.0) -> ObservedScene:
    """What a perfect perception sees of a scene: its products, gaps and pick table.

    Products stand where ``product_poses`` (name -> centre, quaternion) says; without it, where the file puts them.
    """
    products = {}
    for product in scene.products:
        if product_poses is None:
            position, quaternion = np.array(product.position), np.array(yaw_quaternion(product.yaw))
        elif product.name in product_poses:
            position, quaternion = product_poses[product.name]
        else:
            continue
        products[product.name] = ObservedBox(
            product.name, np.asarray(position, float), np.asarray(quaternion, float), product.size
        )
    table = scene.pick_table
    tables = {table.name: ObservedBox(table.name, np.array(table.center), np.array([0.0, 0.0, 0.0, 1.0]), table.size)}
    surfaces = {
        surface.name: ObservedBox(surface.name, surface.frame.position, surface.frame.rotation.as_quat(), surface.size)
        for surface in scene.surfaces.values()
    }
    return ObservedScene(products, dict(scene.gaps), tables, stamp, surfaces)


def marker_stamp(stamp) -> float:
    """A header stamp in seconds: rospy's Time, or a rosbags message's (sec, nanosec)."""
    if hasattr(stamp, "to_sec"):
        return stamp.to_sec()
    return stamp.sec + 1e-9 * stamp.nanosec


def _box(marker, yaw_only: bool) -> ObservedBox:
    """The box a marker describes; InvalidCommandError says why it cannot be one."""
    if not marker.text:
        raise InvalidCommandError("no name in text")
    if marker.header.frame_id.lstrip("/") != WORLD_FRAME:
        raise InvalidCommandError(f"frame '{marker.header.frame_id}' is not '{WORLD_FRAME}'")
    pose = marker.pose
    position = finite_vector([pose.position.x, pose.position.y, pose.position.z], 3, "position")
    quaternion = validate_quaternion(
        [pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w], "orientation"
    )
    if yaw_only and math.hypot(quaternion[0], quaternion[1]) > 1e-3:
        raise InvalidCommandError("orientation must be a rotation about z only")
    size = finite_vector([marker.scale.x, marker.scale.y, marker.scale.z], 3, "scale")
    if np.any(size <= 0.0):
        raise InvalidCommandError(f"scale must be > 0, got {size.tolist()}")
    return ObservedBox(marker.text, position, quaternion, tuple(float(value) for value in size))


def scene_objects(markers: Iterable) -> Tuple[List[Tuple[Marker, ObservedBox]], List[str]]:
    """The markers of a ``teleteach/scene`` message that are objects, each with its box, and why others were left out.

    The objects keep the markers' order. Left out with a reason: a marker of the four classes that cannot be an object
    (other namespaces and DELETEs are skipped). A gap's box is its marker's (scale.x twice the tolerance, scale.y the
    width). Works on rospy messages and on messages read from a bag with rosbags (same field names).
    """
    objects: List[Tuple[Marker, ObservedBox]] = []
    taken: Dict[str, set] = {PRODUCTS: set(), GAPS: set(), TABLES: set(), SURFACES: set()}
    rejected: List[str] = []
    for marker in markers:
        if marker.action != ADD or marker.ns not in taken:
            continue
        try:
            box = _box(marker, yaw_only=marker.ns in (GAPS, TABLES))
            if box.name in taken[marker.ns]:
                raise InvalidCommandError("the name is taken by an earlier marker")
        except InvalidCommandError as error:
            rejected.append(f"{marker.ns} marker '{marker.text}': {error}")
            continue
        taken[marker.ns].add(box.name)
        objects.append((marker, box))
    return objects, rejected


def observed_from_markers(markers: Iterable) -> Tuple[ObservedScene, List[str]]:
    """The scene the markers of a ``teleteach/scene`` message describe, and why each left-out marker was left out.

    Works on rospy messages and on messages read from a bag with rosbags (same field names).
    """
    objects, rejected = scene_objects(markers)
    found: Dict[str, dict] = {PRODUCTS: {}, GAPS: {}, TABLES: {}, SURFACES: {}}
    for marker, box in objects:
        if marker.ns == GAPS:
            found[GAPS][box.name] = Gap(box.name, tuple(box.position.tolist()), box.yaw, box.size[1], box.size[0] / 2.0)
        else:
            found[marker.ns][box.name] = box
    stamp = max((marker_stamp(marker.header.stamp) for marker, _ in objects), default=0.0)
    return ObservedScene(found[PRODUCTS], found[GAPS], found[TABLES], stamp, found[SURFACES]), rejected


def product_poses(markers: Iterable) -> Dict[str, Tuple[np.ndarray, np.ndarray]]:
    """World poses (centre [m], (x, y, z, w) quaternion) of the products in a ``teleteach/scene`` message, by name."""
    return observed_from_markers(markers)[0].product_poses()


def product_positions(markers: Iterable) -> Dict[str, np.ndarray]:
    """World positions [m] of the products in a ``teleteach/scene`` message, by name."""
    return {name: position for name, (position, _) in product_poses(markers).items()}


def gap_box(gap: Gap) -> Tuple[np.ndarray, np.ndarray, Tuple[float, float, float]]:
    """The marker box of a gap: target centre [m], yaw quaternion, scale (2 x tolerance, width, 2 mm) [m]."""
    return np.array(gap.position), np.array(yaw_quaternion(gap.yaw)), (2.0 * gap.tolerance, gap.width, 0.002)


def table_on(scene: ObservedScene, product: ObservedBox, tolerance: float) -> Optional[str]:
    """The table the product stands on, or None.

    On a table: the product's centre is inside the top's outline, half its height above the top (within tolerance [m]).
    """
    for table in scene.tables.values():
        local = table.local(product.position)
        inside = abs(local[0]) <= table.size[0] / 2.0 and abs(local[1]) <= table.size[1] / 2.0
        if inside and abs(local[2] - (table.size[2] + product.size[2]) / 2.0) <= tolerance:
            return table.name
    return None


PRODUCT_COLOUR = (0.8, 0.2, 0.2, 1.0)
GAP_COLOUR = (0.1, 0.8, 0.1, 0.5)
TABLE_COLOUR = (0.5, 0.5, 0.5, 1.0)
SURFACE_COLOUR = (0.95, 0.95, 0.95, 0.6)


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
    header = Header(stamp=genpy.Time.from_sec(stamp), frame_id=WORLD_FRAME)
    markers = list(extras)
    for index, table in enumerate(observed.tables.values()):
        markers.append(
            box_marker(header, TABLES, index, table.position, table.quaternion, table.size, TABLE_COLOUR, table.name)
        )
    for index, gap in enumerate(observed.gaps.values()):
        markers.append(box_marker(header, GAPS, index, *gap_box(gap), GAP_COLOUR, gap.name))
    for index, surface in enumerate(observed.surfaces.values()):
        markers.append(
            box_marker(
                header,
                SURFACES,
                index,
                surface.position,
                surface.quaternion,
                surface.size,
                SURFACE_COLOUR,
                surface.name,
            )
        )
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
