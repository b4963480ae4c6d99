"""The sigma7 node plays a scenario that waits for the system, over a real roscore: the device holds the waiting
keyframe until the system shows what it waits for (here a help request), and a wait in vain ends the node with
status 1 and one line naming the keyframe."""

import subprocess
import time

from conftest import ROOT
from ros_processes import Processes, echo_once, start_roscore, wait_until

KEYFRAME = "rpy: [0.0, 0.0, 0.0], gripper: 0.25"


def write_scenario(path, wait, timeout):
    path.write_text(
        "keyframes:\n"
        f"  - {{t: 0.0, position: [0.0, 0.0, 0.0], {KEYFRAME}}}\n"
        f"  - {{t: 0.5, position: [0.05, 0.0, 0.0], {KEYFRAME}, wait: {wait}, timeout: {timeout}}}\n"
        f"  - {{t: 1.5, position: [-0.05, 0.0, 0.0], {KEYFRAME}}}\n"
    )
    return path


def start_device(processes, name, scenario):
    subprocess.run(
        ["rosparam", "load", str(ROOT / "config" / "device.yaml"), f"/{name}"], env=processes.env, check=True
    )
    command = [str(ROOT / "nodes" / "sigma7_node"), f"__name:={name}", "_backend:=scenario", f"_scenario:={scenario}"]
    return processes.start(name, [*command, "_rate:=100"])


def device_x(processes):
    """The device's x on /sigma7/pose [m], None before it publishes."""
    text = echo_once(processes, "/sigma7/pose/pose/position/x")
    return float(text.split()[0]) if text.strip() else None


def test_the_device_holds_until_the_help_request_then_goes_on(tmp_path):
    scenario = write_scenario(tmp_path / "wait_for_help.yaml", "{help_request: true}", 120)
    with Processes(tmp_path / "logs") as processes:
        start_roscore(processes)
        start_device(processes, "sigma7_node", scenario)
        wait_until(lambda: device_x(processes) is not None, 60, "/sigma7/pose")
        wait_until(lambda: device_x(processes) == 0.05, 20, "the waiting keyframe (x = 0.05 m)")
        # the whole scenario is 1.5 s long: once 3 s have passed the device would be at its end without the wait
        time.sleep(3.0)
        # Expect the device still holding the waiting keyframe
        assert device_x(processes) == 0.05
        processes.start(
            "help",
            ["rostopic", "pub", "-l", "/behaviour_tree/help_request", "teleteach/HelpRequest", "{node_name: PickItem}"],
        )
        # Expect the scenario to go on to its last keyframe once the help request is there
        wait_until(lambda: device_x(processes) == -0.05, 30, "the last keyframe (x = -0.05 m)")


def test_a_wait_in_vain_ends_the_node_naming_the_keyframe(tmp_path):
    scenario = write_scenario(tmp_path / "wait_for_low_level.yaml", "{tab: LOW_LEVEL}", 1.0)
    with Processes(tmp_path / "logs") as processes:
        start_roscore(processes)
        device = start_device(processes, "sigma7_node", scenario)
        device.wait(60)
        output = processes.log("sigma7_node")
    # Expect status 1 and the reason: file, line, keyframe, what it waited for and what it saw (no GUI: nothing)
    assert device.returncode == 1, output
    assert f"{scenario}:3: keyframes[1].wait: still waiting after 1 s for tab LOW_LEVEL (seen None)" in output
    assert "Traceback" not in output
