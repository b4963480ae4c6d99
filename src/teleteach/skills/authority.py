"""Authority that follows the skill's confidence: the operator's correction of a replayed skill, weighted where it is.

The thesis' conclusion asks for shared control that "gradually shift[s] the control percentage between the human and
the robot ... taking into account the robot's confidence in its learned policy". While a skill replays, the operator
may push its equilibrium aside (/skills/correction, a displacement in base_link); the replay adds it weighted by
1 - c, where the confidence c at the skill's time t is

    c(t) = (1 - min(1, s(t) / spread_unsure)) * (1 - min(1, d / distance_unsure)),

s(t) the spread of the demonstrations of its path where the hand is then (RMS distance from their mean, recorded
with a path taught in TELEOP; ``spread_unknown`` for a skill with one demonstration: nothing says how sure it is) and
d how far the target it replays at lies from the one it was taught at (base_link). Confident: the robot leads and a
correction moves nothing; unsure: the operator leads. The applied correction is clipped to ``max_correction`` and
moves no faster than ``correction_speed``: a new, lost or stale correction never jumps the equilibrium.
"""

import dataclasses
from typing import Optional, Tuple

import numpy as np

from teleteach.core import skill_file


@dataclasses.dataclass(frozen=True)
class AuthorityConfig:
    """The ``authority`` section of config/skills_motion.yaml (units and meaning written there)."""

    spread_unsure: float
    spread_unknown: float
    distance_unsure: float
    max_correction: float
    correction_speed: float
    correction_timeout: float


@dataclasses.dataclass(frozen=True)
class AuthorityReport:
    """Who leads the replay now: published on /skills/authority for the GUI."""

    skill: str
    confidence: float  # [0, 1]
    operator_weight: float  # 1 - confidence: the share of the operator's correction that moves the equilibrium
    spread: float  # [m] of the demonstrations where the hand is
    target_distance: float  # [m] of the target from the one taught at
    correction: np.ndarray  # [m] (3,) base_link: what the correction moves the equilibrium by now
    max_correction: float  # [m] the longest correction the replay applies (the GUI's box for the handle)


def confidence(spread: float, target_distance: float, config: AuthorityConfig) -> float:
    """Confidence c = (1 - min(1, spread / spread_unsure)) * (1 - min(1, target_distance / distance_unsure))."""
    from_spread = 1.0 - min(1.0, spread / config.spread_unsure)
    from_distance = 1.0 - min(1.0, target_distance / config.distance_unsure)
    return from_spread * from_distance


def spread_along(skill: skill_file.Skill, times: np.ndarray, config: AuthorityConfig) -> np.ndarray:
    """The spread of the skill's demonstrations [m] at ``times`` [s] from its start.

    From the provenance a path taught in TELEOP leaves (``path_spread`` at ``path_spread_time``, seconds from the
    start); a skill with fewer than two demonstrations of its path has ``spread_unknown`` everywhere.
    """
    provenance = skill.provenance
    if provenance.get("path_demonstrations", 0) < 2 or not {"path_spread", "path_spread_time"} <= provenance.keys():
        return np.full(len(times), config.spread_unknown)
    return np.interp(times, provenance["path_spread_time"], provenance["path_spread"])


def target_distance(skill: skill_file.Skill, target_in_base) -> float:
    """How far [m] the target a target-frame skill replays at lies from where it was taught (base_link); 0 else."""
    if skill.frame != skill_file.TARGET_FRAME:
        return 0.0
    return float(np.linalg.norm(target_in_base.position - skill.target.transform.position))


class Correction:
    """The operator's correction as the replay applies it: clipped, rate limited, dropped when it stops coming."""

    def __init__(self, config: AuthorityConfig):
        self.config = config
        self._applied = np.zeros(3)
        self._time: Optional[float] = None

    def step(self, now: float, latest: Optional[Tuple[np.ndarray, float]]) -> np.ndarray:
        """The correction [m] to apply at ``now`` [s], given the newest one received and when (None: none yet)."""
        config = self.config
        wanted = np.zeros(3)
        if latest is not None and now - latest[1] <= config.correction_timeout:
            wanted = np.asarray(latest[0])
            length = float(np.linalg.norm(wanted))
            if length > config.max_correction:
                wanted = wanted * (config.max_correction / length)
        dt = 0.0 if self._time is None else max(0.0, now - self._time)
        self._time = now
        step = wanted - self._applied
        distance = float(np.linalg.norm(step))
        if distance > config.correction_speed * dt:
            step = step * (config.correction_speed * dt / distance)
        self._applied = self._applied + step
        return self._applied.copy()
