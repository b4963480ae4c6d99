"""Stiffness for a Cartesian variable impedance controller on a real Panda, through ``/stiffness``.

The controller, named exactly (config/robot_controllers.yaml, section ``franka``): ``cartesian_variable_impedance_
controller`` of github.com/platonics-delft/franka_impedance_controller at commit
173448f6bfef6b08103b04c56f3a6c86c4cbcec0 (2024-04-19), type franka_impedance_controller/CartesianVariableImpedance
Controller. Its src/cartesian_variable_impedance_controller.cpp subscribes ``/stiffness`` and reads
std_msgs/Float32MultiArray ``data`` as seven numbers: the diagonal of the translational stiffness [N/m] (clamped there
to [0, 4000]), of the rotational stiffness [Nm/rad] ([0, 50]), and the nullspace stiffness ([0, 50]), in the arm's base
frame, with damping 2 sqrt(K) per axis. It copies ``data`` into a fixed array of seven without checking the length, so
exactly seven are sent, all finite. (franzesegiovanni/franka_human_friendly_controllers had the same subscriber up to
commit 44069fd06e5b2d315084b3551c2d40a82c8b483d; 2443322 of 2024-05-14 removed it for dynamic_reconfigure only.)

A diagonal cannot hold a turned ellipsoid. The bridge sends the diagonal of the thesis' K = V Sigma V^T (eq 1) and
K_R = V K_R V^T (eq 4), i.e. the stiffness along each base axis, and reports the largest off-diagonal term it left out:
exact for ellipsoids aligned with the base axes (in any order), an approximation otherwise.

The bridge's parameters are :class:`StiffnessBridgeConfig`, every value from config/stiffness_bridge.yaml.
"""

from dataclasses import dataclass
from typing import Any, Mapping, Tuple

import numpy as np

from teleteach.control.stiffness import TRANSLATIONAL, stiffness_matrix
from teleteach.core import validation
from teleteach.core.parameters import from_mapping

STIFFNESS_VALUES = 7  # Kx, Ky, Kz [N/m], Krx, Kry, Krz [Nm/rad], nullspace [Nm/rad]


@dataclass(frozen=True)
class StiffnessBridgeConfig:
    """stiffness_bridge's parameters: config/stiffness_bridge.yaml's keys (the one place of values and meanings).

    Args:
        frame: the frame the eigen topics may name (empty is accepted too); the controller's base frame must be
            parallel to it.
        max_stiffness: largest principal stiffness sent [N/m].
        rotational_stiffness: K_R on each rotational axis [Nm/rad].
        nullspace_stiffness: the controller's nullspace stiffness [Nm/rad].
    """

    frame: str
    max_stiffness: float
    rotational_stiffness: float
    nullspace_stiffness: float

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any]) -> "StiffnessBridgeConfig":
        """From the yaml's keys, each perhaps overridden; a missing or unknown key is named."""
        return from_mapping(cls, values, "stiffness_bridge's parameters (config/stiffness_bridge.yaml)")


def franka_stiffness(
    eigenvalues, eigenvectors, rotational_stiffness: float, nullspace_stiffness: float, max_stiffness: float
) -> Tuple[np.ndarray, float]:
    """The seven values of ``/stiffness``, and the largest translational off-diagonal term left out [N/m].

    Args:
        eigenvalues: principal stiffnesses [N/m] (/eigenvalues); each clamped to max_stiffness.
        eigenvectors: quaternion (x, y, z, w) of the principal axes in the base frame (/eigenvectors).
        rotational_stiffness: K_R on each rotational axis [Nm/rad].
        nullspace_stiffness: the controller's nullspace stiffness [Nm/rad].
        max_stiffness: largest principal stiffness sent [N/m].

    Raises:
        InvalidCommandError: NaN or inf, a negative stiffness, a zero or non-unit quaternion.
    """
    values = validation.validate_eigenvalues(eigenvalues, max_stiffness)
    quaternion = validation.validate_quaternion(eigenvectors, "eigenvectors")
    stiffness = stiffness_matrix(values, quaternion, rotational_stiffness)
    translational = stiffness[TRANSLATIONAL, TRANSLATIONAL]
    left_out = float(np.max(np.abs(translational - np.diag(np.diag(translational)))))
    return np.append(np.diag(stiffness), nullspace_stiffness), left_out
