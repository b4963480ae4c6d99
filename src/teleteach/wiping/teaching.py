"""Teaching the stiffness during a wipe, in one demonstration: the clutch (issue 49).

The operator wipes through the shared controller with the device's translation. Holding the clutch moves that
translation from the pattern to the stiffness ellipsoid (thesis II-C: the ellipsoid's semi-axes): meanwhile the shared
controller keeps the pattern it recognised (``SharedControl.keep``), and the equilibrium's depth follows the stiffness
along the normal every cycle (``contact_force / K_n``), so the tool keeps pressing with the force asked for while the
operator softens or stiffens it. Released, the pattern is the operator's again. The whole wipe, its pattern and its
stiffness, is one demonstration, which becomes a wiping skill (teleteach.wiping.skill).

The scripted operator of this module starts where the GUI's wipe teaching starts them (SHARED CONTROL's constant
stiffness, ``shared_control_stiffness`` of config/gui.yaml) and, while the clutch is held, shapes it into another along
a minimum-jerk ramp of each principal stiffness, as the thesis' operator drags the ellipsoid's axes.
"""

import dataclasses
from typing import List, Sequence, Tuple

import numpy as np

from teleteach.core.gui_config import GuiConfig
from teleteach.core.trajectories import minimum_jerk
from teleteach.core.wiping import WipingConfig, contact_mask, force_figures
from teleteach.shared_control.constraints import Box
from teleteach.shared_control.loop import SharedControl, SharedControlConfig, SharedControlRecord
from teleteach.shared_control.surface import wiping_box
from teleteach.wiping.assistance import human_wipe, shared_targets
from teleteach.wiping.trial import SurfaceStiffness, run_wipe


@dataclasses.dataclass(frozen=True)
class ClutchTeaching:
    """An operator holding the clutch from ``start`` to ``end`` [s], shaping the stiffness ``before`` into ``after``.

    Times are from the wipe's start; stiffnesses in the surface's frame.
    """

    start: float
    end: float
    before: SurfaceStiffness
    after: SurfaceStiffness

    def __post_init__(self):
        if not 0.0 <= self.start < self.end:
            raise ValueError(f"the clutch must be held for a while from a time >= 0, got {self.start}-{self.end} s")

    def clutched(self, time: float) -> bool:
        """Whether the clutch is held at ``time`` [s]."""
        return self.start <= time < self.end

    def stiffness(self, time: float) -> SurfaceStiffness:
        """The stiffness the operator gives at ``time`` [s]: ``before``, shaped into ``after`` while clutched."""
        phase = float(minimum_jerk((time - self.start) / (self.end - self.start)))
        values = self.before.eigenvalues() + phase * (self.after.eigenvalues() - self.before.eigenvalues())
        return SurfaceStiffness(*(float(value) for value in values))


def taught_wipe(
    commands: np.ndarray, start: Sequence[float], box: Box, config: SharedControlConfig, teaching: ClutchTeaching
) -> Tuple[np.ndarray, List[SurfaceStiffness], List[SharedControlRecord]]:
    """One demonstration: the shared controller over the operator's commands, on its own pattern while clutched.

    Returns each cycle's executed state (the tool's in-plane target) [m], the stiffness given with it, and the
    controller's records. The operator's commands during the clutch are not used: the hand was on the ellipsoid.
    """
    controller = SharedControl(config, tuple(start), box)
    records, stiffnesses = [], []
    for k, command in enumerate(np.asarray(commands, dtype=float)):
        time = k * config.dt
        records.append(controller.keep() if teaching.clutched(time) else controller.step(command))
        stiffnesses.append(teaching.stiffness(time))
    return np.array([record.state for record in records]), stiffnesses, records


CLUTCH_SHARE = (0.35, 0.6)  # the clutch is held over this part of the wipe (after the pattern is recognised)


def starting_stiffness() -> SurfaceStiffness:
    """What the GUI's wipe teaching starts the ellipsoid at: SHARED CONTROL's constant stiffness (config/gui.yaml)."""
    return SurfaceStiffness(*(float(value) for value in GuiConfig.load().shared_control_stiffness))


def clutch_teaching(duration: float, taught: SurfaceStiffness) -> ClutchTeaching:
    """The scripted teacher of a wipe lasting ``duration`` [s]: the GUI's start, ``taught`` shaped while clutched."""
    return ClutchTeaching(CLUTCH_SHARE[0] * duration, CLUTCH_SHARE[1] * duration, starting_stiffness(), taught)


@dataclasses.dataclass(frozen=True)
class TeachingJob:
    """One operator's wipe with the stiffness taught during it (for teleteach.run.trials.run_trials).

    The same operator is wiped once more under shared control without the clutch (the pattern the hand itself went
    on with), to compare how far the kept pattern travelled. Judged from the world: contact and force before, during
    and after the clutch (the force as the depth follows the stiffness being shaped), and the controller's words.
    """

    group: str
    seed: int
    skill: str
    taught: SurfaceStiffness
    wiping: WipingConfig
    surface: str
    base_pose: str

    def run(self, process: dict) -> dict:
        """The taught wipe of this operator, and how the clutch went."""
        scene = process["scene"]
        surface = scene.surface(self.surface)
        box = wiping_box(surface, scene.wiping_tool.size[:2])
        config = SharedControlConfig.from_yaml()
        commands, start = human_wipe(self.seed, self.skill, box, config.dt)
        teaching = clutch_teaching(len(commands) * config.dt, self.taught)
        targets, stiffnesses, records = taught_wipe(commands, start, box, config, teaching)
        own, _ = shared_targets(commands, start, box, config)
        times = config.dt * np.arange(len(commands))
        clutched = np.array([teaching.clutched(time) for time in times])
        record, _ = run_wipe(
            scene,
            process["kinematics"],
            process["uncertainty"],
            self.wiping,
            surface,
            self.base_pose,
            self.seed,
            targets,
            stiffnesses,
        )
        first, last = np.flatnonzero(clutched)[[0, -1]]
        row = {
            "seed": self.seed,
            "skill": self.skill,
            "clutch_s": [teaching.start, teaching.end],
            "kept_cycles": sum(
                r.skill == self.skill and r.message.startswith("clutch: keeping") for r in records[first : last + 1]
            ),
            "clutch_cycles": int(clutched.sum()),
            "kept_travel_m": float(np.linalg.norm(targets[last] - targets[first])),
            "own_travel_m": float(np.linalg.norm(own[last] - own[first])),
        }
        for part, mask in (("before", times < teaching.start), ("clutch", clutched), ("after", times >= teaching.end)):
            in_contact = contact_mask(record.normal_forces[mask], self.wiping.contact_threshold)
            row[part] = force_figures(record.normal_forces[mask], in_contact)
        return row
