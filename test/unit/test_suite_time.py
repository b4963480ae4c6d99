"""bench/suite_time.py reads a JUnit XML report as pytest writes it: the tiers, what ran alone, the least wall time."""

from bench_scripts import bench_module

suite_time = bench_module("suite_time")

REPORT = """<?xml version="1.0" encoding="utf-8"?>
<testsuites><testsuite name="pytest" errors="0" failures="1" skipped="0" tests="4" time="500.0">
<testcase classname="test.e2e.test_study_e2e" name="test_report" time="300.0"/>
<testcase classname="test.test_rostests" name="test_rostest[bt_help]" time="20.0"/>
<testcase classname="test.test_rostests" name="test_rostest[pick_and_place]" time="60.0">
<failure message="x"/></testcase>
<testcase classname="test.unit.test_bt_tree" name="test_a" time="120.0"/>
</testsuite></testsuites>
"""


def test_a_report_gives_its_tiers_what_ran_alone_and_the_least_wall_time(tmp_path):
    report = tmp_path / "junit.xml"
    report.write_text(REPORT)
    cases, wall = suite_time.test_cases(report)
    result = suite_time.summary(cases, wall, workers=2)
    assert wall == 500.0 and result["tests"] == 4
    assert result["failed"] == ["test/test_rostests.py::test_rostest[pick_and_place]"]
    assert result["tiers"]["rostests"] == {"tests": 2, "seconds": 80.0}
    assert result["tiers"]["test/e2e"]["seconds"] == 300.0 and result["tiers"]["test/unit"]["tests"] == 1
    # Expect: 500 s of tests on 2 workers could take 250 s, but the e2e run alone takes 300 s
    assert result["alone_s"] == 300.0 and result["light_s"] == 20.0
    assert result["least_wall_s"] == 300.0
    assert result["busy_fraction"] == 0.5
    assert result["slowest"][0] == ["test/e2e/test_study_e2e.py::test_report", 300.0]
    assert result["goal"]["met"]
    assert not suite_time.summary(cases, 901.0, workers=2)["goal"]["met"]
