"""Learning a whole taught skill (stiffness and poses) with DMPs, reproducing it, and saving it as a skill file.

A learned skill is one SPD DMP for the translational stiffness (eqs C.6-C.7) and one pose DMP each for the
equilibrium pose x_r and the measured pose x_a (eqs C.1-C.5 for the position; the orientation as the rotation
vector relative to the goal orientation, a Euclidean DMP with goal 0). Reproducing it with a new duration or a new
goal stiffness gives a :class:`teleteach.core.skill_file.Skill` of kind ``dmp`` that the robot replays like a
demonstrated one; the DMPs themselves travel in the file's provenance so the skill can be re-generated. Learned from a
skill in a target's frame, the poses and the stiffness are learned in that frame and the learned skill keeps it: its
goal pose is relative to the target, so replayed at another gap it retargets there.
"""

import dataclasses
import time as clock
from typing import Any, Dict, Optional, Tuple

import numpy as np
from scipy.spatial.transform import Rotation

from teleteach.core import skill_file
from teleteach.core.parameters import from_mapping
from teleteach.core.paths import config_values
from teleteach.learning import spd
from teleteach.learning.dmp import DMP, SPDDMP, DMPParameters, demonstration_regression
from teleteach.learning.preprocess import Demonstration, LearningError, prepare, resample_geodesic

POSE_STREAMS = ("equilibrium_pose", "cartesian_pose")


@dataclasses.dataclass
class LearningParameters:
    """Preprocessing and DMP settings: config/learning.yaml's keys, the one place of their values.

    The values come from the sweep in ``bench/learning.py``.

    Attributes:
        rate: uniform grid and reproduction rate [Hz].
        smoothing: Gaussian smoothing of the stiffness on the manifold, standard deviation [s].
        basis_per_second: basis functions per second of demonstration (N = round(T * this), clipped).
        min_basis: fewest basis functions.
        max_basis: most basis functions.
        alpha_z: spring gain (eq C.1, C.6); beta_z = alpha_z / 4.
        alpha_x: canonical system decay (eq C.3).
        alpha_goal: goal switching filter gain.
        width: standard deviation of each Gaussian as a fraction of the spacing of the centres.
        ridge: Tikhonov regularisation of the weight fit, relative to the mean diagonal of the normal matrix.
        recover_gui_samples: recover the GUI's samples from a zero-order-hold staircase (False: fit the staircase
            as recorded, the thesis' way, kept for comparison).
    """

    rate: float
    smoothing: float
    basis_per_second: float
    min_basis: int
    max_basis: int
    alpha_z: float
    alpha_x: float
    alpha_goal: float
    width: float
    ridge: float
    recover_gui_samples: bool

    @classmethod
    def from_yaml(cls, **changes: Any) -> "LearningParameters":
        """config/learning.yaml's values, with ``changes``; a missing or unknown key is named."""
        values = {**config_values("learning.yaml"), **changes}
        return from_mapping(cls, values, "learn_skill's parameters (config/learning.yaml)")

    def dmp_parameters(self, duration: float) -> DMPParameters:
        """DMP gains and basis for a demonstration of ``duration`` [s]."""
        count = int(np.clip(round(duration * self.basis_per_second), self.min_basis, self.max_basis))
        return DMPParameters(
            basis_count=count,
            alpha_z=self.alpha_z,
            alpha_x=self.alpha_x,
            width=self.width,
            ridge=self.ridge,
            alpha_goal=self.alpha_goal,
        )


class PoseDMP:
    """A pose trajectory: a position DMP and an orientation DMP on rotation vectors relative to the goal orientation."""

    def __init__(self, position: DMP, orientation: DMP, goal_orientation):
        self.position = position
        self.orientation = orientation
        self.goal_orientation = Rotation.from_quat(goal_orientation)

    @classmethod
    def learn(cls, times, poses, parameters: DMPParameters, regression=None) -> "PoseDMP":
        """Fit both DMPs to poses (n, 7) on a uniform grid (``regression`` as in :meth:`DMP.learn`)."""
        goal = Rotation.from_quat(poses[-1, 3:])
        relative = (goal.inv() * Rotation.from_quat(poses[:, 3:])).as_rotvec()
        position = DMP.learn(times, poses[:, :3], parameters, regression)
        return cls(position, DMP.learn(times, relative, parameters, regression), goal.as_quat())

    def rollout(self, duration: Optional[float] = None, dt: float = 0.02) -> Tuple[np.ndarray, np.ndarray]:
        """(times, poses (n, 7)) with the given duration."""
        times, positions = self.position.rollout(duration, dt)
        _, relative = self.orientation.rollout(duration, dt)
        orientations = (self.goal_orientation * Rotation.from_rotvec(relative)).as_quat()
        return times, np.hstack([positions, orientations])

    def to_dict(self) -> Dict[str, Any]:
        """JSON-ready description."""
        return {
            "position": self.position.to_dict(),
            "orientation": self.orientation.to_dict(),
            "goal_orientation": self.goal_orientation.as_quat().tolist(),
        }


@dataclasses.dataclass
class Reproduction:
    """A rollout of a learned skill: times from 0 [s], stiffness (n, m, m) [N/m], poses name -> (n, 7)."""

    time: np.ndarray
    stiffness: np.ndarray
    poses: Dict[str, np.ndarray]


@dataclasses.dataclass
class LearnedSkill:
    """The DMPs of a skill plus what they were learned from."""

    name: str
    stiffness: SPDDMP
    poses: Dict[str, PoseDMP]
    demonstration: Demonstration
    parameters: LearningParameters
    rotational_stiffness: float = dataclasses.field(default_factory=skill_file.shared_rotational_stiffness)
    learning_time: float = 0.0
    learning_cpu_time: float = 0.0
    source: Dict[str, Any] = dataclasses.field(default_factory=dict)
    frame: str = skill_file.BASE_FRAME
    target: Optional[skill_file.Target] = None

    def reproduce(
        self,
        duration: Optional[float] = None,
        goal_stiffness=None,
        switch: Optional[Tuple[float, Any]] = None,
    ) -> Reproduction:
        """Roll all DMPs out at the learning rate with a new duration [s] and/or goal stiffness (m x m, SPD)."""
        if duration is not None and not (np.isfinite(duration) and duration > 0):
            raise LearningError(f"duration must be finite and > 0 s, got {duration}")
        goal = None
        if goal_stiffness is not None:
            goal = np.asarray(goal_stiffness, dtype=float)
            if goal.shape != self.stiffness.goal.shape:
                raise LearningError(f"goal stiffness must be {goal.shape} like the demonstration's, got {goal.shape}")
            try:
                spd.check_spd(goal, "goal stiffness")
            except spd.SPDError as error:
                raise LearningError(str(error)) from None
        dt = 1.0 / self.parameters.rate
        times, stiffness = self.stiffness.rollout(duration, dt, goal=goal, switch=switch)
        poses = {name: dmp.rollout(duration, dt)[1] for name, dmp in self.poses.items()}
        return Reproduction(times, stiffness, poses)

    def error(self, reproduction: Optional[Reproduction] = None) -> Dict[str, float]:
        """:func:`reproduction_error` of a same-duration reproduction against the recorded stiffness samples."""
        reproduction = reproduction or self.reproduce()
        demo = self.demonstration
        return reproduction_error(demo.sample_time, demo.samples, reproduction.time, reproduction.stiffness)

    def to_skill(
        self, reproduction: Reproduction, name: Optional[str] = None, error: Optional[Dict[str, float]] = None
    ) -> skill_file.Skill:
        """The reproduction as a skill file of kind ``dmp`` (3x3 stiffness), the DMPs in its provenance.

        ``error`` is :meth:`error` (computed with a same-duration rollout if None).
        """
        stiffness = reproduction.stiffness
        if stiffness.shape[1] != 3:
            raise LearningError("a skill file holds 3x3 stiffness; learn from 3x3 data to save a skill")
        cartesian = reproduction.poses.get("cartesian_pose", reproduction.poses.get("equilibrium_pose"))
        equilibrium = reproduction.poses.get("equilibrium_pose", cartesian)
        provenance = {
            "learned_from": self.source,
            "learning_parameters": dataclasses.asdict(self.parameters),
            "learning_time": self.learning_time,
            "reproduction_error": self.error() if error is None else error,
            "dmps": {
                "stiffness": self.stiffness.to_dict(),
                **{pose: dmp.to_dict() for pose, dmp in self.poses.items()},
            },
        }
        try:
            return skill_file.Skill(
                name=name or self.name,
                kind="dmp",
                time=reproduction.time,
                stiffness=stiffness,
                equilibrium_pose=_normalised(equilibrium),
                cartesian_pose=_normalised(cartesian),
                rotational_stiffness=self.rotational_stiffness,
                provenance=provenance,
                frame=self.frame,
                target=self.target,
            )
        except skill_file.SkillFileError as error:
            raise LearningError(str(error)) from None


def _normalised(poses):
    poses = np.array(poses, dtype=float)
    poses[:, 3:] /= np.linalg.norm(poses[:, 3:], axis=1, keepdims=True)
    return poses


def learn(
    stiffness_times,
    stiffness,
    poses: Dict[str, Tuple[np.ndarray, np.ndarray]],
    name: str,
    parameters: Optional[LearningParameters] = None,
    rotational_stiffness: Optional[float] = None,
    source: Optional[Dict[str, Any]] = None,
) -> LearnedSkill:
    """Preprocess the streams (:func:`teleteach.learning.preprocess.prepare`) and learn every DMP.

    Raises:
        LearningError: naming the stream and the problem (too few samples, non-SPD, non-monotonic times, ...).

    ``rotational_stiffness`` [Nm/rad] is the skill's K_R (None: the one the nodes share, config/shared/stiffness.yaml).
    """
    parameters = parameters or LearningParameters.from_yaml()
    if rotational_stiffness is None:
        rotational_stiffness = skill_file.shared_rotational_stiffness()
    started, started_cpu = clock.perf_counter(), clock.process_time()
    demonstration = prepare(
        stiffness_times,
        stiffness,
        poses,
        parameters.rate,
        parameters.smoothing,
        recover_gui_samples=parameters.recover_gui_samples,
    )
    dmp_parameters = parameters.dmp_parameters(demonstration.duration)
    try:
        regression = demonstration_regression(demonstration.time, dmp_parameters)
        stiffness_dmp = SPDDMP.learn(demonstration.time, demonstration.stiffness, dmp_parameters, regression)
        pose_dmps = {
            pose: PoseDMP.learn(demonstration.time, values, dmp_parameters, regression)
            for pose, values in demonstration.poses.items()
        }
    except ValueError as error:
        raise LearningError(str(error)) from None
    return LearnedSkill(
        name=name,
        stiffness=stiffness_dmp,
        poses=pose_dmps,
        demonstration=demonstration,
        parameters=parameters,
        rotational_stiffness=rotational_stiffness,
        learning_time=clock.perf_counter() - started,
        learning_cpu_time=clock.process_time() - started_cpu,
        source=dict(source or {}),
    )


def learn_skill(skill: skill_file.Skill, name: str, parameters: Optional[LearningParameters] = None) -> LearnedSkill:
    """Learn from a recorded skill file (all streams share its ``time``)."""
    poses = {pose: (skill.time, getattr(skill, pose)) for pose in POSE_STREAMS}
    source = {"skill": skill.name, "kind": skill.kind, "samples": int(skill.time.size)}
    learned = learn(skill.time, skill.stiffness, poses, name, parameters, skill.rotational_stiffness, source)
    return dataclasses.replace(learned, frame=skill.frame, target=skill.target)


def reproduction_error(sample_times, samples, times, matrices) -> Dict[str, float]:
    """Affine-invariant distance between recorded stiffness samples and a reproduction, absolute and relative.

    e_k = d(D_k, R(t_k)) for each recorded sample D_k at t_k, with R(t_k) taken on the reproduction's geodesic
    interpolation and d(A, B) = ||logm(A^-1/2 B A^-1/2)||_F. The demonstration's spread is its geodesic standard
    deviation s = sqrt(mean_k d(D_k, M)^2) about its Karcher mean M. Returned: ``mean`` and ``max`` of e_k,
    ``spread`` s, ``mean_relative`` = mean / s and ``max_relative`` = max / s (0 when s == 0 and e == 0), and
    ``mean_of_stiffness`` = exp(mean) - 1, ``max_of_stiffness`` = exp(max) - 1: d is a logarithm of stiffness ratios,
    so these are the error as a fraction of the stiffness itself, which means something for a constant demonstration
    too (where s is rounding noise and e / s is not).
    """
    samples = np.asarray(samples, dtype=float)
    reproduced = resample_geodesic(times, matrices, sample_times)
    errors = spd.distance(samples, reproduced)
    spread = float(np.sqrt(np.mean(spd.distance(spd.karcher_mean(samples), samples) ** 2)))
    mean, largest = float(np.mean(errors)), float(np.max(errors))

    def relative(value):
        if spread > 0:
            return value / spread
        return 0.0 if value == 0 else float("inf")

    return {
        "mean": mean,
        "max": largest,
        "spread": spread,
        "mean_relative": relative(mean),
        "max_relative": relative(largest),
        "mean_of_stiffness": float(np.expm1(mean)),
        "max_of_stiffness": float(np.expm1(largest)),
        "samples": int(samples.shape[0]),
    }


def principal_axes_like_base(stiffness) -> Rotation:
    """The principal axes of a 3x3 stiffness as a rotation whose columns best match the base X, Y, Z axes.

    Eigenvectors carry no X/Y/Z labels; this picks the permutation and signs closest to the identity (largest
    trace), so that ``translational_stiffness((kx, ky, kz), principal_axes_like_base(K))`` changes the "X" axis of
    an ellipsoid rotated about Z the way a GUI user expects. Equal eigenvalues leave the axes free within their
    eigenspace: a tiny diagonal perturbation picks the base-aligned ones. At an exact 45-degree tie the positive
    rotation about Z wins.
    """
    stiffness = spd.symmetric(stiffness)
    scale = float(np.abs(stiffness).max())
    _, vectors = np.linalg.eigh(stiffness + 1e-7 * scale * np.diag([3.0, 2.0, 1.0]))
    best, best_score = None, -np.inf
    for order in ((0, 1, 2), (0, 2, 1), (1, 0, 2), (1, 2, 0), (2, 0, 1), (2, 1, 0)):
        columns = vectors[:, order]
        columns = columns * np.where(np.diag(columns) < 0, -1.0, 1.0)
        if np.linalg.det(columns) < 0:
            columns[:, 2] = -columns[:, 2]
        score = np.trace(columns) + 1e-6 * columns[1, 0]
        if score > best_score:
            best, best_score = columns, score
    return Rotation.from_matrix(best)
