"""SHARED CONTROL's pictures of the patterns to draw come from the controller's own skill models (eq. 3)."""

import numpy as np
import pytest

from teleteach.gui.shared_control.view import PICTURED, pattern_points
from teleteach.shared_control.models import SKILLS


def test_every_recognised_skill_is_pictured():
    assert set(PICTURED) == set(SKILLS)


def test_the_wave_sways_across_its_path_and_the_cycloid_loops_at_its_radius():
    # Expect, by hand: a wave of amplitude A is y = A sin(2 pi f x) along x; a cycloid's points turn at radius r
    # around a centre that moves along x with the underlying path (x = s + r cos(2 pi f s), y = r sin(2 pi f s))
    amplitude, frequency, _ = PICTURED["wave"]
    wave = pattern_points("wave", PICTURED["wave"], length=0.1, count=101)
    np.testing.assert_allclose(wave[:, 1], amplitude * np.sin(2 * np.pi * frequency * wave[:, 0]), atol=1e-12)
    radius, frequency, _ = PICTURED["cycloid"]
    cycloid = pattern_points("cycloid", PICTURED["cycloid"], length=0.1, count=101)
    along = np.linspace(0.0, 0.1, 101)
    np.testing.assert_allclose(np.hypot(cycloid[:, 0] - along, cycloid[:, 1]), radius, atol=1e-12)
    assert np.any(np.diff(cycloid[:, 0]) < 0)  # it loops: goes back along x for a while
    assert wave[:, 1].max() == pytest.approx(amplitude, rel=0.01)
