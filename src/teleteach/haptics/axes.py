"""The operator frame, and each device's axes turned into it in one place (the device loop).

Everything downstream of the device node reads the device in the operator frame ``sigma7``: x to the operator's
right, y away from the operator, z up (START's left and right, HIGH-LEVEL's sliders, LOW-LEVEL's ellipsoid axes, the
task plane of shared control, the guidance's detents). A backend reports positions and orientations in its own frame;
``config/device.yaml`` ``axes`` names that frame per backend, as a convention or as a rotation matrix, and
:class:`AxisMapping` turns samples into the operator frame and the guidance's wrench back into the device's.

Conventions:

- ``operator``: already the operator frame (the scenario, virtual and topic backends are written in it);
- ``force_dimension``: the Force Dimension SDK's frame (dhdGetPositionAndOrientationFrame): x toward the operator,
  y to the operator's right, z up, origin at the centre of the workspace. So operator x = device y,
  operator y = -device x, operator z = device z.

A matrix is given by its rows: the operator's x, y and z axes in device coordinates (``R`` with
``p_operator = R p_device``); it must be a rotation (orthonormal, determinant +1).
"""

from typing import Sequence, Union

import numpy as np
from scipy.spatial.transform import Rotation

from teleteach.core.validation import InvalidCommandError, rotation_matrix
from teleteach.haptics.device import DeviceSample
from teleteach.haptics.guidance import Wrench

CONVENTIONS = {
    "operator": np.eye(3),
    "force_dimension": np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]),
}


class AxisMappingError(ValueError):
    """An ``axes`` entry is neither a known convention nor a rotation matrix; the message says which and why."""


class AxisMapping:
    """Device frame -> operator frame: ``p_operator = R p_device``, orientations ``R R_device R^T``.

    Args:
        rotation: ``R``, rows the operator's axes in device coordinates.
    """

    def __init__(self, rotation: np.ndarray):
        self.rotation = np.asarray(rotation, dtype=float)
        self._turn = Rotation.from_matrix(self.rotation)
        self.identity = bool(np.allclose(self.rotation, np.eye(3)))

    @classmethod
    def from_config(cls, value: Union[str, Sequence[Sequence[float]]], name: str = "axes") -> "AxisMapping":
        """A convention name or a 3x3 rotation matrix (rows); ``name`` is what an error calls it (e.g. ~axes/dhd)."""
        if isinstance(value, str):
            if value not in CONVENTIONS:
                raise AxisMappingError(
                    f"{name}: unknown convention {value!r}; one of {', '.join(CONVENTIONS)}, or a 3x3 rotation matrix"
                )
            return cls(CONVENTIONS[value])
        try:
            return cls(rotation_matrix(value, name))
        except InvalidCommandError as error:
            raise AxisMappingError(f"{error} (or a convention name: {', '.join(CONVENTIONS)})") from None

    def to_operator(self, sample: DeviceSample) -> DeviceSample:
        """The sample's position and orientation in the operator frame (gripper and button unchanged)."""
        if self.identity:
            return sample
        position = self.rotation @ np.asarray(sample.position, dtype=float)
        orientation = (self._turn * Rotation.from_quat(sample.orientation) * self._turn.inv()).as_quat()
        orientation *= 1.0 if orientation[3] >= 0.0 else -1.0  # the same rotation, written with w >= 0
        return DeviceSample(position, orientation, sample.gripper, sample.button)

    def to_device(self, wrench: Wrench) -> Wrench:
        """A wrench of the operator frame (the guidance) in the device frame, for the device to render."""
        if self.identity:
            return wrench
        transpose = self.rotation.T
        return Wrench(transpose @ wrench.force, transpose @ wrench.torque, wrench.gripper)
