"""Lint is part of the tests: ruff (lint + format) and catkin_lint must pass."""

import subprocess

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
