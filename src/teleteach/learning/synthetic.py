"""Thesis-like stiffness demonstrations built from the thesis' description, for benchmarks and tests.

Sections III-C and III-D describe the product placement demonstrations: approach with equally low stiffness in X and
Y (circular X-Y ellipse), alignment with Y stiffened and, from a 45-degree base pose, the ellipsoid gradually rotated
45 degrees about Z (then Y slightly lowered), insertion with the orientation kept (45 degrees) or X stiffened (the
perpendicular "peg-in-hole" case); Z stays constant and relatively high. The operator moves smoothly (minimum-jerk
transitions with a small slow wobble); the GUI publishes what it shows at a low, jittery rate with a lag, and the
recorder stores it at the pose rate as a zero-order-hold staircase, which is what made the thesis' fit fail.
"""

from typing import Optional, Tuple

import numpy as np
from scipy.ndimage import gaussian_filter1d
from scipy.spatial.transform import Rotation

from teleteach.control.stiffness import translational_stiffnesses
from teleteach.core.frames import Transform
from teleteach.core.rotations import yaw_rotation
from teleteach.core.skill_file import TARGET_FRAME, Skill, Target
from teleteach.core.trajectories import Trajectory, minimum_jerk

LOW = 300.0  # [N/m] compliant approach stiffness in X and Y
HIGH = 1500.0  # [N/m] alignment stiffness in Y
VERTICAL = 1200.0  # [N/m] constant Z stiffness
DOWN = Rotation.from_euler("x", 180.0, degrees=True)  # gripper pointing down


def minimum_jerk_between(times, start: float, end: float):
    """0 before ``start``, 1 after ``end``, the minimum-jerk profile between (``times`` in [s])."""
    return minimum_jerk((np.asarray(times, dtype=float) - start) / (end - start))


def _wobble(times, rng, amplitude: float, width: float):
    """A smooth random signal of about +-amplitude (relative), correlated over ``width`` seconds."""
    dt = times[1] - times[0]
    noise = gaussian_filter1d(rng.standard_normal(times.size), width / dt, mode="nearest")
    return 1.0 + amplitude * noise / max(np.abs(noise).max(), 1e-12)


def principal_stiffness(times, angle: float, rng) -> Tuple[np.ndarray, np.ndarray]:
    """The operator's intended (smooth) principal stiffnesses (n, 3) [N/m] and yaw (n,) [rad] over ``times``.

    Scaled to the duration: the thesis' phases at 102 s are approach 0-30 s, alignment 30-56 s, insertion after.
    """
    scale = times[-1] / 102.0

    def phase(start, end):
        return minimum_jerk_between(times, start * scale, end * scale)

    ky = LOW + (HIGH - LOW) * phase(30, 34) - 300.0 * phase(52, 55)
    kx = np.full_like(times, LOW)
    yaw = np.zeros_like(times)
    if angle:
        yaw = np.radians(angle) * phase(36, 48)
    else:
        kx = kx + 1200.0 * phase(62, 66)
    kx = kx * _wobble(times, rng, 0.03, 2.0)
    ky = ky * _wobble(times, rng, 0.03, 2.0)
    return np.column_stack([kx, ky, np.full_like(times, VERTICAL)]), yaw


def _as_published(
    truth: np.ndarray, times: np.ndarray, duration: float, gui_rate: float, gui_lag: float, rng: np.random.Generator
) -> np.ndarray:
    """The stiffness the recorder saw at ``times``: the GUI's last publication, late and at a jittered rate."""
    publish_times = [0.0]
    while publish_times[-1] < duration:
        publish_times.append(publish_times[-1] + rng.uniform(0.7, 1.3) / gui_rate)
    publish_times = np.array(publish_times)
    shown = np.interp(publish_times - gui_lag, times, np.arange(times.size))
    shown_index = np.clip(np.round(shown).astype(int), 0, times.size - 1)
    latest = np.clip(np.searchsorted(publish_times, times, side="right") - 1, 0, None)
    return truth[shown_index[latest]]


def placement_demo(
    angle: float = 45.0,
    duration: float = 102.0,
    pose_rate: float = 100.0,
    gui_rate: float = 4.0,
    gui_lag: float = 0.3,
    seed: int = 0,
) -> Tuple[Skill, np.ndarray, np.ndarray]:
    """A recorded placement demonstration and its ground truth.

    Args:
        angle: base angle to the shelf [deg]: 45 (thesis III-D) or 0 (III-C, X stiffened for insertion).
        duration: length [s].
        pose_rate: recorder (pose) rate [Hz].
        gui_rate: mean GUI publication rate [Hz] (jitter +-30 %); ``None`` or <= 0: the GUI publishes every
            recorder sample without lag (a smooth recording).
        gui_lag: delay of the GUI behind the operator [s].
        seed: random seed (wobble, GUI timing jitter, pose noise).

    Returns:
        (skill of kind "stiffness" as the recorder would save it, recorder times, operator's stiffness at them).
    """
    rng = np.random.default_rng(seed)
    times = np.arange(0.0, duration + 0.5 / pose_rate, 1.0 / pose_rate)
    principal, yaw = principal_stiffness(times, angle, rng)
    truth = translational_stiffnesses(principal, yaw_rotation(yaw))
    recorded = _as_published(truth, times, duration, gui_rate, gui_lag, rng) if gui_rate and gui_rate > 0 else truth
    waypoints_t = np.array([0.0, 0.3, 0.55, 0.8, 1.0]) * duration
    waypoints = np.array([[0.35, 0.0, 0.55], [0.5, 0.05, 0.5], [0.6, 0.1, 0.48], [0.68, 0.12, 0.48], [0.7, 0.12, 0.48]])
    equilibrium = np.column_stack([np.interp(times, waypoints_t, waypoints[:, axis]) for axis in range(3)])
    measured = gaussian_filter1d(equilibrium, 0.3 * pose_rate, axis=0, mode="nearest")
    measured = measured + 2e-4 * gaussian_filter1d(rng.standard_normal(measured.shape), 3, axis=0)
    hand = DOWN * yaw_rotation(np.radians(angle) * minimum_jerk_between(times, 0.3 * duration, 0.5 * duration))
    quaternions = hand.as_quat()
    skill = Skill(
        name=f"SyntheticPlace{int(round(angle))}",
        kind="stiffness",
        time=times,
        stiffness=recorded,
        equilibrium_pose=np.hstack([equilibrium, quaternions]),
        cartesian_pose=np.hstack([measured, quaternions]),
        provenance={"synthetic": True, "angle": angle, "gui_rate": gui_rate or 0.0, "seed": seed},
    )
    return skill, times, truth


# The carry posture's TCP (base_link (0.307, 0, 0.885), pointing down) seen from gap_1 when the base stands at
# place_perpendicular (config/supermarket.yaml): where a trajectory that starts at the hand begins.
CARRY_HAND_IN_GAP = np.array([-0.303, 0.0, 0.165, 1.0, 0.0, 0.0, 0.0])
GAP_1_FROM_PLACE_PERPENDICULAR = (0.61, 0.0, 0.72, 0.0, 0.0, 0.0, 1.0)  # gap_1's pose in base_link from there


def placement_on_trajectory(
    name: str = "perpendicular", until: Optional[float] = None, rate: float = 100.0, hand=CARRY_HAND_IN_GAP
) -> Skill:
    """III-C's demonstration, as the GUI records it, on a predefined trajectory.

    A compliant approach (X = Y = 400 N/m), Y stiffened to 2100 N/m for the alignment from 3 s, X stiffened to
    2100 N/m for the insertion from 5 s, Z at 2000 N/m; the equilibrium follows config/trajectories/<name>.yaml (its
    first ``until`` seconds, if given) at ``rate`` [Hz], from ``hand`` (a pose in the trajectory's frame) when it
    starts at the hand. A trajectory relative to a gap gives a skill in that gap's frame, taught from
    place_perpendicular.
    """
    planned = Trajectory.load(name)
    trajectory = planned.resolve(Transform.identity(), hand)
    times = np.arange(0.0, (until or trajectory.duration) + 0.5 / rate, 1.0 / rate)
    poses = np.array([trajectory.sample(time) for time in times])
    diagonal = np.tile([400.0, 400.0, 2000.0], (len(times), 1))
    diagonal[times >= 3.0, 1] = 2100.0
    diagonal[times >= 5.0, 0] = 2100.0
    target = None
    if planned.frame == TARGET_FRAME:
        target = Target(planned.target, GAP_1_FROM_PLACE_PERPENDICULAR)
    return Skill(
        name="DemonstratedPlace_1",
        kind="stiffness",
        time=times,
        stiffness=np.array([np.diag(row) for row in diagonal]),
        equilibrium_pose=poses,
        cartesian_pose=poses,
        provenance={"synthetic": True, "trajectory": name},
        frame=planned.frame,
        target=target,
    )
