"""Draws docs/images/device_axes.png: the Sigma.7 from above, the Force Dimension SDK's axes and the operator frame.

Run from the checkout after ``source build/env.sh``: ``python docs/images/device_axes.py``.
"""

import pathlib

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from matplotlib.patches import Circle, Ellipse, FancyBboxPatch

SDK, OPERATOR = "#c62828", "#1565c0"


def arrow(axes, start, direction, colour, label, offset=(0.0, 0.0)):
    """An axis of a frame: an arrow from ``start`` along ``direction`` and its label beyond the tip."""
    x, y = start
    dx, dy = direction
    axes.annotate("", xy=(x + dx, y + dy), xytext=(x, y), arrowprops={"arrowstyle": "-|>", "color": colour, "lw": 2.5})
    axes.text(x + dx + offset[0], y + dy + offset[1], label, color=colour, fontsize=11, ha="center", va="center")


def up_out_of_the_page(axes, centre, colour):
    """A z axis pointing at the viewer (up, seen from above): a dot in a circle."""
    axes.add_patch(Circle(centre, 0.09, fill=False, edgecolor=colour, lw=2))
    axes.add_patch(Circle(centre, 0.03, color=colour))
    axes.text(centre[0] - 0.38, centre[1] + 0.2, "z up", color=colour, fontsize=11)


def main() -> None:
    """Draw the device, the operator and both frames; save the PNG next to this script."""
    figure, axes = plt.subplots(figsize=(8.0, 5.2))
    axes.set_xlim(-4.0, 4.0)
    axes.set_ylim(-2.6, 2.6)
    axes.set_aspect("equal")
    axes.axis("off")
    axes.set_title("The device seen from above, the operator in front of it", fontsize=13)
    axes.add_patch(FancyBboxPatch((-1.3, 1.2), 2.6, 0.9, boxstyle="round,pad=0.08", fc="#eceff1", ec="#546e7a", lw=2))
    axes.text(0.0, 1.65, "Sigma.7 (base)", ha="center", va="center", color="#37474f", fontsize=11)
    axes.plot([-0.8, -0.2], [1.2, 0.35], color="#78909c", lw=5)
    axes.plot([0.8, 0.2], [1.2, 0.35], color="#78909c", lw=5)
    axes.add_patch(Circle((0.0, 0.2), 0.22, fc="#b0bec5", ec="#455a64", lw=2))
    axes.text(0.0, -0.25, "handle (workspace centre)", ha="center", fontsize=9, color="#37474f")
    axes.add_patch(Ellipse((0.0, -2.15), 2.0, 0.55, fc="#ffe0b2", ec="#e65100", lw=2))
    axes.add_patch(Circle((0.0, -1.8), 0.26, fc="#ffcc80", ec="#e65100", lw=2))
    axes.text(1.25, -2.15, "the operator", color="#bf360c", fontsize=11, va="center")
    origin = (-2.6, 0.2)
    axes.text(origin[0], 1.55, "Force Dimension SDK\n(axes: force_dimension)", color=SDK, ha="center", fontsize=11)
    arrow(axes, origin, (0.0, -1.1), SDK, "x (toward\nthe operator)", (0.0, -0.42))
    arrow(axes, origin, (1.1, 0.0), SDK, "y", (0.18, 0.0))
    up_out_of_the_page(axes, origin, SDK)
    origin = (2.6, 0.2)
    axes.text(origin[0], -1.45, "operator frame\n/sigma7/pose, GUI, guidance", color=OPERATOR, ha="center", fontsize=11)
    arrow(axes, origin, (1.1, 0.0), OPERATOR, "x (right)", (0.0, 0.28))
    arrow(axes, origin, (0.0, 1.1), OPERATOR, "y (away)", (0.0, 0.25))
    up_out_of_the_page(axes, origin, OPERATOR)
    figure.tight_layout()
    figure.savefig(pathlib.Path(__file__).with_suffix(".png"), dpi=100)


if __name__ == "__main__":
    main()
