"""Defaults live in the yaml files: a parameter dataclass has no code default for a value its yaml sets, nor does any
function or field of the library default to a yaml's value, so that reading the code never misleads about what runs;
a value several nodes need is written once (config/shared/); a missing value is named in one line."""

import ast
import dataclasses
import xml.etree.ElementTree as ElementTree

import pytest
import yaml
from conftest import ROOT

from teleteach.bt.ros import BehaviourTreeConfig
from teleteach.control.franka_stiffness import StiffnessBridgeConfig
from teleteach.control.impedance import ImpedanceParams
from teleteach.core.gui_config import GuiConfig, GuiConfigError
from teleteach.core.paths import SharedValueError, config_values, with_shared
from teleteach.haptics.click import ClickParameters
from teleteach.haptics.guidance import GuidanceLimits
from teleteach.haptics.hand import HandParameters
from teleteach.haptics.ros import DeviceMonitorConfig, Sigma7Config
from teleteach.learning.dmp import DMPParameters
from teleteach.learning.skill import LearningParameters
from teleteach.perception.static import StaticSceneConfig
from teleteach.runtime.node import node_parameters
from teleteach.shared_control.config import SharedControlNodeConfig
from teleteach.shared_control.loop import SharedControlConfig
from teleteach.shared_control.plane import TaskPlane
from teleteach.sim.robot_sim import ControllerConfigError, impedance_params, load_controller_config
from teleteach.sim.ros import RobotSimConfig
from teleteach.skills.config import SkillServerConfig
from teleteach.viz.ellipsoid import EllipsoidMarkerConfig, EllipsoidScale


def config(name, *section):
    return config_values(name, *section)


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
    "parameters, where",
    [
        (ImpedanceParams, ("controllers.yaml", "cartesian_impedance_controller")),
        (Sigma7Config, ("device.yaml",)),
        (ClickParameters, ("device.yaml", "click")),
        (GuidanceLimits, ("device.yaml", "guidance")),
        (HandParameters, ("device.yaml", "hand")),
        (DeviceMonitorConfig, ("device_monitor.yaml",)),
        (BehaviourTreeConfig, ("behaviour_tree.yaml",)),
        (SkillServerConfig, ("skill_server.yaml",)),
        (RobotSimConfig, ("robot_sim.yaml",)),
        (SharedControlConfig, ("shared_control.yaml",)),
        (SharedControlNodeConfig, ("shared_control.yaml",)),
        (TaskPlane, ("shared_control.yaml", "plane")),
        (EllipsoidMarkerConfig, ("ellipsoid_marker.yaml",)),
        (EllipsoidScale, ("ellipsoid_marker.yaml",)),
        (StaticSceneConfig, ("static_scene.yaml",)),
        (StiffnessBridgeConfig, ("stiffness_bridge.yaml",)),
        (GuiConfig, ("gui.yaml",)),
        (LearningParameters, ("learning.yaml",)),
        (DMPParameters, ("learning.yaml",)),
    ],
    ids=lambda value: value.__name__ if isinstance(value, type) else "/".join(value),
)
def test_no_code_default_exists_for_a_yaml_key(parameters, where):
    # Expect every value the yaml gives to be required by the dataclass built from it: a default in code would be a
    # second place of the value, which a reader takes for what runs
    values = config(*where)
    read = [field for field in dataclasses.fields(parameters) if field.name in values]
    assert read  # the check looked at something
    assert [field.name for field in read if not is_required(field)] == []


def test_the_sigma7_config_is_its_yaml_key_by_key_and_names_what_is_missing():
    # Expect every nested key of the yaml to reach its field (a private parameter overriding a section's key alone),
    # and a key missing from the yaml to be named, section and all
    server = {"~backend": "virtual", "~topic": {"timeout": 5.0}}
    built = Sigma7Config.from_params(lambda name, default: server.get(name, default))
    values = config("device.yaml")
    hand = values.pop("hand")
    expected = dict(values, backend="virtual", hand={"enabled": hand.pop("enabled"), "model": hand})
    expected["topic"] = dict(expected["topic"], timeout=5.0)
    assert comparable(built) == comparable(expected)
    del values["twist"]["cutoff_frequency"], values["rate"], values["backend"]
    with pytest.raises(ValueError, match=r"\(config/device.yaml\): missing backend, rate; missing twist/cut"):
        Sigma7Config.from_mapping(dict(values, hand=dict(hand, enabled=False)))
    with pytest.raises(ValueError, match=r"\(config/device.yaml\): missing hand/enabled$"):
        Sigma7Config.from_mapping(dict(config("device.yaml"), backend="virtual", scenario="", hand=hand))


@pytest.mark.parametrize(
    "parameters, node, yaml_name, required",
    [
        (BehaviourTreeConfig, "behaviour_tree", "behaviour_tree.yaml", "lost_timeout"),
        (SkillServerConfig, "skill_server", "skill_server.yaml", "motion_file"),
        (RobotSimConfig, "robot_sim", "robot_sim.yaml", "clock"),
        (DeviceMonitorConfig, "device_monitor", "device_monitor.yaml", "margin"),
        (EllipsoidMarkerConfig, "ellipsoid_marker", "ellipsoid_marker.yaml", "frame_id"),
        (StaticSceneConfig, "static_scene", "static_scene.yaml", "tcp_frame"),
        (StiffnessBridgeConfig, "stiffness_bridge", "stiffness_bridge.yaml", "nullspace_stiffness"),
    ],
)
def test_a_node_config_is_its_yaml_and_names_what_is_missing(parameters, node, yaml_name, required):
    values = config(yaml_name)
    if parameters is DeviceMonitorConfig:
        values["scenario"] = "example.yaml"  # required: the yaml has none
    assert comparable(parameters.from_mapping(values)) == comparable(values)
    del values[required]
    with pytest.raises(
        ValueError, match=rf"^{node}'s parameters \(config/{yaml_name}\): missing {required}; unknown x$"
    ):
        parameters.from_mapping(dict(values, x=1.0))


def test_the_device_monitor_needs_a_scenario():
    with pytest.raises(ValueError, match=r"^missing parameter ~scenario \(the scenario file to listen for\)$"):
        DeviceMonitorConfig.from_mapping(config("device_monitor.yaml"))


def test_robot_sim_parameters_replace_the_controllers_file_s_simulation_values_they_set():
    section = config("controllers.yaml", "simulation")
    values = dict(config("robot_sim.yaml"), real_time_factor=0.5, clock="follow")
    simulation = RobotSimConfig.from_mapping(values).simulation(section)
    assert simulation == dict(section, real_time_factor=0.5, clock="follow")
    assert RobotSimConfig.from_mapping(config("robot_sim.yaml")).simulation(section) == section


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


@pytest.mark.parametrize("launch_file", sorted(path.name for path in (ROOT / "launch").glob("*.launch")))
def test_every_launch_argument_says_what_it_does(launch_file):
    """roslaunch --ros-args lists each argument a user can set with its doc: none without one."""
    root = ElementTree.parse(ROOT / "launch" / launch_file).getroot()
    undocumented = [arg.get("name") for arg in root.iter("arg") if arg.get("value") is None and not arg.get("doc")]
    assert undocumented == []


def test_node_parameters_are_the_yaml_unless_a_private_parameter_overrides_them():
    private = {"~server_timeout": 120.0}
    values = node_parameters("behaviour_tree.yaml", lambda name, default: private.get(name, default))
    expected = dict(config("behaviour_tree.yaml"), server_timeout=120.0)
    assert values == expected


@pytest.mark.parametrize(
    "parameters, outside_the_yaml",
    [
        (GuiConfig, []),
        (SharedControlConfig, ["cache_dir"]),
        (Sigma7Config, []),
        (BehaviourTreeConfig, []),
        (SkillServerConfig, []),
        (RobotSimConfig, []),
        (DeviceMonitorConfig, []),
        (SharedControlNodeConfig, []),
        (EllipsoidMarkerConfig, []),
        (StaticSceneConfig, []),
        (StiffnessBridgeConfig, []),
        (LearningParameters, []),
        (DMPParameters, []),
    ],
)
def test_a_config_read_from_its_yaml_has_no_default_in_code(parameters, outside_the_yaml):
    assert [field.name for field in dataclasses.fields(parameters) if not is_required(field)] == outside_the_yaml


def test_a_gui_parameter_missing_from_the_yaml_is_named_in_one_line():
    values = config("gui.yaml")
    assert GuiConfig.from_mapping(values).repaint_rate == values["repaint_rate"]
    del values["repaint_rate"], values["edit_push"]
    with pytest.raises(GuiConfigError, match=r"^GUI parameters \(config/gui.yaml\): missing repaint_rate, edit_push$"):
        GuiConfig.from_mapping(values)


def test_a_gui_key_left_empty_in_the_yaml_is_refused_by_name_unless_it_means_an_empty_list():
    values = config("gui.yaml")
    empty_lists = {"locked_axes"}  # config/gui.yaml: an empty locked_axes locks nothing
    for name, value in values.items():
        if isinstance(value, dict) or name in empty_lists:
            continue
        with pytest.raises(GuiConfigError, match=name):
            GuiConfig.from_mapping({**values, name: None})
    assert GuiConfig.from_mapping({**values, "locked_axes": None}).locked_axes == ()
    with pytest.raises(GuiConfigError, match="guidance must be true or false, got 'yes'"):
        GuiConfig.from_mapping({**values, "guidance": "yes"})


def test_shared_control_config_comes_from_its_yaml_and_names_what_is_missing():
    values = config("shared_control.yaml")
    built = SharedControlConfig.from_parameters(values)
    # Expect each field to be the yaml's value, the rate as the cycle period
    assert built.dt == pytest.approx(1.0 / values["rate"])
    fields = {name: value for name, value in dataclasses.asdict(built).items() if name not in ("dt", "cache_dir")}
    assert len(fields) > 20 and comparable(fields) == comparable({name: values[name] for name in fields})
    assert SharedControlConfig.from_yaml(solver="fast") == dataclasses.replace(built, solver="fast")
    del values["switch_hold"]
    with pytest.raises(ValueError, match=r"^config/shared_control.yaml: missing switch_hold$"):
        SharedControlConfig.from_parameters(values)
    del values["rate"]
    with pytest.raises(ValueError, match=r"^config/shared_control.yaml: missing rate$"):
        SharedControlConfig.from_parameters(values)


def test_the_shared_control_node_config_is_its_yaml_and_names_what_is_missing():
    # Expect the MPC's keys in ``mpc`` and every other key of the yaml in a field of the node's own
    values = config("shared_control.yaml")
    built = SharedControlNodeConfig.from_parameters(values)
    assert built.mpc == SharedControlConfig.from_parameters(values)
    own = {name: value for name, value in dataclasses.asdict(built).items() if name not in ("mpc", "plane")}
    assert comparable(own) == comparable({name: values[name] for name in own})
    assert repr(built.plane) == repr(TaskPlane(**values["plane"])) and built.box is not None
    assert SharedControlNodeConfig.from_parameters(dict(values, boundary=[])).box is None
    del values["joy_scale"]
    with pytest.raises(ValueError, match=r"\(config/shared_control.yaml\): missing joy_scale; unknown x$"):
        SharedControlNodeConfig.from_parameters(dict(values, x=1.0))
    with pytest.raises(ValueError, match=r"^input must be one of"):
        SharedControlNodeConfig.from_parameters(dict(config("shared_control.yaml"), input="mouse"))


def test_the_learning_parameters_are_their_yaml_and_make_the_dmps():
    values = config("learning.yaml")
    parameters = LearningParameters.from_yaml()
    assert comparable(parameters) == comparable(values)
    dmp = parameters.dmp_parameters(10.0)
    assert (
        dmp
        == DMPParameters.from_yaml(basis_count=60)
        == DMPParameters.from_yaml(round(10.0 * values["basis_per_second"]))
    )
    with pytest.raises(ValueError, match=r"^learn_skill's parameters \(config/learning.yaml\): unknown x$"):
        LearningParameters.from_yaml(x=1.0)


def yaml_numbers():
    """{key: the numbers some config/*.yaml gives it (shared sections included)}, nested keys by their own name."""
    found = {}

    def collect(values):
        for key, value in values.items():
            if isinstance(value, dict):
                collect(value)
            elif isinstance(value, (int, float)) and not isinstance(value, bool):
                found.setdefault(key, set()).add(float(value))

    for path in sorted((ROOT / "config").glob("*.yaml")):
        collect(config(path.name))
    return found


def number_defaults(tree):
    """(line, name, value) of each argument or class field of ``tree`` that defaults to a number."""
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            arguments = node.args.posonlyargs + node.args.args
            named = list(zip(arguments[len(arguments) - len(node.args.defaults) :], node.args.defaults))
            named += [(arg, default) for arg, default in zip(node.args.kwonlyargs, node.args.kw_defaults) if default]
            pairs = [(arg.arg, default) for arg, default in named]
        elif isinstance(node, ast.ClassDef):
            pairs = [
                (statement.target.id, statement.value)
                for statement in node.body
                if isinstance(statement, ast.AnnAssign) and isinstance(statement.target, ast.Name) and statement.value
            ]
        else:
            continue
        for name, default in pairs:
            value = getattr(default, "value", None)
            if isinstance(default, ast.Constant) and isinstance(value, (int, float)) and not isinstance(value, bool):
                yield default.lineno, name, float(value)


def test_no_code_default_in_the_library_repeats_a_yaml_value():
    # Expect no argument or field anywhere in the library to default to the number a yaml gives the key of its name
    # (rotational_stiffness = 30.0 stood in three places beside the yaml): the caller passes the yaml's value. Zero
    # is left out: it says "none" (no offset, no seed) more often than it copies a value.
    numbers = yaml_numbers()
    copies = [
        f"{path.relative_to(ROOT)}:{line} {name} = {value:g}"
        for path in sorted((ROOT / "src" / "teleteach").rglob("*.py"))
        for line, name, value in number_defaults(ast.parse(path.read_text()))
        if value != 0.0 and value in numbers.get(name, ())
    ]
    assert copies == []


def test_the_check_for_copied_defaults_sees_arguments_and_fields():
    tree = ast.parse("def f(a, rate=1.0, *, seed=0, gain=2):\n    pass\nclass C:\n    width: float = 0.5\n")
    assert [(name, value) for _, name, value in number_defaults(tree)] == [
        ("rate", 1.0),
        ("seed", 0.0),
        ("gain", 2.0),
        ("width", 0.5),
    ]


def test_a_value_two_nodes_need_is_written_once():
    # Expect the GUI, the simulated impedance controller and the real robot's bridge to read max_stiffness and
    # rotational_stiffness from config/shared/stiffness.yaml alone, through the one reader of the yaml files
    shared = yaml.safe_load((ROOT / "config" / "shared" / "stiffness.yaml").read_text())
    assert set(shared) == {"max_stiffness", "rotational_stiffness"}
    readers = [("gui.yaml",), ("controllers.yaml", "cartesian_impedance_controller"), ("stiffness_bridge.yaml",)]
    for where in readers:
        raw = yaml.safe_load((ROOT / "config" / where[0]).read_text())
        for key in where[1:]:
            raw = raw[key]
        assert not set(shared) & set(raw), where
        assert {key: config(*where)[key] for key in shared} == shared, where
    assert (
        GuiConfig.load().max_stiffness
        == StiffnessBridgeConfig.from_mapping(config("stiffness_bridge.yaml")).max_stiffness
    )
    with pytest.raises(SharedValueError, match=r"^here/section: max_stiffness written again"):
        with_shared({"section": {"shared": ["stiffness"], "max_stiffness": 4000.0}}, "here")
    with pytest.raises(SharedValueError, match=r"^here: no shared section 'stiff'"):
        with_shared({"shared": ["stiff"]}, "here")
