"""Validation of every command that reaches the robot, in one place.

Each function takes plain values (the ROS layer unpacks the messages), returns the cleaned command, or raises
:class:`InvalidCommandError` with a reason a person can act on. A rejected command changes nothing: the caller keeps
the last good one.
"""

import math

import numpy as np
from scipy.spatial.transform import Rotation

QUATERNION_NORM_TOLERANCE = 1e-3
TYPED_ROTATION_TOLERANCE = 1e-3  # a rotation matrix typed with 4 decimals (0.7071) is this close to orthonormal


class InvalidCommandError(ValueError):
    """A command was rejected; the message says why."""


def check_stamp(stamp, now, max_age):
    """Reject a stamp further than max_age [s] from now [s]; a zero stamp means "now" (tf convention)."""
    if stamp == 0.0:
        return
    if not math.isfinite(stamp):
        raise InvalidCommandError(f"stamp is not finite ({stamp})")
    age = now - stamp
    if abs(age) > max_age:
        raise InvalidCommandError(f"stale stamp: {age:+.3f} s away from the current time (limit {max_age:.3f} s)")


def check_frame(frame_id, expected):
    """Reject a frame other than expected (a leading slash is tolerated)."""
    if frame_id.lstrip("/") != expected:
        raise InvalidCommandError(f"frame '{frame_id}' is wrong: expected '{expected}'")


def finite_vector(values, size, what):
    """The values as a float array of the given size, or InvalidCommandError if the size is wrong or one is NaN/inf."""
    array = np.asarray(values, dtype=float)
    if array.shape != (size,):
        raise InvalidCommandError(f"{what} must have {size} values, got {array.size}")
    if not np.all(np.isfinite(array)):
        raise InvalidCommandError(f"{what} contains NaN or inf: {array.tolist()}")
    return array


def validate_eigenvalues(values, max_stiffness):
    """Principal stiffnesses [N/m]: finite and non-negative; values above max_stiffness are clamped to it."""
    eigenvalues = finite_vector(values, 3, "eigenvalues")
    if np.any(eigenvalues < 0.0):
        raise InvalidCommandError(f"negative stiffness: {eigenvalues.tolist()} N/m")
    return np.minimum(eigenvalues, max_stiffness)


def rotation_matrix(values, what):
    """A 3x3 rotation matrix (rows) as a person types it, made exactly orthonormal (the nearest rotation).

    Within TYPED_ROTATION_TOLERANCE of orthonormal rows with determinant +1: typed to a few decimals, a rotation is
    never exactly orthonormal. A mirror, a scaled or skewed matrix: InvalidCommandError.
    """
    try:
        matrix = np.array(values, dtype=float)
    except (TypeError, ValueError):
        matrix = np.zeros(0)
    if matrix.shape != (3, 3) or not np.all(np.isfinite(matrix)):
        raise InvalidCommandError(f"{what}: a 3x3 matrix of numbers (rows), got {values!r}")
    off = np.abs(matrix @ matrix.T - np.eye(3)).max()
    if off > TYPED_ROTATION_TOLERANCE or np.linalg.det(matrix) <= 0.0:
        raise InvalidCommandError(f"{what}: {values!r} is not a rotation (orthonormal rows, determinant +1)")
    return Rotation.from_matrix(matrix).as_matrix()


def validate_quaternion(values, what="quaternion"):
    """A unit quaternion (x, y, z, w): zero, non-finite or non-unit (beyond 1e-3) ones are rejected."""
    quaternion = finite_vector(values, 4, what)
    norm = float(np.linalg.norm(quaternion))
    if norm == 0.0:
        raise InvalidCommandError(f"{what} is zero")
    if abs(norm - 1.0) > QUATERNION_NORM_TOLERANCE:
        raise InvalidCommandError(f"{what} is not unit (norm {norm:.6f})")
    return quaternion / norm


def validate_pose(frame_id, expected_frame, position, quaternion):
    """A pose in expected_frame: (position [m], unit quaternion (x, y, z, w))."""
    check_frame(frame_id, expected_frame)
    return finite_vector(position, 3, "position"), validate_quaternion(quaternion, "orientation")


def validate_joint_trajectory(joint_names, points, expected_names, lower_limits, upper_limits):
    """A joint trajectory over exactly expected_names, reordered to them.

    Args:
        joint_names: names of the trajectory's columns.
        points: (positions [rad], velocities [rad/s] or empty, time_from_start [s]) per point.
        expected_names: the controller's joints in their order.
        lower_limits: lower position limits [rad], in expected_names' order.
        upper_limits: upper position limits [rad].

    Returns:
        (times, positions, velocities or None) as arrays, columns in expected_names' order.
    """
    names = list(joint_names)
    if sorted(names) != sorted(expected_names) or len(set(names)) != len(names):
        raise InvalidCommandError(f"joint names {names} must be exactly {list(expected_names)}")
    if not points:
        raise InvalidCommandError("trajectory has no points")
    order = [names.index(name) for name in expected_names]
    times, positions, velocities = [], [], []
    for index, (point_positions, point_velocities, time_from_start) in enumerate(points):
        ordered = finite_vector(point_positions, len(names), f"positions of point {index}")[order]
        if np.any(ordered < lower_limits) or np.any(ordered > upper_limits):
            raise InvalidCommandError(f"point {index} is outside the joint limits: {ordered.tolist()}")
        positions.append(ordered)
        if len(point_velocities):
            velocities.append(finite_vector(point_velocities, len(names), f"velocities of point {index}")[order])
        if not math.isfinite(time_from_start) or time_from_start < 0.0:
            raise InvalidCommandError(f"time_from_start of point {index} is invalid ({time_from_start})")
        if times and time_from_start <= times[-1]:
            raise InvalidCommandError(f"time_from_start must increase strictly (point {index})")
        times.append(time_from_start)
    if velocities and len(velocities) != len(positions):
        raise InvalidCommandError("velocities must be given for every point or for none")
    return np.array(times), np.array(positions), (np.array(velocities) if velocities else None)


def validate_base_goal(frame_id, position, quaternion):
    """A planar base goal in 'world': returns (x [m], y [m], yaw [rad]); the orientation must be a pure yaw."""
    position, quaternion = validate_pose(frame_id, "world", position, quaternion)
    x, y, z, w = quaternion
    if math.hypot(x, y) > 1e-3:
        raise InvalidCommandError("base goal orientation must be a rotation about z only")
    return float(position[0]), float(position[1]), 2.0 * math.atan2(z, w)
