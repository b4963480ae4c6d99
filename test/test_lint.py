"""Lint is part of the tests: ruff (lint + format), catkin_lint, Python 3.8 compatibility (vermin) and the Noetic
pins, which must resolve for CPython 3.8 (Ubuntu 20.04's 3.8.10)."""

import subprocess
import sys

from conftest import ROOT


def run(*command):
    return subprocess.run(command, cwd=ROOT, capture_output=True, text=True)


def test_ruff_lint():
    result = run("ruff", "check", ".")
    assert result.returncode == 0, result.stdout + result.stderr


def test_ruff_format():
    result = run("ruff", "format", "--check", ".")
    assert result.returncode == 0, result.stdout + result.stderr


def test_catkin_lint():
    # Checked through the workspace link so that the folder name is the package name.
    result = run("catkin_lint", "-W2", "--strict", str(ROOT / "build" / "src" / "teleteach"))
    assert result.returncode == 0, result.stdout + result.stderr


def test_the_code_runs_on_python_3_8():
    """ROS Noetic's Python: no syntax, module or library call newer than 3.8 in the library and the nodes."""
    nodes = sorted(str(path) for path in (ROOT / "nodes").iterdir())
    result = run("vermin", "--target=3.8-", "--no-tips", "--violations", "--eval-annotations", "src", "bench", *nodes)
    assert result.returncode == 0, result.stdout + result.stderr


def test_the_noetic_pins_resolve_for_python_3_8(tmp_path):
    """Every pin of requirements-noetic.txt has a CPython 3.8 wheel (the file pins the closed set, so --no-deps)."""
    command = [sys.executable, "-m", "pip", "download", "--no-deps", "--only-binary=:all:", "--python-version"]
    command += ["3.8.10", "--disable-pip-version-check", "-d", str(tmp_path), "-r", "requirements-noetic.txt"]
    result = run(*command)
    # scripts/setup needs PyPI too: a machine that cannot reach it has no teleteach to test, so this fails, not skips
    assert result.returncode == 0, result.stdout + result.stderr
    pins = [line.split("==")[0] for line in (ROOT / "requirements-noetic.txt").read_text().splitlines() if "==" in line]
    assert len(list(tmp_path.glob("*.whl"))) == len(pins)
