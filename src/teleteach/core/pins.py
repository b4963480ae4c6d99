"""The PyPI libraries teleteach runs on, checked against the versions this checkout pins before a node starts.

The venv (scripts/setup) holds exactly the pinned versions; another install earlier on ``sys.path`` (an apt
python3-py-trees 0.7 on Noetic, a user's ``pip install --user``) would shadow them, and py_trees 0.7 fails deep in a
tree's tick instead of at the start. :func:`check` compares what Python would import with ``requirements.txt``
(``requirements-noetic.txt`` on CPython 3.8, ROS Noetic's) and says in one line what is wrong and how to fix it.
"""

import importlib.metadata
import pathlib
import sys
from typing import Dict, List, Optional

from teleteach.core.paths import share_dir

RUNTIME = ("numpy", "scipy", "matplotlib", "casadi", "pybullet", "py_trees", "rosbags")  # what the nodes import


class PinError(RuntimeError):
    """A runtime library is missing or at another version than the pinned one."""


def requirements_file(version: Optional[tuple] = None) -> pathlib.Path:
    """The pins of this Python: requirements-noetic.txt for CPython 3.8 (Ubuntu 20.04), else requirements.txt."""
    version = version or sys.version_info[:2]
    return share_dir() / ("requirements-noetic.txt" if tuple(version) == (3, 8) else "requirements.txt")


def pinned(path: pathlib.Path) -> Dict[str, str]:
    """``name==version`` lines of a requirements file, by normalised name (py_trees and py-trees alike)."""
    pins = {}
    for line in path.read_text().splitlines():
        requirement = line.split("#", 1)[0].strip()
        if "==" in requirement:
            name, version = (part.strip() for part in requirement.split("==", 1))
            pins[_normalised(name)] = version
    return pins


def _normalised(name: str) -> str:
    return name.lower().replace("-", "_").replace(".", "_")


def problems(pins: Optional[Dict[str, str]] = None, names=RUNTIME) -> List[str]:
    """What differs from the pins, one phrase per library (``[]`` when all is as pinned)."""
    pins = pinned(requirements_file()) if pins is None else pins
    found = []
    for name in names:
        wanted = pins.get(_normalised(name))
        if wanted is None:
            continue  # not from PyPI here (Debian's scipy, matplotlib)
        try:
            distribution = importlib.metadata.distribution(name)
        except importlib.metadata.PackageNotFoundError:
            found.append(f"{name} is not installed (teleteach needs {wanted})")
            continue
        if distribution.version != wanted:
            where = distribution.locate_file("")
            found.append(f"{name} {distribution.version} from {where} is first on the path (teleteach needs {wanted})")
    return found


def check() -> None:
    """Raise :class:`PinError` naming every runtime library that is not as pinned, and the fix, in one line."""
    found = problems()
    if found:
        raise PinError(
            f"{'; '.join(found)}: run bash scripts/setup and source build/env.sh (its venv has the pins of "
            f"{requirements_file().name}), or remove the other install"
        )
