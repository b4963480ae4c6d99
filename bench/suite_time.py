"""Benchmark: where the full suite's time goes, and the least wall time its tests allow on this many workers (issue 50).

Runs the full suite as CI does (``bash scripts/test``: one pytest-xdist worker per core) with a JUnit XML report, or
reads one a run left (``--report``), and prints pytest's wall time, the tests' own times added up per tier, the
slowest tests, and the least wall time any schedule could give: the tests' total over the workers, and never less
than the tests that run alone (test/conftest.py's ALONE). Writes bench/results/suite_time.json.

    source build/env.sh && python bench/suite_time.py [--report junit.xml --workers 2]
"""

import argparse
import collections
import json
import os
import pathlib
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ElementTree

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "test"))

from bench_scripts import suite_rule  # noqa: E402

from teleteach.run.provenance import provenance  # noqa: E402

RULE = suite_rule()  # test/conftest.py's ALONE and LIGHT

RESULT = ROOT / "bench" / "results" / "suite_time.json"
GOAL = 15 * 60.0  # [s] issue 50: the full suite on a fresh Debian 12
TIERS = {  # JUnit classname prefix -> tier
    "test.e2e.": "test/e2e",
    "test.test_rostests": "rostests",
    "test.ros.": "test/ros",
    "test.gui.": "test/gui",
    "test.unit.": "test/unit",
    "test.test_lint": "lint",
}


def test_cases(report: pathlib.Path):
    """(pytest node id, seconds, failed) of every test case, and pytest's wall time [s]."""
    root = ElementTree.parse(report).getroot()
    suite = root if root.tag == "testsuite" else root.find("testsuite")
    cases = []
    for case in suite.iter("testcase"):
        path = case.get("classname").replace(".", "/") + ".py"
        failed = case.find("failure") is not None or case.find("error") is not None
        cases.append((f"{path}::{case.get('name')}", float(case.get("time") or 0.0), failed))
    return cases, float(suite.get("time"))


def summary(cases, wall: float, workers: int) -> dict:
    """The figures of one run: per tier, alone, light, the least wall time, the goal."""
    tiers = collections.defaultdict(lambda: {"tests": 0, "seconds": 0.0})
    for nodeid, seconds, _ in cases:
        classname = nodeid.split("::")[0].removesuffix(".py").replace("/", ".")
        tier = next((name for prefix, name in TIERS.items() if classname.startswith(prefix)), "other")
        tiers[tier]["tests"] += 1
        tiers[tier]["seconds"] += seconds
    total = sum(seconds for _, seconds, _ in cases)
    alone = sum(seconds for nodeid, seconds, _ in cases if nodeid.startswith(tuple(RULE.ALONE)))
    light = sum(seconds for nodeid, seconds, _ in cases if nodeid.startswith(tuple(RULE.LIGHT)))
    least = max(total / workers, alone)
    return {
        "workers": workers,
        "tests": len(cases),
        "failed": [nodeid for nodeid, _, failed in cases if failed],
        "wall_s": wall,
        "tests_total_s": total,
        "tiers": dict(tiers),
        "alone_s": alone,
        "light_s": light,
        "least_wall_s": least,
        "busy_fraction": total / (workers * wall),
        "slowest": [[nodeid, seconds] for nodeid, seconds, _ in sorted(cases, key=lambda case: -case[1])[:25]],
        "goal": {
            "goal": f"pytest's wall time <= {GOAL:.0f} s (the fresh machine's setup comes on top)",
            "met": wall <= GOAL,
            "measured": f"{wall:.0f} s; no schedule of these tests on {workers} workers can go below {least:.0f} s",
        },
    }


def run_suite(report: pathlib.Path) -> None:
    command = ["bash", str(ROOT / "scripts" / "test"), "-q", "-p", "no:cacheprovider", f"--junitxml={report}"]
    subprocess.run(command, cwd=ROOT, check=False)


def print_figures(result: dict) -> None:
    print(f"{result['tests']} tests, {len(result['failed'])} failed, {result['wall_s']:.0f} s of pytest's wall time")
    print(f"the tests' own times: {result['tests_total_s']:.0f} s on {result['workers']} workers", end="")
    print(f" ({100 * result['busy_fraction']:.0f} % busy)")
    for tier, figures in sorted(result["tiers"].items(), key=lambda item: -item[1]["seconds"]):
        print(f"  {tier:10s} {figures['tests']:5d} tests {figures['seconds']:7.0f} s")
    print(f"alone (ALONE): {result['alone_s']:.0f} s; beside them (LIGHT): {result['light_s']:.0f} s")
    print(f"least wall time of any schedule: {result['least_wall_s']:.0f} s; the goal: {GOAL:.0f} s")
    print(f"{'met' if result['goal']['met'] else 'NOT MET'}: {result['goal']['goal']}: {result['goal']['measured']}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--report", type=pathlib.Path, help="a JUnit XML report of a full run (default: run one)")
    parser.add_argument("--workers", type=int, default=os.cpu_count(), help="the run's workers (scripts/test's)")
    options = parser.parse_args()
    origin, started = provenance([]), time.perf_counter()  # what it measures: bench/measures.yaml
    with tempfile.TemporaryDirectory() as folder:
        report = options.report or pathlib.Path(folder) / "junit.xml"
        if options.report is None:
            run_suite(report)
        cases, wall = test_cases(report)
    origin["wall_s"] = time.perf_counter() - started
    if options.report is not None:
        origin["report"] = str(options.report)  # a run this bench did not watch: its commit is the caller's word
    result = {"provenance": origin, **summary(cases, wall, options.workers)}
    print_figures(result)
    RESULT.parent.mkdir(exist_ok=True)
    RESULT.write_text(json.dumps(result, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
