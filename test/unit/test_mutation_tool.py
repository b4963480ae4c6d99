"""scripts/mutation's own logic (bench/mutation.py): its config, mutmut's results and diffs read, the figures and
the results file merged. mutmut itself never runs here (minutes per module; not part of the suite)."""

import re

import pytest
from bench_scripts import bench_module
from conftest import ROOT

SOURCE = '''"""A module."""


def flick(base, t, duration):
    """Dips."""
    if not 0.0 <= t <= duration:
        return base
    return base * 0.5


class Detector:
    @property
    def ready(self):
        return True

    def update(self, angle):
        if angle > 0.2:
            return True
        if angle > 0.2:
            return False
        return None
'''


ROS_LAYER = re.compile(r"\bimport rospy\b|teleteach\.msg\b|teleteach(\.\w+)*\.ros\b")


@pytest.fixture(scope="module")
def mutation():
    return bench_module("mutation")


def test_every_module_of_the_issue_is_configured_with_existing_tests(mutation):
    modules = mutation.load_config()
    expected = {
        "control/stiffness.py",
        "control/impedance.py",
        "core/validation.py",
        "core/placement.py",
        "bt/editor.py",
        "bt/tree.py",
        "learning/spd.py",
        "learning/dmp.py",
        "shared_control/models.py",
        "haptics/click.py",
        "study/report.py",
    }
    # the issue's core, and the modules added since (core/parameters.py: how every <Part>Config is read;
    # shared_control/constraints.py: what keeps the MPC's states and plans inside the boundary;
    # runtime/experiment.py: what every experiment on a ROS system runs on; core/teleoperation.py: what moves the arm
    # from the device in TELEOP; shared_control/placement.py: what keeps the held product out of the neighbours;
    # skills/authority.py: how much of the operator's correction moves a replayed skill; shared_control/surface.py: the
    # wipe's plane, pressing depth, boundary and the stiffness range it takes)
    added = {
        "core/parameters.py",
        "shared_control/constraints.py",
        "runtime/experiment.py",
        "core/teleoperation.py",
        "shared_control/placement.py",
        "skills/authority.py",
        "shared_control/surface.py",
    }
    assert set(modules) == expected | added
    for module, entry in modules.items():
        assert (ROOT / "src" / "teleteach" / module).is_file(), module
        for test in entry["tests"]:
            assert (ROOT / test).is_file(), test
            assert test.startswith("test/unit/"), test  # never rostests, GUI or e2e tests
            # mutmut's copy of the package has no catkin messages: a test importing the ROS layer fails to collect
            assert not ROS_LAYER.search((ROOT / test).read_text()), test
        for exclusion in entry["equivalent"]:
            assert exclusion["reason"].strip(), exclusion


def test_an_equivalent_mutant_without_a_reason_is_refused(mutation, tmp_path):
    config = tmp_path / "mutation.yaml"
    config.write_text("modules:\n  placement.py:\n    tests: [t.py]\n    equivalent: [{mutant: a, mutation: b}]\n")
    with pytest.raises(ValueError, match="lacks reason"):
        mutation.load_config(config)


@pytest.mark.parametrize(
    "argument", ["haptics/click.py", "haptics.click", "teleteach.haptics.click", "src/teleteach/haptics/click.py"]
)
def test_a_module_is_named_as_a_path_or_a_dotted_name(mutation, argument):
    assert mutation.module_key(argument, {"haptics/click.py": {}}) == "haptics/click.py"


def test_an_unknown_module_is_refused(mutation):
    with pytest.raises(KeyError, match="not a module"):
        mutation.module_key("haptics/dhd.py", {"haptics/click.py": {}})


def test_the_setup_cfg_mutates_one_file_and_selects_the_module_s_tests(mutation):
    text = mutation.setup_cfg("haptics/click.py", ["test/unit/a.py", "test/unit/b.py"])
    assert "only_mutate = src/teleteach/haptics/click.py\n" in text
    assert "pytest_add_cli_args_test_selection =\n    test/unit/a.py\n    test/unit/b.py\n" in text


def test_results_are_read_from_mutmut_s_listing(mutation):
    text = (
        "    teleteach.haptics.click.x_flick__mutmut_1: killed\n"
        "    teleteach.haptics.click.xǁDetectorǁupdate__mutmut_12: survived\n"
        "    teleteach.haptics.click.xǁDetectorǁupdate__mutmut_13: no tests\n"
        "some other line\n"
    )
    assert mutation.parse_results(text) == {
        "teleteach.haptics.click.x_flick__mutmut_1": "killed",
        "teleteach.haptics.click.xǁDetectorǁupdate__mutmut_12": "survived",
        "teleteach.haptics.click.xǁDetectorǁupdate__mutmut_13": "no tests",
    }


def test_the_figures_count_timeouts_as_caught_and_unreached_mutants_as_survivors(mutation):
    statuses = {"a": "killed", "b": "killed", "c": "timeout", "d": "survived", "e": "no tests", "f": "survived"}
    figures = mutation.tally(statuses, equivalent=["f"])
    assert figures["mutants"] == 5
    assert (figures["killed"], figures["timeout"], figures["survived"]) == (2, 1, 2)
    assert figures["score"] == pytest.approx(0.6)
    assert figures["no_tests"] == 1
    assert figures["equivalent_excluded"] == 1
    assert figures["not_checked"] == 0


def test_no_mutants_give_no_score(mutation):
    assert mutation.tally({})["score"] is None


def test_a_run_on_a_subset_keeps_the_other_modules_entries(mutation):
    existing = {"placement.py": {"score": 0.9}, "haptics/click.py": {"score": 0.5}}
    merged = mutation.merge(existing, {"haptics/click.py": {"score": 0.8}, "bt/tree.py": {"score": 0.7}})
    assert merged == {
        "bt/tree.py": {"score": 0.7},
        "haptics/click.py": {"score": 0.8},
        "placement.py": {"score": 0.9},
    }
    assert list(merged) == sorted(merged)


def diff(old_start, body):
    return f"--- src/m.py\n+++ src/m.py\n@@ -{old_start},9 +{old_start},9 @@\n" + body


def test_a_survivor_is_placed_on_its_line_in_the_module(mutation):
    mutant_diff = diff(
        1,
        " def flick(base, t, duration):\n"
        '     """Dips."""\n'
        "-    if not 0.0 <= t <= duration:\n"
        "+    if not 0.0 <= t < duration:\n"
        "         return base\n",
    )
    assert mutation.survivor_line(SOURCE, "m.x_flick__mutmut_4", mutant_diff) == (
        6,
        "if not 0.0 <= t <= duration:",
        "if not 0.0 <= t < duration:",
    )


def test_a_method_s_survivor_among_identical_lines_is_the_one_the_diff_s_offset_names(mutation):
    second = diff(1, " def update(self, angle):\n     if angle > 0.2:\n         return True\n-    if angle > 0.2:\n")
    second += "+    if angle >= 0.2:\n         return False\n"
    assert mutation.survivor_line(SOURCE, "m.xǁDetectorǁupdate__mutmut_7", second)[0] == 19
    first = diff(1, " def update(self, angle):\n-    if angle > 0.2:\n+    if angle >= 0.2:\n         return True\n")
    assert mutation.survivor_line(SOURCE, "m.xǁDetectorǁupdate__mutmut_2", first)[0] == 17


def test_a_removed_line_is_reported_as_such(mutation):
    removed = diff(1, ' def flick(base, t, duration):\n     """Dips."""\n     if not 0.0 <= t <= duration:\n')
    removed += "         return base\n-    return base * 0.5\n"
    assert mutation.survivor_line(SOURCE, "m.x_flick__mutmut_9", removed) == (8, "return base * 0.5", "")


def test_an_exclusion_applies_only_while_its_mutant_still_mutates_as_written(mutation):
    diffs = {"m.x_flick__mutmut_4": diff(1, "-    return base * 0.5\n+    return base / 0.5\n")}
    still = {"mutant": "m.x_flick__mutmut_4", "mutation": "return base / 0.5", "reason": "r"}
    changed = {"mutant": "m.x_flick__mutmut_4", "mutation": "return base * 1.5", "reason": "r"}
    gone = {"mutant": "m.x_flick__mutmut_5", "mutation": "x", "reason": "r"}
    applied, warnings = mutation.applicable_exclusions([still, changed, gone], diffs)
    assert applied == ["m.x_flick__mutmut_4"]
    assert len(warnings) == 2
    assert "now mutates to 'return base / 0.5'" in warnings[0]
    assert "no such surviving mutant" in warnings[1]
