"""Teaching the stiffness in a wipe from SHARED CONTROL: the gripper clutch moves the handle from the pattern to the
ellipsoid in the surface's axes, taken over softly, and the stiffness stays as shaped when it is released."""

import math

import numpy as np
from scipy.spatial.transform import Rotation

from teleteach.core.gui_config import GuiConfig
from teleteach.gui.device import DeviceSample
from teleteach.gui.shared_control.teaching import WipeTeaching

CONFIG = GuiConfig.load()
TURNED = Rotation.from_euler("xz", [math.pi, -math.pi / 2])  # a board's axes in base_link: u along -y, normal down
CLOSED, OPEN = 0.0, 0.5  # [rad] the gripper (teleop.clutch_below 0.1, clutch_release_above 0.2)


def handle(x=0.0, y=0.0, z=0.0):
    return DeviceSample(x, y, z, 0.0, 0.0, 0.0)


def stiffness_at(x):
    """The principal stiffness a handle coordinate x [m] maps to (LOW-LEVEL's scale)."""
    span = CONFIG.max_pixels - CONFIG.min_stiffness / CONFIG.stiffness_per_pixel
    fraction = (x + CONFIG.device_range) / (2 * CONFIG.device_range)
    return (CONFIG.min_stiffness / CONFIG.stiffness_per_pixel + fraction * span) * CONFIG.stiffness_per_pixel


def test_the_handle_shapes_the_stiffness_only_while_the_gripper_clutch_is_held_and_it_stays_as_shaped():
    teaching = WipeTeaching(CONFIG, TURNED)
    start = np.array(CONFIG.shared_control_stiffness, dtype=float)
    values, quaternion = teaching.stiffness()
    np.testing.assert_allclose(values, start)  # what SHARED CONTROL commands otherwise
    np.testing.assert_allclose(np.abs(quaternion), np.abs(TURNED.as_quat()))  # the surface's axes
    # Expect: wiping (gripper open), the handle's motion changes nothing here: it is the pattern
    assert not teaching.update(0.0, OPEN, handle(0.09, 0.09, -0.09))
    np.testing.assert_allclose(teaching.stiffness()[0], start)
    # a click-long closing is no clutch; held past clutch_hold it is
    assert not teaching.update(1.0, CLOSED, handle())
    assert not teaching.update(1.0 + 0.5 * CONFIG.teleop.clutch_hold, CLOSED, handle())
    assert teaching.update(1.0 + CONFIG.teleop.clutch_hold, CLOSED, handle(0.05, 0.0, -0.09))
    # Expect: engaging moves nothing (each axis waits for the handle to meet it) ...
    np.testing.assert_allclose(teaching.stiffness()[0], start)
    # ... the handle swept through every value: the axes follow it from then on
    low = -CONFIG.device_range
    teaching.update(2.0, CLOSED, handle(low, low, low))
    teaching.update(2.1, CLOSED, handle(0.05, 0.05, -0.06))
    shaped = teaching.stiffness()[0]
    np.testing.assert_allclose(shaped, [stiffness_at(0.05), stiffness_at(0.05), stiffness_at(-0.06)], rtol=1e-6)
    assert shaped[2] < shaped[0]  # compliant along the normal, stiff along the surface
    # released: the handle is the pattern's again, the stiffness stays as shaped
    assert not teaching.update(3.0, OPEN, handle(0.09, 0.09, 0.09))
    np.testing.assert_allclose(teaching.stiffness()[0], shaped)


def test_a_lost_gripper_reading_releases_the_clutch():
    teaching = WipeTeaching(CONFIG, TURNED)
    teaching.update(0.0, CLOSED, handle())
    assert teaching.update(CONFIG.teleop.clutch_hold, CLOSED, handle())
    assert not teaching.update(CONFIG.teleop.clutch_hold + 0.1, None, handle())
    assert not teaching.update(CONFIG.teleop.clutch_hold + 0.2, math.nan, handle())
