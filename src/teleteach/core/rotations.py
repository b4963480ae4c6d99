"""Roll, pitch, yaw as the thesis uses them (eq. 2): R = Rz(yaw) Ry(pitch) Rx(roll), about the fixed axes.

scipy's extrinsic "xyz" sequence is exactly this convention; these wrappers name it once for the device, the GUI and
the tools. Quaternions are (x, y, z, w), as in geometry_msgs and scipy.
"""

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


def yaw_rotation(yaw: float) -> Rotation:
    """Rotation about the vertical (Z) by yaw [rad]: a mobile base's or a shelf slot's heading."""
    return Rotation.from_euler("z", yaw)


def yaw_quaternion(yaw: float) -> np.ndarray:
    """Unit quaternion (x, y, z, w) of a rotation about the vertical by yaw [rad]."""
    return yaw_rotation(yaw).as_quat()


def quaternion_to_rpy(quaternion: Sequence[float]) -> np.ndarray:
    """Roll, pitch, yaw [rad] of a quaternion (x, y, z, w) (normalised first), pitch within [-pi/2, pi/2]."""
    return Rotation.from_quat(quaternion).as_euler(FIXED_AXES)
