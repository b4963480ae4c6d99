"""The sigma7 node's params, and its refusals run for real: the node against a roscore started here, on a free port.

Bad scenario files and a missing Force Dimension SDK must make the node exit non-zero with one line naming the
problem (file:line, keyframe index and field; or the library), before it publishes anything. With the Force Dimension
SDK's C stand-in (test/data/fake_dhd.c) the node publishes what the library reports and sends the guidance's forces
to it, bounded by the caps.
"""

import itertools
import math
import os
import pathlib
import signal
import subprocess
import textwrap
import time

import numpy as np
import pytest
import roslib.packages

from teleteach.haptics.guidance import GuidanceError, GuidanceLimits, render
from teleteach.haptics.ros import Sigma7Config, guidance_from_message
from teleteach.msg import HapticGuidance

ROOT = pathlib.Path(__file__).resolve().parents[2]


def params(**values):
    """``get_param`` of a parameter server holding ``values`` (a section as a mapping of the keys it overrides)."""
    return lambda name, default: values.get(name.lstrip("~"), default)


def echo_once(topic, env):
    """One message of topic as ``rostopic echo`` prints it (the CompletedProcess: stdout, and stderr to show)."""
    return subprocess.run(["rostopic", "echo", "-n", "1", topic], env=env, capture_output=True, text=True, timeout=60)


def test_config_reads_every_param():
    config = Sigma7Config.from_params(
        params(
            backend="dhd",
            rate=500,
            click={"close_threshold": 0.05, "release_threshold": 0.15},
            dhd={"native_button": True},
        )
    )
    assert config.backend == "dhd"
    assert config.rate == 500.0
    assert (config.click.close_threshold, config.click.release_threshold) == (0.05, 0.15)
    assert config.dhd.native_button is True and config.dhd.library == ""
    assert config.click.max_duration == 0.5  # the yaml's, the rest of the section overridden
    assert Sigma7Config.from_params(params(scenario="x.yaml")).rate == 1000.0
    assert Sigma7Config.from_params(params(scenario="x.yaml")).hand_model is None
    hand = Sigma7Config.from_params(params(scenario="x.yaml", hand={"enabled": True, "tremor_rms": 0.002, "seed": 7}))
    assert (hand.hand_model.tremor_rms, hand.hand_model.seed, hand.hand_model.mass) == (0.002, 7, 0.3)


@pytest.mark.parametrize(
    ("values", "expected"),
    [
        ({"backend": "joystick"}, "~backend must be one of dhd, scenario, virtual, topic"),
        ({"backend": "scenario"}, "needs ~scenario"),
        ({"scenario": "x.yaml", "rate": 0}, "~rate must be a positive number"),
        ({"scenario": "x.yaml", "at_end": "loop"}, "~at_end must be one of hold, exit"),
        ({"scenario": "x.yaml", "click": {"close_threshold": 0.3}}, "close_threshold < release_threshold"),
        (
            {"backend": "dhd", "hand": {"enabled": True}},
            "~hand/enabled models a hand for the scenario, virtual and topic",
        ),
        ({"scenario": "x.yaml", "hand": {"enabled": True, "mass": -1.0}}, "hand mass must be a positive number"),
        ({"scenario": "x.yaml", "twist": {"cutoff": 5.0}}, r"\(config/device.yaml\): unknown twist/cutoff$"),
        ({"scenario": "x.yaml", "force_rate": 2000.0}, r"~force_rate must be in \(0, ~rate\]"),
        ({"scenario": "x.yaml", "publish_rate": 0.0}, "~publish_rate must be a positive number"),
    ],
)
def test_config_refuses_bad_params(values, expected):
    with pytest.raises(ValueError, match=expected):
        Sigma7Config.from_params(params(**values))


def random_message(rng):
    """A plausible guidance, or (half of the time) one with a few fields NaN, infinite, negative, huge or unknown."""
    message = HapticGuidance()
    message.modes = [str(rng.choice(["free", "hold", "detents"])) for _ in range(6)]
    message.centres = list(rng.uniform(-0.1, 0.1, 6))
    message.stiffness = list(rng.uniform(0.0, 1e4, 6))
    message.detent_widths = list(rng.uniform(1e-3, 0.2, 6))
    message.damping = list(rng.uniform(0.0, 50.0, 6))
    for axis in ("x", "y", "z", "roll", "pitch", "yaw"):
        setattr(message, f"detents_{axis}", list(rng.uniform(-0.2, 0.2, int(rng.integers(1, 30)))))
    message.gripper_click = bool(rng.integers(2))
    message.gripper_detent, message.gripper_width = rng.uniform(0.0, 0.5), rng.uniform(1e-3, 0.2)
    message.gripper_stiffness = rng.uniform(0.0, 100.0)
    message.max_force, message.max_torque = rng.uniform(0.0, 50.0), rng.uniform(0.0, 2.0)
    if rng.integers(2):
        arrays = ("centres", "stiffness", "detent_widths", "damping", "detents_x", "detents_roll")
        scalars = ("gripper_detent", "gripper_width", "gripper_stiffness", "max_force", "max_torque")
        for _ in range(int(rng.integers(1, 4))):
            bad = float(rng.choice([math.nan, math.inf, -math.inf, -1.0, 1e300]))
            field = str(rng.choice(arrays + scalars + ("modes",)))
            if field == "modes":
                message.modes[int(rng.integers(6))] = str(rng.choice(["sticky", "", "HOLD"]))
            elif field in arrays:
                values = list(getattr(message, field))
                values[int(rng.integers(len(values)))] = bad
                setattr(message, field, values)
            else:
                setattr(message, field, bad)
    return message


def test_any_guidance_message_is_refused_with_a_reason_or_rendered_finite_and_within_the_caps():
    rng = np.random.default_rng(11)
    limits = GuidanceLimits.from_yaml()
    rendered = refused = 0
    for _ in range(3000):
        message = random_message(rng)
        try:
            guidance = guidance_from_message(message)
        except GuidanceError as error:
            assert str(error), "a refusal says why"
            refused += 1
            continue
        for _ in range(5):
            position, velocity, spin = rng.uniform(-0.3, 0.3, 3), rng.uniform(-5.0, 5.0, 3), rng.uniform(-20, 20, 3)
            quaternion = rng.normal(size=4)
            wrench = render(guidance, limits, position, quaternion / np.linalg.norm(quaternion), velocity, spin, 0.2)
            assert np.all(np.isfinite(wrench.force)) and np.all(np.isfinite(wrench.torque))
            assert np.linalg.norm(wrench.force) <= min(limits.max_force, message.max_force) + 1e-9
            assert np.linalg.norm(wrench.torque) <= min(limits.max_torque, message.max_torque) + 1e-9
            assert math.isfinite(wrench.gripper) and abs(wrench.gripper) <= limits.max_gripper_force + 1e-9
        rendered += 1
    # Expect both outcomes to have been exercised many times
    assert rendered > 100 and refused > 100, (rendered, refused)


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
    # Expect the launch to end by itself (the operator's own device is required by default), saying why
    result = subprocess.run(
        ["roslaunch", "teleteach", "device.launch", "backend:=dhd"],
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
        echo = echo_once("/sigma7/gripper_angle", roscore)
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
        echo = echo_once("/sigma7/pose", env)
        # Expect the operator frame (config/device.yaml axes: dhd force_dimension): the SDK's (0.01, 0.02, 0.03), x
        # toward the operator and y to the right, is 0.02 to the operator's right and 0.01 towards them
        assert "x: 0.02\n    y: -0.01\n    z: 0.03" in echo.stdout, echo.stdout + echo.stderr
        assert "z: 0.247403959" in echo.stdout  # sin(0.25): the 0.5 rad yaw of the fake device, about the same z
    finally:
        process.send_signal(signal.SIGINT)
        output, _ = process.communicate(timeout=30)
    assert process.returncode == 0, output


def test_the_node_sends_the_guidance_to_the_sdk_bounded_and_ends_at_zero(roscore, fake_dhd, tmp_path):
    """The real node renders /sigma7/guidance through the stand-in library, which records every force command."""
    record = tmp_path / "received.txt"
    node = roslib.packages.find_node("teleteach", "sigma7_node")[0]
    env = dict(roscore, FAKE_DHD_DEVICES="1", FAKE_DHD_RECORD=str(record))
    process = subprocess.Popen(
        [node, "__name:=sigma7_dhd_forces", "_backend:=dhd", f"_dhd/library:={fake_dhd}"],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    # Springs to the origin far stiffer than the caps allow: the stand-in sits at (0.01, 0.02, 0.03) m, yawed 0.5 rad
    springs = (
        "{modes: [hold, hold, hold, free, free, hold], stiffness: [10000, 10000, 10000, 0, 0, 1.0], "
        "max_force: 50.0, max_torque: 1.0}"
    )
    publisher = subprocess.Popen(
        ["rostopic", "pub", "-r", "10", "/sigma7/guidance", "teleteach/HapticGuidance", springs],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )

    def commands():
        lines = record.read_text().splitlines() if record.exists() else []
        return np.array([[float(value) for value in line.split()] for line in lines if len(line.split()) == 7])

    def wait_for(condition, what):
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            received = commands()
            if len(received) and condition(received):
                return received
            time.sleep(0.1)
        raise AssertionError(f"the stand-in never received {what}; last commands {commands()[-3:]}")

    try:
        # Expect, once blended in, the node's caps along the directions back to the centres: 4 N and 0.1 Nm
        capped = np.array([*(-4.0 * np.array([1.0, 2.0, 3.0]) / np.sqrt(14.0)), 0.0, 0.0, -0.1, 0.0])
        guided = wait_for(lambda received: np.allclose(received[-1], capped, atol=1e-6), "the capped guidance")
        publisher.send_signal(signal.SIGINT)
        publisher.wait(30)
        # Expect zero once the guidance is no longer refreshed
        wait_for(lambda received: np.all(received[-1] == 0.0), "zero force after the guidance went stale")
    finally:
        if publisher.poll() is None:
            publisher.send_signal(signal.SIGINT)
            publisher.wait(30)
        process.send_signal(signal.SIGINT)
        output, _ = process.communicate(timeout=30)
    assert process.returncode == 0, output
    received = commands()
    # Expect every command bounded (never above the caps, all finite), and the last one, on shutdown, zero
    assert np.all(np.isfinite(received))
    assert np.max(np.linalg.norm(received[:, :3], axis=1)) <= 4.0 + 1e-9
    assert np.max(np.linalg.norm(received[:, 3:6], axis=1)) <= 0.1 + 1e-9
    assert np.all(np.abs(received[:, 6]) <= 1.0 + 1e-9)
    assert np.all(received[-1] == 0.0), received[-3:]
    print(f"the stand-in received {len(received)} force commands, the largest {np.linalg.norm(guided[-1, :3]):.3f} N")


def test_the_topic_backend_publishes_another_program_s_input_and_refuses_bad_input(roscore):
    node = roslib.packages.find_node("teleteach", "sigma7_node")[0]
    process = subprocess.Popen(
        [node, "__name:=sigma7_topic", "_backend:=topic"],
        env=roscore,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )

    def publish(topic, message_type, message):
        return subprocess.Popen(
            ["rostopic", "pub", "-r", "50", topic, message_type, message],
            env=roscore,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )

    publishers = [
        publish(
            "/sigma7/input/pose", "geometry_msgs/PoseStamped", "{pose: {position: {x: 0.03}, orientation: {w: 1}}}"
        ),
        publish("/sigma7/input/gripper_angle", "std_msgs/Float64", "{data: -1.0}"),
    ]
    try:
        echo = echo_once("/sigma7/pose", roscore)
        assert "x: 0.03\n    y: 0.0\n    z: 0.0" in echo.stdout, echo.stdout + echo.stderr
        echo = echo_once("/sigma7/gripper_angle", roscore)
        # Expect the configured resting angle: the negative input angle was refused
        assert "data: 0.25" in echo.stdout, echo.stdout + echo.stderr
    finally:
        for publisher in publishers:
            publisher.send_signal(signal.SIGINT)
            publisher.wait(30)
        process.send_signal(signal.SIGINT)
        output, _ = process.communicate(timeout=30)
    assert process.returncode == 0, output
    assert "input refused: input gripper angle must be a finite number >= 0 rad, got -1.0" in output, output
