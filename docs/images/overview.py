"""Draws docs/images/overview.png from a run folder: the GUI's LOW-LEVEL tab beside RViz's window, as the run saw them.

Run from the checkout after ``bash scripts/demo``: ``python docs/images/overview.py <data dir>/runs/<timestamp>``.
The pictures are the run's own screenshots (its last ``gui_NN_low_level_latest.png``, the arm handed over, and
``rviz.png``), cropped to the windows and scaled to one height.
"""

import argparse
import pathlib

from PIL import Image

HEIGHT = 480  # [px] both pictures are scaled to this height
GAP = 8  # [px] white between them


def overview(run: pathlib.Path) -> Image.Image:
    """The two screenshots of ``run`` side by side, the GUI on the left."""
    low_level = sorted(run.glob("gui_*_low_level_latest.png"))
    if not low_level:
        raise SystemExit(f"{run} has no screenshot of the LOW-LEVEL tab (gui_NN_low_level_latest.png)")
    pictures = []
    for path in (low_level[-1], run / "rviz.png"):
        with Image.open(path) as shot:
            picture = shot.crop(shot.convert("L").point(lambda value: value > 0).getbbox())  # the display's black
            width = round(picture.width * HEIGHT / picture.height)
            pictures.append(picture.convert("RGB").resize((width, HEIGHT), Image.LANCZOS))
    canvas = Image.new("RGB", (sum(picture.width for picture in pictures) + GAP, HEIGHT), "white")
    canvas.paste(pictures[0], (0, 0))
    canvas.paste(pictures[1], (pictures[0].width + GAP, 0))
    return canvas


def main():
    """Writes overview.png beside this file from the run folder given on the command line."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", type=pathlib.Path, help="a run folder of run_thesis (<data dir>/runs/<timestamp>)")
    arguments = parser.parse_args()
    overview(arguments.run).save(pathlib.Path(__file__).with_name("overview.png"), optimize=True)


if __name__ == "__main__":
    main()
