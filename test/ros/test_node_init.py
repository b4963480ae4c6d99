"""teleteach.runtime.node.init_node against a real roscore: the rosout parameter that keeps rospy's logging cheap is set
to its default when missing, and a value the user chose is kept; static_scene with a broken scene file names what is
wrong in one line (a node without its parameters: test/unit/test_node_start.py)."""

import subprocess
import sys

from ros_processes import Processes, start_roscore, wait_until

from teleteach.runtime.node import ROSOUT_TOPICS_PARAM

PROBE = (
    "import rospy; from teleteach.runtime.node import init_node; init_node('probe', anonymous=True); "
    f"rospy.loginfo('probe up'); print(rospy.get_param_cached({ROSOUT_TOPICS_PARAM!r}))"
)


def rosparam(processes, *arguments):
    result = subprocess.run(["rosparam", *arguments], env=processes.env, capture_output=True, text=True, timeout=60)
    return result.returncode, result.stdout.strip()


def run_probe(processes):
    result = subprocess.run(
        [sys.executable, "-c", PROBE], env=processes.env, capture_output=True, text=True, timeout=60
    )
    assert result.returncode == 0, result.stderr
    return result.stdout.strip().splitlines()[-1]


def test_init_node_sets_the_rosout_parameter_only_when_missing(tmp_path):
    with Processes(tmp_path / "logs") as processes:
        start_roscore(processes)
        wait_until(lambda: rosparam(processes, "list")[0] == 0, 60, "roscore")
        assert rosparam(processes, "get", ROSOUT_TOPICS_PARAM)[0] != 0
        # Expect a node to set the missing parameter to rospy's default, and to read it from its cache
        assert run_probe(processes) == "False"
        assert rosparam(processes, "get", ROSOUT_TOPICS_PARAM) == (0, "false")
        # Expect a value the user set to be kept
        assert rosparam(processes, "set", ROSOUT_TOPICS_PARAM, "true")[0] == 0
        assert run_probe(processes) == "True"
        assert rosparam(processes, "get", ROSOUT_TOPICS_PARAM) == (0, "true")


def test_static_scene_with_a_broken_scene_file_names_it_in_one_line(tmp_path):
    node = subprocess.run(["rospack", "find", "teleteach"], capture_output=True, text=True, check=True).stdout.strip()
    broken = tmp_path / "shop.yaml"
    broken.write_text("product_defaults: {size: [0.06, 0.05, 0.14], mass: 0.3, friction: 0.6}\nproducts: []\n")
    with Processes(tmp_path / "logs") as processes:
        start_roscore(processes)
        result = subprocess.run(
            [sys.executable, f"{node}/nodes/static_scene", f"_scene_file:={broken}"],
            env=processes.env,
            capture_output=True,
            text=True,
            timeout=60,
        )
    # Expect: exit 2 with one fatal line naming the file and the missing section
    fatal = [line for line in result.stderr.splitlines() + result.stdout.splitlines() if "[FATAL]" in line]
    assert result.returncode == 2, result.stdout + result.stderr
    assert len(fatal) == 1 and f"static_scene cannot start: {broken}: KeyError('pick_table')" in fatal[0], fatal
