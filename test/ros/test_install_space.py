"""`catkin_make install` gives a package that runs without the source tree: robot_sim and a skill started from an
install space in a temporary directory, with its own environment (no devel space, no checkout on any path), and the
robot's meshes found through the package there."""

import os
import pathlib
import re
import subprocess
import sys

from conftest import ROOT
from ros_processes import Processes, start_roscore

SKILL = """
import sys, actionlib, rospy
from teleteach.msg import ExecuteSkillAction, ExecuteSkillGoal
import teleteach
rospy.init_node("install_space_check")
client = actionlib.SimpleActionClient("/skills/LookToShelf", ExecuteSkillAction)
assert client.wait_for_server(rospy.Duration(120.0)), "no /skills/LookToShelf"
client.send_goal(ExecuteSkillGoal(skill="LookToShelf"))
assert client.wait_for_result(rospy.Duration(120.0)), "LookToShelf did not finish"
print("result", client.get_result().success, client.get_result().message, "module", teleteach.__file__)
"""


def install_environment(prefix):
    """The environment of a shell that sourced only the install space's setup.bash and the virtualenv."""
    clean = {"PATH": "/usr/bin:/bin", "HOME": os.environ["HOME"], "ROS_IP": "127.0.0.1"}
    script = f"source {prefix}/setup.bash && source {ROOT}/.venv/bin/activate && env -0"
    dump = subprocess.run(["bash", "-c", script], env=clean, capture_output=True, check=True).stdout
    return dict(entry.split("=", 1) for entry in dump.decode().split("\0") if "=" in entry)


def test_an_install_space_runs_the_robot_and_a_skill(tmp_path):
    package = tmp_path / "ws" / "src" / "teleteach"
    package.mkdir(parents=True)
    for entry in ROOT.iterdir():
        if not entry.name.startswith(".") and entry.name not in ("build", "test-artifacts"):
            (package / entry.name).symlink_to(entry)
    prefix = tmp_path / "install"
    build = subprocess.run(
        ["catkin_make", "install", f"-DCMAKE_INSTALL_PREFIX={prefix}", f"-DPYTHON_EXECUTABLE={sys.executable}"],
        cwd=tmp_path / "ws",
        env={"PATH": "/usr/bin:/bin", "HOME": os.environ["HOME"]},
        capture_output=True,
        text=True,
        check=False,
    )
    assert build.returncode == 0, build.stdout[-3000:] + build.stderr[-3000:]
    env = install_environment(prefix)
    assert str(ROOT) not in env.get("PYTHONPATH", "") + env.get("ROS_PACKAGE_PATH", "")
    with Processes(tmp_path / "logs", env=env) as processes:
        start_roscore(processes)
        processes.start("sim", ["roslaunch", "teleteach", "sim.launch", "real_time_factor:=0"])
        skill = subprocess.run(
            [env["VIRTUAL_ENV"] + "/bin/python", "-c", SKILL],
            env=processes.env,
            capture_output=True,
            text=True,
            timeout=300,
            check=False,
        )
        assert skill.returncode == 0, skill.stdout + skill.stderr + processes.log("sim")[-3000:]
        # Expect: the skill ran on the robot, and everything came from the install space
        assert "result True looking at the shelf, gripper open" in skill.stdout, skill.stdout
        assert f"module {prefix}/lib/python3/dist-packages/teleteach/__init__.py" in skill.stdout, skill.stdout
        commands = subprocess.run(["ps", "-eo", "args"], capture_output=True, text=True, check=True).stdout
        for node in ("robot_sim", "skill_server"):
            assert f"{prefix}/lib/teleteach/{node}" in commands, commands
        # Expect: the robot description names its meshes through the package, and ROS finds every one of them in the
        # install space (what RViz on another machine with teleteach installed does)
        read = "import rosgraph; print(rosgraph.Master('/install_space_check').getParam('/robot_description'))"
        description = subprocess.run(
            [env["VIRTUAL_ENV"] + "/bin/python", "-c", read],
            env=processes.env,
            capture_output=True,
            text=True,
            check=True,
        ).stdout
        share = subprocess.run(
            ["rospack", "find", "teleteach"], env=processes.env, capture_output=True, text=True, check=True
        ).stdout.strip()
        assert share == f"{prefix}/share/teleteach", share
        meshes = sorted(set(re.findall(r'filename="([^"]+)"', description)))
        assert len(meshes) > 10 and all(mesh.startswith("package://teleteach/meshes/panda/") for mesh in meshes)
        missing = [mesh for mesh in meshes if not (pathlib.Path(share) / mesh[len("package://teleteach/") :]).is_file()]
        assert missing == [], missing
