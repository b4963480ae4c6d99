"""The stiffness ablation's question (teleteach.run.ablation) and its statistics (teleteach.run.trials)."""

import numpy as np
import pytest
from scipy import stats

from teleteach.core import skill_file
from teleteach.core.frames import Transform
from teleteach.run.ablation import (
    HIGH_STIFFNESS,
    INSERTION_START,
    SWEEP,
    across_contrast,
    goals,
    insertion_stiffness,
    stiffness_profiles,
    sweep_name,
    vertical_name,
)
from teleteach.run.trials import bootstrap_median_interval, summarise, wilson_interval


def taught_skill():
    """Compliant start, then Y and X stiffened: a variable profile like a demonstration's, in a gap's frame."""
    times = np.linspace(0.0, 11.0, 45)
    diagonal = np.tile([400.0, 430.0, 2000.0], (len(times), 1))
    diagonal[times >= 3.0, 1] = 1900.0
    diagonal[times >= 5.0, 0] = 1900.0
    poses = np.tile([-0.3, 0.0, 0.1, 1.0, 0.0, 0.0, 0.0], (len(times), 1))
    poses[:, 0] = np.linspace(-0.3, 0.0, len(times))
    stiffness = np.array([np.diag(row) for row in diagonal])
    base = skill_file.Skill("DemonstratedPlace_1", "stiffness", times, stiffness, poses, poses)
    return base.relative_to("gap_1", Transform.identity())


def test_the_profiles_change_only_the_stiffness_and_the_sweep_only_the_insertion():
    taught = taught_skill()
    profiles = stiffness_profiles(taught)
    assert list(profiles)[:3] == ["constant_low", "constant_high", "taught"]
    assert len(profiles) == 3 + len(SWEEP) ** 2
    for name, skill in profiles.items():
        skill_file.validate(skill)
        assert skill.name == f"DemonstratedPlace_1_{name}"
        np.testing.assert_array_equal(skill.time, taught.time)
        np.testing.assert_array_equal(skill.equilibrium_pose, taught.equilibrium_pose)
        assert skill.target == taught.target and skill.rotational_stiffness == taught.rotational_stiffness
    # Expect: low = the approach preset throughout, high = 3000 N/m on every axis, taught unchanged
    np.testing.assert_array_equal(
        profiles["constant_low"].stiffness, np.tile(np.diag([400.0, 430.0, 2000.0]), (45, 1, 1))
    )
    np.testing.assert_array_equal(profiles["constant_high"].stiffness, np.tile(HIGH_STIFFNESS * np.eye(3), (45, 1, 1)))
    np.testing.assert_array_equal(profiles["taught"].stiffness, taught.stiffness)
    # Expect: a sweep cell is the taught profile before the insertion, (along, across, taught z) from it on
    cell = profiles[sweep_name(150.0, 3000.0)]
    before = taught.time < INSERTION_START
    np.testing.assert_array_equal(cell.stiffness[before], taught.stiffness[before])
    np.testing.assert_array_equal(
        cell.stiffness[~before], np.tile(np.diag([150.0, 3000.0, 2000.0]), ((~before).sum(), 1, 1))
    )
    assert insertion_stiffness(cell) == (150.0, 3000.0)
    assert insertion_stiffness(taught) == (1900.0, 1900.0)


def test_a_vertical_cell_is_the_taught_profile_with_its_z_stiffness_from_the_insertion_on():
    taught = taught_skill()
    profiles = stiffness_profiles(taught, sweep=(), vertical=(300.0, 1000.0))
    assert list(profiles) == ["constant_low", "constant_high", "taught", "vertical_300", "vertical_1000"]
    assert vertical_name(300.0) == "vertical_300"
    cell = profiles["vertical_300"]
    skill_file.validate(cell)
    before = taught.time < INSERTION_START
    np.testing.assert_array_equal(cell.stiffness[before], taught.stiffness[before])
    np.testing.assert_array_equal(
        cell.stiffness[~before], np.tile(np.diag([1900.0, 1900.0, 300.0]), ((~before).sum(), 1, 1))
    )
    np.testing.assert_array_equal(taught.stiffness[~before][:, 2, 2], 2000.0)  # the taught skill is left alone


@pytest.mark.parametrize("successes, trials", [(0, 30), (3, 30), (27, 30), (30, 30), (10, 10), (0, 7), (12, 19)])
def test_the_wilson_interval_is_the_score_test_s(successes, trials):
    low, high = wilson_interval(successes, trials)
    rate = successes / trials
    # Expect: the bounds are the rates at which the score statistic is exactly 1.96 (an independent root-finding)
    for bound in (low, high):
        if 1e-9 < bound < 1 - 1e-9:
            score = abs(rate - bound) / np.sqrt(bound * (1 - bound) / trials)
            assert score == pytest.approx(stats.norm.ppf(0.975), rel=1e-6)
    assert low <= rate <= high
    if successes in (0, trials):
        assert (low, high)[successes == trials] == pytest.approx(float(successes == trials))


def test_the_bootstrap_interval_covers_the_median_and_narrows_with_more_trials():
    rng = np.random.default_rng(4)
    few, many = rng.normal(10.0, 2.0, 12), rng.normal(10.0, 2.0, 400)
    low_few, high_few = bootstrap_median_interval(few, seed=1)
    low_many, high_many = bootstrap_median_interval(many, seed=1)
    assert low_few <= np.median(few) <= high_few and low_many <= np.median(many) <= high_many
    assert high_many - low_many < 0.5 * (high_few - low_few)


def trial(success, peak, skill_success=None, move=0.0):
    return {
        "seed": 0,
        "success": success,
        "skill_success": success if skill_success is None else skill_success,
        "peak_force_n": peak,
        "peak_neighbour_force_n": peak / 2,
        "neighbour_max_move_m": move,
        "sim_s": 18.0,
        "wall_s": 3.0,
    }


def test_a_summary_counts_the_world_s_verdict_and_where_the_skill_disagrees():
    trials = [trial(True, 10.0), trial(True, 12.0, skill_success=False), trial(False, 40.0, move=0.02)]
    summary = summarise(trials)
    assert summary["success_rate"] == pytest.approx(2 / 3)
    assert summary["skill_success_rate"] == pytest.approx(1 / 3)
    assert summary["verdicts_disagree"] == 1
    assert summary["median_peak_force_n"] == 12.0 and summary["peak_force_n"] == 40.0
    assert summary["neighbour_max_move_m"] == 0.02
    assert summary["success_interval"] == pytest.approx(list(wilson_interval(2, 3)))


def results_with(cells):
    """Ablation results whose cells are summaries of the given (successes, peak force) per trial."""
    summaries = {name: summarise([trial(ok, peak) for ok, peak in rows]) for name, rows in cells.items()}
    profiles = {name: summaries.pop(name) for name in ("constant_low", "constant_high", "taught")}
    vertical = {name: summaries.pop(name) for name in list(summaries) if name.startswith("vertical_")}
    return {"profiles": profiles, "sweep": {"cells": summaries}, "vertical": {"cells": vertical}}


def test_the_goals_are_judged_from_the_figures():
    rng = np.random.default_rng(0)
    compliant = [(True, peak) for peak in rng.normal(8.0, 1.0, 30)]
    stiff = [(index % 2 == 0, peak) for index, peak in enumerate(rng.normal(40.0, 3.0, 30))]
    cells = {"constant_low": compliant, "constant_high": stiff, "taught": compliant, "sweep_a": stiff}
    lines = goals(results_with(cells))
    assert lines[0].startswith("met: the world tells profiles apart")
    assert "constant_high vs constant_low (success)" in lines[0]
    assert lines[1].startswith("met: taught places at 100 %")
    same = [(True, peak) for peak in rng.normal(20.0, 1.0, 30)]
    lines = goals(results_with({"constant_low": same, "constant_high": same, "taught": same, "sweep_a": same}))
    assert lines[0].startswith("not met: the world tells profiles apart (0 pairs")
    assert lines[1].startswith("not met: taught places at 100 %")  # its force is constant high's, not half of it
    soft = [(True, peak) for peak in rng.normal(6.0, 1.0, 30)]
    lines = goals(results_with({"constant_low": same, "constant_high": same, "taught": same, "vertical_300": soft}))
    assert lines[0].startswith("met: the world tells profiles apart (3 pairs")  # the vertical cell counts
    assert lines[2].startswith("met: vertical_300 places at 100 %")


def contact(seed, move, lateral):
    return {"seed": seed, "neighbour_max_move_m": move, "lateral_m": lateral}


def test_across_the_gap_compliant_and_stiff_are_compared_on_the_trials_that_touched_a_neighbour():
    # seeds 0-5 touched: the compliant cell moved the neighbour less in five, more in one; seeds 6-9 touched nothing
    compliant_moves = [0.0002, 0.0003, 0.0001, 0.0004, 0.0002, 0.003, 0.0001, 0.0001, 0.0, 0.0001]
    stiff_moves = [0.0028, 0.0011, 0.0026, 0.0009, 0.0014, 0.001, 0.0001, 0.0002, 0.0001, 0.0]
    compliant = [contact(seed, move, -0.005) for seed, move in enumerate(compliant_moves)]
    stiff = [contact(seed, move, 0.007) for seed, move in enumerate(stiff_moves)]
    trials = {
        "sweep_150_150": compliant,
        "sweep_150_3000": stiff,
        "sweep_3000_150": compliant,
        "sweep_3000_3000": list(reversed(stiff)),  # listed in another order: paired by seed, not by position
        "constant_low": stiff,
        "constant_high": compliant,  # the other way round: the compliant one is the stiffer here
    }
    first, second, profiles = across_contrast(trials, [3000.0, 150.0])
    assert (first["compliant"], first["stiff"]) == ("sweep_150_150", "sweep_150_3000")
    assert (second["compliant"], second["stiff"]) == ("sweep_3000_150", "sweep_3000_3000")
    assert (profiles["compliant"], profiles["stiff"]) == ("constant_low", "constant_high")
    for contrast in (first, second):
        assert contrast["trials"] == 10 and contrast["touched"] == 6 and contrast["compliant_moved_less"] == 5
        assert contrast["sign_test_p"] == pytest.approx(stats.binomtest(5, 6).pvalue)
        assert contrast["neighbour_move_m"] == pytest.approx([0.00025, 0.00125])
        assert contrast["lateral_offset_m"] == pytest.approx([0.005, 0.007])
    assert profiles["compliant_moved_less"] == 1 and profiles["touched"] == 6
    # a pair where no trial touched a neighbour says nothing
    untouched = {name: [contact(seed, 0.0001, 0.0) for seed in range(5)] for name in trials}
    quiet = across_contrast(untouched, [150.0, 3000.0])[0]
    assert quiet["touched"] == 0 and quiet["sign_test_p"] == 1.0 and np.isnan(quiet["neighbour_move_m"][0])
    # one stiffness swept: only the profiles are compared (a cell against itself says nothing)
    assert [(c["compliant"], c["stiff"]) for c in across_contrast(trials, [3000.0])] == [
        ("constant_low", "constant_high")
    ]
