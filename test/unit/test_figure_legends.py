"""The legends of the report's figures and of learn_skill's Fig. C.1 stand beside the plots: no curve lies under one."""

import numpy as np
import pytest
from session_bags import write_session

from teleteach.core.plotting import covered_points
from teleteach.learning.plot import figure_c1
from teleteach.learning.synthetic import placement_demo
from teleteach.recording.report import high_level_figure, rotation_figure, stiffness_figure, tree_edits
from teleteach.recording.session import read_session


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    return read_session(write_session(tmp_path_factory.mktemp("bags") / "session_2026-01-01-00-00-00.bag"))


@pytest.mark.parametrize("make", ["high_level", "stiffness", "rotation"])
def test_the_report_s_legends_cover_no_curve(session, make):
    figure, _ = {
        "high_level": lambda: high_level_figure(session, tree_edits(session.trees)),
        "stiffness": lambda: stiffness_figure(session),
        "rotation": lambda: rotation_figure(session),
    }[make]()
    assert figure.legends  # the check looked at legends
    assert covered_points(figure) == []


def test_learn_skill_s_figure_legend_covers_no_curve():
    skill, _, _ = placement_demo(angle=45.0, duration=8.0, gui_rate=4.0, seed=4)
    times = np.linspace(skill.time[0], skill.time[-1], 200)
    figure = figure_c1(
        skill.time, skill.stiffness, times, skill.stiffness[np.linspace(0, len(skill.time) - 1, 200).astype(int)]
    )
    assert figure.legends and covered_points(figure) == []
