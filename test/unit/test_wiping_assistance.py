"""The RSS controller on the wiped surface (teleteach.wiping.assistance).

The boundary of the tool's centre, the scripted operators nobody tuned to, direct and shared control over the same
commands, and the bench's verdicts.
"""

import numpy as np
import pytest
from bench_scripts import bench_module

from teleteach.core.scene import load_scene
from teleteach.shared_control import wipe_measures
from teleteach.shared_control.loop import SharedControlConfig
from teleteach.shared_control.surface import wiping_box
from teleteach.wiping.assistance import direct_targets, human_wipe, shared_targets, solve_times

SCENE = load_scene()
BOARD = SCENE.surface("counter_board")
BOX = wiping_box(BOARD, SCENE.wiping_tool.size[:2])
CONFIG = SharedControlConfig.from_yaml()


def test_the_boundary_keeps_the_whole_patch_on_the_marked_area():
    assert (BOX.x_min, BOX.y_min, BOX.x_max, BOX.y_max) == pytest.approx((-0.175, -0.07, 0.175, 0.07))


def test_an_operator_wipes_right_to_left_the_same_for_a_seed_and_differently_for_another():
    commands, start = human_wipe(3, "wave", BOX, CONFIG.dt)
    again, _ = human_wipe(3, "wave", BOX, CONFIG.dt)
    np.testing.assert_array_equal(commands, again)
    assert not np.array_equal(commands[:50], human_wipe(4, "wave", BOX, CONFIG.dt)[0][:50])
    targets = direct_targets(commands, start, CONFIG.dt)
    assert targets[0, 0] > 0.1 and targets[-1, 0] < -0.1  # across most of the box, right to left
    along = -np.diff(targets[:, 0]) / CONFIG.dt
    assert 0.03 < np.mean(along) < 0.08  # ~5 cm/s along u on average
    pace = np.convolve(along, np.ones(50) / 50, mode="valid")  # over 1 s: the hand's pace, not the pattern's
    assert np.std(pace) > 0.1 * np.mean(pace)  # the hand's reaches: its pace changes along the stroke


def test_the_operators_pattern_is_not_the_models_it_wanders_in_size():
    commands, start = human_wipe(1, "cycloid", BOX, CONFIG.dt)
    targets = direct_targets(commands, start, CONFIG.dt)
    times = CONFIG.dt * np.arange(len(commands))
    fit = wipe_measures.pattern_fits("cycloid", times, commands, targets)
    assert fit["F_x"] > 1e-4  # a model-made cycloid fits to ~1e-10 (test_wiping_measures)


def test_shared_control_keeps_the_tool_inside_where_a_drifting_operator_leaves_it():
    seed = next(
        seed
        for seed in range(40)
        if wipe_measures.boundary_violations(direct_targets(*human_wipe(seed, "wave", BOX, CONFIG.dt), CONFIG.dt), BOX)[
            "count"
        ]
        > 10
    )
    commands, start = human_wipe(seed, "wave", BOX, CONFIG.dt)
    shared, records = shared_targets(commands, start, BOX, CONFIG)
    assert wipe_measures.boundary_violations(shared, BOX, 1e-6)["count"] == 0
    recognised = [record.skill for record in records[CONFIG.n_window :]]
    assert recognised.count("wave") > 0.8 * len(recognised)
    assert len(solve_times(records)) == len(commands) and np.all(solve_times(records) >= 0.0)


def rows(skill, direct_fx, shared_fx, direct_violations=0, shared_violations=0, over=0):
    return [
        {
            "skill": skill,
            "cycles": 100,
            "direct": {
                "F_x": d,
                "F_h": 1.0,
                "F_x_targets": d,
                "contact_fraction": 1.0,
                "covered_fraction": 0.5,
                "boundary_violations": direct_violations,
            },
            "shared": {
                "F_x": s,
                "F_h": 1.0,
                "F_x_targets": s,
                "contact_fraction": 1.0,
                "covered_fraction": 0.5,
                "boundary_violations": shared_violations,
                "misidentified": 0,
                "solve_p99_ms": 2.0,
                "over_cycle": over,
            },
        }
        for d, s in zip(direct_fx, shared_fx)
    ]


def test_the_bench_judges_each_goal_from_the_paired_trials():
    bench = bench_module("wiping_shared_control")
    good = rows("cycloid", [2.0, 2.0, 2.0], [1.0, 1.5, 3.0], direct_violations=5) + rows("wave", [1.0] * 3, [1.1] * 3)
    summary = bench.summarise(good)
    assert summary["cycloid"]["shared_over_direct_F_x_median"] == pytest.approx(0.75)
    assert summary["cycloid"]["shared_F_x_lower_in"] == 2
    assert [check["met"] for check in bench.goals(summary)] == [True, True, True, True]
    bad = rows("cycloid", [1.0] * 3, [1.2] * 3, shared_violations=1, over=3) + rows("wave", [1.0] * 3, [1.11] * 3)
    assert [check["met"] for check in bench.goals(bench.summarise(bad))] == [False, False, False, False]


def test_the_moving_edge_comes_down_over_the_board_and_shared_control_keeps_off_it_where_direct_control_crosses():
    from teleteach.wiping.assistance import OBSTACLE_FAR, OBSTACLE_NEAR, OBSTACLE_PERIOD, moving_edge

    assert moving_edge(0.0).y == pytest.approx(OBSTACLE_FAR) and moving_edge(OBSTACLE_PERIOD / 2).y == pytest.approx(
        OBSTACLE_NEAR
    )
    assert moving_edge(0.3).distance(np.array([0.0, -0.05]))[0] > 0.0  # below the edge is free

    def crossings(targets):
        edges = [moving_edge(k * CONFIG.dt) for k in range(len(targets))]
        return wipe_measures.obstacle_violations(targets, edges, 1e-6)["count"]

    seed = next(
        seed
        for seed in range(40)
        if crossings(direct_targets(*human_wipe(seed, "wave", BOX, CONFIG.dt), CONFIG.dt)) > 10
    )
    commands, start = human_wipe(seed, "wave", BOX, CONFIG.dt)
    shared, _ = shared_targets(commands, start, BOX, CONFIG, moving_edge)
    assert crossings(shared) == 0
    assert wipe_measures.boundary_violations(shared, BOX, 1e-6)["count"] == 0
