"""The commanded stiffness ellipsoid as an RViz SPHERE Marker at the end effector (thesis Appendix A.2.3).

The thesis draws the ellipsoid with its semi-axis lengths equal to the principal stiffnesses (footnote 2: not the
isopotential ellipsoid, whose semi-axes are 1/sqrt(eigenvalue)). RViz needs metres, so each principal stiffness is
mapped linearly to a diameter, clamped so that a very soft axis stays visible and a very stiff one does not hide the
robot:

    diameter_i = clip(metres_per_stiffness * eigenvalue_i, min_diameter, max_diameter)

With config/ellipsoid_marker.yaml's values (1e-4 m per N/m, 0.02 m .. 0.4 m) the GUI's maximum of 3000 N/m is a
0.3 m diameter. The node's parameters are :class:`EllipsoidMarkerConfig`, every value from that yaml.
"""

import math
from dataclasses import dataclass
from typing import Any, Mapping, Optional, Sequence, Tuple

import numpy as np
import yaml
from geometry_msgs.msg import PoseStamped, QuaternionStamped, Vector3Stamped
from visualization_msgs.msg import Marker

from teleteach.core.parameters import from_mapping
from teleteach.core.paths import config_file
from teleteach.core.validation import (
    InvalidCommandError,
    check_frame,
    finite_vector,
    validate_eigenvalues,
    validate_quaternion,
)

DRAWN_RESOLUTION = 1e-4  # [m] of position and diameter, [-] of quaternion component: a smaller change looks the same


def drawn_as(marker: Marker) -> Tuple[float, ...]:
    """What RViz draws of the ellipsoid marker, to DRAWN_RESOLUTION: equal for markers that look the same.

    The simulated arm holding still still moves by micrometres each tick; such a marker is not sent again.
    """
    pose, scale = marker.pose, marker.scale
    values = (
        pose.position.x,
        pose.position.y,
        pose.position.z,
        pose.orientation.x,
        pose.orientation.y,
        pose.orientation.z,
        pose.orientation.w,
        scale.x,
        scale.y,
        scale.z,
    )
    return tuple(round(value / DRAWN_RESOLUTION) for value in values)


@dataclass(frozen=True)
class EllipsoidScale:
    """Linear map from principal stiffness [N/m] to marker diameter [m], clamped to [min, max].

    Args:
        metres_per_stiffness: diameter per unit of stiffness [m / (N/m)].
        min_diameter: smallest drawn diameter [m], so that a zero stiffness still shows.
        max_diameter: largest drawn diameter [m].
    """

    metres_per_stiffness: float
    min_diameter: float
    max_diameter: float

    def __post_init__(self):
        numbers = (self.metres_per_stiffness, self.min_diameter, self.max_diameter)
        if not all(math.isfinite(number) and number > 0.0 for number in numbers):
            raise ValueError(f"ellipsoid scale parameters must be finite and > 0, got {numbers}")
        if self.min_diameter > self.max_diameter:
            raise ValueError(f"min_diameter {self.min_diameter} m exceeds max_diameter {self.max_diameter} m")

    def diameters(self, eigenvalues: Sequence[float]) -> np.ndarray:
        """Marker diameters [m] along the three principal axes."""
        return np.clip(
            np.asarray(eigenvalues, dtype=float) * self.metres_per_stiffness, self.min_diameter, self.max_diameter
        )


@dataclass(frozen=True)
class EllipsoidMarkerConfig:
    """ellipsoid_marker's parameters: config/ellipsoid_marker.yaml's keys (the one place of values and meanings)."""

    metres_per_stiffness: float
    min_diameter: float
    max_diameter: float
    rate: float
    frame_id: str

    def __post_init__(self):
        if not (math.isfinite(self.rate) and self.rate > 0.0):
            raise ValueError(f"rate must be a finite number > 0 Hz, got {self.rate}")
        self.scale  # noqa: B018 - a bad scale is refused here, with its reason

    @property
    def scale(self) -> EllipsoidScale:
        """The stiffness-to-diameter map."""
        return EllipsoidScale(self.metres_per_stiffness, self.min_diameter, self.max_diameter)

    def builder(self) -> "EllipsoidMarkerBuilder":
        """A builder of the marker with this scale, in this frame."""
        return EllipsoidMarkerBuilder(self.scale, self.frame_id)

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any]) -> "EllipsoidMarkerConfig":
        """From the yaml's keys, each perhaps overridden; a missing or unknown key is named."""
        return from_mapping(cls, values, "ellipsoid_marker's parameters (config/ellipsoid_marker.yaml)")

    @classmethod
    def from_yaml(cls) -> "EllipsoidMarkerConfig":
        """The yaml's values, as a node started without parameters has them."""
        return cls.from_mapping(yaml.safe_load(config_file("ellipsoid_marker.yaml").read_text()))


class EllipsoidMarkerBuilder:
    """Keeps the last good eigenvalues, eigenvectors and end-effector position, and builds the Marker from them.

    Messages are checked with the controller's own validation (teleteach.core.validation), so the marker shows
    what the controller accepts. Invalid messages raise InvalidCommandError and change nothing: the last good ellipsoid
    stays on screen. The eigen topics may leave the frame empty (the controller ignores it); the end-effector pose
    must be in the base frame.

    Args:
        scale: stiffness-to-diameter map.
        frame_id: frame of the stiffness and of the end-effector pose (the robot base frame).
        rgba: marker colour; the thesis shows the commanded ellipsoid in red.
        namespace: marker namespace in RViz.
    """

    def __init__(
        self,
        scale: EllipsoidScale,
        frame_id: str,
        rgba: Tuple[float, float, float, float] = (0.9, 0.1, 0.1, 0.6),
        namespace: str = "stiffness_ellipsoid",
    ):
        self.scale = scale
        self.frame_id = frame_id
        self.rgba = rgba
        self.namespace = namespace
        self.eigenvalues: Optional[np.ndarray] = None
        self.quaternion: Optional[np.ndarray] = None
        self.position: Optional[np.ndarray] = None

    def _check_frame(self, what: str, frame_id: str) -> None:
        if frame_id:
            try:
                check_frame(frame_id, self.frame_id)
            except InvalidCommandError as error:
                raise InvalidCommandError(f"{what}: {error}") from None

    def set_eigenvalues(self, message: Vector3Stamped) -> None:
        """Take the principal stiffnesses [N/m] from /eigenvalues."""
        self._check_frame("eigenvalues", message.header.frame_id)
        vector = message.vector
        self.eigenvalues = validate_eigenvalues((vector.x, vector.y, vector.z), math.inf)

    def set_eigenvectors(self, message: QuaternionStamped) -> None:
        """Take the orientation of the principal axes from /eigenvectors."""
        self._check_frame("eigenvectors", message.header.frame_id)
        quaternion = message.quaternion
        self.quaternion = validate_quaternion((quaternion.x, quaternion.y, quaternion.z, quaternion.w), "eigenvectors")

    def set_pose(self, message: PoseStamped) -> None:
        """Take the end-effector position from /cartesian_pose."""
        check_frame(message.header.frame_id, self.frame_id)
        position = message.pose.position
        self.position = finite_vector((position.x, position.y, position.z), 3, "end-effector position")

    @property
    def ready(self) -> bool:
        """True once a good message of each input has arrived."""
        return self.eigenvalues is not None and self.quaternion is not None and self.position is not None

    def marker(self) -> Optional[Marker]:
        """The ellipsoid Marker, or None until every input has arrived once.

        Its stamp stays zero ("the latest transform"): RViz then never drops it for waiting on TF, which matters
        under /use_sim_time where the marker's clock and the TF buffer advance separately.
        """
        if not self.ready:
            return None
        marker = Marker()
        marker.header.frame_id = self.frame_id
        marker.ns = self.namespace
        marker.id = 0
        marker.type = Marker.SPHERE
        marker.action = Marker.ADD
        marker.pose.position.x, marker.pose.position.y, marker.pose.position.z = self.position.tolist()
        orientation = marker.pose.orientation
        orientation.x, orientation.y, orientation.z, orientation.w = (
            self.quaternion / np.linalg.norm(self.quaternion)
        ).tolist()
        marker.scale.x, marker.scale.y, marker.scale.z = self.scale.diameters(self.eigenvalues).tolist()
        marker.color.r, marker.color.g, marker.color.b, marker.color.a = self.rgba
        marker.frame_locked = False
        return marker
