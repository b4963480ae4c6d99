"""Study files: the example loads, and every mistake is refused in one line naming the file, the line and the field."""

import pathlib
import textwrap

import pytest
import yaml

import teleteach.runtime.node
from teleteach.core.gui_config import GuiConfig
from teleteach.core.questionnaire import TLX_NAMES
from teleteach.haptics.ros import Sigma7Config
from teleteach.runtime.node import node_parameters
from teleteach.runtime.processes import launch_value
from teleteach.shared_control.ros import SharedControlNode
from teleteach.study.parameters import RUNNER_NODE_PARAMETERS, check_parameter, node_defaults, parameters_file
from teleteach.study.schema import StudyError, load_study, parse_study

ROOT = pathlib.Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "config" / "studies" / "example.yaml"

GOOD = """\
name: small
conditions:
  guided:
    parameters:
      teaching_gui/guidance: true
  unguided:
    parameters:
      teaching_gui/guidance: false
tasks:
  remove:
    goal:
      tree: {absent: [PlaceItem]}
"""


def study_of(text, tmp_path):
    path = tmp_path / "study.yaml"
    path.write_text(textwrap.dedent(text))
    return parse_study(path.read_text(), path)


def error_of(text, tmp_path):
    with pytest.raises(StudyError) as caught:
        study_of(text, tmp_path)
    message = str(caught.value)
    assert "\n" not in message
    return message.replace(str(tmp_path / "study.yaml"), "study.yaml")


def test_the_example_study_loads_with_its_conditions_tasks_and_questionnaire():
    study = load_study(EXAMPLE)
    assert study.name == "guidance_example"
    assert [condition.name for condition in study.conditions] == ["guided", "unguided"]
    assert study.condition("unguided").parameters == {"teaching_gui/guidance": False}
    assert [task.name for task in study.tasks] == ["remove_place_item", "stiffen_y"]
    remove, stiffen = study.tasks
    assert remove.goal.kinds == ("tree",) and remove.goal.tree.absent == ("PlaceItem",)
    assert stiffen.goal.stiffness.bounds == ((50.0, 800.0), (2000.0, 3000.0), (50.0, 800.0))
    assert remove.trials == stiffen.trials == 2
    assert remove.script == EXAMPLE.parent / "scripts" / "remove_place_item.yaml"
    assert [item.name for item in study.questionnaire] == [*TLX_NAMES, "in_control"]
    assert study.questionnaire[-1].points == 7 and study.questionnaire[-1].maximum == 7.0
    assert study.scripted.parameters["sigma7_node/hand/tremor_rms"] == 0.002 and study.scripted.aim == 0.0035


def test_defaults_of_a_minimal_study(tmp_path):
    study = study_of(GOOD, tmp_path)
    (task,) = study.tasks
    assert (task.timeout, task.trials, task.pause_tree, task.script, task.title) == (
        180.0,
        1,
        "instructions",
        None,
        "remove",
    )
    assert (study.order.conditions, study.order.tasks) == ("latin_square", "fixed")
    assert [item.name for item in study.questionnaire] == list(TLX_NAMES)


@pytest.mark.parametrize(
    "old, new, expected",
    [
        (
            "teaching_gui/guidance: false",
            "teaching_gui/guidence: false",
            "study.yaml:8: conditions.unguided.parameters.teaching_gui/guidence: unknown parameter "
            "'teaching_gui/guidence': teaching_gui has no parameter 'guidence' (its parameters: config/gui.yaml); "
            "did you mean teaching_gui/guidance?",
        ),
        (
            "teaching_gui/guidance: false",
            "teach_gui/guidance: false",
            "study.yaml:8: conditions.unguided.parameters.teach_gui/guidance: unknown node 'teach_gui' in "
            "'teach_gui/guidance' (a study sets parameters of teaching_gui, sigma7_node, shared_control, "
            "behaviour_tree)",
        ),
        (
            "teaching_gui/guidance: false",
            "teaching_gui/guidance: 'no'",
            "study.yaml:8: conditions.unguided.parameters.teaching_gui/guidance: teaching_gui/guidance must be true "
            "or false like its default in config/gui.yaml (True), got 'no'",
        ),
        (
            "teaching_gui/guidance: false",
            "teaching_gui/guidance_max_force: -1.0",
            "study.yaml:8: conditions.unguided.parameters.teaching_gui/guidance_max_force: "
            "teaching_gui/guidance_max_force: GUI parameter guidance_max_force must be a positive number, got -1.0",
        ),
        (
            "teaching_gui/guidance: false",
            "sigma7_node/hand: 0.002",
            "study.yaml:8: conditions.unguided.parameters.sigma7_node/hand: 'sigma7_node/hand' is a group of "
            "parameters; name one of angular_damping, angular_stiffness, damping, drift_rms, enabled, inertia, mass, "
            "seed, stiffness, tremor_rms",
        ),
        (
            "      tree: {absent: [PlaceItem]}",
            "      time: 10",
            "study.yaml:12: tasks.remove.goal.time: unknown field (allowed: tree, stiffness, placement)",
        ),
        (
            "    goal:\n      tree: {absent: [PlaceItem]}",
            "    title: Remove",
            "study.yaml:10: tasks.remove: no goal: a task needs a goal judged from the world (tree, stiffness, "
            "placement)",
        ),
        (
            "      tree: {absent: [PlaceItem]}",
            "      {}",
            "study.yaml:11: tasks.remove.goal: empty: a task needs a goal judged from the world (tree, stiffness, "
            "placement)",
        ),
        (
            "      tree: {absent: [PlaceItem]}",
            "      stiffness: {y: [3000, 2000]}",
            "study.yaml:12: tasks.remove.goal.stiffness.y: low 3000 is above high 2000",
        ),
        (
            "      tree: {absent: [PlaceItem]}",
            "      placement: {product: product_pick_1, gap: gap_9}",
            "study.yaml:12: tasks.remove.goal.placement: the scene has no gap 'gap_9' "
            "(it has gap_1, gap_2, gap_3, gap_4, gap_5, gap_6, gap_7)",
        ),
        (
            "      tree: {absent: [PlaceItem]}",
            "      tree: {}",
            "study.yaml:12: tasks.remove.goal.tree: names nothing to judge (give absent, present or children)",
        ),
        (
            "      tree: {absent: [PlaceItem]}",
            "      tree: {absent: [PlaceItem]}\n    script: missing.yaml",
            "study.yaml:13: tasks.remove.script: not a playable scenario: ",
        ),
        (
            "name: small",
            "name: small\nsystem: {device: dhd}",
            "study.yaml:2: system.device: device is set by the study runner for every trial",
        ),
        (
            "name: small",
            "name: small\nsystem: {shared_contrl: false}",
            "study.yaml:2: system.shared_contrl: unknown full.launch argument 'shared_contrl'; did you mean "
            "shared_control?",
        ),
        (
            "name: small",
            "name: small\norder: {conditions: alphabetical}",
            "study.yaml:2: order.conditions: must be one of latin_square, random, fixed",
        ),
        (
            "name: small",
            "name: small\nquestionnaire: {items: [{name: effort, question: Again}]}",
            "study.yaml:2: questionnaire.items[0].name: must be a new name of letters, digits, '_' or '-', got "
            "'effort'",
        ),
        (
            "    goal:",
            "    pause_tree: yes\n    goal:",
            "study.yaml:11: tasks.remove.pause_tree: must be one of instructions, always, never, got True",
        ),
        ("name: small", "name: sm all", "study.yaml:1: name: must be letters, digits, '_' or '-' (a folder name)"),
        ("tasks:", "tasks: [", "study.yaml:11: not valid YAML: expected ',' or ']'"),
    ],
)
def test_a_mistake_is_refused_in_one_line_naming_file_line_and_field(tmp_path, old, new, expected):
    assert old in GOOD
    message = error_of(GOOD.replace(old, new), tmp_path)
    assert message.startswith(expected), message


def test_a_placement_goal_for_a_product_left_out_of_the_scene_is_refused(tmp_path):
    text = GOOD.replace(
        "      tree: {absent: [PlaceItem]}",
        "      placement: {product: product_pick_1, gap: gap_1}\n    system: {absent_products: [product_pick_1]}",
    )
    assert error_of(text, tmp_path) == (
        "study.yaml:12: tasks.remove.goal.placement.product: product_pick_1 is left out of the scene by absent_products"
    )


def test_a_missing_file_is_one_line(tmp_path):
    with pytest.raises(StudyError, match=r"nothing\.yaml: cannot read the study file \(No such file or directory\)$"):
        load_study(tmp_path / "nothing.yaml")


def test_node_parameters_become_a_rosparam_file_in_the_root_namespace():
    text = parameters_file(
        {"teaching_gui/guidance": False, "sigma7_node/hand/tremor_rms": 0.002, "sigma7_node/hand/enabled": True}
    )
    assert yaml.safe_load(text) == {
        "sigma7_node": {"hand": {"enabled": True, "tremor_rms": 0.002}},
        "teaching_gui": {"guidance": False},
    }
    assert [launch_value(value) for value in (True, 0.5, ["product_pick_1"], "x")] == [
        "true",
        "0.5",
        "[product_pick_1]",
        "x",
    ]


def test_every_node_parameter_a_condition_may_set_is_one_its_node_reads():
    # Expect the parameters named in docs/study.md's examples to be accepted with the right types, integers as numbers
    assert check_parameter("shared_control/blend_authority", False) is None
    assert check_parameter("sigma7_node/hand/tremor_rms", 0) is None
    assert check_parameter("behaviour_tree/tick_rate", 20) is None
    assert check_parameter("sigma7_node/hand/seed", 2.5).startswith("sigma7_node/hand/seed must be integer")
    assert check_parameter("behaviour_tree/tree", "/studies/tree_b.yaml") is None


def test_a_condition_cannot_set_what_the_runner_sets_for_every_trial():
    assert check_parameter("behaviour_tree/data_dir", "/tmp/elsewhere") == (
        "behaviour_tree/data_dir is set by the study runner for every trial"
    )
    assert (
        check_parameter("sigma7_node/backend", "dhd")
        == "sigma7_node/backend is set by the study runner for every trial"
    )


def changed(value):
    """A value of the same type as ``value`` and different from it."""
    if isinstance(value, bool):
        return not value
    if isinstance(value, (int, float)):
        return value * 2 + 1
    if isinstance(value, str):
        return value + "_changed"
    if isinstance(value, list):
        return [changed(item) for item in value] if value else [1.0]
    raise TypeError(value)


def nested(flat):
    """``{"a/b": 1}`` -> ``{"a": {"b": 1}}``: the parameters as the node finds them under its private namespace."""
    tree = {}
    for name, value in flat.items():
        *groups, leaf = name.split("/")
        node = tree
        for group in groups:
            node = node.setdefault(group, {})
        node[leaf] = value
    return tree


def build_gui(parameters):
    return GuiConfig.load(**nested(parameters))


def build_sigma7(parameters):
    # backend and scenario: the study runner sets them (full.launch's device and scenario)
    values = nested({"backend": "virtual", "scenario": "operator.yaml", **parameters})
    return Sigma7Config.from_params(lambda name, default: values.get(name.lstrip("~"), default))


def built_node(node_class, parameters, monkeypatch):
    """The arguments ``node_class.from_params`` builds its node with, its parameters overridden as a launch would."""
    overrides = nested(parameters)
    real = node_parameters

    def from_yaml_and_overrides(defaults_file, get_param=None):
        return real(defaults_file, lambda name, default: overrides.get(name.lstrip("~"), default))

    monkeypatch.setattr(teleteach.runtime.node, "node_parameters", from_yaml_and_overrides)

    class Captured(node_class):
        def __init__(self, *args, **kwargs):
            self.arguments = repr((args, kwargs))

    return Captured.from_params().arguments


def read_when(node, name):
    """The other parameters under which the node reads ``name``: a backend's axes when that backend runs, the hand
    model's parameters when the model is on."""
    if node != "sigma7_node":
        return {}
    group, _, leaf = name.partition("/")
    if group == "axes":
        return {"backend": leaf}
    if group == "hand" and leaf != "enabled":
        return {"hand/enabled": True}
    return {}


@pytest.mark.parametrize("node", ["teaching_gui", "sigma7_node", "shared_control"])
def test_every_parameter_a_study_may_set_reaches_its_node(node, monkeypatch):
    # Expect: each parameter check_parameter accepts changes what the node is built with (or the node refuses the
    # value), so that a condition setting it is never silently ignored
    build = {
        "teaching_gui": build_gui,
        "sigma7_node": build_sigma7,
        "shared_control": lambda parameters: built_node(SharedControlNode, parameters, monkeypatch),
    }[node]
    ignored = []
    for name, value in node_defaults(node).items():
        if isinstance(value, dict) or f"{node}/{name}" in RUNNER_NODE_PARAMETERS:
            continue
        assert check_parameter(f"{node}/{name}", value) is None
        context = read_when(node, name)
        try:
            if build({**context, name: changed(value)}) == build(context):
                ignored.append(name)
        except ValueError:
            pass  # the node reads the value and refuses it
    assert ignored == []
