"""What the report's figures and learn_skill's Fig. C.1 draw alike: legends beside the plots, stiffness ellipses.

A legend inside the axes sits on whatever data passes there (the report's 'upper left' covered the device's first
seconds); here the plots take the left part of the figure and each legend stands to their right, level with the top
of its axes. :func:`covered_points` measures what a layout leaves under its legends. :func:`stiffness_ellipses` draws
the X-Y block of a stiffness as the thesis does (section II-C, footnote 2): semi-axes equal to its eigenvalues, along
its eigenvectors.
"""

from typing import List, Sequence

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Ellipse

LEGEND_ROOM = 0.2  # fraction of the figure's width kept right of the plots for the legends


def legends_beside(figure: Figure, groups: Sequence[Sequence], fontsize: float = 8) -> None:
    """Lay the figure out and put one legend per group of axes (an axes and its twins) beside the group's top."""
    figure.tight_layout(rect=(0.0, 0.0, 1.0 - LEGEND_ROOM, 1.0))
    for group in groups:
        handles, labels = [], []
        for axes in group:
            more_handles, more_labels = axes.get_legend_handles_labels()
            handles += more_handles
            labels += more_labels
        if handles:
            figure.legend(
                handles,
                labels,
                loc="upper left",
                bbox_to_anchor=(1.0 - LEGEND_ROOM + 0.01, group[0].get_position().y1),
                fontsize=fontsize,
                borderaxespad=0.0,
            )


def stiffness_ellipses(axes, times: Sequence[float], stiffnesses, scale: float, **style) -> None:
    """Draw the X-Y block of each stiffness (n, m, m) [N/m] as an ellipse centred at (time [s], 0) on ``axes``.

    Its semi-axes are the block's eigenvalues times ``scale`` [s per N/m] along its eigenvectors; ``style`` holds the
    patches' matplotlib properties (facecolor, edgecolor, linewidth, ...).
    """
    principal, vectors = np.linalg.eigh(np.asarray(stiffnesses, dtype=float)[:, :2, :2])
    for time, lengths, axes_vectors in zip(times, principal, vectors):
        angle = np.degrees(np.arctan2(axes_vectors[1, 1], axes_vectors[0, 1]))  # direction of the larger axis
        axes.add_patch(Ellipse((time, 0.0), 2 * lengths[1] * scale, 2 * lengths[0] * scale, angle=angle, **style))


def covered_points(figure: Figure) -> List[str]:
    """The plotted lines that have a data point under a legend (drawn as the figure is), by label."""
    canvas = figure.canvas if isinstance(figure.canvas, FigureCanvasAgg) else FigureCanvasAgg(figure)
    canvas.draw()
    renderer = canvas.get_renderer()
    boxes = [legend.get_window_extent(renderer) for legend in figure.legends]
    boxes += [axes.get_legend().get_window_extent(renderer) for axes in figure.axes if axes.get_legend() is not None]
    covered = []
    for axes in figure.axes:
        for line in axes.get_lines():
            points = line.get_transform().transform(np.column_stack(line.get_data()).astype(float))
            points = points[np.all(np.isfinite(points), axis=1)]
            if any(box.contains(x, y) for box in boxes for x, y in points):
                covered.append(str(line.get_label()))
    return covered
