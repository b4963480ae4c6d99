"""full.launch and a study: study:= starts only the study node; study_parameters override the nodes' own."""

import pathlib
import subprocess

import rosgraph
import yaml

from teleteach.study.parameters import parameters_file

ROOT = pathlib.Path(__file__).resolve().parents[2]


def roslaunch(*args):
    return subprocess.run(["roslaunch", *args], capture_output=True, text=True, check=True).stdout


def test_a_study_runs_the_study_node_alone_with_the_launch_s_arguments():
    study = ROOT / "config" / "studies" / "example.yaml"
    common = ("teleteach", "full.launch", f"study:={study}", "participant:=P07", "device:=dhd")
    assert roslaunch("--nodes", *common).split() == ["/study"]
    command = roslaunch("--args", "study", *common, "study_resume:=true", "data_dir:=/tmp/d").split()
    assert rosgraph.myargv(command)[1:] == [  # what the node parses: without roslaunch's remaps, name and log
        str(study),
        "--participant",
        "P07",
        "--device",
        "dhd",
        "--use-master",
        "--resume",
        "--data-dir",
        "/tmp/d",
    ]


def test_a_condition_s_parameters_are_loaded_last_and_override_the_nodes_own(tmp_path):
    parameters = tmp_path / "parameters.yaml"
    parameters.write_text(
        parameters_file(
            {
                "teaching_gui/guidance": False,
                "sigma7_node/hand/enabled": True,
                "sigma7_node/hand/tremor_rms": 0.003,
                "behaviour_tree/tick_rate": 20.0,
            }
        )
    )
    dumped = yaml.safe_load(
        roslaunch("--dump-params", "teleteach", "full.launch", "device:=scenario", f"study_parameters:={parameters}")
    )
    # Expect the condition's values over gui.launch's guidance arg, device.launch's hand args and bt's yaml
    assert dumped["/teaching_gui/guidance"] is False
    assert (dumped["/sigma7_node/hand/enabled"], dumped["/sigma7_node/hand/tremor_rms"]) == (True, 0.003)
    assert dumped["/behaviour_tree/tick_rate"] == 20.0
    plain = yaml.safe_load(roslaunch("--dump-params", "teleteach", "full.launch", "device:=scenario"))
    assert plain["/teaching_gui/guidance"] is True and plain["/sigma7_node/hand/enabled"] is False
