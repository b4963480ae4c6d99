"""full.launch for a newcomer at a screen: with the virtual device the tree waits for the operator's start, so the
keys can be learned before the robot's task runs out (unattended and scripted runs keep starting at once)."""

import subprocess

import pytest
import yaml


def start_paused(*args):
    dump = subprocess.run(
        ["roslaunch", "--dump-params", "teleteach", "full.launch", *args], capture_output=True, text=True, check=True
    ).stdout
    return yaml.safe_load(dump)["/behaviour_tree/start_paused"]


@pytest.mark.parametrize(
    "args, paused",
    [
        (["device:=virtual"], True),
        (["device:=virtual", "start_paused:=false"], False),
        (["device:=scenario"], False),
        (["device:=dhd"], False),
        (["device:=dhd", "real_robot:=true"], True),
    ],
)
def test_the_tree_waits_for_its_start_with_the_virtual_device_and_on_a_real_robot(args, paused):
    assert start_paused(*args) is paused
