"""The offline report: reads a session bag with rosbags, plots like the thesis, and refuses bad files clearly."""

import math
import shutil
import subprocess

import numpy as np
import pytest
from conftest import ROOT
from scipy.spatial.transform import Rotation
from session_bags import write_session

from teleteach.control.stiffness import translational_stiffnesses
from teleteach.recording.report import clicks, make_report, tree_edits
from teleteach.recording.session import Series, SessionError, TreeSnapshot, axes_yaw_of, read_session


@pytest.fixture(scope="module")
def session_bag(tmp_path_factory):
    return write_session(tmp_path_factory.mktemp("bags") / "session_2026-01-01-00-00-00.bag")


def test_session_is_read_without_a_master(session_bag):
    session = read_session(session_bag)
    assert session.duration == pytest.approx(9.995, abs=0.01)
    assert session.topics["/sigma7/pose"].count == 2000
    assert session.topics["/sigma7/pose"].msgtype == "geometry_msgs/msg/PoseStamped"
    assert session.device_position.values.shape == (2000, 3)
    # The scripted device turns by 45 degrees about Z.
    assert math.degrees(session.device_yaw.values[-1]) == pytest.approx(45.0, abs=1e-6)
    assert len(session.trees) == 4


def test_report_writes_three_figures_and_a_summary(session_bag, tmp_path, artifacts_dir):
    report = make_report(session_bag, tmp_path / "report")
    assert sorted(report.figures) == ["high_level.png", "rotation.png", "stiffness.png"]
    assert report.skipped == {} and all(notes == [] for notes in report.notes.values())
    for path in report.figures.values():
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and path.stat().st_size > 20_000
    # Expect the two structural edits only (the status update at 1 s is not an edit)
    assert [(edit.removed, edit.added) for edit in report.edits] == [(("PlaceItem",), ()), ((), ("PlaceItem_2",))]
    assert [round(edit.time, 2) for edit in report.edits] == [3.9, 9.5]
    summary = report.summary.read_text()
    # Expect the run summary's words: where the new node stands among its parent's children
    assert "removed PlaceItem" in summary and "inserted PlaceItem_2 at index" in summary
    assert "| `/sigma7/pose` | geometry_msgs/PoseStamped | 2000 |" in summary
    assert "| Z | 2000.0 | 2000.0 |" in summary
    assert "Ellipsoid yaw (modulo 180 deg: an axis has no sign): 0.0 deg .. 45.0 deg." in summary
    shutil.copytree(tmp_path / "report", artifacts_dir / "report_unit", dirs_exist_ok=True)


def test_a_report_from_a_session_already_read_is_the_report_of_its_bag(session_bag, tmp_path, monkeypatch):
    import teleteach.recording.report as report_module

    expected = make_report(session_bag, tmp_path / "read_here")
    session = read_session(session_bag)
    monkeypatch.setattr(report_module, "read_session", lambda path: pytest.fail(f"{path} read a second time"))
    given = make_report(session_bag, tmp_path / "given", session=session)
    assert given.summary.read_text() == expected.summary.read_text()
    assert given.stiffness_table.read_text() == expected.stiffness_table.read_text()
    assert sorted(given.figures) == sorted(expected.figures) and given.edits == expected.edits


def test_stiffness_table_pairs_each_command_with_the_end_effector_position(session_bag, tmp_path):
    report = make_report(session_bag, tmp_path / "report")
    table = np.genfromtxt(report.stiffness_table, delimiter=",", names=True)
    assert len(table) == read_session(session_bag).topics["/eigenvalues"].count
    last = table[-1]
    # Independent check at 45 degrees about Z: K_xy = (lambda_x - lambda_y) sin cos, K_xx = (lambda_x + lambda_y) / 2
    assert last["k_xy"] == pytest.approx((last["lambda_x"] - last["lambda_y"]) / 2, rel=1e-6)
    assert last["k_xx"] == pytest.approx((last["lambda_x"] + last["lambda_y"]) / 2, rel=1e-6)
    assert last["k_zz"] == pytest.approx(2000.0)
    # The scripted end effector moves at 0.03 m/s along X, sampled at 100 Hz: the held pose is at most 10 ms old
    assert last["ee_x"] == pytest.approx(0.4 + 0.03 * last["t"], abs=0.03 * 0.0101)


def test_missing_topics_skip_their_figures_with_a_note(tmp_path):
    device_only = write_session(
        tmp_path / "device.bag", duration=2.0, topics={"/sigma7/pose", "/sigma7/gripper_angle", "/sigma7/button"}
    )
    report = make_report(device_only, tmp_path / "out")
    assert list(report.figures) == ["high_level.png"]
    assert report.notes["high_level.png"] == ["no tree edits marked: missing /behaviour_tree/log/tree"]
    assert report.skipped["stiffness.png"] == "missing /eigenvalues, /eigenvectors"
    summary = report.summary.read_text()
    assert "Fig. 7: ellipsoid rotation about Z: skipped (missing /eigenvalues, /eigenvectors)" in summary
    assert "No tree log" in summary


def test_missing_end_effector_pose_leaves_its_panel_empty_with_a_note(tmp_path):
    everything = {"/sigma7/pose", "/sigma7/gripper_angle", "/sigma7/button", "/eigenvalues", "/eigenvectors"}
    report = make_report(write_session(tmp_path / "no_robot.bag", topics=everything), tmp_path / "out")
    assert sorted(report.figures) == ["high_level.png", "rotation.png", "stiffness.png"]
    assert report.notes["stiffness.png"] == ["end-effector panel empty: missing /cartesian_pose"]
    assert "(end-effector panel empty: missing /cartesian_pose)" in report.summary.read_text()


def test_empty_bag_gives_a_summary_and_no_figures(tmp_path):
    report = make_report(write_session(tmp_path / "empty.bag", topics=set()), tmp_path / "out")
    assert report.figures == {}
    assert "duration: 0.00 s" in report.summary.read_text()


def run_report(*arguments):
    # The node itself, not through rosrun (whose `find` warns about the workspace's link loop on stderr).
    return subprocess.run([str(ROOT / "nodes" / "report"), *map(str, arguments)], capture_output=True, text=True)


def test_report_command_writes_next_to_the_bag_by_default(session_bag):
    result = run_report(session_bag)
    assert result.returncode == 0, result.stderr
    folder = session_bag.with_name(session_bag.stem + "_report")
    assert f"wrote {folder / 'summary.md'}" in result.stdout
    assert (folder / "stiffness.png").is_file()


BAD_FILES = {
    "truncated-half": (
        lambda path, bag: path.write_bytes(bag.read_bytes()[: bag.stat().st_size // 2]),
        "cannot read bag",
    ),
    "truncated-header": (lambda path, bag: path.write_bytes(bag.read_bytes()[:20]), "cannot read bag"),
    "foreign": (lambda path, bag: path.write_text("not a bag at all\n"), "is not a ROS 1 bag"),
    "empty-file": (lambda path, bag: path.write_bytes(b""), "is not a ROS 1 bag"),
    "missing": (lambda path, bag: None, "does not exist"),
}


@pytest.mark.parametrize("kind", sorted(BAD_FILES))
def test_bad_files_are_refused_naming_the_problem(tmp_path, session_bag, kind):
    make_file, reason = BAD_FILES[kind]
    path = tmp_path / "bad.bag"
    make_file(path, session_bag)
    with pytest.raises(SessionError, match=reason):
        make_report(path, tmp_path / "out")
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("kind", ["truncated-half", "foreign"])
def test_report_command_gives_one_line_and_no_traceback_for_a_bad_file(tmp_path, session_bag, kind):
    make_file, reason = BAD_FILES[kind]
    path = tmp_path / "bad.bag"
    make_file(path, session_bag)
    result = run_report(path, "--out", tmp_path / "out")
    assert result.returncode == 2
    assert result.stderr.startswith("report: error: ") and reason in result.stderr
    assert "Traceback" not in result.stderr and len(result.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "out").exists()


def test_unfinished_recording_is_named(tmp_path, session_bag):
    active = tmp_path / "session.bag.active"
    active.write_bytes(session_bag.read_bytes())
    with pytest.raises(SessionError, match="unfinished recording"):
        read_session(active)


def test_tree_edits_name_removed_added_and_moved_nodes():
    def snapshot(time, names):
        return TreeSnapshot(time, ("Root", *names), {"Root": tuple(names)})

    trees = [snapshot(0, "ABC"), snapshot(1, "ABC"), snapshot(2, "AC"), snapshot(3, "CA"), snapshot(4, "CAD")]
    edits = tree_edits(trees)
    assert [(e.time, e.removed, e.added, e.moved) for e in edits] == [
        (2, ("B",), (), ()),
        (3, (), (), ("A", "C")),
        (4, (), ("D",), ()),
    ]
    assert edits[0].describe() == "removed B"
    assert edits[2].describe() == "inserted D at index 2"


def test_tree_edits_name_a_converted_composite():
    names, children = ("Root", "Work", "A"), {"Root": ("Work",), "Work": ("A",)}
    sequence = TreeSnapshot(0, names, children, types={"Root": 3, "Work": 2, "A": 1})
    selector = TreeSnapshot(1, names, children, types={"Root": 3, "Work": 3, "A": 1})
    edits = tree_edits([sequence, sequence, selector])
    assert [(edit.time, edit.describe()) for edit in edits] == [(1, "converted Work")]


def test_stiffness_matrix_matches_a_hand_derivation():
    # diag(100, 400, 900) turned 90 degrees about Z swaps the X and Y stiffnesses.
    quaternion = Rotation.from_euler("z", 90, degrees=True).as_quat()
    matrix = translational_stiffnesses(np.array([[100.0, 400.0, 900.0]]), np.array([quaternion]))[0]
    np.testing.assert_allclose(matrix, np.diag([400.0, 100.0, 900.0]), atol=1e-9)


def test_clicks_are_rising_edges():
    button = Series(np.arange(6.0), np.array([[0], [1], [1], [0], [1], [0]], dtype=float))
    np.testing.assert_array_equal(clicks(button), [1.0, 4.0])


def test_invalid_stiffness_and_device_samples_are_left_out_with_a_note(tmp_path):
    import rosbag
    from session_bags import eigenvalues_message, eigenvectors_message, pose_message, stamp
    from std_msgs.msg import Float64

    path = tmp_path / "bad_values.bag"
    with rosbag.Bag(str(path), "w") as bag:
        for step in range(20):
            t = 0.1 * step
            values = (float("nan"), 1.0, 1.0) if step == 5 else (-3.0, 1.0, 1.0) if step == 6 else (500.0, 800.0, 900.0)
            bag.write("/eigenvalues", eigenvalues_message(*values, t=t), stamp(t))
            vectors = eigenvectors_message(0.3, t=t)
            if step == 7:
                vectors.quaternion.w = vectors.quaternion.z = 0.0
            bag.write("/eigenvectors", vectors, stamp(t))
            device = pose_message(0.01 * step, t=t, frame="sigma7")
            if step == 8:
                device.pose.orientation.w = 0.0
            bag.write("/sigma7/pose", device, stamp(t))
            bag.write("/sigma7/gripper_angle", Float64(0.25), stamp(t))
    report = make_report(path, tmp_path / "out")
    assert sorted(report.figures) == ["high_level.png", "rotation.png", "stiffness.png"]
    summary = report.summary.read_text()
    assert "Left out 2 `/eigenvalues` messages the controller rejects" in summary
    assert "Left out 1 `/eigenvectors` messages the controller rejects" in summary
    assert "| X | 500.0 | 500.0 |" in summary


def test_an_ellipsoid_s_yaw_is_reported_modulo_180_degrees(tmp_path):
    """The same ellipsoid with two axes flipped (an eigendecomposition's sign) is no turn of 180 degrees."""
    import rosbag
    from session_bags import eigenvalues_message, eigenvectors_message, pose_message, stamp

    flips = [0.0, math.pi, math.radians(-179.8), math.radians(45.0), math.radians(-135.0), math.radians(44.0)]
    path = tmp_path / "flipped_axes.bag"
    with rosbag.Bag(str(path), "w") as bag:
        for step, yaw in enumerate(flips):
            t = 0.5 * step
            bag.write("/eigenvalues", eigenvalues_message(500.0, 800.0, 900.0, t=t), stamp(t))
            bag.write("/eigenvectors", eigenvectors_message(yaw, t=t), stamp(t))
            bag.write("/sigma7/pose", pose_message(t=t, frame="sigma7"), stamp(t))
            bag.write("/cartesian_pose", pose_message(t=t), stamp(t))
    report = make_report(path, tmp_path / "out")
    # Expect the device's rotation 0 and the ellipsoid's axes at 0, 0.2 and 45 degrees: never -180
    np.testing.assert_allclose(
        np.degrees(axes_yaw_of(read_session(path).eigenvectors.values)), [0.0, 0.0, 0.2, 45.0, 45.0, 44.0], atol=1e-9
    )
    assert "Ellipsoid yaw (modulo 180 deg: an axis has no sign): 0.0 deg .. 45.0 deg." in report.summary.read_text()


def test_an_axes_yaw_starts_within_90_degrees_and_is_continuous_modulo_180():
    quaternions = Rotation.from_euler("ZYX", [[math.radians(yaw), 0.0, 0.0] for yaw in (170, 179, -179, -100)])
    np.testing.assert_allclose(np.degrees(axes_yaw_of(quaternions.as_quat())), [-10, -1, 1, 80], atol=1e-9)
    # a flip about X or Y (roll or pitch by 180 degrees) is the same ellipsoid as well
    flips = Rotation.from_euler("ZYX", [[0.3, 0.0, math.pi], [0.3, math.pi, 0.0]]).as_quat()
    np.testing.assert_allclose(axes_yaw_of(flips), [0.3, 0.3], atol=1e-9)
    bad = np.array([[0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]])
    assert np.isnan(axes_yaw_of(bad)[0]) and axes_yaw_of(bad)[1] == 0.0
