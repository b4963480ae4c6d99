"""The robot's two controllers teleteach switches between, named in one place: ``config/robot_controllers.yaml``.

The GUI (LOW-LEVEL, SHARED CONTROL) and the skill server (predefined skills, replayed stiffness skills) both read them
here, by the section their ``~controllers`` parameter names (``simulation`` for robot_sim, ``franka`` for a real Panda).
"""

import dataclasses
from typing import Optional

import yaml

from teleteach.core.paths import config_file


class ControllerNamesError(ValueError):
    """An unknown section, or a section without both names; the message says which and lists the known ones."""


@dataclasses.dataclass(frozen=True)
class ControllerNames:
    """The position (joint trajectory) controller and the Cartesian impedance controller of one robot."""

    position: str
    impedance: str


def controller_names(section: Optional[str] = None) -> ControllerNames:
    """The controllers of ``section`` of config/robot_controllers.yaml (None or "": its ``default``)."""
    path = config_file("robot_controllers.yaml")
    data = yaml.safe_load(path.read_text()) or {}
    section = section or data.get("default", "")
    sections = sorted(name for name, value in data.items() if isinstance(value, dict))
    entry = data.get(section)
    if not isinstance(entry, dict):
        raise ControllerNamesError(f"controllers {section!r} unknown: one of {', '.join(sections)} ({path})")
    missing = [key for key in ("position", "impedance") if not isinstance(entry.get(key), str) or not entry[key]]
    if missing:
        raise ControllerNamesError(f"controllers {section!r} of {path} has no {' or '.join(missing)} controller name")
    return ControllerNames(position=entry["position"], impedance=entry["impedance"])
