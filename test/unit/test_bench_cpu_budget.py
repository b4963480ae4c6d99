"""bench/cpu_budget.py's profile: py-spy (installed by scripts/setup) samples a running process from outside and the
bench names the function its CPU went to."""

import subprocess
import sys
import time

import pytest
from bench_scripts import bench_module

BUSY = """
import time

def spin_in_python():
    total = 0
    for number in range(200000):
        total += number

def sleep_between():
    time.sleep(0.01)

start = time.monotonic()
while time.monotonic() - start < 20.0:
    spin_in_python()
    sleep_between()
"""


@pytest.fixture(scope="module")
def cpu_budget():
    return bench_module("cpu_budget")


@pytest.mark.slow
def test_a_profile_names_the_function_the_cpu_went_to(cpu_budget, tmp_path, monkeypatch):
    monkeypatch.setattr(cpu_budget, "PROFILES", tmp_path)
    busy = subprocess.Popen([sys.executable, "-c", BUSY])
    try:
        time.sleep(1.0)  # the interpreter is up: py-spy finds its version in its memory
        samplers = cpu_budget.start_profiles({"busy": busy.pid}, 2.0, "idle")
        functions = cpu_budget.hot_functions(cpu_budget.stop_profile(*samplers["busy"]))
    finally:
        busy.kill()
        busy.wait()
    # Expect the loop's function first with most samples; the sleeping function costs no samples (idle threads are
    # not sampled), so it is absent or far behind
    assert functions[0][0] == "spin_in_python (<string>)", functions
    assert functions[0][1] > 80.0, functions
    assert (tmp_path / "idle_busy.txt").stat().st_size > 0


def test_hot_functions_add_a_function_s_own_samples_over_its_stacks(cpu_budget):
    stacks = (
        "main (node.py:1);step (sim.py:10) 30\n"
        "main (node.py:1);publish (ros.py:5);serialize (msg.py:2) 10\n"
        "other (node.py:20);step (sim.py:10) 20\n"
        "main (node.py:1) 40\n"
    )
    # Expect step's two stacks added (50 of 100 samples), then main's own 40, then serialize's 10; publish has none
    assert cpu_budget.hot_functions(stacks) == [
        ["step (sim.py)", 50.0],
        ["main (node.py)", 40.0],
        ["serialize (msg.py)", 10.0],
    ]
