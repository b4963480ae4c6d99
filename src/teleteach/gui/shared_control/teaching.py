"""Teaching the stiffness during a wipe, from the SHARED CONTROL tab (issue 49); no ROS, no Qt.

While the shared controller wipes a surface, the device's translation commands the pattern. Closing the gripper (held
longer than a click: TELEOP's clutch gesture, ``teleop.clutch_*``) moves that translation to the stiffness
ellipsoid, as in LOW-LEVEL (thesis II-C): the handle's x, y and z set the principal stiffnesses along the surface's u,
v and normal, taken over softly (a value follows the handle only once the handle has met it), the axes those of the
surface. Meanwhile the shared controller keeps the pattern it recognised (/shared_control/clutch); opening the
gripper gives the pattern back to the handle, and the stiffness stays as shaped. So one demonstration holds both the
pattern and the stiffness, as the wipe's recording keeps them.
"""

from typing import Optional, Tuple

import numpy as np
from scipy.spatial.transform import Rotation

from teleteach.core.gui_config import GuiConfig
from teleteach.core.teleoperation import Clutch, GripperClutch
from teleteach.gui.device import DeviceSample
from teleteach.gui.ellipsoid import EllipsoidCommand


class WipeTeaching:
    """The clutch and the ellipsoid of one wipe, on the surface whose axes in base_link are ``surface_axes``.

    The ellipsoid starts at ``shared_control_stiffness`` (config/gui.yaml), what SHARED CONTROL commands otherwise.
    """

    def __init__(self, config: GuiConfig, surface_axes: Rotation):
        self.config = config
        self.clutch = GripperClutch(config.teleop)
        self.ellipsoid = EllipsoidCommand(config, initial=config.shared_control_stiffness)
        self.axes = surface_axes

    @property
    def clutched(self) -> bool:
        """Whether the handle shapes the stiffness now (the shared controller keeps the pattern)."""
        return self.clutch.state is Clutch.ENGAGED

    def update(self, now: float, gripper: Optional[float], sample: Optional[DeviceSample]) -> bool:
        """Follow the gripper [rad] and the handle at ``now`` [s]; True while clutched."""
        if self.clutch.update(now, gripper):
            self.ellipsoid.hold(sample)  # every axis waits for the handle: engaging never makes it jump
        elif self.clutched and sample is not None:
            self.ellipsoid.device(sample)
        return self.clutched

    def stiffness(self) -> Tuple[np.ndarray, Tuple[float, float, float, float]]:
        """Principal stiffnesses along u, v and the normal [N/m]; the surface's axes as a quaternion (x, y, z, w)."""
        values, _ = self.ellipsoid.stiffness()
        return values, tuple(float(value) for value in self.axes.as_quat())
