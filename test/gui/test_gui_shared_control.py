"""The SHARED CONTROL tab with the real shared_control node, the real behaviour tree node and the real robot
simulation: the tab shows the identified skill and the plan inside the boundary, a recording becomes a
``shared_control`` skill in the library."""

import math
import threading

import numpy as np
import pytest
import yaml
from conftest import ROOT, pump, pump_until, start, stop
from geometry_msgs.msg import PolygonStamped, PoseStamped, QuaternionStamped, Vector3Stamped
from std_msgs.msg import Bool
from test_gui_recording import robot_sim  # noqa: F401 - the fixture

from teleteach.core import skill_file
from teleteach.core.scene import load_scene
from teleteach.msg import SharedControlState, SharedControlTask, SkillLibrary
from teleteach.shared_control.models import synthetic_commands
from teleteach.shared_control.plane import TaskPlane

pytestmark = pytest.mark.gui
BOUNDARY = (-0.25, -0.15, 0.25, 0.15)  # config/shared_control.yaml


class Operator:
    """Publishes a noisy wave (the paper's IV-B input) on /shared_control/operator_command at 50 Hz."""

    def __init__(self):
        import rospy

        self._rospy = rospy
        self._publisher = rospy.Publisher("/shared_control/operator_command", Vector3Stamped, queue_size=10)
        self._commands = synthetic_commands("wave", (0.03, 20.0, 0.0), math.pi - 0.3, 0.05, np.arange(0, 60.0, 0.02))
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self):
        rate = self._rospy.Rate(50)
        for x, y in self._commands:
            if self._stop.is_set() or self._rospy.is_shutdown():
                return
            message = Vector3Stamped()  # stamp 0 = "now" for the node: this process is not on the sim's /clock
            message.vector.x, message.vector.y = float(x), float(y)
            self._publisher.publish(message)
            rate.sleep()

    def close(self):
        self._stop.set()
        self._thread.join(2)
        self._publisher.unregister()


@pytest.fixture
def shared_control_node(robot_sim, data_root):  # noqa: F811 - the imported fixture
    import rospy

    process = start(
        ["roslaunch", "teleteach", "shared_control.launch", "solver:=fast"], data_root.parent / "shared_control.log"
    )
    # up once its boundary is out (latched, at start); it drives only while a window's SHARED CONTROL enables it
    rospy.wait_for_message("/shared_control/boundary", PolygonStamped, timeout=60)
    yield process
    stop(process)


def open_shared_control(qapp, window, device):
    """START: the device up selects SHARED CONTROL, a click opens it."""
    device.move(y=0.08)
    pump_until(qapp, lambda: window.start_tab.selected == 2, 5, "START to select SHARED CONTROL")
    device.click()
    pump_until(qapp, lambda: window.tabs.currentIndex() == 3, 5, "SHARED CONTROL")


def record_a_skill(qapp, window, device, while_recording=lambda: None):
    """A double click records the MPC's output, over 60 samples, another double click stops: a skill is saved."""
    device.click()
    device.click()
    pump_until(qapp, lambda: window.shared_recorder.active, 5, "recording after a double click")
    pump_until(qapp, lambda: len(window.shared_recorder) > 60, 20, "samples recorded")
    pump(qapp, 0.5)
    while_recording()
    device.click()
    device.click()
    pump_until(qapp, lambda: not window.shared_recorder.active, 5, "the recording to stop")


def inside(points, margin=1e-6):
    points = np.asarray(points)
    return bool(
        np.all(points[:, 0] >= BOUNDARY[0] - margin)
        and np.all(points[:, 0] <= BOUNDARY[2] + margin)
        and np.all(points[:, 1] >= BOUNDARY[1] - margin)
        and np.all(points[:, 1] <= BOUNDARY[3] + margin)
    )


def test_shared_control_tab_shows_the_plan_and_records_a_skill(
    qapp, bt_node, shared_control_node, device, make_window, topic_log, data_root, artifacts_dir
):
    library_log = topic_log("/behaviour_tree/skill_library", SkillLibrary)
    equilibrium_log = topic_log("/equilibrium_pose", PoseStamped)
    window = make_window()
    tab = window.shared_control
    operator = Operator()
    try:
        open_shared_control(qapp, window, device)

        def sharing():
            status = tab.status
            return status is not None and status.mode == SharedControlState.SHARED and len(tab.view.plan) > 10

        pump_until(qapp, sharing, 30, "SHARED mode with a plan in the tab")
        pump_until(qapp, lambda: tab.status.skill == "wave" and len(tab.view.trail) > 100, 20, "the wave identified")
        assert "wave" in tab.skill_label.text() and "SHARED" in tab.mode_label.text()
        assert "cycloid" in tab.errors_label.text() and "ms" in tab.times_label.text()
        corners = sorted(map(tuple, np.round(tab.view.boundary, 6)))
        assert corners == sorted([(-0.25, -0.15), (0.25, -0.15), (0.25, 0.15), (-0.25, 0.15)])
        assert inside(tab.view.plan) and inside(list(tab.view.trail))
        # the arm's own trail (/cartesian_pose on the plane) follows the executed state inside the boundary
        pump_until(qapp, lambda: len(tab.view.arm_trail) > 50, 10, "the arm's trail in the tab")
        arm = np.array(tab.view.arm_trail)
        assert inside(arm[-10:], margin=0.005)
        assert np.linalg.norm(arm[-1] - np.array(tab.view.trail[-1])) < 0.03
        # the plan starts where the robot is and goes somewhere
        assert np.linalg.norm(tab.view.plan[0] - np.array(tab.view.trail[-1])) < 0.05
        assert np.linalg.norm(tab.view.plan[-1] - tab.view.plan[0]) > 0.005
        window.screenshot().save(str(artifacts_dir / "gui_shared_control.png"))

        # double click: record the MPC's output, double click again: a shared_control skill
        record_a_skill(
            qapp,
            window,
            device,
            lambda: window.screenshot().save(str(artifacts_dir / "gui_shared_control_recording.png")),
        )
    finally:
        operator.close()

    skills = data_root / "skills"
    pump_until(qapp, lambda: list(skills.glob("*.npz")), 5, "a skill file in the data directory")
    (path,) = skills.glob("*.npz")
    name = path.stem
    assert name.startswith("SharedControl_")

    def in_library():
        message = library_log.last()
        return message is not None and name in message.names

    pump_until(qapp, in_library, 10, f"{name} in /behaviour_tree/skill_library")
    message = library_log.last()
    assert message.kinds[list(message.names).index(name)] == "shared_control"
    pump_until(qapp, lambda: name in window.high_level.choices()[1], 5, f"a HIGH-LEVEL button for {name}")

    skill = skill_file.load(path)
    assert skill.kind == "shared_control"
    assert np.allclose(skill.stiffness, np.diag([500.0, 500.0, 500.0]))
    # the recorded equilibrium is the MPC's: on the task plane (config/shared_control.yaml), inside the boundary
    plane = TaskPlane.from_params(yaml.safe_load((ROOT / "config" / "shared_control.yaml").read_text())["plane"])
    planar = np.array([plane.to_plane(position) for position in skill.equilibrium_pose[:, :3]])
    np.testing.assert_allclose([plane.to_base(point) for point in planar], skill.equilibrium_pose[:, :3], atol=1e-6)
    assert inside(planar)
    assert np.ptp(planar[:, 0]) > 0.01  # the robot moved
    assert np.all(np.isfinite(skill.cartesian_pose))
    assert equilibrium_log.messages

    # gripper fully open: back to START
    device.set_gripper(0.5)
    pump_until(qapp, lambda: window.tabs.currentIndex() == 0, 5, "START")


@pytest.fixture
def wiping_system(ros_master, data_root):
    """robot_sim with the eraser mounted, its base driven to the counter's board, and shared_control on the board."""
    import rospy

    from teleteach.wiping.ros import drive_to

    simulation = start(
        ["roslaunch", "teleteach", "sim.launch", "skills:=false", "wiping_tool:=true"], data_root.parent / "sim.log"
    )
    rospy.wait_for_message("/cartesian_pose", PoseStamped, timeout=90)
    assert drive_to(), "the base did not arrive at the counter"
    controller = start(
        ["roslaunch", "teleteach", "shared_control.launch", "solver:=fast", "surface:=counter_board", "enabled:=false"],
        data_root.parent / "shared_control.log",
    )
    rospy.wait_for_message("/shared_control/task", SharedControlTask, timeout=60)
    yield
    stop(controller)
    stop(simulation, timeout=20)
    rospy.delete_param("/use_sim_time")  # sim.launch set it on the shared master; later nodes run on wall time


def test_wiping_in_shared_control_the_gripper_clutch_teaches_the_stiffness_while_the_wave_goes_on(
    qapp, bt_node, wiping_system, device, make_window, topic_log, data_root, artifacts_dir
):
    from teleteach.core.gui_config import GuiConfig
    from teleteach.core.wiping import load_wiping_config
    from teleteach.shared_control.surface import wiping_box

    config = GuiConfig.load()
    tasks = topic_log("/shared_control/task", SharedControlTask)
    clutch = topic_log("/shared_control/clutch", Bool)
    eigenvalues = topic_log("/eigenvalues", Vector3Stamped)
    eigenvectors = topic_log("/eigenvectors", QuaternionStamped)
    window = make_window()
    tab = window.shared_control
    operator = Operator()
    try:
        open_shared_control(qapp, window, device)
        # Expect: the node locates the board and says so; the tab draws the board's marked area (its own frame)
        pump_until(
            qapp, lambda: tab.teaching_label.text().startswith("wiping counter_board"), 30, "the wipe in the tab"
        )
        assert tasks.last().surface == "counter_board"
        area = wiping_box(load_scene().surface("counter_board"), load_scene().wiping_tool.size[:2])
        expected = np.array(sorted((x, y) for x in (area.x_min, area.x_max) for y in (area.y_min, area.y_max)))

        def board_drawn():  # the plane's own boundary comes first (latched), the board's once the node located it
            corners = np.array(sorted(map(tuple, np.round(tab.view.boundary, 6))))
            return corners.shape == expected.shape and np.allclose(corners, expected, atol=1e-6)

        pump_until(qapp, board_drawn, 10, lambda: f"the board's boundary, drawn: {tab.view.boundary.round(4).tolist()}")
        pump_until(qapp, lambda: tab.status is not None and tab.status.skill == "wave", 30, "the wave identified")

        # the gripper closed past clutch_hold: the clutch, the wave kept by the controller
        device.set_gripper(0.0)
        pump_until(qapp, lambda: tab.teaching_label.text().startswith("CLUTCH"), 5, "the clutch in the tab")
        pump_until(qapp, lambda: clutch.last() is not None and clutch.last().data, 2, "/shared_control/clutch true")
        pump_until(qapp, lambda: tab.status.message.startswith("clutch: keeping the wave"), 5, "the wave kept")
        # the handle sweeps low (every axis meets it), then shapes: stiff along the board, soft into it
        device.move(x=-0.1, y=-0.1, z=-0.1)
        pump(qapp, 0.3)
        device.move(x=0.09, y=0.09, z=-0.08)
        pump(qapp, 0.5)
        window.screenshot().save(str(artifacts_dir / "gui_shared_control_wipe_clutch.png"))
        taught = np.array([eigenvalues.last().vector.x, eigenvalues.last().vector.y, eigenvalues.last().vector.z])
        assert taught[0] > 3 * taught[2] and taught[1] > 3 * taught[2], taught  # shaped along the board's axes
        q = eigenvectors.last().quaternion
        board = tasks.last().surface_pose.orientation
        assert abs(abs(np.dot([q.x, q.y, q.z, q.w], [board.x, board.y, board.z, board.w])) - 1.0) < 1e-6

        # opened halfway: the pattern is the operator's again, the stiffness stays as taught
        device.set_gripper(0.3)
        pump_until(qapp, lambda: tab.teaching_label.text().startswith("wiping"), 5, "the clutch released")
        pump_until(qapp, lambda: not tab.status.message.startswith("clutch"), 5, "the node's clutch released")
        pump(qapp, 0.3)
        assert window.tabs.currentIndex() == 3  # halfway open is no way back to START
        kept = np.array([eigenvalues.last().vector.x, eigenvalues.last().vector.y, eigenvalues.last().vector.z])
        np.testing.assert_allclose(kept, taught, rtol=1e-6)

        # a recording of the wipe is a skill relative to the board, with the stiffness taught
        record_a_skill(qapp, window, device)
    finally:
        operator.close()
    skills = data_root / "skills"
    pump_until(qapp, lambda: list(skills.glob("*.npz")), 5, "a skill file in the data directory")
    (path,) = skills.glob("*.npz")
    skill = skill_file.load(path)
    assert skill.target.kind == skill_file.SURFACE and skill.target.name == "counter_board"
    np.testing.assert_allclose(np.diag(skill.stiffness[-1]), taught, rtol=1e-3)  # in the board's own axes
    reach, depth = load_scene().wiping_tool.reach, load_wiping_config().contact_force / taught[2]
    np.testing.assert_allclose(skill.equilibrium_pose[-1, 2], reach - depth, atol=0.002)  # pressing into the board
    assert config.shared_control_stiffness[2] != taught[2]
