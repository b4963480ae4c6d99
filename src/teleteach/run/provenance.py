"""Where a bench's result came from: the commit, the command, the configuration read, the machine, the date.

A figure in the README is a claim; stored with this beside it, anyone can tell which code and settings produced it and
whether the result is older than the code it measures.
"""

import datetime
import hashlib
import os
import pathlib
import platform
import subprocess
import sys
from importlib import metadata
from typing import Iterable

PACKAGES = ("numpy", "scipy", "pybullet", "casadi", "py_trees")  # the ones a simulated figure depends on


def _git(*arguments: str) -> str:
    root = pathlib.Path(__file__).resolve().parents[3]
    try:
        return subprocess.run(
            ["git", *arguments], cwd=root, capture_output=True, text=True, check=True, timeout=10
        ).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return ""


def _version(package: str) -> str:
    try:
        return metadata.version(package)
    except metadata.PackageNotFoundError:
        return "not installed"


def commit() -> str:
    """The commit this checkout is at (``unknown`` outside a git checkout)."""
    return _git("rev-parse", "HEAD") or "unknown"


def provenance(config_files: Iterable[pathlib.Path]) -> dict:
    """The provenance of a result whose run starts now (call it first: the code may change while a bench runs).

    The git commit (and whether tracked files other than stored results differed from it: a bench run after another
    has rewritten that one's result, which is an output, not an input), the command line, the SHA-256 of each
    configuration file read, the machine (cores, Python, key packages), the date; the bench adds its wall time [s] as
    ``wall_s``.
    """
    changed = _git("status", "--porcelain", "--untracked-files=no", "--", ".", ":(exclude)bench/results")
    return {
        "commit": commit(),
        "dirty": bool(changed),
        "command": [pathlib.Path(sys.argv[0]).name, *sys.argv[1:]],
        "config_sha256": {
            pathlib.Path(path).name: hashlib.sha256(pathlib.Path(path).read_bytes()).hexdigest()
            for path in config_files
        },
        "machine": {
            "cores": os.cpu_count(),
            "python": platform.python_version(),
            "packages": {package: _version(package) for package in PACKAGES},
        },
        "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
    }
