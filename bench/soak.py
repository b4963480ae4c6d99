"""Soak: the test suite N times while a busy loop holds one core; prints, per test, how often it failed.

Each round is one pytest session (``bash scripts/test`` without setup) writing a JUnit XML report; a test that
failed or errored in a round counts once. Extra arguments go to pytest (e.g. a subset: ``-k bt_``). Writes
bench/results/soak.json. Exit status 0 when no test ever failed.

    source build/env.sh && python bench/soak.py 3      (or: bash scripts/soak 3)
"""

import argparse
import collections
import json
import os
import pathlib
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ElementTree

from stress import busy_loop

ROOT = pathlib.Path(__file__).resolve().parents[1]
RESULTS = ROOT / "bench" / "results"


def outcomes(report: pathlib.Path):
    """(test id, failed) for every test case of a JUnit XML report."""
    for case in ElementTree.parse(report).getroot().iter("testcase"):
        name = f"{case.get('classname')}::{case.get('name')}"
        yield name, case.find("failure") is not None or case.find("error") is not None


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("rounds", type=int, help="how many times to run the suite")
    parser.add_argument("--busy-core", type=int, default=(os.cpu_count() or 1) - 1, help="core of the busy loop")
    options, pytest_arguments = parser.parse_known_args()
    failures, runs = collections.Counter(), collections.Counter()
    busy = busy_loop(options.busy_core)
    try:
        for round_number in range(1, options.rounds + 1):
            report = pathlib.Path(tempfile.mkdtemp(prefix="teleteach_soak_")) / "junit.xml"
            command = [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", f"--junitxml={report}"]
            status = subprocess.run([*command, *pytest_arguments], cwd=ROOT).returncode
            print(f"soak: round {round_number} of {options.rounds}: pytest exit status {status}", flush=True)
            if not report.is_file():
                print("soak: pytest wrote no report (collection failed?)")
                return 2
            for name, failed in outcomes(report):
                runs[name] += 1
                failures[name] += failed
    finally:
        busy.kill()
        busy.wait()
    RESULTS.mkdir(exist_ok=True)
    table = {name: {"runs": runs[name], "failures": failures[name]} for name in sorted(runs)}
    (RESULTS / "soak.json").write_text(json.dumps({"rounds": options.rounds, "tests": table}, indent=2) + "\n")
    flaky = [(name, failures[name]) for name in sorted(runs) if failures[name]]
    for name, count in flaky:
        print(f"  {count} of {runs[name]} failed: {name}")
    print(f"soak: {len(runs)} tests x {options.rounds} rounds, {len(flaky)} ever failed")
    return 0 if not flaky else 1


if __name__ == "__main__":
    sys.exit(main())
