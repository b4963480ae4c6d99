"""The TELEOP tab with the real GUI and the real robot simulation: what the operator reads while the device moves
the arm (the clutch, the reasons it holds, both poses), and what reaches /equilibrium_pose.

The window here is this process, on the wall clock, while robot_sim runs on simulated time: the simulation refuses
its equilibria as stale (config/controllers.yaml command_validation), so the arm itself does not move here. Its
motion is checked by test/ros/teleop.test, where every node is on the simulated clock.
"""

import math
import time

import numpy as np
import pytest
from conftest import pump, pump_until, start, stop
from geometry_msgs.msg import PoseStamped
from test_gui_recording import IMPEDANCE, REAL_TIME_FACTOR, double_click, running_controllers

from teleteach.core import skill_file
from teleteach.core.active_tab import Tab
from teleteach.core.teleoperation import Clutch
from teleteach.core.trajectories import Trajectory
from teleteach.msg import SkillLibrary

pytestmark = pytest.mark.gui


@pytest.fixture
def robot_sim(ros_master, data_root):
    """sim.launch without skill servers, at half real time, and without perception noise: the paths taught here are
    kept relative to a gap 1.75 m away, where 0.1 deg of noise on its perceived yaw moves them by 3 mm."""
    import rospy

    command = [
        "roslaunch",
        "teleteach",
        "sim.launch",
        "skills:=false",
        f"real_time_factor:={REAL_TIME_FACTOR}",
        "perception_noise:=false",
    ]
    process = start(command, data_root.parent / "sim.log")
    rospy.wait_for_service("/controller_manager/switch_controller", timeout=90)
    rospy.wait_for_message("/cartesian_pose", PoseStamped, timeout=30)
    yield process
    stop(process, timeout=20)
    rospy.delete_param("/use_sim_time")


def open_teleop(qapp, window, device):
    device.move(y=-0.08)
    pump_until(qapp, lambda: window.start_tab.selected == 3, 5, "START to select TELEOP")
    device.click()
    pump_until(qapp, lambda: window.tabs.currentIndex() == Tab.TELEOP, 5, "the TELEOP tab to open")


def test_teleop_shows_the_clutch_and_why_the_arm_holds(
    qapp,
    device,
    make_window,
    topic_log,
    artifacts_dir,
    robot_sim,
):
    equilibria = topic_log("/equilibrium_pose", PoseStamped)
    window = make_window()
    tab = window.teleop
    open_teleop(qapp, window, device)
    pump_until(qapp, lambda: IMPEDANCE in running_controllers(), 30, "the impedance controller")
    device.move()
    pump_until(qapp, lambda: tab.view.driving and tab.view.equilibrium is not None, 10, "TELEOP driving the arm")
    assert tab.clutch_label.text() == "clutch released: the arm holds its pose"
    # Expect the placement's assistance to say it has no gap to help at (the base stands 1.75 m from the shelf)
    no_gap = "assistance: no gap within 35 cm"
    shown = tab.assistance_label.text
    pump_until(qapp, lambda: shown() == no_gap, 5, lambda: f"{no_gap!r} (the tab shows {shown()!r})")
    start = tab.view.equilibrium.copy()
    # Expect the commanded pose to start where the arm is (no jump when the device takes it)
    assert np.linalg.norm(start[:3] - tab.view.measured[:3]) < 0.01

    device.set_gripper(0.0)
    pump_until(qapp, lambda: tab.view.clutch is Clutch.ENGAGED, 5, "the clutch engaged")
    assert tab.clutch_label.text() == "CLUTCH ENGAGED: the arm follows your hand"
    for step in range(1, 41):  # 3 cm to the operator's right in 2 s
        device.move(x=0.03 * step / 40)
        pump(qapp, 0.05)
    pump(qapp, 1.0)
    # Expect the right of the operator behind the robot to be the robot's -y, in the tab and on /equilibrium_pose
    pose = equilibria.last().pose.position
    assert (pose.x - start[0], pose.y - start[1], pose.z - start[2]) == pytest.approx((0.0, -0.03, 0.0), abs=1e-3)
    assert tab.cells[1, 1].text() == f"{start[1] - 0.03:+.3f}"

    # Expect a device pose that is no pose to hold the arm, say why, and release the clutch
    device.raw((math.nan, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
    pump_until(qapp, lambda: "device pose refused" in tab.reason_label.text(), 5, "the refusal shown")
    assert tab.view.clutch is Clutch.RELEASED
    held = equilibria.last().pose.position
    device.move(x=0.0)
    pump(qapp, 0.5)
    assert "open the gripper, then close it" in tab.reason_label.text()
    assert equilibria.last().pose.position == held

    # Expect the device's loss to be shown loudly, the arm held
    device.close()  # like the device node ending: its topics go with it
    pump_until(qapp, lambda: tab.device_lost.isVisible(), 5, "DEVICE LOST shown")
    pump_until(qapp, lambda: tab.reason_label.text().startswith("device lost"), 5, "the reason: the device's silence")
    assert equilibria.last().pose.position == held
    window.screenshot().save(str(artifacts_dir / "gui_teleop_device_lost.png"))


def glide(qapp, device, start, end, seconds):
    """Move the handle in a straight line (x, y of the device) over ``seconds`` of wall time."""
    steps = int(seconds / 0.02)
    for step in range(1, steps + 1):
        fraction = step / steps
        device.move(x=start[0] + fraction * (end[0] - start[0]), y=start[1] + fraction * (end[1] - start[1]))
        pump(qapp, 0.02)


def clutched_glide(qapp, tab, device, start, end, seconds=2.0):
    """Close the gripper until the clutch engages, move the handle, open the gripper again; how long the move took."""
    device.set_gripper(0.0)
    pump_until(qapp, lambda: tab.view.clutch is Clutch.ENGAGED, 5, "the clutch engaged")
    began = time.monotonic()
    glide(qapp, device, start, end, seconds)
    took = time.monotonic() - began
    pump(qapp, 0.5)
    device.set_gripper(0.25)
    pump_until(qapp, lambda: tab.view.clutch is Clutch.RELEASED, 5, "the clutch released")
    return took


def record_path(qapp, window, device, start, end):
    double_click(device)
    pump_until(qapp, lambda: window.path_recorder.active, 5, "the path recording")
    took = clutched_glide(qapp, window.teleop, device, start, end)
    double_click(device)
    pump_until(qapp, lambda: not window.path_recorder.active, 5, "the path recording stopped")
    return took


def test_a_path_taught_in_teleop_is_taught_its_stiffness_in_low_level_and_becomes_a_dmp_skill(
    qapp,
    bt_node,
    robot_sim,
    device,
    make_window,
    topic_log,
    data_root,
    artifacts_dir,
):
    library_log = topic_log("/behaviour_tree/skill_library", SkillLibrary)
    equilibria = topic_log("/equilibrium_pose", PoseStamped)
    window = make_window()
    pump_until(qapp, lambda: window.high_level.library, 20, "the skill library in the GUI")
    open_teleop(qapp, window, device)
    device.move()
    tab = window.teleop
    pump_until(qapp, lambda: tab.view.driving and tab.view.equilibrium is not None, 30, "TELEOP driving the arm")

    # A first demonstration: 4 cm of handle away from the operator, the arm 4 cm forward
    took = [record_path(qapp, window, device, (0.0, 0.0), (0.0, 0.04))]
    saved = data_root / "trajectories" / "TaughtPath_1.yaml"
    pump_until(qapp, lambda: saved.is_file(), 5, "the taught path saved")
    taught = Trajectory.load(saved)
    assert (taught.frame, taught.starts_at_hand, taught.demonstrations) == ("target", True, 1)
    assert window.trajectory.name == "TaughtPath_1"
    # Expect the path kept relative to its gap: placed back at that gap, it ends where the arm was sent
    gap, why = window.worker.perception.target_in_base(taught.target)
    assert gap is not None, why
    end = taught.resolve(gap, np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0])).positions[-1]
    last = equilibria.last().pose.position
    assert np.linalg.norm(end - [last.x, last.y, last.z]) < 1e-4
    assert taught.positions[-1] - taught.positions[0] == pytest.approx(
        gap.rotation.inv().apply([0.04, 0.0, 0.0]), abs=1e-3
    )

    # Back to the start 1 cm to the robot's right (not recorded), and a second demonstration from there
    clutched_glide(qapp, tab, device, (0.0, 0.04), (0.01, 0.0))
    took.append(record_path(qapp, window, device, (0.01, 0.0), (0.01, 0.04)))
    pump_until(qapp, lambda: Trajectory.load(saved).demonstrations == 2, 5, "the second demonstration")
    taught = Trajectory.load(saved)
    demonstrations = [
        Trajectory.load(data_root / "trajectories" / "TaughtPath_1" / f"demonstration_{k}.yaml") for k in (1, 2)
    ]
    # Expect their mean half-way between them: at the ends, each demonstration is 5 mm from it
    for index in (0, -1):
        apart = np.linalg.norm(demonstrations[0].positions[index] - demonstrations[1].positions[index])
        assert taught.spread[index] == pytest.approx(apart / 2, abs=1e-4)
        assert apart == pytest.approx(0.01, abs=5e-4)
    # Expect each path as long as the handle moved (this window is on the wall clock), the pauses around left out
    assert [d.duration for d in demonstrations] == pytest.approx(took, abs=0.1)
    assert "2 demonstration(s)" in tab.path_label.text()
    window.screenshot().save(str(artifacts_dir / "gui_teleop_path_taught.png"))

    # LOW-LEVEL teaches the stiffness along the mean; the stiffness skill becomes a DMP skill of the library
    device.set_gripper(0.5)
    pump_until(qapp, lambda: window.tabs.currentIndex() == Tab.START, 5, "START")
    device.set_gripper(0.25)
    device.move(x=0.05)
    pump_until(qapp, lambda: window.start_tab.selected == 1, 5, "START to select LOW-LEVEL")
    device.click()
    pump_until(qapp, lambda: window.tabs.currentIndex() == Tab.LOW_LEVEL, 5, "LOW-LEVEL")
    pump_until(qapp, lambda: IMPEDANCE in running_controllers(), 30, "the impedance controller")
    double_click(device)
    pump_until(qapp, lambda: window.recorder.active, 10, "the stiffness recording")
    duration = window.player.trajectory.duration
    assert duration == pytest.approx(taught.duration, abs=0.01)
    pump(qapp, duration / REAL_TIME_FACTOR + 1.0)
    double_click(device)
    pump_until(qapp, lambda: not window.recorder.active, 5, "the stiffness recording stopped")
    learning = "learning DemonstratedPlace_1_dmp"
    pump_until(qapp, lambda: learning in window.statusBar().currentMessage(), 5, "the DMP being learned")

    # Expect the window closed while the DMP is learned to let it finish: the skill is there once the window is gone
    window.close()
    learned = skill_file.load(data_root / "skills" / "DemonstratedPlace_1_dmp.npz")

    def in_library():
        message = library_log.last()
        return message is not None and "DemonstratedPlace_1_dmp" in message.names

    pump_until(qapp, in_library, 5, "DemonstratedPlace_1_dmp in /behaviour_tree/skill_library")
    message = library_log.last()
    assert message.kinds[list(message.names).index("DemonstratedPlace_1_dmp")] == "dmp"
    assert "DemonstratedPlace_1" not in message.names  # the raw demonstration is what the DMP was learned from
    demonstration = skill_file.load(data_root / "skills" / "DemonstratedPlace_1.npz")
    assert demonstration.provenance["trajectory"] == "TaughtPath_1"
    assert demonstration.provenance["path_demonstrations"] == 2
    # Expect the path's spread along the skill's time (the replay's confidence), and in the learned skill too
    spread_time = demonstration.provenance["path_spread_time"]
    np.testing.assert_allclose(spread_time, taught.times, atol=1e-3)
    assert spread_time[-1] <= demonstration.duration + 0.5
    assert learned.provenance["path_spread"] == demonstration.provenance["path_spread"]
    assert window.trajectory.name == window.config.trajectory  # LOW-LEVEL back on its predefined trajectory
