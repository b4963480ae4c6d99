"""Whether a screenshot shows what it should: RViz's own window with the robot and the scene drawn.

RViz takes seconds to show its main window (a splash screen first) and more to draw the robot from TF and the
scene's markers; a picture taken after a fixed wait showed the splash, or whatever window lay on top. The picture
is judged on its content: most of it is the 3D view's background colour (the main window is up), and inside the
view enough pixels are not (something is drawn).
"""

import pathlib
from typing import Sequence, Tuple, Union

import numpy as np

MIN_VIEW_SHARE = 0.25  # the 3D view fills at least this much of RViz's display when its main window is shown
MIN_DRAWN_SHARE = 0.03  # of the 3D view's box, this much at least is robot, shelf, products, marker
TOLERANCE = 3  # [0-255] per channel: a pixel this close to the background colour is background


def rviz_picture(path: Union[str, pathlib.Path], background: Sequence[int]) -> Tuple[bool, float, str]:
    """(whether the picture shows RViz's 3D view with a drawn scene, the drawn share of the view, why not).

    Args:
        path: a screenshot of the display RViz alone runs on.
        background: the 3D view's background colour (the .rviz file's Global Options, Background Color).
    """
    from PIL import Image

    with Image.open(path) as picture:
        pixels = np.asarray(picture.convert("RGB"), dtype=int)
    is_background = np.all(np.abs(pixels - np.asarray(background, dtype=int)) <= TOLERANCE, axis=2)
    share = float(is_background.mean())
    if share < MIN_VIEW_SHARE:
        return False, 0.0, f"only {100 * share:.0f} % of it is the 3D view's background: RViz's window is not up"
    rows, columns = np.nonzero(is_background)
    view = is_background[rows.min() : rows.max() + 1, columns.min() : columns.max() + 1]
    drawn = float(1.0 - view.mean())
    if drawn < MIN_DRAWN_SHARE:
        return False, drawn, f"its 3D view is empty ({100 * drawn:.1f} % drawn): the robot and the scene are not drawn"
    return True, drawn, ""


def background_colour(rviz_config: Union[str, pathlib.Path]) -> Tuple[int, int, int]:
    """The 3D view's background colour of an .rviz file (Global Options: Background Color: r; g; b)."""
    import yaml

    options = yaml.safe_load(pathlib.Path(rviz_config).read_text())["Visualization Manager"]["Global Options"]
    red, green, blue = (int(value) for value in str(options["Background Color"]).split(";"))
    return red, green, blue
