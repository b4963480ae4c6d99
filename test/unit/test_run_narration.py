"""The main job's live output tells the operator's steps as thesis_full.yaml plays them, in the summary's words."""

from teleteach.core.active_tab import Tab
from teleteach.run.narration import HOLD, Narration

INITIAL = ("LookToShelf", "PickItem", "MoveBase", "PlaceItem", "DropItem", "Idle")
AFTER_REMOVAL = ("LookToShelf", "PickItem", "MoveBase", "DropItem", "Idle")


def test_the_tree_edit_the_teaching_and_the_taught_skill_are_told_once_each():
    narration = Narration(INITIAL)
    # Expect: the GUI opening in START by itself is no step of the operator's; HIGH-LEVEL is
    assert narration.tab(Tab.START) is None
    assert narration.tab(Tab.HIGH_LEVEL) == "operator: opened HIGH-LEVEL"
    assert narration.tree(INITIAL) is None
    assert narration.tree(AFTER_REMOVAL) == "operator: tree edit: removed PlaceItem"
    assert narration.tree(AFTER_REMOVAL) is None
    assert narration.tab(Tab.LOW_LEVEL) == "operator: opened LOW-LEVEL"
    assert narration.recording(False) is None  # the GUI's latched false at its start
    assert narration.recording(True) == "operator: LOW-LEVEL teaching: recording started"
    assert narration.recording(False) == "operator: LOW-LEVEL teaching: recording stopped"
    assert narration.taught(["DemonstratedPlace_1"]) == "operator: taught DemonstratedPlace_1 (a new HIGH-LEVEL button)"
    assert narration.taught(["DemonstratedPlace_1"]) is None
    inserted = AFTER_REMOVAL[:3] + ("DemonstratedPlace_1",) + AFTER_REMOVAL[3:]
    # Expect the summary's words (outcome.describe_edit): "inserted ... at index 3", not "added"
    assert narration.tree(inserted) == "operator: tree edit: inserted DemonstratedPlace_1 at index 3"
    assert Narration.help_request("PickItem", "no product") == "help request: PickItem: no product"


def test_the_stiffness_is_told_once_the_handle_held_it_and_again_when_turned_45_degrees():
    narration = Narration(INITIAL)
    narration.tab(Tab.LOW_LEVEL)
    soft = (404.0, 404.0, 2006.0)
    # Expect nothing while the handle moves, the values once they held for HOLD of ROS time
    assert narration.stiffness(0.0, (900.0, 700.0, 1500.0), 0.0) is None
    assert narration.stiffness(0.1, soft, 0.0) is None
    assert narration.stiffness(0.1 + HOLD / 2, soft, 0.0) is None
    told = "operator: stiffness X/Y/Z 404/404/2006 N/m, ellipsoid turned 0 deg about Z"
    assert narration.stiffness(0.1 + HOLD, soft, 0.0) == told
    assert narration.stiffness(0.2 + HOLD, soft, 0.0) is None  # told once
    assert narration.stiffness(5.0, (410.0, 404.0, 2006.0), 2.0) is None  # a small change is not a new step
    stiff_y = (404.0, 2189.0, 2006.0)
    narration.stiffness(6.0, stiff_y, 0.0)
    assert narration.stiffness(6.0 + HOLD, stiff_y, 0.0) == told.replace("404/404", "404/2189")
    # Expect: a turn on its way (a new yaw every 20 ms) is not told; where it stops is
    assert all(narration.stiffness(7.0 + k * 0.02, stiff_y, -k) is None for k in range(46))
    assert narration.stiffness(7.9 + HOLD, stiff_y, -45.0).endswith("ellipsoid turned -45 deg about Z")
    # Expect: the same axes with their signs flipped (yaw 135 deg) are the same ellipsoid, not a turn
    narration.stiffness(9.0, stiff_y, 135.0)
    assert narration.stiffness(9.0 + HOLD, stiff_y, 135.0) is None


def test_the_stiffness_outside_low_level_is_no_step_of_the_operators():
    narration = Narration(INITIAL)
    narration.tab(Tab.SHARED_CONTROL)
    narration.stiffness(0.0, (500.0, 500.0, 500.0), 0.0)
    assert narration.stiffness(1.0, (500.0, 500.0, 500.0), 0.0) is None
