"""Operators for the sweep: a pattern around any path is eq. 3 again, LASA strokes and minimum-jerk reaches as asked."""

import math

import numpy as np
import pytest

from teleteach.shared_control.models import synthetic_commands
from teleteach.shared_control.operators import (
    commands_around_path,
    lasa_path,
    lasa_shapes,
    minimum_jerk,
    reaching_path,
    retime,
)

DT = 0.02


@pytest.mark.parametrize("skill", ["wave", "cycloid"])
def test_a_pattern_around_a_straight_path_is_the_models_own_command(skill):
    # Independent computation: models.synthetic_commands differentiates eq. 3 symbolically (eq. 4); here the
    # hand's positions are differentiated numerically around a straight line at constant speed.
    heading, speed, rho = 0.7, 0.05, (0.02, 15.0, 0.01)
    times = np.arange(0.0, 4.0, DT)
    path = speed * times[:, None] * np.array([math.cos(heading), math.sin(heading)])
    ours = commands_around_path(path, DT, ((skill, rho), (skill, rho)), switch_time=10.0)
    model = synthetic_commands(skill, rho, heading, speed, times)
    # Central differences inside (O(dt^2)); the two ends are one-sided.
    assert np.max(np.abs(ours[1:-1] - model[1:-1])) < 2e-3 * np.max(np.abs(model))


def test_the_switch_blends_without_a_jump_of_the_hand():
    path = 0.05 * np.arange(0.0, 4.0, DT)[:, None] * np.array([1.0, 0.0])
    commands = commands_around_path(path, DT, (("wave", (0.015, 14.0, 0.0)), ("cycloid", (0.012, 22.0, 0.0))), 2.0)
    # A hand jumping between the two offsets in one sample would move up to 2.7 cm in 20 ms (1.35 m/s).
    assert np.max(np.linalg.norm(commands, axis=1)) < 0.5


def test_a_lasa_stroke_is_scaled_and_timed_as_asked():
    assert len(lasa_shapes()) == 30 and "Sine" in lasa_shapes()
    path = lasa_path("Sine", 0, DT, 0.2, 0.05)
    assert np.ptp(path, axis=0).max() == pytest.approx(0.2, rel=0.02)
    length = np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1))
    assert length / (DT * (len(path) - 1)) == pytest.approx(0.05, rel=0.02)
    assert np.allclose(path[0], 0.0)
    # The human speed profile is kept: not constant.
    speed = np.linalg.norm(np.diff(path, axis=0), axis=1) / DT
    assert speed.max() > 1.5 * speed.min()


def test_minimum_jerk_reaches_and_retiming():
    assert minimum_jerk(np.array([0.0, 0.5, 1.0])).tolist() == [0.0, 0.5, 1.0]
    path = reaching_path([[0.1, 0.0], [0.1, 0.1]], [1.0, 1.0], 0.4, DT / 10)
    assert np.allclose(path[0], 0.0)
    assert np.min(np.linalg.norm(np.diff(path, axis=0), axis=1)) > 0.0  # overlapping reaches: the hand never stops
    slower = retime(path, DT / 10, DT, 0.02)
    length = np.sum(np.linalg.norm(np.diff(slower, axis=0), axis=1))
    assert length / (DT * (len(slower) - 1)) == pytest.approx(0.02, rel=0.03)
