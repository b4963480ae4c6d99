"""What a study may set: the real parameters of the real nodes, and the arguments of ``full.launch``.

A condition names node parameters as ``<node>/<parameter>`` (``teaching_gui/guidance``, ``sigma7_node/hand/tremor_rms``,
``shared_control/blend_authority``). The parameters a node has are the keys of its yaml in ``config/`` (where every
default lives, and what its launch file loads into its private namespace), so a name is checked against that yaml and
a value against the type of its default. The runner loads the chosen values last into ``full.launch``
(``study_parameters``), so that each node reads them at its start like any of its parameters.
"""

import difflib
import functools
import xml.etree.ElementTree as ElementTree
from typing import Any, Dict, List, Optional, Tuple

import yaml

from teleteach.core.gui_config import GuiConfig, GuiConfigError
from teleteach.core.paths import config_values, share_dir

NODE_PARAMETER_FILES = {
    "teaching_gui": "gui.yaml",
    "sigma7_node": "device.yaml",
    "shared_control": "shared_control.yaml",
    "behaviour_tree": "behaviour_tree.yaml",
}
"""The nodes of full.launch whose parameters a study may set, and the yaml holding each one's parameters."""

RUNNER_LAUNCH_ARGUMENTS = (
    "device",
    "scenario",
    "device_node",
    "gui",
    "headless",
    "data_dir",
    "record",
    "record_prefix",
    "study",
    "participant",
    "study_resume",
    "study_parameters",
)
"""full.launch arguments the study runner sets itself for every trial."""

RUNNER_NODE_PARAMETERS = ("behaviour_tree/data_dir", "sigma7_node/backend", "sigma7_node/scenario")
"""Node parameters the study runner sets itself for every trial (through full.launch's data_dir, device, scenario)."""


@functools.lru_cache(maxsize=None)
def node_defaults(node: str) -> Dict[str, Any]:
    """The parameters of ``node`` as its yaml gives them, flattened to ``a/b`` names."""
    data = config_values(NODE_PARAMETER_FILES[node])
    return dict(_flatten(data))


def _flatten(data: Dict[str, Any], prefix: str = "") -> List[Tuple[str, Any]]:
    items: List[Tuple[str, Any]] = []
    for key, value in data.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            items.append((name, value))  # a group: named to say so, never settable as a whole
            items += _flatten(value, name + "/")
        else:
            items.append((name, value))
    return items


def check_parameter(name: str, value: Any) -> Optional[str]:
    """Why ``value`` cannot be given to the node parameter ``name`` (``<node>/<parameter>``), or None when it can."""
    node, _, parameter = name.partition("/")
    if name in RUNNER_NODE_PARAMETERS:
        return f"{name} is set by the study runner for every trial"
    if node not in NODE_PARAMETER_FILES:
        return f"unknown node {node!r} in {name!r} (a study sets parameters of {', '.join(NODE_PARAMETER_FILES)})"
    defaults = node_defaults(node)
    where = f"config/{NODE_PARAMETER_FILES[node]}"
    if parameter not in defaults:
        close = difflib.get_close_matches(parameter, list(defaults), n=1)
        hint = f"; did you mean {node}/{close[0]}?" if close else ""
        return f"unknown parameter {name!r}: {node} has no parameter {parameter!r} (its parameters: {where}){hint}"
    default = defaults[parameter]
    if isinstance(default, dict):
        return f"{name!r} is a group of parameters; name one of {', '.join(sorted(default))}"
    expected = _type_name(default)
    if _type_name(value) != expected and not (expected == "number" and _type_name(value) == "integer"):
        return f"{name} must be {expected} like its default in {where} ({default!r}), got {value!r}"
    if node == "teaching_gui":
        *groups, leaf = parameter.split("/")
        override: Dict[str, Any] = {leaf: value}
        for group in reversed(groups):  # a parameter of a section (teleop/assistance/enabled) overrides just that key
            override = {group: override}
        try:
            GuiConfig.load(**override)
        except GuiConfigError as error:
            return f"{name}: {error}"
    return None


def _type_name(value: Any) -> str:
    if isinstance(value, bool):
        return "true or false"
    if isinstance(value, int):
        return "integer"
    if isinstance(value, float):
        return "number"
    if isinstance(value, str):
        return "text"
    if isinstance(value, list):
        return "a list"
    return type(value).__name__


@functools.lru_cache(maxsize=1)
def launch_arguments() -> Tuple[str, ...]:
    """The arguments full.launch declares."""
    root = ElementTree.parse(share_dir() / "launch" / "full.launch").getroot()
    return tuple(argument.get("name") for argument in root.iter("arg"))


def check_launch_argument(name: str, value: Any) -> Optional[str]:
    """Why ``name: value`` cannot be passed to full.launch for a study's trials, or None."""
    if name in RUNNER_LAUNCH_ARGUMENTS:
        return f"{name} is set by the study runner for every trial"
    if name not in launch_arguments():
        close = difflib.get_close_matches(name, launch_arguments(), n=1)
        hint = f"; did you mean {close[0]}?" if close else ""
        return f"unknown full.launch argument {name!r}{hint}"
    if not isinstance(value, (str, bool, int, float, list)):
        return f"{name} must be text, a number, true/false or a list, got {value!r}"
    return None


def parameters_file(parameters: Dict[str, Any]) -> str:
    """A rosparam yaml setting ``<node>/<parameter>`` values in the root namespace (full.launch study_parameters)."""
    nested: Dict[str, Any] = {}
    for name, value in sorted(parameters.items()):
        *groups, leaf = name.split("/")
        level = nested
        for group in groups:
            level = level.setdefault(group, {})
        level[leaf] = value
    return yaml.safe_dump(nested, default_flow_style=False, sort_keys=True)
