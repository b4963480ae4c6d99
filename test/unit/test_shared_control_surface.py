"""The shared controller's task plane on a wiped surface (teleteach.shared_control.surface), at turned frames."""

import dataclasses

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from teleteach.control.stiffness import translational_stiffness
from teleteach.core.frames import Transform
from teleteach.core.scene import load_scene
from teleteach.core.wiping import ARM_REACH, WipingError, load_wiping_config
from teleteach.shared_control.constraints import Box
from teleteach.shared_control.plane import TaskPlane
from teleteach.shared_control.surface import (
    RANGE_SLACK,
    SurfaceError,
    SurfaceWipe,
    check_reach,
    check_stiffness,
    pressing_depth,
    surface_plane,
    wiping_box,
)

SCENE = load_scene()
BOARD = SCENE.surface("counter_board")
TOOL = SCENE.wiping_tool
TURNED = Transform(np.array([0.55, -0.1, 0.3]), Rotation.from_euler("xyz", [0.2, -0.15, 2.0]))
MAX_STIFFNESS = 3000.0  # [N/m] config/shared/stiffness.yaml


def board_wipe() -> SurfaceWipe:
    return SurfaceWipe(BOARD, TOOL, load_wiping_config(), SCENE.robot.mount_height, MAX_STIFFNESS)


def taught_in(frame: Transform) -> np.ndarray:
    """3000 N/m along the surface, 300 N/m along its normal, in the frame the surface is given in."""
    return translational_stiffness([3000.0, 3000.0, 300.0], frame.rotation)


def test_the_depth_is_the_force_over_the_stiffness_along_the_normal_whatever_the_frame():
    normal = TURNED.rotation.apply([0.0, 0.0, 1.0])
    settings = load_wiping_config()
    assert settings.contact_force == 10.0
    assert pressing_depth(settings, taught_in(TURNED), normal) == pytest.approx(10.0 / 300.0)
    assert pressing_depth(settings, taught_in(Transform.identity()), normal) != pytest.approx(10.0 / 300.0)
    with pytest.raises(SurfaceError, match="normal"):
        pressing_depth(settings, np.zeros((3, 3)), normal)
    soft = translational_stiffness([3000.0, 3000.0, 100.0], TURNED.rotation)  # 10 cm asked: clipped as the arm clips
    assert pressing_depth(settings, soft, normal) == pytest.approx(settings.max_depth)
    barely = translational_stiffness([3000.0, 3000.0, 0.5], TURNED.rotation)  # 0.5 N/m is soft, not absent
    assert pressing_depth(settings, barely, normal) == pytest.approx(settings.max_depth)


def test_the_plane_has_the_surfaces_axes_and_holds_the_tcp_pressing_beyond_the_face_the_tool_square():
    plane = surface_plane(TURNED, TOOL, 0.02)
    np.testing.assert_allclose(plane.x_axis, TURNED.rotation.apply([1.0, 0.0, 0.0]), atol=1e-12)
    np.testing.assert_allclose(plane.y_axis, TURNED.rotation.apply([0.0, 1.0, 0.0]), atol=1e-12)
    np.testing.assert_allclose(plane.to_base((0.1, -0.05)), TURNED.apply_point([0.1, -0.05, TOOL.reach - 0.02]))
    tool_z = Rotation.from_quat(plane.orientation).apply([0.0, 0.0, 1.0])
    np.testing.assert_allclose(tool_z, -TURNED.rotation.apply([0.0, 0.0, 1.0]), atol=1e-12)  # into the surface


def test_a_wipe_starts_on_a_surface_in_reach_and_its_depth_follows_the_stiffness():
    wipe = board_wipe()
    in_base = Transform(np.array([0.55, 0.0, 0.63]), BOARD.frame.rotation)
    plane, box = wipe.start(in_base, taught_in(in_base))
    u_min, v_min, u_max, v_max = BOARD.area
    half_u, half_v = TOOL.size[0] / 2.0, TOOL.size[1] / 2.0
    assert (box.x_min, box.y_min, box.x_max, box.y_max) == pytest.approx(
        (u_min + half_u, v_min + half_v, u_max - half_u, v_max - half_v)
    )
    assert (box.x_min, box.y_max) == pytest.approx((-0.175, 0.07))
    stiff = wipe.plane(in_base, translational_stiffness([3000.0] * 3, np.eye(3)))
    normal = in_base.rotation.apply([0.0, 0.0, 1.0])
    assert (plane.origin - stiff.origin) @ normal == pytest.approx(-(10.0 / 300.0 - 10.0 / 3000.0))


def test_a_surface_out_of_reach_or_with_an_area_smaller_than_the_tool_is_refused_with_the_reason():
    wipe = board_wipe()
    far = Transform(np.array([1.2, 0.0, 0.63]), BOARD.frame.rotation)
    with pytest.raises(SurfaceError, match="out of the arm's reach"):
        wipe.start(far, taught_in(far))
    tiny = dataclasses.replace(BOARD, area=(-0.02, -0.02, 0.02, 0.02))
    with pytest.raises(SurfaceError, match="smaller than the tool"):
        wiping_box(tiny, TOOL.size[:2])
    footprint = (0.05, 0.1)
    for narrow in ((-0.025, -0.2, 0.025, 0.2), (-0.2, -0.05, 0.2, 0.05)):  # as wide or as long as the patch, not more
        with pytest.raises(SurfaceError, match="smaller than the tool"):
            wiping_box(dataclasses.replace(BOARD, area=narrow), footprint)
    snug = wiping_box(dataclasses.replace(BOARD, area=(-0.03, -0.06, 0.03, 0.06)), footprint)  # 1 cm of room each way
    assert (snug.x_min, snug.y_min, snug.x_max, snug.y_max) == pytest.approx((-0.005, -0.01, 0.005, 0.01))


def test_a_boundary_whose_farthest_corner_is_exactly_at_the_arms_reach_is_in_reach():
    mount_height = SCENE.robot.mount_height
    # A corner at ARM_REACH from the shoulder, the box's edges leading back toward it: that corner is the farthest
    towards = np.array([-1.0, -1.0, 0.0]) / np.sqrt(2.0), np.array([-1.0, 1.0, 0.0]) / np.sqrt(2.0)
    box = Box(0.0, 0.0, 0.1, 0.1)
    check_reach(TaskPlane([ARM_REACH, 0.0, mount_height], *towards, [0.0, 0.0, 0.0, 1.0]), box, mount_height)
    beyond = TaskPlane([ARM_REACH + 1e-6, 0.0, mount_height], *towards, [0.0, 0.0, 0.0, 1.0])
    with pytest.raises(SurfaceError, match="out of the arm's reach"):
        check_reach(beyond, box, mount_height)


def test_wiping_settings_out_of_range_are_refused(tmp_path):
    path = tmp_path / "wiping.yaml"
    text = (load_wiping_config.__globals__["DEFAULT_WIPING_FILE"]).read_text()
    path.write_text(text.replace("contact_force: 10.0", "contact_force: -1.0"))
    with pytest.raises(WipingError, match="finite and > 0"):
        load_wiping_config(str(path))
    path.write_text(text.replace("contact_force: 10.0", "contact_force: .nan"))
    with pytest.raises(WipingError):
        load_wiping_config(str(path))


def test_a_wipe_that_ends_holds_the_tool_off_the_surface_over_where_it_was():
    wipe = board_wipe()
    off = wipe.off_surface(TURNED, (0.1, -0.05))
    face = TURNED.inverse().apply_point(off) - [0.0, 0.0, TOOL.reach]  # where the tool's face is, in the surface frame
    np.testing.assert_allclose(face, [0.1, -0.05, load_wiping_config().approach_height], atol=1e-12)


def test_a_stiffness_the_arm_would_clamp_is_refused_whatever_its_axes_and_one_at_the_maximum_is_taken():
    wipe = board_wipe()
    in_base = Transform(np.array([0.55, 0.0, 0.63]), BOARD.frame.rotation)
    at_max = translational_stiffness([3000.0, 3000.0, 300.0], TURNED.rotation)  # turned axes: rounding, not a breach
    check_stiffness(at_max, MAX_STIFFNESS)
    wipe.plane(in_base, at_max)
    for values in ([3000.1, 3000.0, 300.0], [3000.0, 300.0, 5000.0]):
        with pytest.raises(SurfaceError, match=r"outside the arm's range \[0, 3000\] N/m"):
            wipe.plane(in_base, translational_stiffness(values, TURNED.rotation))
    with pytest.raises(SurfaceError, match="outside the arm's range"):
        check_stiffness(np.diag([3000.0, -0.1, 300.0]), MAX_STIFFNESS)
    check_stiffness(np.diag([3000.0, 0.0, 300.0]), MAX_STIFFNESS)
    slack = RANGE_SLACK * MAX_STIFFNESS  # the rounding the range allows, at its very edges
    check_stiffness(np.diag([MAX_STIFFNESS + slack, -slack, 300.0]), MAX_STIFFNESS)
    with pytest.raises(SurfaceError, match=r"^the stiffness \[50.0, 300.0, 3100.4\] N/m is outside"):
        check_stiffness(np.diag([3100.44, 50.0, 300.0]), MAX_STIFFNESS)
    with pytest.raises(SurfaceError, match="not finite"):
        check_stiffness(np.diag([3000.0, np.nan, 300.0]), MAX_STIFFNESS)
    with pytest.raises(SurfaceError, match="normal"):  # in range, but nothing presses along the normal
        wipe.plane(in_base, translational_stiffness([3000.0, 3000.0, 0.0], in_base.rotation))
