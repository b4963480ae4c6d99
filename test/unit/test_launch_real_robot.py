"""full.launch real_robot:=true beside franka_ros: no node of the same name as franka_control.launch's, and the
controllers of config/robot_controllers.yaml's franka section handed to the GUI and the skills."""

import pathlib
import re
import shlex
import subprocess

import yaml

from teleteach.core.robot_controllers import controller_names

# The nodes franka_ros' franka_control/launch/franka_control.launch (noetic-devel) starts, and those of
# platonics-delft/franka_impedance_controller's launch/franka_control.launch and
# cartesian_variable_impedance_controller.launch (173448f6bfef6b08103b04c56f3a6c86c4cbcec0): roslaunch kills the older
# of two nodes of one name, so none may appear in full.launch's real-robot system.
ROOT = pathlib.Path(__file__).resolve().parents[2]
FRANKA_CONTROL_NODES = {
    "/franka_control",
    "/franka_gripper",
    "/state_controller_spawner",
    "/robot_state_publisher",
    "/joint_state_publisher",
    "/controller_spawner",
    "/rviz",
}


def launch(option, *args):
    return subprocess.run(
        ["roslaunch", option, "teleteach", "full.launch", *args], capture_output=True, text=True, check=True
    ).stdout


def test_a_real_robot_system_starts_no_node_franka_control_launch_starts():
    nodes = {line.strip() for line in launch("--nodes", "real_robot:=true", "rviz:=false").splitlines()}
    assert nodes & FRANKA_CONTROL_NODES == set()
    assert {"/skill_server", "/behaviour_tree", "/teaching_gui", "/stiffness_bridge"} <= nodes


def test_the_real_robot_s_controllers_reach_the_gui_and_the_skills():
    params = yaml.safe_load(launch("--dump-params", "real_robot:=true"))
    assert params["/teaching_gui/controllers"] == params["/skill_server/controllers"] == "franka"
    assert controller_names("franka").impedance == "cartesian_variable_impedance_controller"
    params = yaml.safe_load(launch("--dump-params"))
    assert params["/teaching_gui/controllers"] == "simulation"


def full_launch_lines(text):
    """The ``roslaunch teleteach full.launch ...`` commands of a page (in code blocks or inline), as argument lists."""
    commands = []
    for match in re.finditer(r"roslaunch teleteach full\.launch([^`#\n]*)", text):
        commands.append(shlex.split(match.group(1).replace("$HOME", "/home/operator")))
    return commands


def test_every_full_launch_line_of_the_real_robot_page_starts_no_simulated_robot():
    """A reader copies these lines on the robot PC: robot_sim there would publish its own /joint_states and /clock
    beside franka_control's."""
    commands = full_launch_lines((ROOT / "docs" / "real_robot.md").read_text())
    assert len(commands) >= 2, commands
    for arguments in commands:
        nodes = set(launch("--nodes", *arguments, "rviz:=false").split())
        assert "/robot_sim" not in nodes, arguments
        assert {"/skill_server", "/behaviour_tree", "/teaching_gui"} <= nodes, arguments
