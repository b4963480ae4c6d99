"""The SHARED CONTROL tab with the real shared_control node, the real behaviour tree node and the real robot
simulation: the tab shows the identified skill and the plan inside the boundary, a recording becomes a
``shared_control`` skill in the library."""

import math
import threading

import numpy as np
import pytest
import yaml
from conftest import ROOT, pump, pump_until, start, stop
from geometry_msgs.msg import PolygonStamped, PoseStamped, Vector3Stamped
from test_gui_recording import robot_sim  # noqa: F401 - the fixture

from teleteach.core import skill_file
from teleteach.msg import SharedControlState, SkillLibrary
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
        # START: device up selects SHARED CONTROL, a click opens it
        device.move(y=0.08)
        pump_until(qapp, lambda: window.start_tab.selected == 2, 5, "START to select SHARED CONTROL")
        device.click()
        pump_until(qapp, lambda: window.tabs.currentIndex() == 3, 5, "SHARED CONTROL")

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
        device.click()
        device.click()
        pump_until(qapp, lambda: window.shared_recorder.active, 5, "recording after a double click")
        pump_until(qapp, lambda: len(window.shared_recorder) > 60, 15, "samples recorded")
        pump(qapp, 0.5)
        window.screenshot().save(str(artifacts_dir / "gui_shared_control_recording.png"))
        device.click()
        device.click()
        pump_until(qapp, lambda: not window.shared_recorder.active, 5, "the recording to stop")
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
