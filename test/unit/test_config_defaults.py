"""Defaults live in the yaml files: a parameter dataclass either has no code default for a value its yaml sets, or
the same one, so that reading the code never misleads about what runs; a missing value is named in one line."""

import dataclasses
import inspect
import xml.etree.ElementTree as ElementTree

import pytest
import yaml
from conftest import ROOT

from teleteach.bt.ros import ActionSkill, BehaviourTreeNode
from teleteach.control.impedance import ImpedanceParams
from teleteach.gui.config import GuiConfig
from teleteach.haptics.click import ClickParameters
from teleteach.haptics.guidance import GuidanceLimits
from teleteach.haptics.hand import HandParameters
from teleteach.haptics.ros import Sigma7Config
from teleteach.node import node_parameters
from teleteach.shared_control.loop import SharedControlConfig
from teleteach.sim.robot_sim import ControllerConfigError, impedance_params, load_controller_config


def config(name, *section):
    data = yaml.safe_load((ROOT / "config" / name).read_text())
    for key in section:
        data = data[key]
    return data


def comparable(value):
    if dataclasses.is_dataclass(value):
        return comparable(dataclasses.asdict(value))
    if isinstance(value, dict):
        return {key: comparable(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [comparable(item) for item in value]
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return float(value)
    return value


def is_required(field):
    return field.default is dataclasses.MISSING and field.default_factory is dataclasses.MISSING


@pytest.mark.parametrize(
    "parameters, yaml_values",
    [
        (ImpedanceParams, config("controllers.yaml", "cartesian_impedance_controller")),
        (GuiConfig, config("gui.yaml")),
        (Sigma7Config, config("device.yaml")),
        (ClickParameters, config("device.yaml", "click")),
        (GuidanceLimits, config("device.yaml", "guidance")),
        (HandParameters, config("device.yaml", "hand")),
        (SharedControlConfig, config("shared_control.yaml")),
    ],
    ids=["impedance", "gui", "sigma7", "click", "guidance", "hand", "shared_control"],
)
def test_no_code_default_disagrees_with_its_yaml(parameters, yaml_values):
    # Sigma7Config's sections twist, virtual, topic, dhd and hand are flat fields, compared by parameter name below
    disagreeing = {}
    for field in dataclasses.fields(parameters):
        if field.name not in yaml_values:
            continue
        if field.default is not dataclasses.MISSING:
            default = field.default
        elif field.default_factory is not dataclasses.MISSING:
            default = field.default_factory()
        else:
            continue
        if comparable(default) != comparable(yaml_values[field.name]):
            disagreeing[field.name] = (default, yaml_values[field.name])
    assert disagreeing == {}


def test_sigma7_defaults_are_the_yaml_s_values_of_the_parameters_they_stand_for():
    # Expect each default the node passes to get_param (a flattened field such as topic_timeout for ~topic/timeout
    # too) to be the yaml's value of that parameter, and every value of the yaml asked for
    asked = {}
    launch = {"~scenario": "scenario.yaml", "~hand/enabled": True}  # launch arguments: the yaml leaves them out

    def get_param(name, default):
        asked[name] = default
        return launch.get(name, default)

    Sigma7Config.from_params(get_param)
    yaml_values = {}
    for name, value in config("device.yaml").items():
        items = value.items() if isinstance(value, dict) else [(None, value)]
        yaml_values.update({f"~{name}/{key}" if key else f"~{name}": item for key, item in items})
    axes = {name: yaml_values.pop(name) for name in list(yaml_values) if name.startswith("~axes/")}
    assert set(yaml_values) <= set(asked)
    assert {"~topic/timeout", "~twist/cutoff_frequency", "~virtual/click_duration", "~dhd/library"} <= set(asked)
    # Expect each backend to ask for its own entry of ~axes only, with the yaml's value as the default
    for name, value in axes.items():
        backend = name.split("/")[1]
        launch.update({"~backend": backend, "~hand/enabled": backend != "dhd"})
        asked.clear()
        Sigma7Config.from_params(get_param)
        assert [key for key in asked if key.startswith("~axes/")] == [name]
        assert asked[name] == value
    disagreeing = {
        name: (asked[name], value)
        for name, value in yaml_values.items()
        if comparable(asked[name]) != comparable(value)
    }
    assert disagreeing == {}


def test_the_behaviour_tree_node_s_argument_defaults_are_the_yaml_s():
    yaml_values = config("behaviour_tree.yaml")
    defaults = {}
    for function in (BehaviourTreeNode.__init__, ActionSkill.__init__):
        for name, parameter in inspect.signature(function).parameters.items():
            if name in yaml_values and parameter.default is not inspect.Parameter.empty:
                defaults[name] = parameter.default
    # ActionClients' namespace has its own name; the pause's two are read from the yaml alone and handed to
    # TeachingTree, whose own defaults are the library's (started, never preempted) for in-process trees
    from_yaml_alone = {"skill_namespace", "start_paused", "pause_preempt_after"}
    assert set(defaults) == set(yaml_values) - from_yaml_alone
    source = inspect.getsource(BehaviourTreeNode.from_params)
    assert all(f'params["{name}"]' in source for name in from_yaml_alone)
    disagreeing = {name: (default, yaml_values[name]) for name, default in defaults.items()}
    disagreeing = {name: pair for name, pair in disagreeing.items() if pair[0] != pair[1]}
    assert disagreeing == {}


def test_the_impedance_gains_come_only_from_the_yaml_and_a_missing_one_is_named():
    settings = load_controller_config()
    # Expect no code default at all (so none to disagree), and what runs to be each of the yaml's values
    assert [field.name for field in dataclasses.fields(ImpedanceParams) if not is_required(field)] == []
    yaml_values = config("controllers.yaml", "cartesian_impedance_controller")
    assert len(yaml_values) == len(dataclasses.fields(ImpedanceParams)) == 14
    assert comparable(impedance_params(settings)) == comparable(yaml_values)
    del settings["cartesian_impedance_controller"]["nullspace_stiffness"]
    settings["cartesian_impedance_controller"]["nullspace_damping"] = 1.0
    with pytest.raises(ControllerConfigError) as error:
        impedance_params(settings)
    assert str(error.value) == (
        "controller settings, cartesian_impedance_controller: missing nullspace_stiffness; unknown nullspace_damping"
    )


def launch_arguments(name):
    root = ElementTree.parse(ROOT / "launch" / name).getroot()
    return {arg.get("name"): arg.get("default") for arg in root.iter("arg")}


@pytest.mark.parametrize(
    "launch_file, yaml_values",
    [
        ("bt.launch", config("behaviour_tree.yaml")),
        ("sim.launch", config("controllers.yaml", "simulation")),
        ("rviz.launch", config("ellipsoid_marker.yaml")),
    ],
)
def test_launch_arguments_of_yaml_values_default_to_the_yaml(launch_file, yaml_values):
    # Expect an argument that overrides a yaml value to say "config" by default (= the yaml's), never a second value
    arguments = launch_arguments(launch_file)
    shadowing = {name: arguments[name] for name in yaml_values if arguments.get(name) not in (None, "config")}
    assert shadowing == {}
    assert set(yaml_values) & set(arguments)  # the check looked at something


@pytest.mark.parametrize("launch_file", sorted(path.name for path in (ROOT / "launch").glob("*.launch")))
def test_no_launch_argument_looks_required_but_has_a_default(launch_file):
    """roslaunch --ros-args lists an argument with an empty default as "Required": every default says what it is."""
    empty = [name for name, default in launch_arguments(launch_file).items() if default == ""]
    assert empty == []


def test_node_parameters_are_the_yaml_unless_a_private_parameter_overrides_them():
    private = {"~server_timeout": 120.0}
    values = node_parameters("behaviour_tree.yaml", lambda name, default: private.get(name, default))
    expected = dict(config("behaviour_tree.yaml"), server_timeout=120.0)
    assert values == expected


def test_shared_control_config_comes_from_its_yaml_and_names_what_is_missing():
    values = config("shared_control.yaml")
    # Expect the yaml to give the node's configuration, the rate as the cycle period
    assert SharedControlConfig.from_parameters(values) == dataclasses.replace(SharedControlConfig(), dt=0.02)
    del values["switch_hold"], values["rate"]
    with pytest.raises(ValueError, match=r"^missing parameter ~rate, ~switch_hold \(see config/shared_control.yaml\)$"):
        SharedControlConfig.from_parameters(values)
