"""Starting a node: --help without a master lists what it does and its parameters with the yaml's defaults; a library
at another version than the pinned one stops it in one line; a node run without a launch file has its parameters."""

import os
import signal
import subprocess
import time

import pytest
import yaml
from conftest import ROOT

from teleteach.core import pins
from teleteach.runtime.node import file_parameters, node_parameters, parameters_help, yaml_parameters

NODES = sorted(path for path in (ROOT / "nodes").iterdir() if path.is_file())
PARAMETER_FILES = {  # each node's yaml: every key must show in its --help
    "behaviour_tree": "behaviour_tree.yaml",
    "ellipsoid_marker": "ellipsoid_marker.yaml",
    "shared_control": "shared_control.yaml",
    "sigma7_node": "device.yaml",
    "static_scene": "static_scene.yaml",
    "stiffness_bridge": "stiffness_bridge.yaml",
    "teaching_gui": "gui.yaml",
}


def without_master():
    """An environment whose master cannot be reached, and no display: --help must need neither."""
    env = {key: value for key, value in os.environ.items() if key not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env["ROS_MASTER_URI"] = "http://127.0.0.1:1"
    return env


@pytest.mark.parametrize("node", NODES, ids=[path.name for path in NODES])
def test_help_says_what_the_node_does_and_its_parameters_without_a_master(node):
    result = subprocess.run(
        [str(node), "--help"], env=without_master(), capture_output=True, text=True, timeout=180, cwd=ROOT
    )
    # Expect usage, the node's own first line, and no attempt to reach ROS (rospy would hang, then fail on time)
    assert result.returncode == 0, result.stdout + result.stderr
    assert result.stdout.startswith(f"usage: {node.name}"), result.stdout
    assert "Failed to initialize time" not in result.stderr and "Traceback" not in result.stderr, result.stderr
    if node.name in PARAMETER_FILES:
        keys = [entry.name for entry in file_parameters(PARAMETER_FILES[node.name])]
        assert keys and "shared" not in keys  # a shared section's keys are listed, not its name
        missing = [key for key in keys if f"~{key} (default " not in result.stdout]
        assert missing == []


def test_the_parameters_of_a_yaml_with_nested_keys_and_continued_comments():
    text = "rate: 10.0   # [Hz] how often\n             #   and more\nclick:\n  close: 0.1  # [rad] closed\nname: ''\n"
    entries = [(entry.name, entry.default, entry.meaning) for entry in yaml_parameters(text)]
    assert entries == [
        ("rate", "10.0", "[Hz] how often and more"),
        ("click/close", "0.1", "[rad] closed"),
        ("name", "''", ""),
    ]
    assert "~click/close (default 0.1): [rad] closed" in parameters_help(parameters=yaml_parameters(text))


def test_a_library_at_another_version_than_pinned_is_named_with_the_fix():
    wanted = pins.pinned(pins.requirements_file())
    assert wanted["py_trees"] and wanted["casadi"]  # the check compares something
    assert pins.problems() == []
    found = pins.problems(dict(wanted, py_trees="0.7.6"))
    assert len(found) == 1 and found[0].startswith("py_trees 2.") and "(teleteach needs 0.7.6)" in found[0]
    assert pins.requirements_file((3, 8)).name == "requirements-noetic.txt"


def test_a_node_with_a_shadowing_py_trees_stops_in_one_line(tmp_path):
    """An apt py_trees 0.7 first on the path (as on Noetic with python3-py-trees): the node says so and stops."""
    metadata = tmp_path / "py_trees-0.7.6.dist-info"
    metadata.mkdir()
    (metadata / "METADATA").write_text("Metadata-Version: 2.1\nName: py_trees\nVersion: 0.7.6\n")
    env = dict(without_master(), PYTHONPATH=f"{tmp_path}:{os.environ.get('PYTHONPATH', '')}")
    result = subprocess.run(
        [str(ROOT / "nodes" / "behaviour_tree")], env=env, capture_output=True, text=True, timeout=180
    )
    lines = result.stderr.strip().splitlines()
    assert result.returncode == 1 and len(lines) == 1, result.stderr
    assert lines[0].startswith(f"behaviour_tree cannot start: py_trees 0.7.6 from {tmp_path}")
    assert "teleteach needs 2." in lines[0] and "scripts/setup" in lines[0]


def test_the_runtime_libraries_are_pinned_in_both_requirement_files():
    for path in (ROOT / "requirements.txt", ROOT / "requirements-noetic.txt"):
        pinned = pins.pinned(path)
        assert {"numpy", "casadi", "pybullet", "py_trees", "rosbags"} <= set(pinned), path


def test_the_yaml_defaults_are_the_node_defaults_in_the_help():
    device = yaml.safe_load((ROOT / "config" / "device.yaml").read_text())
    assert f"~rate (default {device['rate']})" in parameters_help("device.yaml")


def test_a_node_with_two_yamls_lists_both_in_its_help():
    # Expect the behaviour tree's own parameters and its tree policy's (the thresholds a study varies), both named
    text = parameters_help(("behaviour_tree.yaml", "tree_policy.yaml"))
    assert "~tick_rate (default 10.0)" in text and "~veto_window (default 5.0)" in text
    assert "defaults from config/behaviour_tree.yaml, config/tree_policy.yaml" in text


def test_shared_control_without_a_launch_file_runs_on_its_yaml(roscore, tmp_path):
    """rosrun teleteach shared_control died with KeyError: '~'; its parameters now come from its yaml.

    Its stdout is a file and PYTHONUNBUFFERED is unset, as in a CI log or ``roslaunch ... | tee``: the log line must
    be there while the node runs, not only once it exits (CI waited 600 s for a quiet node's line).
    """
    log = tmp_path / "shared_control.log"
    env = {key: value for key, value in roscore.items() if key != "PYTHONUNBUFFERED"}
    with open(log, "w") as output:
        process = subprocess.Popen(
            [str(ROOT / "nodes" / "shared_control"), "_solver:=fast"], env=env, stdout=output, stderr=output
        )
    try:
        deadline = time.monotonic() + 120
        while (
            time.monotonic() < deadline and process.poll() is None and "shared_control: running" not in log.read_text()
        ):
            time.sleep(0.2)
        running = process.poll() is None and "shared_control: running" in log.read_text()
    finally:
        process.send_signal(signal.SIGINT)
        process.wait(60)
    text = log.read_text()
    assert running, f"no log line while the node ran:\n{text}"
    assert "KeyError" not in text and "Traceback" not in text, text


def test_a_nested_parameter_is_overridden_key_by_key():
    """A launch that sets only ~plane/origin keeps the yaml's plane/normal (the server answers with what is set)."""
    defaults = yaml.safe_load((ROOT / "config" / "shared_control.yaml").read_text())
    overrides = {"~plane": {"origin": [0.5, 0.0, 0.4]}, "~twist_scale": 3.0}
    parameters = node_parameters("shared_control.yaml", lambda name, default: overrides.get(name, default))
    assert parameters["plane"] == {**defaults["plane"], "origin": [0.5, 0.0, 0.4]}
    assert parameters["twist_scale"] == 3.0
    assert parameters["boundary"] == defaults["boundary"]


def fatal_start(env, node, *arguments) -> str:
    """Run a node that must not start: it exits with status 2 and one fatal line, returned."""
    result = subprocess.run(
        [str(ROOT / "nodes" / node), *arguments], env=env, capture_output=True, text=True, timeout=120
    )
    output = result.stdout + result.stderr
    fatal = [line for line in output.splitlines() if "[FATAL]" in line]
    assert result.returncode == 2 and len(fatal) == 1, output
    assert "Traceback" not in output, output
    return fatal[0]


def test_a_bad_parameter_ends_the_node_in_one_fatal_line(roscore):
    fatal = fatal_start(roscore, "shared_control", "_solver:=fast", "_twist_projection:=[[1.0, 0.0]]")
    assert "shared_control cannot start: twist_projection must be a finite 2 x 3 matrix" in fatal


def test_a_bad_motion_file_ends_the_skill_server_in_one_fatal_line(roscore, tmp_path):
    motion = tmp_path / "motion.yaml"
    motion.write_text("speeds: fast\n")
    assert f"skill_server cannot start: {motion}" in fatal_start(roscore, "skill_server", f"_motion_file:={motion}")


def test_a_bad_uncertainty_file_ends_the_simulator_in_one_fatal_line(roscore, tmp_path):
    uncertainty = tmp_path / "uncertainty.yaml"
    uncertainty.write_text("seed: -3\n")
    fatal = fatal_start(roscore, "robot_sim", f"_uncertainty_file:={uncertainty}")
    assert "robot_sim cannot start: " in fatal and str(uncertainty) in fatal, fatal


def test_a_node_without_a_required_parameter_names_it_in_one_line(roscore):
    assert fatal_start(roscore, "device_monitor").endswith(
        "device_monitor cannot start: missing parameter ~scenario (the scenario file to listen for)"
    )
