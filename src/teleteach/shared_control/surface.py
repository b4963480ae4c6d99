"""The shared controller's task plane on a surface it wipes, from the surface as perceived and the stiffness commanded.

The plane has the surface's own axes (u, v), so the MPC plans in the surface's frame; its origin lies beyond the face
along the normal by the pressing depth, ``contact_force / K_n`` with K_n the commanded stiffness along the normal: the
equilibrium asks for the same force whatever the operator teaches, where perception is right. The boundary is the
marked area shrunk by half the tool's contact patch. A stiffness outside the range the arm's impedance controller
takes (config/shared/stiffness.yaml) is refused: the controller would clamp it, and the depth would press with
another force than the one asked.
"""

import dataclasses
import math
from typing import Sequence, Tuple

import numpy as np

from teleteach.core.frames import Transform
from teleteach.core.scene import Surface, WipingTool
from teleteach.core.wiping import ARM_REACH, TOOL_DOWN, WipingConfig, off_surface
from teleteach.shared_control.constraints import Box
from teleteach.shared_control.plane import TaskPlane

RANGE_SLACK = 1e-9  # of max_stiffness: the rounding of R diag(lambda) R^T, not a tolerance on the range


class SurfaceError(ValueError):
    """The surface cannot be wiped as asked; the message says why (nothing is driven then)."""


def pressing_depth(settings: WipingConfig, stiffness: np.ndarray, normal: Sequence[float]) -> float:
    """How far beyond the face the equilibrium lies [m]: the contact force [N] over the stiffness along the normal.

    At most ``settings.max_depth``: a stiffness that soft along the normal presses with less than the force asked.

    Args:
        settings: the wiping settings (the force asked for, the deepest equilibrium).
        stiffness: translational stiffness (3 x 3) [N/m], in the frame of ``normal``.
        normal: the surface's normal (unit vector).
    """
    normal = np.asarray(normal, dtype=float)
    along = float(normal @ np.asarray(stiffness, dtype=float) @ normal)
    if not math.isfinite(along) or along <= 0.0:
        raise SurfaceError(f"the stiffness along the surface's normal must be > 0 N/m, got {along}")
    return min(settings.contact_force / along, settings.max_depth)


def check_stiffness(stiffness: np.ndarray, max_stiffness: float) -> None:
    """Raise SurfaceError unless every principal stiffness of ``stiffness`` (3 x 3) lies in [0, max_stiffness] [N/m]."""
    stiffness = np.asarray(stiffness, dtype=float)
    if not np.all(np.isfinite(stiffness)):
        raise SurfaceError(f"the stiffness is not finite: {stiffness.tolist()}")
    principal = np.linalg.eigvalsh(stiffness)
    slack = RANGE_SLACK * max_stiffness
    if principal.min() < -slack or principal.max() > max_stiffness + slack:
        raise SurfaceError(
            f"the stiffness {np.round(principal, 1).tolist()} N/m is outside the arm's range [0, {max_stiffness:g}] N/m"
        )


def wiping_box(surface: Surface, footprint: Tuple[float, float]) -> Box:
    """The boundary of the tool's centre: the marked area shrunk by half the contact patch (u, v) [m] on each side."""
    u_min, v_min, u_max, v_max = surface.area
    half_u, half_v = footprint[0] / 2.0, footprint[1] / 2.0
    if u_max - u_min <= 2 * half_u or v_max - v_min <= 2 * half_v:
        raise SurfaceError(f"the marked area of {surface.name} is smaller than the tool's patch {list(footprint)} m")
    return Box(u_min + half_u, v_min + half_v, u_max - half_u, v_max - half_v)


def surface_plane(surface_in_base: Transform, tool: WipingTool, depth: float) -> TaskPlane:
    """The task plane of a wipe: the surface's axes, the TCP pressing ``depth`` beyond the face, the tool square."""
    rotation = surface_in_base.rotation
    return TaskPlane(
        origin=surface_in_base.apply_point([0.0, 0.0, tool.reach - depth]),
        x_axis=rotation.apply([1.0, 0.0, 0.0]),
        y_axis=rotation.apply([0.0, 1.0, 0.0]),
        orientation=(rotation * TOOL_DOWN).as_quat(),
    )


def check_reach(plane: TaskPlane, box: Box, mount_height: float) -> None:
    """Raise SurfaceError when a corner of the boundary lies beyond the arm's reach from panda_link0."""
    shoulder = np.array([0.0, 0.0, mount_height])
    corners = [(box.x_min, box.y_min), (box.x_max, box.y_min), (box.x_max, box.y_max), (box.x_min, box.y_max)]
    farthest = max(float(np.linalg.norm(plane.to_base(corner) - shoulder)) for corner in corners)
    if farthest > ARM_REACH:
        raise SurfaceError(f"the surface is out of the arm's reach: a corner is {farthest:.2f} m away (> {ARM_REACH})")


@dataclasses.dataclass(frozen=True)
class SurfaceWipe:
    """A wipe of one surface under shared control: the surface (its marked area), the tool, the force to press with.

    Attributes:
        surface: the surface as the scene file has it (its pose is perceived; its marked area is known).
        tool: the mounted wiping tool.
        settings: the wiping settings (the force to press with, how far to retract, when the input counts as lost).
        mount_height: panda_link0 above base_link [m] (the arm's reach is measured from there).
        max_stiffness: the largest principal stiffness the arm's impedance controller takes [N/m].
    """

    surface: Surface
    tool: WipingTool
    settings: WipingConfig
    mount_height: float
    max_stiffness: float

    def plane(self, surface_in_base: Transform, stiffness: np.ndarray) -> TaskPlane:
        """The task plane on the surface perceived at ``surface_in_base``, pressing with ``stiffness`` (base_link).

        Raises:
            SurfaceError: the stiffness is outside the arm's range, or has none along the normal.
        """
        check_stiffness(stiffness, self.max_stiffness)
        normal = surface_in_base.rotation.apply([0.0, 0.0, 1.0])
        depth = pressing_depth(self.settings, stiffness, normal)
        return surface_plane(surface_in_base, self.tool, depth)

    def off_surface(self, surface_in_base: Transform, point: Sequence[float]) -> np.ndarray:
        """The TCP's position that holds the tool's face ``approach_height`` off the surface over ``point`` (u, v)."""
        return off_surface(surface_in_base, self.tool, self.settings, point)

    def box(self) -> Box:
        """The boundary of the tool's centre on the surface."""
        return wiping_box(self.surface, self.tool.size[:2])

    def start(self, surface_in_base: Transform, stiffness: np.ndarray) -> Tuple[TaskPlane, Box]:
        """Plane and boundary to start a wipe with; SurfaceError says why the wipe cannot start."""
        plane, box = self.plane(surface_in_base, stiffness), self.box()
        check_reach(plane, box, self.mount_height)
        return plane, box
