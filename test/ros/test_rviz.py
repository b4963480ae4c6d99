"""RViz with the teleteach layout: a valid config, and a real RViz under Xvfb showing the simulated robot, the
supermarket scene and the stiffness ellipsoid for 10 s without errors (screenshot kept in test-artifacts/)."""

import re
import shutil
import subprocess
import time

import pytest
import yaml
from conftest import ROOT
from ros_processes import Processes, start_roscore, start_xvfb, wait_until

CONFIG = ROOT / "rviz" / "teleteach.rviz"
ERROR_LINE = re.compile(r"\[ *(ERROR|FATAL)\]|has died|Segmentation fault|Traceback")
# pybullet_data 3.2.7's Panda meshes (collision/link0.obj, link7.obj, used as visuals) name a material whose texture
# is a Windows path of its author ("D:\dev\pybullet_robots\..."): RViz reports it and draws those links untextured.
# An upstream data defect, allowed by this exact path only; any other error fails the test.
UPSTREAM_TEXTURE = "D:\\dev\\pybullet_robots\\data\\franka_panda\\meshes\\visual\\colors.png"


def displays(config):
    return {display["Name"]: display for display in config["Visualization Manager"]["Displays"]}


def test_rviz_config_is_valid_yaml_with_every_display():
    # RViz silently falls back to its default layout when the YAML is invalid: check it here.
    config = yaml.safe_load(CONFIG.read_text())
    manager = config["Visualization Manager"]
    assert manager["Global Options"]["Fixed Frame"] == "world"
    shown = displays(config)
    assert shown["RobotModel"]["Class"] == "rviz/RobotModel"
    assert shown["RobotModel"]["Robot Description"] == "robot_description"
    assert shown["Scene"] == {**shown["Scene"], "Class": "rviz/MarkerArray", "Marker Topic": "/teleteach/scene"}
    assert shown["StiffnessEllipsoid"]["Marker Topic"] == "/visualization_marker"
    assert shown["EquilibriumPose"] == {**shown["EquilibriumPose"], "Class": "rviz/Pose", "Topic": "/equilibrium_pose"}
    assert shown["TF"]["Class"] == "rviz/TF"
    assert all(display["Enabled"] for display in shown.values())
    view = manager["Views"]["Current"]
    assert view["Class"] == "rviz/Orbit" and view["Focal Point"]["X"] > 1.0  # looks toward the shelf (x = 2 m)
    assert isinstance(config["Window Geometry"]["QMainWindow State"], str)


def publish(processes, name, topic, msg_type, yaml_message, rate=10):
    return processes.start(name, ["rostopic", "pub", "-r", str(rate), topic, msg_type, yaml_message])


@pytest.mark.gui
def test_rviz_shows_robot_scene_and_ellipsoid_without_errors(tmp_path, artifacts_dir):
    with Processes(tmp_path) as processes:
        start_xvfb(processes)
        start_roscore(processes)
        processes.start("sim", ["roslaunch", "teleteach", "sim.launch", "skills:=false"])
        publish(
            processes,
            "eigenvalues",
            "/eigenvalues",
            "geometry_msgs/Vector3Stamped",
            "{header: {frame_id: base_link}, vector: {x: 1000, y: 3000, z: 2000}}",
        )
        publish(
            processes,
            "eigenvectors",
            "/eigenvectors",
            "geometry_msgs/QuaternionStamped",
            "{header: {frame_id: base_link}, quaternion: {x: 0, y: 0, z: 0.3826834, w: 0.9238795}}",
        )

        def marker_published():
            result = subprocess.run(
                ["rostopic", "echo", "-n", "1", "/visualization_marker/type"],
                env=processes.env,
                capture_output=True,
                text=True,
                timeout=30,
            )
            return result.stdout.startswith("2")

        rviz = processes.start("rviz", ["roslaunch", "teleteach", "rviz.launch"])
        wait_until(marker_published, 60, "the ellipsoid marker (SPHERE) on /visualization_marker")
        time.sleep(10.0)
        assert rviz.poll() is None, processes.log("rviz")
        screenshot = tmp_path / "rviz.png"
        subprocess.run(["import", "-window", "root", str(screenshot)], env=processes.env, check=True, timeout=30)
        shutil.copy(screenshot, artifacts_dir / "rviz.png")
        # The 10 s of running are what is judged (errors go to stderr, unbuffered): RViz 1.14 on llvmpipe sometimes
        # segfaults while tearing down. Its INFO lines (stdout, buffered in a pipe) may only arrive at the stop.
        running_log = processes.log("rviz")
        processes.stop("rviz")
        log = processes.log("rviz")
    assert "rviz version" in log, log
    errors = [line for line in running_log.splitlines() if ERROR_LINE.search(line) and UPSTREAM_TEXTURE not in line]
    assert errors == [], "\n".join(errors)
    assert screenshot.stat().st_size > 50_000
