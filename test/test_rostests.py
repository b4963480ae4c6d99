"""Runs every rostest launch file in test/ros (each beside its check): real nodes over a real roscore (started by
rostest)."""

import subprocess

import pytest
from conftest import ROOT

ROSTESTS = sorted((ROOT / "test" / "ros").glob("*.test"))  # each beside its check; CMakeLists.txt globs the same


@pytest.mark.rostest
@pytest.mark.parametrize("launch_file", ROSTESTS, ids=[path.stem for path in ROSTESTS])
def test_rostest(launch_file):
    result = subprocess.run(
        ["rostest", "teleteach", launch_file.name], cwd=ROOT, capture_output=True, text=True, timeout=900
    )
    output = result.stdout + result.stderr
    assert result.returncode == 0, output[-6000:]
    assert "SUMMARY" in output and "* RESULT: SUCCESS" in output, output[-6000:]
