"""A perception for a robot without one: the objects of a scene file, where the robot's own actions put them.

Products, gaps and tables stand where the file says, except the product the gripper holds: a grasp that succeeds with a
product's centre within ``attach_distance`` of the TCP attaches it (like MoveIt's attached objects), it then moves with
the TCP, and it stays where it was when the fingers open more than ``release_margin`` beyond the width they held it at.
This is a belief, not a measurement: a product that slips, falls or is moved by hand is not seen. The skills judge their
success from it all the same, so on a real robot it must be right: the products and gaps of the file where they are.
The node's parameters are :class:`StaticSceneConfig`, every value from config/static_scene.yaml.
"""

from dataclasses import dataclass
from typing import Any, Dict, Mapping, Optional, Tuple

import numpy as np
from scipy.spatial.transform import Rotation

from teleteach.core.observed import ObservedScene, observed_from_scene
from teleteach.core.parameters import from_mapping
from teleteach.core.rotations import yaw_quaternion
from teleteach.core.scene import SceneObjects


@dataclass(frozen=True)
class StaticSceneConfig:
    """static_scene's parameters: config/static_scene.yaml's keys (the one place of values and meanings)."""

    scene_file: str
    rate: float
    tcp_frame: str
    finger_joints: Tuple[str, ...]
    attach_distance: float
    release_margin: float

    def __post_init__(self):
        if not self.rate > 0.0:
            raise ValueError(f"~rate must be a positive number of Hz, got {self.rate}")

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any]) -> "StaticSceneConfig":
        """From the yaml's keys, each perhaps overridden; a missing or unknown key is named."""
        return from_mapping(cls, values, "static_scene's parameters (config/static_scene.yaml)")


@dataclass(frozen=True)
class Held:
    """The attached product, its pose in the TCP frame (position [m], quaternion), the width it was grasped at [m]."""

    name: str
    offset_position: np.ndarray
    offset_rotation: Rotation
    width: float


class StaticScene:
    """The scene file's objects, with the held product following the hand.

    Args:
        objects: products, pick table and gaps of the scene file (teleteach.core.scene.load_objects()).
        attach_distance: a product whose centre is this close to the TCP when a grasp succeeds is the grasped one [m].
        release_margin: the fingers opening this much beyond the grasped width release the product [m].
    """

    def __init__(self, objects: SceneObjects, attach_distance: float, release_margin: float):
        self.objects = objects
        self.attach_distance = float(attach_distance)
        self.release_margin = float(release_margin)
        self.poses: Dict[str, Tuple[np.ndarray, np.ndarray]] = {
            product.name: (np.array(product.position), np.array(yaw_quaternion(product.yaw)))
            for product in objects.products
        }
        self.held: Optional[Held] = None

    def grasped(self, tcp_position, tcp_quaternion, width) -> Optional[str]:
        """A grasp succeeded with the TCP at this pose in world, the fingers at width [m]: the product attached, if any.

        Nothing is attached while a product is held, or when no product's centre is within attach_distance of the TCP.
        """
        if self.held is not None:
            return None
        tcp_position = np.asarray(tcp_position, dtype=float)
        distances = {name: float(np.linalg.norm(pose[0] - tcp_position)) for name, pose in self.poses.items()}
        if not distances:
            return None
        name = min(distances, key=distances.get)
        if distances[name] > self.attach_distance:
            return None
        tcp = Rotation.from_quat(tcp_quaternion)
        position, quaternion = self.poses[name]
        offset_position = tcp.inv().apply(position - tcp_position)
        self.held = Held(name, offset_position, tcp.inv() * Rotation.from_quat(quaternion), float(width))
        return name

    def follow(self, tcp_position, tcp_quaternion, width) -> Optional[str]:
        """Move the held product with the hand (TCP pose in world, fingers at width [m]), or release it where it is.

        Returns the name of a product released now (the fingers opened), else None.
        """
        if self.held is None:
            return None
        held = self.held
        if width > held.width + self.release_margin:
            self.held = None
            return held.name
        tcp = Rotation.from_quat(tcp_quaternion)
        position = np.asarray(tcp_position, dtype=float) + tcp.apply(held.offset_position)
        self.poses[held.name] = (position, (tcp * held.offset_rotation).as_quat())
        return None

    def observed(self, stamp: float) -> ObservedScene:
        """The scene as believed now, stamped stamp [s]."""
        return observed_from_scene(self.objects, self.poses, stamp)
