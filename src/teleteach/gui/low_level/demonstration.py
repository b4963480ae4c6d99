"""LOW-LEVEL's demonstration: the trajectory played while the stiffness is recorded, then a skill of the library.

The trajectory is placed relative to the perceived target when it has one, and starts from the hand when it says so.
"""

import time

from teleteach.core.skill_file import TARGET_FRAME
from teleteach.core.trajectories import Trajectory
from teleteach.gui.low_level.view import LowLevelTab


def start_recording(window, view: LowLevelTab) -> None:
    """Play the trajectory (placed relative to the perceived target, from where the hand is) and record."""
    window.teaching_target = None
    trajectory = window.trajectory
    if trajectory.frame == TARGET_FRAME:
        target, why = window.worker.perception.target_in_base(trajectory.target)
        if target is None:
            window.carry_out(window.session.recording_refused())
            window.statusBar().showMessage(
                f"recording not started: trajectory {trajectory.name} places relative to {trajectory.target}: "
                f"{why}",
                15000,
            )
            return
        window.teaching_target = (trajectory.target, target)
    hand = window.worker.arm.hand_pose()
    if trajectory.starts_at_hand and hand is None:
        window.carry_out(window.session.recording_refused())
        window.statusBar().showMessage("recording not started: no /cartesian_pose of the arm yet", 15000)
        return
    window.recorder.start()
    window.topics.send_recording(True)
    window.player.start(trajectory.resolve(window.teaching_target and window.teaching_target[1], hand))
    view.recording_since = time.monotonic()
    where = f" at {trajectory.target}" if trajectory.frame == TARGET_FRAME else ""
    window.statusBar().showMessage(f"recording: playing trajectory {trajectory.name}{where}", 5000)


def stop_recording(window, view: LowLevelTab) -> None:
    """Stop recording and playing."""
    window.recorder.stop()
    window.topics.send_recording(False)
    window.player.stop()
    view.recording_since = None


def save_skill(window) -> None:
    """The demonstration becomes a new skill of the library (III-E), relative to its target when it had one.

    Along a path taught in TELEOP, the skill of the library is the DMP learned from it (learn_skill), and
    LOW-LEVEL goes back to its predefined trajectory.
    """
    trajectory = window.trajectory
    provenance = {"trajectory": trajectory.name}
    if trajectory.demonstrations:
        provenance["path_demonstrations"] = trajectory.demonstrations
        provenance["path_spread"] = [float(value) for value in trajectory.spread]
        provenance["path_spread_time"] = [float(value) for value in trajectory.times]  # [s] from the start
    saved = window.skills.save(
        window.recorder,
        "stiffness",
        window.config.skill_prefix,
        provenance,
        window.teaching_target,
        add=not trajectory.demonstrations,
    )
    if trajectory.demonstrations and saved is not None:
        window.skills.learn_dmp(saved)
        window.path_series = []
        window.trajectory = Trajectory.load(window.config.trajectory)
