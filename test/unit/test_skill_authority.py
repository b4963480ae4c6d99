"""Authority that follows the skill's confidence (teleteach.skills.authority): its rules, worked out by hand (the replay
on the simulation: test_skills_replay_authority.py)."""

import dataclasses

import numpy as np
import pytest

from teleteach.core.frames import Transform
from teleteach.learning.synthetic import placement_on_trajectory
from teleteach.skills import authority
from teleteach.skills.config import load_motion_config

CONFIG = load_motion_config().authority


def test_confidence_falls_with_the_spread_and_the_distance_from_the_taught_target():
    assert authority.confidence(0.0, 0.0, CONFIG) == 1.0
    assert authority.confidence(CONFIG.spread_unsure / 2, 0.0, CONFIG) == pytest.approx(0.5)
    assert authority.confidence(0.0, CONFIG.distance_unsure / 4, CONFIG) == pytest.approx(0.75)
    assert authority.confidence(CONFIG.spread_unsure / 2, CONFIG.distance_unsure / 4, CONFIG) == pytest.approx(0.375)
    assert authority.confidence(2 * CONFIG.spread_unsure, 0.0, CONFIG) == 0.0
    assert authority.confidence(0.0, 2 * CONFIG.distance_unsure, CONFIG) == 0.0


def with_path(skill, demonstrations, spread, at):
    provenance = dict(skill.provenance, path_demonstrations=demonstrations, path_spread=spread, path_spread_time=at)
    return dataclasses.replace(skill, provenance=provenance)


def test_the_spread_comes_from_the_taught_paths_demonstrations_where_the_hand_is():
    skill = placement_on_trajectory("perpendicular")
    times = np.array([0.0, 1.0, 2.0, 10.0])
    # one demonstration: nothing says how sure it is
    assert authority.spread_along(skill, times, CONFIG).shape == times.shape
    np.testing.assert_allclose(authority.spread_along(skill, times, CONFIG), CONFIG.spread_unknown)
    without_times = dataclasses.replace(skill, provenance={"path_demonstrations": 2, "path_spread": [0.0, 0.02]})
    np.testing.assert_allclose(authority.spread_along(without_times, times, CONFIG), CONFIG.spread_unknown)
    without_spread = dataclasses.replace(skill, provenance={"path_demonstrations": 2, "path_spread_time": [0.0, 2.0]})
    np.testing.assert_allclose(authority.spread_along(without_spread, times, CONFIG), CONFIG.spread_unknown)
    once = with_path(skill, 1, [0.0, 0.02], [0.0, 2.0])
    np.testing.assert_allclose(authority.spread_along(once, times, CONFIG), CONFIG.spread_unknown)
    twice = with_path(skill, 2, [0.0, 0.02], [0.0, 2.0])
    np.testing.assert_allclose(authority.spread_along(twice, times, CONFIG), [0.0, 0.01, 0.02, 0.02])


def test_the_target_distance_is_measured_from_where_the_skill_was_taught():
    skill = placement_on_trajectory("perpendicular")
    taught = skill.target.transform
    assert authority.target_distance(skill, taught) == pytest.approx(0.0)
    moved = Transform.from_pose(taught.as_pose() + np.array([0.03, -0.04, 0.0, 0, 0, 0, 0]))
    assert authority.target_distance(skill, moved) == pytest.approx(0.05)
    assert authority.target_distance(skill.in_base(taught), moved) == 0.0  # replayed where recorded


def test_the_applied_correction_is_clipped_rate_limited_and_dropped_when_it_stops_coming():
    first = authority.Correction(CONFIG).step(3.0, (np.array([0.0, 0.0, 0.01]), 3.0))
    np.testing.assert_allclose(first, 0.0)  # the first step: no time has passed, nothing moves yet
    correction = authority.Correction(CONFIG)
    assert correction.step(0.0, None).shape == (3,)
    np.testing.assert_allclose(correction.step(0.0, None), 0.0)
    asked = (np.array([0.0, 0.0, 0.5]), 0.0)  # longer than max_correction
    np.testing.assert_allclose(correction.step(0.0, asked), 0.0)  # no time passed: no step
    step = correction.step(0.1, (asked[0], 0.1))
    np.testing.assert_allclose(step, [0.0, 0.0, CONFIG.correction_speed * 0.1])
    for now in np.arange(0.2, 2.0, 0.1):
        applied = correction.step(now, (asked[0], now))
    np.testing.assert_allclose(applied, [0.0, 0.0, CONFIG.max_correction])
    last = (asked[0], 1.9)  # not renewed from here: held until it is stale, then back at the same speed
    for now in np.arange(2.0, 1.9 + CONFIG.correction_timeout, 0.1):
        np.testing.assert_allclose(correction.step(now, last), [0.0, 0.0, CONFIG.max_correction])
    at_timeout = authority.Correction(CONFIG)
    at_timeout.step(1.0, (asked[0], 1.0))
    timeout = CONFIG.correction_timeout  # a correction exactly that old still counts
    applied = at_timeout.step(1.0 + timeout, (asked[0], 1.0))
    np.testing.assert_allclose(applied, [0.0, 0.0, min(CONFIG.correction_speed * timeout, CONFIG.max_correction)])
    stale = 1.9 + CONFIG.correction_timeout + 0.05
    applied = correction.step(stale, last)
    assert applied[2] == pytest.approx(CONFIG.max_correction - CONFIG.correction_speed * (stale - now))
    for now in np.arange(stale + 0.1, stale + 1.0, 0.1):
        applied = correction.step(now, last)
    np.testing.assert_allclose(applied, 0.0)
