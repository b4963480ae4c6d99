"""The benches of bench/ for the tests that check them (bench scripts run from the checkout, they are no package), and
the suite's side-by-side rule for the bench that measures the suite."""

import importlib.util
import pathlib

BENCH = pathlib.Path(__file__).resolve().parents[1] / "bench"


def bench_module(name):
    """bench/<name>.py as a module."""
    spec = importlib.util.spec_from_file_location(f"bench_{name}", BENCH / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def suite_rule():
    """test/conftest.py as a module of its own: ``conftest`` in sys.modules is the folder pytest loaded last."""
    spec = importlib.util.spec_from_file_location("teleteach_suite_rule", BENCH.parent / "test" / "conftest.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
