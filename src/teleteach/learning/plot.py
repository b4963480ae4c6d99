"""A figure like thesis Fig. C.1: demonstrated and reproduced X-Y stiffness ellipses over time.

Each ellipse is the X-Y block of K at one instant, drawn with semi-axes equal to its eigenvalues along its
eigenvectors (the thesis' convention, section II-C), centred at its time. A third panel plots the X-Y entries of
K over time: the recorded samples as steps, the reproduction as lines.
"""

import io
import pathlib
from typing import Union

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from teleteach.core.datadir import atomic_write_bytes
from teleteach.core.plotting import legends_beside, stiffness_ellipses
from teleteach.learning.preprocess import resample_geodesic


def write_figure_c1(
    path: Union[str, pathlib.Path],
    sample_times,
    samples,
    times,
    reproduction,
    title: str = "",
    count: int = 21,
) -> pathlib.Path:
    """Write :func:`figure_c1` as a PNG (atomically) and return its path."""
    figure = figure_c1(sample_times, samples, times, reproduction, title, count)
    path = pathlib.Path(path)
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=110)
    atomic_write_bytes(path, buffer.getvalue())
    return path


def figure_c1(sample_times, samples, times, reproduction, title: str = "", count: int = 21) -> Figure:
    """Recorded and reproduced stiffness as ellipses over time, and the entries K_xx, K_yy, K_xy (thesis Fig. C.1).

    Args:
        sample_times: (k,) times of the recorded stiffness samples [s].
        samples: (k, m, m) recorded stiffness [N/m] (m = 2 or 3; the X-Y block is drawn).
        times: (n,) times of the reproduction [s].
        reproduction: (n, m, m) reproduced stiffness [N/m].
        title: figure title.
        count: number of ellipses per row.
    """
    sample_times = np.asarray(sample_times, dtype=float)
    times = np.asarray(times, dtype=float)
    end = max(sample_times[-1], times[-1])
    instants = np.linspace(0.0, end, count)
    nearest = np.abs(sample_times[:, None] - instants[None, :]).argmin(axis=0)
    shown_demo = np.asarray(samples)[nearest]
    shown_reproduction = resample_geodesic(times, reproduction, np.clip(instants, times[0], times[-1]))
    spacing = end / max(count - 1, 1)
    largest = max(
        np.linalg.eigvalsh(shown_demo[:, :2, :2]).max(), np.linalg.eigvalsh(shown_reproduction[:, :2, :2]).max()
    )
    scale = 0.45 * spacing / largest
    figure = Figure(figsize=(12, 6.5))
    FigureCanvasAgg(figure)
    grid = figure.add_gridspec(3, 1, height_ratios=[1, 1, 1.6])
    rows = (
        ("demonstrated (recorded)", shown_demo, "tab:red"),
        ("reproduced (SPD DMP)", shown_reproduction, "tab:green"),
    )
    for row, (label, matrices, colour) in enumerate(rows):
        axes = figure.add_subplot(grid[row])
        stiffness_ellipses(
            axes, instants, matrices, scale, facecolor=colour, edgecolor="black", linewidth=0.6, alpha=0.7
        )
        axes.set_xlim(-0.6 * spacing, end + 0.6 * spacing)
        axes.set_ylim(-0.55 * spacing, 0.55 * spacing)
        axes.set_aspect("equal")
        axes.set_yticks([])
        axes.set_ylabel(label, fontsize=8)
        axes.set_xlabel("time [s]")
    entries = figure.add_subplot(grid[2])
    _plot_entries(entries, sample_times, samples, times, reproduction)
    if title:
        figure.suptitle(title)
    legends_beside(figure, [(entries,)], fontsize=7)
    return figure


def _plot_entries(entries, sample_times, samples, times, reproduction) -> None:
    """K_xx, K_yy and K_xy over time, recorded as steps and reproduced as lines, to compare their values."""
    for (row, column), label, colour in (
        ((0, 0), "K_xx", "tab:red"),
        ((1, 1), "K_yy", "tab:green"),
        ((0, 1), "K_xy", "tab:blue"),
    ):
        entries.step(
            sample_times,
            np.asarray(samples)[:, row, column],
            where="post",
            color=colour,
            alpha=0.45,
            label=f"{label} recorded",
        )
        entries.plot(times, np.asarray(reproduction)[:, row, column], color=colour, label=f"{label} reproduced")
    entries.set_xlabel("time [s]")
    entries.set_ylabel("stiffness [N/m]")
    entries.grid(alpha=0.3)
