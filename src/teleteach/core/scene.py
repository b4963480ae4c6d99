"""The supermarket scene description (config/supermarket.yaml) as plain data.

robot_sim reads all of it (:func:`load_scene`); the skill server only the site (:func:`load_site`: how the arm sits on
the base, named base poses); static_scene only the objects (:func:`load_objects`: products, pick table, gaps), which
the skills then perceive on ``teleteach/scene`` (teleteach.perception). A word the simulation, perception, skills,
runs and studies share, so it lives below all of them.
"""

import dataclasses
import math
import pathlib
from dataclasses import dataclass
from typing import Dict, Iterable, List, Optional, Tuple

import numpy as np
import yaml

from teleteach.core.frames import Transform
from teleteach.core.paths import config_file
from teleteach.core.rotations import rpy_rotation, yaw_quaternion

DEFAULT_SCENE_FILE = config_file("supermarket.yaml")


class SceneError(ValueError):
    """The scene file is missing something or holds a wrong value."""


@dataclass(frozen=True)
class Box:
    """A static box: centre [m], full edge lengths [m] and yaw about the vertical [rad] in world."""

    name: str
    center: Tuple[float, float, float]
    size: Tuple[float, float, float]
    friction: float
    yaw: float = 0.0


@dataclass(frozen=True)
class Product:
    """A product: an upright box that physics moves, its vertical edges rounded with corner_radius [m]."""

    name: str
    position: Tuple[float, float, float]
    yaw: float
    size: Tuple[float, float, float]
    mass: float
    friction: float
    corner_radius: float = 0.0


@dataclass(frozen=True)
class BasePose:
    """A pose of base_link in world: x [m], y [m], yaw [rad]."""

    x: float
    y: float
    yaw: float

    def quaternion(self):
        """The (x, y, z, w) quaternion of the yaw."""
        return yaw_quaternion(self.yaw)


@dataclass(frozen=True)
class Gap:
    """A free slot on the shelf: target product centre [m], yaw into the shelf [rad], free width [m], tolerance [m]."""

    name: str
    position: Tuple[float, float, float]
    yaw: float
    width: float
    tolerance: float

    @property
    def frame(self) -> Transform:
        """The gap's frame in world: origin where the placed product's centre belongs, x into the shelf, z up."""
        return Transform.from_planar(self.position[0], self.position[1], self.yaw, self.position[2])

    def distance(self, position) -> Tuple[float, float]:
        """Horizontal [m] and vertical [m] distance of a product centre at ``position`` from the target."""
        offset = np.asarray(position, dtype=float) - np.asarray(self.position, dtype=float)
        return float(math.hypot(offset[0], offset[1])), float(abs(offset[2]))


@dataclass(frozen=True)
class Surface:
    """A flat surface to wipe: the pose of its top face's centre, its size and the area marked on it.

    Attributes:
        name: the surface's name.
        center: the top face's centre in world [m].
        rpy: (roll, pitch, yaw) [rad] of its frame in world: x (u) and y (v) along the face, z its outward normal.
        size: (u, v, thickness) [m].
        area: the rectangle to sweep, (u_min, v_min, u_max, v_max) [m] in the surface frame.
        friction: lateral friction coefficient [-] (pybullet multiplies it with the tool's).
    """

    name: str
    center: Tuple[float, float, float]
    rpy: Tuple[float, float, float]
    size: Tuple[float, float, float]
    area: Tuple[float, float, float, float]
    friction: float

    @property
    def frame(self) -> Transform:
        """The surface's frame in world: maps (u, v, height above the face) to world."""
        return Transform(np.array(self.center, dtype=float), rpy_rotation(self.rpy))


@dataclass(frozen=True)
class WipingTool:
    """The tool mounted in the hand to wipe.

    A box (size along the TCP's x, y, z [m]) whose contact face lies ``reach`` [m] beyond the TCP along its z, with its
    mass [kg], friction [-] and contact compliance (stiffness [N/m], damping [N s/m]).
    """

    size: Tuple[float, float, float]
    reach: float
    mass: float
    friction: float
    contact_stiffness: float
    contact_damping: float


@dataclass(frozen=True)
class RobotSetup:
    """How the Panda sits on the mobile base, and where it starts."""

    mount_height: float
    base_size: Tuple[float, float, float]
    ready_joint_positions: Tuple[float, ...]
    start_gripper_width: float


def _named(objects: Dict[str, object], kind: str, name: str):
    """The object called name; SceneError lists the ones there are."""
    try:
        return objects[name]
    except KeyError:
        raise SceneError(f"the scene has no {kind} '{name}' (it has {', '.join(objects) or 'none'})") from None


class GapLookup:
    """Finding gaps by name or position in a ``gaps`` mapping (the scene file's, or the perceived one)."""

    gaps: Dict[str, Gap]

    def gap(self, name) -> Gap:
        """The gap called name.

        Raises:
            SceneError: the scene has no such gap (the message lists the ones it has).
        """
        return _named(self.gaps, "gap", name)

    def nearest_gap(self, position) -> Gap:
        """The gap whose target is horizontally closest to position (world) [m]."""
        if not self.gaps:
            raise SceneError("the scene has no gaps")
        return min(self.gaps.values(), key=lambda gap: gap.distance(position)[0])


@dataclass(frozen=True)
class Site:
    """What the skills know of a site without perceiving it: the arm on the base, base poses, the tool to wipe with."""

    robot: RobotSetup
    base_poses: Dict[str, BasePose]
    wiping_tool: Optional[WipingTool] = None


@dataclass(frozen=True)
class SceneObjects(GapLookup):
    """The objects of a scene file: products where they start, the pick table, the gaps, the surfaces to wipe."""

    products: List[Product]
    pick_table: Box
    gaps: Dict[str, Gap]
    surfaces: Dict[str, Surface] = dataclasses.field(default_factory=dict)


@dataclass(frozen=True)
class Scene(GapLookup):
    """Everything config/supermarket.yaml describes."""

    robot: RobotSetup
    base_poses: Dict[str, BasePose]
    floor_friction: float
    shelf: List[Box]
    pick_table: Box
    products: List[Product]
    gaps: Dict[str, Gap]
    surfaces: Dict[str, Surface] = dataclasses.field(default_factory=dict)
    wiping_tool: Optional[WipingTool] = None

    def product(self, name):
        """The product called name (KeyError if there is none)."""
        for product in self.products:
            if product.name == name:
                return product
        raise KeyError(f"no product '{name}' in the scene")

    def surface(self, name) -> Surface:
        """The surface called name.

        Raises:
            SceneError: the scene has no such surface (the message lists the ones it has).
        """
        return _named(self.surfaces, "surface", name)

    def without_products(self, names: Iterable[str]) -> "Scene":
        """The scene with the named products left out: a product missing from the start, e.g. so that a pick fails.

        Raises:
            SceneError: a name is not a product of the scene (nothing is left out then).
        """
        names = {names} if isinstance(names, str) else set(names)
        unknown = sorted(names - {product.name for product in self.products})
        if unknown:
            raise SceneError(f"cannot leave out {', '.join(unknown)}: no such product in the scene")
        return dataclasses.replace(self, products=[product for product in self.products if product.name not in names])


def _read(path: Optional[str], parse):
    path = pathlib.Path(path) if path else DEFAULT_SCENE_FILE
    try:
        data = yaml.safe_load(path.read_text())
        return parse(data)
    except (OSError, KeyError, TypeError, ValueError, AttributeError, yaml.YAMLError) as error:
        raise SceneError(f"{path}: {error!r}") from error


def load_scene(path: Optional[str] = None) -> Scene:
    """Read the whole scene file (default: the package's config/supermarket.yaml).

    Raises:
        SceneError: the file is missing a key or holds a value of the wrong shape.
    """
    return _read(path, _parse)


def load_site(path: Optional[str] = None) -> Site:
    """Read the sections ``robot``, ``base_poses``, ``wiping_tool`` of a scene file (default: config/supermarket.yaml).

    Raises:
        SceneError: one is missing or holds a value of the wrong shape.
    """
    return _read(path, _parse_site)


def load_objects(path: Optional[str] = None) -> SceneObjects:
    """Read the sections ``product_defaults``, ``products``, ``pick_table``, ``gaps`` and ``surfaces`` of a scene file.

    Raises:
        SceneError: one is missing or holds a value of the wrong shape.
    """
    return _read(path, _parse_objects)


def _triple(values):
    if len(values) != 3:
        raise ValueError(f"expected 3 values, got {values}")
    return tuple(float(value) for value in values)


def _parse_site(data):
    robot = data["robot"]
    return Site(
        robot=RobotSetup(
            mount_height=float(robot["mount_height"]),
            base_size=_triple(robot["base_size"]),
            ready_joint_positions=tuple(float(value) for value in robot["ready_joint_positions"]),
            start_gripper_width=float(robot["start_gripper_width"]),
        ),
        base_poses={
            name: BasePose(float(pose["x"]), float(pose["y"]), float(pose["yaw"]))
            for name, pose in data["base_poses"].items()
        },
        wiping_tool=_parse_tool(data.get("wiping_tool")),
    )


def _parse_objects(data):
    defaults = data["product_defaults"]
    products = [
        Product(
            name=str(item["name"]),
            position=_triple(item["position"]),
            yaw=float(item.get("yaw", 0.0)),
            size=_triple(item.get("size", defaults["size"])),
            mass=float(item.get("mass", defaults["mass"])),
            friction=float(item.get("friction", defaults["friction"])),
            corner_radius=float(item.get("corner_radius", defaults.get("corner_radius", 0.0))),
        )
        for item in data["products"]
    ]
    for product in products:
        if not 0.0 <= product.corner_radius < min(product.size[:2]) / 2.0:
            raise ValueError(f"{product.name}: corner_radius {product.corner_radius} m must be in [0, half its width)")
        if product.mass <= 0.0 or product.friction < 0.0:
            raise ValueError(f"{product.name}: mass must be > 0 kg and friction >= 0")
    table = data["pick_table"]
    gaps = {
        str(name): Gap(
            str(name), _triple(gap["position"]), float(gap["yaw"]), float(gap["width"]), float(gap["tolerance"])
        )
        for name, gap in data["gaps"].items()
    }
    return SceneObjects(
        products=products,
        pick_table=Box("pick_table", _triple(table["center"]), _triple(table["size"]), float(table["friction"])),
        gaps=gaps,
        surfaces={str(name): _parse_surface(name, values) for name, values in (data.get("surfaces") or {}).items()},
    )


def _parse_surface(name, values) -> Surface:
    area = tuple(float(value) for value in values["area"])
    surface = Surface(
        name=str(name),
        center=_triple(values["center"]),
        rpy=_triple(values["rpy"]),
        size=_triple(values["size"]),
        area=area,
        friction=float(values["friction"]),
    )
    half_u, half_v = surface.size[0] / 2.0, surface.size[1] / 2.0
    if len(area) != 4 or not (-half_u <= area[0] < area[2] <= half_u and -half_v <= area[1] < area[3] <= half_v):
        raise ValueError(f"surface {name}: area {list(area)} must be (u_min, v_min, u_max, v_max) on the surface")
    if min(surface.size) <= 0.0 or surface.friction < 0.0:
        raise ValueError(f"surface {name}: size must be > 0 m and friction >= 0")
    return surface


def _parse_tool(values) -> Optional[WipingTool]:
    if values is None:
        return None
    tool = WipingTool(
        size=_triple(values["size"]),
        reach=float(values["reach"]),
        mass=float(values["mass"]),
        friction=float(values["friction"]),
        contact_stiffness=float(values["contact_stiffness"]),
        contact_damping=float(values["contact_damping"]),
    )
    if min(tool.size) <= 0.0 or tool.mass <= 0.0 or tool.contact_stiffness <= 0.0 or tool.contact_damping < 0.0:
        raise ValueError("wiping_tool: size, mass and contact_stiffness must be > 0, contact_damping >= 0")
    if tool.reach <= 0.0:
        raise ValueError(f"wiping_tool: reach {tool.reach} m must put the contact face beyond the TCP (> 0)")
    return tool


def _parse(data):
    site, objects = _parse_site(data), _parse_objects(data)
    shelf_friction = float(data["shelf"]["friction"])
    return Scene(
        robot=site.robot,
        base_poses=site.base_poses,
        floor_friction=float(data["floor"]["friction"]),
        shelf=[
            Box(
                str(part["name"]),
                _triple(part["center"]),
                _triple(part["size"]),
                shelf_friction,
                float(part.get("yaw", 0.0)),
            )
            for part in data["shelf"]["parts"]
        ],
        pick_table=objects.pick_table,
        products=objects.products,
        gaps=objects.gaps,
        surfaces=objects.surfaces,
        wiping_tool=_parse_tool(data.get("wiping_tool")),
    )
