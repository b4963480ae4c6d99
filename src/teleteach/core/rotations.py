"""Roll, pitch, yaw as the thesis uses them (eq. 2): R = Rz(yaw) Ry(pitch) Rx(roll), about the fixed axes.

scipy's extrinsic "xyz" sequence is exactly this convention; these wrappers name it once for the device, the GUI and
the tools. Quaternions are (x, y, z, w), as in geometry_msgs and scipy. A rotation about the vertical alone (a mobile
base's or a gap's heading) and an angle wrapped into [-pi, pi] live here too.
"""

import math
from typing import Sequence

import numpy as np
from scipy.spatial.transform import Rotation

FIXED_AXES = "xyz"  # extrinsic: roll about X, then pitch about Y, then yaw about Z


def rpy_rotation(rpy) -> Rotation:
    """The rotation of (roll, pitch, yaw) [rad], or of each row of an (N, 3) array of them."""
    return Rotation.from_euler(FIXED_AXES, rpy)


def rpy_to_quaternion(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Unit quaternion (x, y, z, w) of R = Rz(yaw) Ry(pitch) Rx(roll)."""
    return rpy_rotation([roll, pitch, yaw]).as_quat()


def rpy_to_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """R = Rz(yaw) Ry(pitch) Rx(roll); its columns are the rotated X, Y, Z axes."""
    return rpy_rotation([roll, pitch, yaw]).as_matrix()


def yaw_rotation(yaw) -> Rotation:
    """Rotation about the vertical (Z) by yaw [rad]: a mobile base's or a shelf slot's heading (or one per yaw)."""
    return Rotation.from_euler("z", yaw)


def yaw_matrix(yaw: float) -> np.ndarray:
    """The 3x3 matrix of :func:`yaw_rotation`, written out: a physics step at 1 kHz cannot afford scipy's."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def unyawed_quaternion(quaternion: Sequence[float], yaw: float) -> np.ndarray:
    """The orientation (x, y, z, w) ``quaternion`` seen from a frame turned by ``yaw`` [rad] about the vertical.

    Rz(yaw)^-1 q, written out like :func:`yaw_matrix` (the Hamilton product with (0, 0, sin(-yaw/2), cos(-yaw/2))).
    """
    x, y, z, w = quaternion
    hs, hc = math.sin(-yaw / 2.0), math.cos(-yaw / 2.0)
    return np.array((hc * x - hs * y, hc * y + hs * x, hc * z + hs * w, hc * w - hs * z))


def wrap_angle(angle):
    """``angle`` [rad] wrapped into [-pi, pi]: a number, or each element of an array."""
    if isinstance(angle, (int, float)):
        return math.atan2(math.sin(angle), math.cos(angle))
    return np.arctan2(np.sin(angle), np.cos(angle))


def yaw_quaternion(yaw: float) -> np.ndarray:
    """Unit quaternion (x, y, z, w) of a rotation about the vertical by yaw [rad]."""
    return yaw_rotation(yaw).as_quat()


def quaternion_to_rpy(quaternion: Sequence[float]) -> np.ndarray:
    """Roll, pitch, yaw [rad] of a quaternion (x, y, z, w) (normalised first), pitch within [-pi/2, pi/2]."""
    return Rotation.from_quat(quaternion).as_euler(FIXED_AXES)
