"""TELEOP's taught paths: a recorded path joins the demonstrations at its gap; LOW-LEVEL teaches along their mean."""

import pathlib

from teleteach.core.trajectories import Trajectory, TrajectoryError, mean_trajectory
from teleteach.gui.recording import unique_skill_name
from teleteach.gui.teleop.view import TeleopTab


def start_recording(window, view: TeleopTab) -> None:
    """Record the path the arm takes."""
    window.path_recorder.start()
    window.topics.send_recording(True)
    view.show_path("RECORDING the path: move the arm with the clutch; double click to stop", True)


def stop_recording(window) -> None:
    """Stop recording the path."""
    window.path_recorder.stop()
    window.topics.send_recording(False)


def save_path(window, view: TeleopTab) -> None:
    """The recorded path joins the demonstrations at its gap; LOW-LEVEL teaches stiffness along their mean.

    The gap is the perceived one nearest where the path ended. A path at another gap than the demonstrations
    before it starts a new taught path. Each demonstration and the mean are kept in the data directory's
    trajectories/ (yaml, as config/trajectories/).
    """
    directory = window.data_root / "trajectories"
    series = window.path_series
    name = series[0].name if series else _new_path_name(window.config, directory)
    try:
        path = window.path_recorder.to_trajectory(name)
        gap, target, why = window.worker.perception.nearest_gap(path.positions[-1])
        if gap is None:
            raise TrajectoryError(f"path {name!r}: no gap to keep it relative to: {why}")
        if series and series[0].target != gap:
            series, name = [], _new_path_name(window.config, directory)
        demonstration = path.relative_to(gap, target)
        demonstration.name = name
        series = [*series, demonstration]
        mean = mean_trajectory(series, name)
        taught = Trajectory(
            mean.times + window.config.taught_path_approach,
            mean.positions,
            mean.quaternions,
            mean.frame,
            name,
            mean.target,
            starts_at_hand=True,
            spread=mean.spread,
            demonstrations=mean.demonstrations,
        )
        demonstration.save(directory / name / f"demonstration_{len(series)}.yaml")
        saved = taught.save(directory / f"{name}.yaml")
    except (TrajectoryError, OSError) as error:
        view.show_path(f"path not kept: {error}", False)
        window.statusBar().showMessage(f"path not kept: {error}", 15000)
        return
    window.path_series, window.trajectory = series, taught
    text = (
        f"{name}: {len(series)} demonstration(s) at {gap}, {mean.duration - mean.times[0]:.1f} s long, spread up "
        f"to {1000 * float(taught.spread.max()):.0f} mm. LOW-LEVEL now teaches its stiffness along their mean; or "
        "record another demonstration here."
    )
    view.show_path(text, False)
    window.statusBar().showMessage(f"{text} ({saved})", 15000)


def _new_path_name(config, directory: pathlib.Path) -> str:
    """``TaughtPath_<n>``, not yet taken in ``directory``."""
    taken = {path.stem for path in directory.glob("*.yaml")} if directory.is_dir() else set()
    return unique_skill_name(config.path_prefix, taken)
