"""The ellipsoid marker mapping: size from the principal stiffnesses, orientation from the eigenvectors."""

import dataclasses
import math

import numpy as np
import pytest
import yaml
from geometry_msgs.msg import PoseStamped, QuaternionStamped, Vector3Stamped
from scipy.spatial.transform import Rotation
from visualization_msgs.msg import Marker

from teleteach.core.paths import config_file
from teleteach.core.validation import InvalidCommandError
from teleteach.viz.ellipsoid import DRAWN_RESOLUTION, EllipsoidMarkerConfig, EllipsoidScale, drawn_as


def eigenvalues(x, y, z, frame="base_link"):
    message = Vector3Stamped()
    message.header.frame_id = frame
    message.vector.x, message.vector.y, message.vector.z = x, y, z
    return message


def eigenvectors(x, y, z, w, frame="base_link"):
    message = QuaternionStamped()
    message.header.frame_id = frame
    q = message.quaternion
    q.x, q.y, q.z, q.w = x, y, z, w
    return message


def pose(x, y, z, frame="base_link"):
    message = PoseStamped()
    message.header.frame_id = frame
    message.pose.position.x, message.pose.position.y, message.pose.position.z = x, y, z
    message.pose.orientation.w = 1.0
    return message


def ready_builder():
    builder = EllipsoidMarkerConfig.from_yaml().builder()
    builder.set_eigenvalues(eigenvalues(500.0, 1500.0, 3000.0))
    yaw45 = Rotation.from_euler("z", 45, degrees=True).as_quat()
    builder.set_eigenvectors(eigenvectors(*yaw45))
    builder.set_pose(pose(0.5, -0.1, 0.7))
    return builder


def test_no_marker_until_every_input_arrived():
    builder = EllipsoidMarkerConfig.from_yaml().builder()
    assert builder.marker() is None
    builder.set_eigenvalues(eigenvalues(100.0, 100.0, 100.0))
    builder.set_pose(pose(0.0, 0.0, 0.0))
    assert builder.marker() is None
    builder.set_eigenvectors(eigenvectors(0.0, 0.0, 0.0, 1.0))
    assert builder.marker() is not None


def test_a_marker_is_drawn_anew_only_for_a_change_a_display_shows():
    builder = ready_builder()
    shown = drawn_as(builder.marker())
    # Expect the same picture for the arm holding still (micrometres) and a new one for a millimetre or a new stiffness
    builder.set_pose(pose(0.5 + 0.1 * DRAWN_RESOLUTION, -0.1, 0.7))
    assert drawn_as(builder.marker()) == shown
    builder.set_pose(pose(0.501, -0.1, 0.7))
    assert drawn_as(builder.marker()) != shown
    builder.set_pose(pose(0.5, -0.1, 0.7))
    builder.set_eigenvalues(eigenvalues(500.0, 1500.0, 2990.0))
    assert drawn_as(builder.marker()) != shown


def test_marker_is_a_sphere_at_the_end_effector_scaled_and_oriented_as_the_stiffness():
    marker = ready_builder().marker()
    assert marker.type == Marker.SPHERE and marker.action == Marker.ADD
    assert marker.header.frame_id == "base_link"
    assert (marker.pose.position.x, marker.pose.position.y, marker.pose.position.z) == (0.5, -0.1, 0.7)
    # Expect 1e-4 m per N/m: 500, 1500, 3000 N/m -> 0.05, 0.15, 0.3 m diameters
    np.testing.assert_allclose([marker.scale.x, marker.scale.y, marker.scale.z], [0.05, 0.15, 0.3])
    # The marker's local x axis (first principal axis) points along the base frame's 45-degree diagonal.
    o = marker.pose.orientation
    first_axis = Rotation.from_quat([o.x, o.y, o.z, o.w]).apply([1.0, 0.0, 0.0])
    np.testing.assert_allclose(first_axis, [math.sqrt(0.5), math.sqrt(0.5), 0.0], atol=1e-12)


def test_marker_shape_matches_the_stiffness_matrix():
    # Independent check: the marker's axes, scaled by the diameters, rebuild K = R diag(lambda) R^T (eq. 2/6).
    builder = ready_builder()
    marker = builder.marker()
    o = marker.pose.orientation
    rotation = Rotation.from_quat([o.x, o.y, o.z, o.w]).as_matrix()
    stiffness_from_marker = rotation @ np.diag([marker.scale.x, marker.scale.y, marker.scale.z]) @ rotation.T / 1e-4
    expected = np.array([[1000.0, -500.0, 0.0], [-500.0, 1000.0, 0.0], [0.0, 0.0, 3000.0]])
    np.testing.assert_allclose(stiffness_from_marker, expected, atol=1e-9)


def test_diameters_are_clamped():
    scale = EllipsoidScale(metres_per_stiffness=1e-3, min_diameter=0.05, max_diameter=0.5)
    np.testing.assert_allclose(scale.diameters([0.0, 200.0, 10000.0]), [0.05, 0.2, 0.5])


SCALE = {"metres_per_stiffness": 1e-4, "min_diameter": 0.02, "max_diameter": 0.4}


@pytest.mark.parametrize(
    "kwargs",
    [
        {"metres_per_stiffness": 0.0},
        {"metres_per_stiffness": float("nan")},
        {"min_diameter": -0.1},
        {"min_diameter": 0.5, "max_diameter": 0.1},
        {"max_diameter": float("inf")},
    ],
)
def test_bad_scale_parameters_are_refused(kwargs):
    with pytest.raises(ValueError):
        EllipsoidScale(**dict(SCALE, **kwargs))


def test_the_node_s_parameters_are_its_yaml_and_a_bad_one_is_named():
    values = yaml.safe_load(config_file("ellipsoid_marker.yaml").read_text())
    config = EllipsoidMarkerConfig.from_mapping(values)
    assert dataclasses.asdict(config) == values
    assert config.scale == EllipsoidScale(
        values["metres_per_stiffness"], values["min_diameter"], values["max_diameter"]
    )
    with pytest.raises(ValueError, match=r"^rate must be a finite number > 0 Hz, got 0.0$"):
        EllipsoidMarkerConfig.from_mapping(dict(values, rate=0.0))
    with pytest.raises(ValueError, match=r"^min_diameter 0.5 m exceeds max_diameter 0.4 m$"):
        EllipsoidMarkerConfig.from_mapping(dict(values, min_diameter=0.5))
    del values["rate"]
    with pytest.raises(ValueError, match=r"\(config/ellipsoid_marker.yaml\): missing rate$"):
        EllipsoidMarkerConfig.from_mapping(values)


@pytest.mark.parametrize(
    ("setter", "message", "reason"),
    [
        ("set_eigenvalues", eigenvalues(float("nan"), 1.0, 1.0), "NaN or inf"),
        ("set_eigenvalues", eigenvalues(100.0, -1.0, 1.0), "negative stiffness"),
        ("set_eigenvalues", eigenvalues(100.0, 100.0, float("inf")), "NaN or inf"),
        ("set_eigenvalues", eigenvalues(100.0, 100.0, 100.0, frame="world"), "frame 'world' is wrong"),
        ("set_eigenvectors", eigenvectors(0.0, 0.0, 0.0, 0.0), "is zero"),
        ("set_eigenvectors", eigenvectors(0.0, 0.0, 0.5, 0.5), "not unit"),
        ("set_eigenvectors", eigenvectors(0.0, float("nan"), 0.0, 1.0), "NaN or inf"),
        ("set_pose", pose(float("nan"), 0.0, 0.0), "NaN or inf"),
        ("set_pose", pose(0.0, 0.0, 0.0, frame="panda_hand"), "frame 'panda_hand' is wrong"),
        ("set_pose", pose(0.0, 0.0, 0.0, frame=""), "frame '' is wrong"),
    ],
)
def test_invalid_input_is_rejected_and_the_last_good_marker_stays(setter, message, reason):
    builder = ready_builder()
    before = builder.marker()
    with pytest.raises(InvalidCommandError, match=reason):
        getattr(builder, setter)(message)
    assert builder.marker() == before


def test_eigen_topics_may_leave_the_frame_empty_like_the_controller_accepts():
    builder = EllipsoidMarkerConfig.from_yaml().builder()
    builder.set_eigenvalues(eigenvalues(100.0, 100.0, 100.0, frame=""))
    builder.set_eigenvectors(eigenvectors(0.0, 0.0, 0.0, 1.0, frame="/base_link"))
    builder.set_pose(pose(1.0, 2.0, 3.0))
    assert builder.ready
