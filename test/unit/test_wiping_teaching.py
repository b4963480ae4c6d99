"""Teaching the stiffness during a wipe with the clutch: the stiffness shaped while clutched, the pattern kept by the
shared controller meanwhile, and the demonstration pressing each cycle with that cycle's stiffness (issue 49)."""

import math

import numpy as np
import pytest

from teleteach.core.gui_config import GuiConfig
from teleteach.core.scene import load_scene
from teleteach.core.wiping import WipingError, load_wiping_config
from teleteach.shared_control.loop import SHARED, SharedControlConfig
from teleteach.shared_control.surface import pressing_depth, wiping_box
from teleteach.sim.robot_sim import RobotSim
from teleteach.sim.uncertainty import UncertaintySettings
from teleteach.wiping.ablation import TAUGHT
from teleteach.wiping.assistance import human_wipe
from teleteach.wiping.teaching import ClutchTeaching, clutch_teaching, taught_wipe
from teleteach.wiping.trial import SurfaceStiffness, SurfaceWiper, wiping_scene

SCENE = load_scene()
BOARD = SCENE.surface("counter_board")
CONFIG = load_wiping_config()
STIFF = SurfaceStiffness(3000.0, 3000.0, 3000.0)


def test_the_stiffness_is_shaped_only_while_the_clutch_is_held():
    teaching = ClutchTeaching(2.0, 4.0, STIFF, TAUGHT)
    assert teaching.stiffness(0.0) == STIFF and teaching.stiffness(1.99) == STIFF
    assert teaching.stiffness(4.0) == TAUGHT and teaching.stiffness(9.0) == TAUGHT
    halfway = teaching.stiffness(3.0)
    assert halfway.along_u == 3000.0 and math.isclose(halfway.normal, 1650.0)  # minimum jerk: half at half time
    assert teaching.stiffness(2.5).normal > 2600.0  # slow at first, as a hand starts
    assert [teaching.clutched(t) for t in (1.99, 2.0, 3.99, 4.0)] == [False, True, True, False]
    with pytest.raises(ValueError, match="held for a while"):
        ClutchTeaching(3.0, 3.0, STIFF, TAUGHT)


def test_while_clutched_the_controller_keeps_the_operators_pattern_and_gives_it_back_on_release():
    config = SharedControlConfig.from_yaml(solver="fast")
    box = wiping_box(BOARD, SCENE.wiping_tool.size[:2])
    commands, start = human_wipe(8, "wave", box, config.dt)
    teaching = clutch_teaching(len(commands) * config.dt, TAUGHT)
    targets, stiffnesses, records = taught_wipe(commands, start, box, config, teaching)
    times = config.dt * np.arange(len(commands))
    clutched = [index for index, time in enumerate(times) if teaching.clutched(time)]
    assert len(clutched) > 50
    for index in clutched:
        assert records[index].message.startswith("clutch: keeping the wave"), (index, records[index].message)
        assert records[index].mode == SHARED and records[index].skill == "wave"
    after = clutched[-1] + 1
    assert not records[after].message.startswith("clutch")
    np.testing.assert_allclose(records[after].command, commands[after])  # the operator's command again
    # the scripted operator starts where the GUI's wipe teaching starts the ellipsoid: SHARED CONTROL's stiffness
    assert stiffnesses[0] == SurfaceStiffness(*GuiConfig.load().shared_control_stiffness)
    assert stiffnesses[-1] == TAUGHT
    travel = np.linalg.norm(targets[clutched[-1]] - targets[clutched[0]])
    assert travel > 0.02  # the wave went on across the board meanwhile
    assert np.all(np.linalg.norm(np.diff(targets, axis=0), axis=1) <= 0.3 * config.dt)  # no jump at either end


def test_a_demonstration_presses_each_cycle_as_deep_as_that_cycles_stiffness_asks():
    sim = RobotSim(wiping_scene(SCENE, BOARD), uncertainty=UncertaintySettings.none())
    try:
        sim.place_base(SCENE.base_poses["wipe_counter"])
        wiper = SurfaceWiper(sim, None, BOARD, CONFIG)
        targets = np.zeros((3, 2))
        skill = wiper.pattern_skill(targets, [STIFF, ClutchTeaching(0, 1, STIFF, TAUGHT).stiffness(0.5), TAUGHT])
        depths = SCENE.wiping_tool.reach - skill.equilibrium_pose[:, 2]
        expected = [pressing_depth(CONFIG, np.diag([3000.0, 3000.0, k]), (0, 0, 1)) for k in (3000.0, 1650.0, 300.0)]
        np.testing.assert_allclose(depths, expected, rtol=1e-9)  # 3.3 mm, 6.1 mm, 33 mm for 10 N
        np.testing.assert_allclose(np.diag(skill.stiffness[2]), TAUGHT.eigenvalues())
        with pytest.raises(WipingError, match="2 stiffnesses for 3 targets"):
            wiper.pattern_skill(targets, [STIFF, TAUGHT])
    finally:
        sim.close()
