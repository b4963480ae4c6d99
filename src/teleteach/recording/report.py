"""Offline report of a teaching session bag: plots like the thesis' Fig. 5, 6 and 7 and a markdown summary.

- ``high_level.png`` (Fig. 5): device X, Y [m] and gripper angle [rad] over time, clicks and tree edits marked,
  the active GUI tab shaded.
- ``stiffness.png`` (Fig. 6): end-effector position; device translations (dark) against the ellipsoid's principal
  stiffnesses (light); the X-Y section of the stiffness ellipsoid over time.
- ``rotation.png`` (Fig. 7): end-effector position; device rotation about Z against the ellipsoid's yaw (modulo 180
  degrees: an axis has no sign); the X-Y ellipses over time.
- ``stiffness.csv``: the demonstrated stiffness trajectory with the end-effector position at each command.
- ``summary.md``: duration, topics with counts and rates, tree edits, stiffness ranges, and the figures made or
  skipped (a figure whose topics are missing is skipped with the reason, a missing end-effector pose leaves its
  panel empty with a note; never a crash).

Ellipse convention as in the thesis (footnote 2): semi-axis lengths are the principal stiffnesses themselves.
"""

import dataclasses
import io
import pathlib
from typing import Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
from matplotlib.figure import Figure

from teleteach.control.stiffness import translational_stiffnesses
from teleteach.core.active_tab import Tab
from teleteach.core.datadir import atomic_write_bytes, atomic_write_text
from teleteach.core.plotting import legends_beside, stiffness_ellipses
from teleteach.recording.session import Series, Session, TreeSnapshot, axes_yaw_of, read_session

TAB_COLOURS = {
    Tab.HIGH_LEVEL: "#d9f2d9",
    Tab.LOW_LEVEL: "#f8d7d7",
    Tab.SHARED_CONTROL: "#d7e3f8",
    Tab.TELEOP: "#fff3c4",
}
AXIS_COLOURS = {"dark": ("#b2182b", "#1a7a1a", "#2b4fb2"), "light": ("#f4a6a6", "#9be09b", "#a6bdf4")}
ELLIPSES_OVER_TIME = 12


class MissingDataError(Exception):
    """A figure cannot be drawn because the bag lacks the topics it needs; the message names them."""


@dataclasses.dataclass
class TreeEdit:
    """A change of the tree's structure between two consecutive tree-log messages."""

    time: float
    removed: Tuple[str, ...]
    added: Tuple[str, ...]
    moved: Tuple[str, ...]
    after: TreeSnapshot
    converted: Tuple[str, ...] = ()

    def describe(self) -> str:
        """A short text such as 'removed PlaceItem; inserted PlaceItem_2 at index 3' (the index in its parent)."""
        inserted = [(name, _index_in_parent(self.after, name)) for name in self.added]
        return describe_edit(self.removed, inserted, self.moved, self.converted)


def _index_in_parent(tree: TreeSnapshot, name: str) -> Optional[int]:
    """Where ``name`` stands among its parent's children; None for the root."""
    return next((children.index(name) for children in tree.children.values() if name in children), None)


def describe_edit(
    removed: Sequence[str],
    inserted: Sequence[Tuple[str, Optional[int]]],
    moved: Sequence[str] = (),
    converted: Sequence[str] = (),
) -> str:
    """An edit in the words the run's summary and live output use too: 'removed A; inserted B at index 8'.

    ``inserted``: (name, index among its parent's children, None when unknown).
    """
    parts = [f"removed {', '.join(removed)}"] if removed else []
    parts += [f"inserted {name}" + ("" if index is None else f" at index {index}") for name, index in inserted]
    parts += [f"{verb} {', '.join(names)}" for verb, names in (("moved", moved), ("converted", converted)) if names]
    return "; ".join(parts)


def tree_edits(trees: List[TreeSnapshot]) -> List[TreeEdit]:
    """The structural changes along the tree log (status-only updates are not edits)."""
    edits = []
    for before, after in zip(trees, trees[1:]):
        converted = tuple(
            name for name in after.names if name in before.types and before.types[name] != after.types.get(name)
        )
        if before.names == after.names and before.children == after.children and not converted:
            continue
        removed = tuple(name for name in before.names if name not in after.names)
        added = tuple(name for name in after.names if name not in before.names)
        kept_before = [name for name in before.names if name in after.names]
        kept_after = [name for name in after.names if name in before.names]
        moved = tuple(name for name, other in zip(kept_before, kept_after) if name != other)
        edits.append(TreeEdit(after.time, removed, added, moved, after, converted))
    return edits


def clicks(button: Optional[Series]) -> np.ndarray:
    """Times of the rising edges of /sigma7/button."""
    if button is None:
        return np.zeros(0)
    state = button.values[:, 0] > 0.5
    rising = np.flatnonzero(state[1:] & ~state[:-1]) + 1
    if len(state) and state[0]:
        rising = np.concatenate(([0], rising))
    return button.times[rising]


def _require(session: Session, **series) -> None:
    missing = [topic for topic, value in series.items() if value is None]
    if missing:
        raise MissingDataError("missing " + ", ".join(missing))


def _save(figure: Figure, path: pathlib.Path) -> None:
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=110)
    atomic_write_bytes(path, buffer.getvalue())


def _shade_tabs(axes, session: Session) -> None:
    tab = session.active_tab
    if tab is None:
        return
    boundaries = np.append(tab.times, session.duration)
    labelled = set()
    for start, end, value in zip(boundaries[:-1], boundaries[1:], tab.values[:, 0].astype(int)):
        if value in TAB_COLOURS:
            label = Tab(value).title if value not in labelled else None
            labelled.add(value)
            axes.axvspan(start, end, color=TAB_COLOURS[value], alpha=0.6, lw=0, label=label)


def _mark_edits(axes, edits: List[TreeEdit], label: bool) -> None:
    for number, edit in enumerate(edits):
        axes.axvline(edit.time, color="#7b3294", ls="--", lw=1.2, label="tree edit" if number == 0 and label else None)
        if label:
            axes.annotate(
                edit.describe(),
                (edit.time, 1.0),
                xycoords=("data", "axes fraction"),
                rotation=90,
                va="top",
                ha="right",
                fontsize=7,
                color="#7b3294",
            )


def plot_high_level(session: Session, path: pathlib.Path, edits: List[TreeEdit]) -> List[str]:
    """Fig. 5 written to ``path``; notes on what the bag lacked."""
    figure, notes = high_level_figure(session, edits)
    _save(figure, path)
    return notes


def high_level_figure(session: Session, edits: List[TreeEdit]) -> Tuple[Figure, List[str]]:
    """Fig. 5: device X, Y and gripper over time with clicks and tree edits marked."""
    _require(session, **{"/sigma7/pose": session.device_position, "/sigma7/gripper_angle": session.gripper})
    figure = Figure(figsize=(10, 6))
    position_axes, gripper_axes = figure.subplots(2, 1, sharex=True)
    for axes in (position_axes, gripper_axes):
        _shade_tabs(axes, session)
    device = session.device_position
    position_axes.plot(device.times, device.values[:, 0], color=AXIS_COLOURS["dark"][0], label="device X")
    position_axes.plot(device.times, device.values[:, 1], color=AXIS_COLOURS["dark"][1], label="device Y")
    position_axes.set_ylabel("translation [m]")
    _mark_edits(position_axes, edits, label=True)
    gripper_axes.plot(session.gripper.times, session.gripper.values[:, 0], color="#762a83", label="gripper")
    click_times = clicks(session.button)
    if len(click_times):
        gripper_axes.plot(click_times, session.gripper.at(click_times)[:, 0], "v", color="black", label="click")
    _mark_edits(gripper_axes, edits, label=False)
    gripper_axes.set_ylabel("gripper angle [rad]")
    gripper_axes.set_xlabel("time [s]")
    position_axes.set_title("High-level teaching: device input and tree edits")
    for axes in (position_axes, gripper_axes):
        axes.grid(alpha=0.3)
    legends_beside(figure, [(position_axes,), (gripper_axes,)])
    return figure, [] if session.trees else ["no tree edits marked: missing /behaviour_tree/log/tree"]


def _stiffness(session: Session) -> Tuple[Series, np.ndarray]:
    """Eigenvalues with the eigenvector quaternion held at each eigenvalue time, and K at those times."""
    values = session.eigenvalues
    quaternions = session.eigenvectors.at(values.times)
    return values, translational_stiffnesses(values.values, quaternions)


def _plot_cartesian(axes, session: Session) -> List[str]:
    """End-effector position panel; an explanatory text (and a note for the summary) when the bag has none."""
    cartesian = session.cartesian_position
    if cartesian is None:
        axes.text(0.5, 0.5, "no /cartesian_pose in this bag", transform=axes.transAxes, ha="center", va="center")
        axes.set_yticks([])
        return ["end-effector panel empty: missing /cartesian_pose"]
    for column, name in enumerate("XYZ"):
        axes.plot(cartesian.times, cartesian.values[:, column], color=AXIS_COLOURS["dark"][column], label=name)
    axes.set_ylabel("end effector [m]")
    axes.grid(alpha=0.3)
    return []


def _plot_ellipses(axes, times: np.ndarray, matrices: np.ndarray, duration: float) -> None:
    """X-Y sections of K drawn along the time axis, semi-axes = principal stiffnesses of the 2x2 block."""
    samples = np.unique(np.linspace(times[0], times[-1], ELLIPSES_OVER_TIME))  # while stiffness was commanded
    index = np.clip(np.searchsorted(times, samples, side="right") - 1, 0, len(times) - 1)
    shown = matrices[index]
    spacing = (samples[-1] - samples[0]) / max(len(samples) - 1, 1) or 1.0
    largest = float(np.max(np.linalg.eigvalsh(shown[:, :2, :2]))) or 1.0
    scale = 0.45 * spacing / largest  # [s per N/m]: the largest semi-axis fills 45 % of the spacing
    stiffness_ellipses(axes, samples, shown, scale, facecolor="#f4a6a6", edgecolor="#b2182b", lw=1.0)
    axes.set_ylim(-spacing, spacing)
    axes.set_xlim(0.0, max(duration, samples[-1]) + spacing)
    axes.set_aspect("equal", adjustable="datalim")  # x is shared with the plots above: only y adapts
    axes.set_yticks([])
    axes.set_ylabel("K (X-Y)")
    axes.text(
        0.99,
        0.05,
        f"largest semi-axis {largest:.0f} N/m; X right, Y up",
        transform=axes.transAxes,
        ha="right",
        fontsize=7,
    )


def plot_stiffness(session: Session, path: pathlib.Path) -> List[str]:
    """Fig. 6 written to ``path``; notes on what the bag lacked."""
    figure, notes = stiffness_figure(session)
    _save(figure, path)
    return notes


def stiffness_figure(session: Session) -> Tuple[Figure, List[str]]:
    """Fig. 6: end-effector position, device translation vs principal stiffness, X-Y ellipses over time."""
    _require(
        session,
        **{
            "/sigma7/pose": session.device_position,
            "/eigenvalues": session.eigenvalues,
            "/eigenvectors": session.eigenvectors,
        },
    )
    values, matrices = _stiffness(session)
    figure = Figure(figsize=(10, 9))
    cartesian_axes, device_axes, ellipse_axes = figure.subplots(3, 1, sharex=True, height_ratios=(1, 1.3, 0.9))
    notes = _plot_cartesian(cartesian_axes, session)
    stiffness_axes = device_axes.twinx()
    device = session.device_position
    for column, name in enumerate("XYZ"):
        device_axes.plot(
            device.times, device.values[:, column], color=AXIS_COLOURS["dark"][column], label=f"device {name}"
        )
        stiffness_axes.plot(
            values.times,
            values.values[:, column],
            color=AXIS_COLOURS["light"][column],
            lw=2,
            drawstyle="steps-post",
            label=f"principal stiffness {name}",
        )
    device_axes.set_ylabel("device translation [m]")
    stiffness_axes.set_ylabel("principal stiffness [N/m]")
    device_axes.grid(alpha=0.3)
    _plot_ellipses(ellipse_axes, values.times, matrices, session.duration)
    ellipse_axes.set_xlabel("time [s]")
    cartesian_axes.set_title("Low-level teaching: stiffness ellipsoid size and shape")
    legends_beside(figure, [(cartesian_axes,), (device_axes, stiffness_axes)])
    return figure, notes


def plot_rotation(session: Session, path: pathlib.Path) -> List[str]:
    """Fig. 7 written to ``path``; notes on what the bag lacked."""
    figure, notes = rotation_figure(session)
    _save(figure, path)
    return notes


def rotation_figure(session: Session) -> Tuple[Figure, List[str]]:
    """Fig. 7: end-effector position, device rotation about Z vs ellipsoid yaw, X-Y ellipses over time."""
    _require(
        session,
        **{
            "/sigma7/pose": session.device_yaw,
            "/eigenvalues": session.eigenvalues,
            "/eigenvectors": session.eigenvectors,
        },
    )
    values, matrices = _stiffness(session)
    figure = Figure(figsize=(10, 8))
    cartesian_axes, yaw_axes, ellipse_axes = figure.subplots(3, 1, sharex=True, height_ratios=(1, 1, 0.9))
    notes = _plot_cartesian(cartesian_axes, session)
    device_yaw = session.device_yaw
    ellipsoid_yaw = axes_yaw_of(session.eigenvectors.values)
    yaw_axes.plot(device_yaw.times, np.degrees(device_yaw.values), color="#2b4fb2", label="device rotation about Z")
    yaw_axes.plot(
        session.eigenvectors.times,
        np.degrees(ellipsoid_yaw),
        color="#a6bdf4",
        lw=2,
        drawstyle="steps-post",
        label="ellipsoid yaw mod 180°",
    )
    yaw_axes.set_ylabel("rotation about Z [deg]")
    yaw_axes.grid(alpha=0.3)
    _plot_ellipses(ellipse_axes, values.times, matrices, session.duration)
    ellipse_axes.set_xlabel("time [s]")
    cartesian_axes.set_title("Low-level teaching: stiffness ellipsoid orientation")
    legends_beside(figure, [(cartesian_axes,), (yaw_axes,)])
    return figure, notes


@dataclasses.dataclass
class Report:
    """What :func:`make_report` wrote.

    Figures by name (with notes on empty panels), skipped figures with the reason, the tree edits, the summary file
    and the stiffness trajectory table (None without stiffness in the bag).
    """

    summary: pathlib.Path
    figures: Dict[str, pathlib.Path]
    notes: Dict[str, List[str]]
    skipped: Dict[str, str]
    edits: List[TreeEdit]
    stiffness_table: Optional[pathlib.Path] = None


STIFFNESS_COLUMNS = (
    "t",
    "lambda_x",
    "lambda_y",
    "lambda_z",
    "qx",
    "qy",
    "qz",
    "qw",
    "k_xx",
    "k_xy",
    "k_xz",
    "k_yy",
    "k_yz",
    "k_zz",
    "ee_x",
    "ee_y",
    "ee_z",
)
"""Columns of stiffness.csv, one row per stiffness command: t [s], principal stiffnesses [N/m], axes quaternion,
the upper triangle of K_T [N/m], the end-effector position [m] held at t (empty without /cartesian_pose)."""


def stiffness_table(session: Session) -> Optional[np.ndarray]:
    """The demonstrated stiffness trajectory aligned with the end-effector position (thesis Appendix C.2.1).

    The GUI publishes stiffness more slowly than the controller publishes poses, so each stiffness command is paired
    with the latest pose at its time instead of matching the two streams sample by sample.
    """
    if session.eigenvalues is None or session.eigenvectors is None:
        return None
    values, matrices = _stiffness(session)
    quaternions = session.eigenvectors.at(values.times)
    upper = matrices[:, [0, 0, 0, 1, 1, 2], [0, 1, 2, 1, 2, 2]]
    if session.cartesian_position is None:
        positions = np.full((len(values), 3), np.nan)
    else:
        positions = session.cartesian_position.at(values.times)
    return np.column_stack([values.times, values.values, quaternions, upper, positions])


def _write_stiffness_table(table: np.ndarray, path: pathlib.Path) -> None:
    stream = io.StringIO()
    np.savetxt(stream, table, delimiter=",", fmt="%.9g", header=",".join(STIFFNESS_COLUMNS), comments="")
    atomic_write_text(path, stream.getvalue().replace("nan", ""))


FIGURES = (
    ("high_level.png", "Fig. 5: device input and tree edits"),
    ("stiffness.png", "Fig. 6: ellipsoid size and shape"),
    ("rotation.png", "Fig. 7: ellipsoid rotation about Z"),
)


def _summary(session: Session, report: Report) -> str:
    lines = [
        f"# Teaching session report: {session.path.name}",
        "",
        f"- bag: `{session.path}`",
        f"- duration: {session.duration:.2f} s",
        "",
    ]
    lines += ["## Topics", "", "| topic | type | messages | mean rate [Hz] |", "|---|---|---|---|"]
    for topic, info in sorted(session.topics.items()):
        rate = info.count / session.duration if session.duration > 0 else 0.0
        lines.append(f"| `{topic}` | {info.msgtype.replace('/msg/', '/')} | {info.count} | {rate:.1f} |")
    lines += ["", "## Tree edits", ""]
    if not session.trees:
        lines.append("No tree log (`/behaviour_tree/log/tree`) in the bag.")
    elif not report.edits:
        lines.append("None: the tree kept its structure.")
    else:
        lines += ["| t [s] | edit | BehaviorExecution after |", "|---|---|---|"]
        for edit in report.edits:
            sequence = edit.after.children.get("BehaviorExecution", edit.after.names)
            lines.append(f"| {edit.time:.2f} | {edit.describe()} | {', '.join(sequence)} |")
    lines += ["", "## Stiffness", ""]
    for topic, count in session.rejected.items():
        lines.append(f"Left out {count} `{topic}` messages the controller rejects (NaN, negative, non-unit).")
    if session.rejected:
        lines.append("")
    if session.eigenvalues is None:
        lines.append("No valid `/eigenvalues` in the bag.")
    else:
        lines += ["| principal axis | min [N/m] | max [N/m] |", "|---|---|---|"]
        for column, name in enumerate("XYZ"):
            column_values = session.eigenvalues.values[:, column]
            lines.append(f"| {name} | {column_values.min():.1f} | {column_values.max():.1f} |")
        if session.eigenvectors is not None:
            yaw = np.degrees(axes_yaw_of(session.eigenvectors.values))
            axes = "modulo 180 deg: an axis has no sign"
            lines += ["", f"Ellipsoid yaw ({axes}): {np.nanmin(yaw):.1f} deg .. {np.nanmax(yaw):.1f} deg."]
    if report.stiffness_table is not None:
        lines += ["", f"Stiffness trajectory with the end-effector position: `{report.stiffness_table.name}`."]
    lines += ["", "## Figures", ""]
    for name, caption in FIGURES:
        if name in report.figures:
            notes = "".join(f" ({note})" for note in report.notes[name])
            lines.append(f"- {caption}: ![{name}]({name}){notes}")
        else:
            lines.append(f"- {caption}: skipped ({report.skipped[name]})")
    return "\n".join(lines) + "\n"


def make_report(
    bag: Union[str, pathlib.Path], out_dir: Union[str, pathlib.Path, None] = None, session: Optional[Session] = None
) -> Report:
    """Read ``bag`` and write the figures and ``summary.md`` into ``out_dir`` (default: ``<bag stem>_report``).

    ``session``: ``bag`` already read (:func:`read_session`), by a caller that needed it too (run_thesis judges the
    placements from it): a 40 MB bag takes ~3 s to read.

    Raises:
        SessionError: the bag cannot be read (missing, foreign, truncated); nothing is written.
    """
    if session is None:
        session = read_session(bag)
    out = pathlib.Path(out_dir) if out_dir else session.path.with_name(session.path.stem + "_report")
    out.mkdir(parents=True, exist_ok=True)
    edits = tree_edits(session.trees)
    plotters = {
        "high_level.png": lambda path: plot_high_level(session, path, edits),
        "stiffness.png": lambda path: plot_stiffness(session, path),
        "rotation.png": lambda path: plot_rotation(session, path),
    }
    report = Report(out / "summary.md", {}, {}, {}, edits)
    table = stiffness_table(session)
    if table is not None:
        report.stiffness_table = out / "stiffness.csv"
        _write_stiffness_table(table, report.stiffness_table)
    for name, plot in plotters.items():
        try:
            report.notes[name] = plot(out / name)
            report.figures[name] = out / name
        except MissingDataError as reason:
            report.skipped[name] = str(reason)
    atomic_write_text(report.summary, _summary(session, report))
    return report
