"""The RViz picture is judged on what it shows: RViz's 3D view with a drawn scene, not its splash nor the GUI."""

import numpy as np
from conftest import ROOT
from PIL import Image

from teleteach.run.pictures import background_colour, rviz_picture

GREY = (48, 48, 48)  # rviz/teleteach.rviz's background


def picture(tmp_path, pixels):
    path = tmp_path / "shot.png"
    Image.fromarray(np.asarray(pixels, dtype=np.uint8)).save(path)
    return path


def screen(fill=(0, 0, 0)):
    return np.full((400, 600, 3), fill, dtype=np.uint8)


def test_the_layout_s_background_is_read_from_the_rviz_file():
    assert background_colour(ROOT / "rviz" / "teleteach.rviz") == GREY


def test_rviz_with_its_scene_drawn_is_taken(tmp_path):
    shot = screen((239, 239, 239))  # panels
    shot[20:380, 150:590] = GREY  # the 3D view
    shot[150:300, 300:420] = (200, 120, 60)  # the robot and the shelf
    drawn, share, why = rviz_picture(picture(tmp_path, shot), GREY)
    assert drawn and 0.05 < share < 0.2 and why == ""


def test_the_splash_screen_the_gui_and_an_empty_view_are_not(tmp_path):
    splash = screen()
    splash[150:250, 200:400] = (30, 60, 120)
    assert not rviz_picture(picture(tmp_path, splash), GREY)[0]
    gui = screen((250, 240, 250))  # the teaching GUI's START tab
    gui[100:300, 20:580] = (200, 230, 200)
    drawn, _, why = rviz_picture(picture(tmp_path, gui), GREY)
    assert not drawn and "RViz's window is not up" in why
    empty = screen((239, 239, 239))
    empty[20:380, 150:590] = GREY
    drawn, _, why = rviz_picture(picture(tmp_path, empty), GREY)
    assert not drawn and "not drawn" in why
