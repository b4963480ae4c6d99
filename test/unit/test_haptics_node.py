"""The sigma7 node's params, and its refusals run for real: the node against a roscore started here, on a free port.

Bad scenario files and a missing Force Dimension SDK must make the node exit non-zero with one line naming the
problem (file:line, keyframe index and field; or the library), before it publishes anything.
"""

import itertools
import os
import pathlib
import signal
import subprocess
import textwrap

import pytest
import roslib.packages

from teleteach.haptics.ros import Sigma7Config
from teleteach.run.processes import Processes, own_master

ROOT = pathlib.Path(__file__).resolve().parents[2]


def params(**values):
    return lambda name, default: values.get(name.lstrip("~").replace("/", "_"), default)


def test_config_reads_every_param():
    config = Sigma7Config.from_params(
        params(
            backend="dhd", rate=500, click_close_threshold=0.05, click_release_threshold=0.15, dhd_native_button=True
        )
    )
    assert config.backend == "dhd"
    assert config.rate == 500.0
    assert (config.click.close_threshold, config.click.release_threshold) == (0.05, 0.15)
    assert config.dhd_native_button is True
    assert Sigma7Config.from_params(params(scenario="x.yaml")).rate == 1000.0
    assert Sigma7Config.from_params(params(scenario="x.yaml")).hand_model is None
    hand = Sigma7Config.from_params(params(scenario="x.yaml", hand_enabled=True, hand_tremor_rms=0.002, hand_seed=7))
    assert (hand.hand_model.tremor_rms, hand.hand_model.seed, hand.hand_model.mass) == (0.002, 7, 0.3)


@pytest.mark.parametrize(
    ("values", "expected"),
    [
        ({"backend": "joystick"}, "~backend must be one of dhd, scenario, virtual"),
        ({"backend": "scenario"}, "needs ~scenario"),
        ({"scenario": "x.yaml", "rate": 0}, "~rate must be a positive number"),
        ({"scenario": "x.yaml", "at_end": "loop"}, "~at_end must be one of hold, exit"),
        ({"scenario": "x.yaml", "click_close_threshold": 0.3}, "close_threshold < release_threshold"),
        ({"backend": "dhd", "hand_enabled": True}, "~hand/enabled models a hand for the scenario and virtual"),
        ({"scenario": "x.yaml", "hand_enabled": True, "hand_mass": -1.0}, "hand mass must be a positive number"),
        ({"scenario": "x.yaml", "force_rate": 2000.0}, r"~force_rate must be in \(0, ~rate\]"),
    ],
)
def test_config_refuses_bad_params(values, expected):
    with pytest.raises(ValueError, match=expected):
        Sigma7Config.from_params(params(**values))


@pytest.fixture(scope="module")
def roscore(tmp_path_factory):
    """A roscore of our own on a free port (own_master), stopped by its PID afterwards."""
    env = dict(os.environ, ROS_LOG_DIR=str(tmp_path_factory.mktemp("log")))
    processes = Processes()

    def start_roscore(port):
        env["ROS_MASTER_URI"] = f"http://localhost:{port}"
        return processes.start("roscore", ["roscore", "-p", str(port)], env=env)

    own_master(start_roscore, processes.stop)
    try:
        yield env
    finally:
        processes.stop_all()


RUNS = itertools.count()


def run_node(env, *args):
    """The node once, under a name of its own: private parameters set on the command line stay on the master, and
    another test's (e.g. ~dhd/library) must not reach this run."""
    node = roslib.packages.find_node("teleteach", "sigma7_node")[0]  # what roslaunch and rosrun run
    name = f"sigma7_refusal_{next(RUNS)}"
    return subprocess.run([node, f"__name:={name}", *args], env=env, capture_output=True, text=True, timeout=60)


def fatal_line(result):
    lines = [line for line in result.stderr.splitlines() if "[FATAL]" in line]
    assert len(lines) == 1, result.stdout + result.stderr
    return lines[0]


@pytest.mark.parametrize(
    ("second_keyframe", "expected"),
    [
        ("{t: 1.0, position: [0, 0, 0], rpy: [0, 0, 0]}", ":3: keyframes[1]: missing field 'gripper'"),
        ("{t: 0.0, position: [0, 0, 0], rpy: [0, 0, 0], gripper: 0.25}", ":3: keyframes[1].t: times must increase"),
        (
            "{t: 1.0, position: [0, .nan, 0], rpy: [0, 0, 0], gripper: 0.25}",
            ":3: keyframes[1].position: must be finite",
        ),
    ],
    ids=["missing_field", "non_monotonic", "nan"],
)
def test_node_refuses_a_bad_scenario(roscore, tmp_path, second_keyframe, expected):
    scenario = tmp_path / "bad.yaml"
    scenario.write_text(
        textwrap.dedent(
            f"""\
            keyframes:
              - {{t: 0.0, position: [0, 0, 0], rpy: [0, 0, 0], gripper: 0.25}}
              - {second_keyframe}
            """
        )
    )
    result = run_node(roscore, "_backend:=scenario", f"_scenario:={scenario}")
    assert result.returncode == 1
    assert f"sigma7_node cannot start: {scenario}{expected}" in fatal_line(result)


def test_node_refuses_a_click_its_thresholds_cannot_detect(roscore, tmp_path):
    scenario = tmp_path / "low.yaml"
    scenario.write_text(
        "keyframes:\n"
        "  - {t: 0.0, position: [0, 0, 0], rpy: [0, 0, 0], gripper: 0.25, click: true}\n"
        "  - {t: 1.0, position: [0, 0, 0], rpy: [0, 0, 0], gripper: 0.25}\n"
    )
    result = run_node(roscore, "_backend:=scenario", f"_scenario:={scenario}", "_click/release_threshold:=0.3")
    assert result.returncode == 1
    assert f"{scenario}:2: keyframes[0].click: this flick would not be detected" in fatal_line(result)


def test_node_without_the_force_dimension_sdk_says_so_in_one_line(roscore):
    result = run_node(roscore, "_backend:=dhd")
    assert result.returncode == 1
    assert "sigma7_node cannot start: Force Dimension SDK library not found (tried libdhd.so, libdhd.so.3)" in (
        fatal_line(result)
    )


def test_device_launch_with_dhd_ends_with_the_node_exit_code(roscore):
    result = subprocess.run(
        ["roslaunch", "teleteach", "device.launch", "backend:=dhd", "required:=true"],
        env=roscore,
        capture_output=True,
        text=True,
        timeout=120,
    )
    output = result.stdout + result.stderr
    assert "Force Dimension SDK library not found" in output
    assert "exit code 1" in output


def test_virtual_backend_without_a_display_says_so(roscore):
    env = {key: value for key, value in roscore.items() if key not in ("DISPLAY", "WAYLAND_DISPLAY")}
    result = run_node(env, "_backend:=virtual")
    assert result.returncode == 1
    assert "the virtual backend needs a display, but DISPLAY is not set" in fatal_line(result)


@pytest.mark.gui
def test_virtual_backend_publishes_from_its_window(roscore):
    assert os.environ.get("DISPLAY"), "pytest-xvfb provides the X server"
    node = roslib.packages.find_node("teleteach", "sigma7_node")[0]
    process = subprocess.Popen(
        [node, "__name:=sigma7_virtual", "_backend:=virtual"],
        env=roscore,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        echo = subprocess.run(
            ["rostopic", "echo", "-n", "1", "/sigma7/gripper_angle"],
            env=roscore,
            capture_output=True,
            text=True,
            timeout=60,
        )
        assert "data: 0.25" in echo.stdout, echo.stdout + echo.stderr
    finally:
        process.send_signal(signal.SIGINT)
        output, _ = process.communicate(timeout=30)
    assert process.returncode == 0, output
    assert "published" in output and "cycles at" in output


@pytest.fixture(scope="module")
def fake_dhd(tmp_path_factory):
    """test/data/fake_dhd.c (the SDK's C functions, simulated device) compiled into a shared library."""
    library = tmp_path_factory.mktemp("fake_dhd") / "libdhd.so"
    subprocess.run(
        ["cc", "-shared", "-fPIC", "-o", str(library), str(ROOT / "test/data/fake_dhd.c"), "-lm"], check=True
    )
    return str(library)


def test_node_without_a_device_says_so_in_one_line(roscore, fake_dhd):
    result = run_node(dict(roscore, FAKE_DHD_DEVICES="0"), "_backend:=dhd", f"_dhd/library:={fake_dhd}")
    assert result.returncode == 1
    assert "sigma7_node cannot start: no Force Dimension device found: dhdOpen failed (no device found)" in (
        fatal_line(result)
    )


def test_node_publishes_what_the_dhd_library_reports(roscore, fake_dhd):
    node = roslib.packages.find_node("teleteach", "sigma7_node")[0]
    env = dict(roscore, FAKE_DHD_DEVICES="1")
    process = subprocess.Popen(
        [node, "__name:=sigma7_dhd", "_backend:=dhd", f"_dhd/library:={fake_dhd}"],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        echo = subprocess.run(
            ["rostopic", "echo", "-n", "1", "/sigma7/pose"], env=env, capture_output=True, text=True, timeout=60
        )
        assert "x: 0.01\n    y: 0.02\n    z: 0.03" in echo.stdout, echo.stdout + echo.stderr
        assert "z: 0.247403959" in echo.stdout  # sin(0.25): the 0.5 rad yaw of the fake device
    finally:
        process.send_signal(signal.SIGINT)
        output, _ = process.communicate(timeout=30)
    assert process.returncode == 0, output
