"""A wiping skill: taught once by a wipe on one surface, learned, and replayed alone on a surface elsewhere.

The demonstration is what the arm executed on the perceived surface (the pattern the operator made, through the
shared controller, and the stiffness taught with it), stored in that surface's frame; the thesis' learning
(teleteach.learning.skill: DMPs for the poses, an SPD DMP for the stiffness) turns it into a skill of kind ``dmp`` in
the same frame, which replays relative to whatever surface the robot perceives where it is used. Judged from the
world: contact, and the share of the demonstration's wiped area that the replay wipes too (each in its own surface's
frame).
"""

import dataclasses
import pathlib
from typing import Dict

import numpy as np

from teleteach.core import skill_file
from teleteach.core.scene import Surface
from teleteach.core.wiping import WipingConfig, contact_mask, coverage_of, force_figures
from teleteach.learning.skill import learn_skill
from teleteach.wiping.ablation import coverage
from teleteach.wiping.trial import run_wipe


def learned_wiping_skill(demonstration: skill_file.Skill, name: str) -> skill_file.Skill:
    """The demonstration learned with DMPs and reproduced at its own duration, in the demonstration's frame."""
    learned = learn_skill(demonstration, name)
    return learned.to_skill(learned.reproduce(), name)


@dataclasses.dataclass(frozen=True)
class ReplayJob:
    """A learned wiping skill replayed on one surface pose (for teleteach.run.trials.run_trials)."""

    group: str
    seed: int
    surface: Surface
    skill_path: str
    reference_path: str
    config: WipingConfig
    base_pose: str

    def run(self, process: dict) -> Dict[str, object]:
        """The replay, judged from the world against the demonstration's covered area (``reference_path``)."""
        scene = dataclasses.replace(process["scene"], surfaces={self.surface.name: self.surface})
        skill = skill_file.load(self.skill_path)
        record, _ = run_wipe(
            scene,
            process["kinematics"],
            process["uncertainty"],
            self.config,
            self.surface,
            self.base_pose,
            self.seed,
            skill,
        )
        footprint = scene.wiping_tool.size[:2]
        grid = coverage(record, self.config, footprint, self.surface.area)["grid"]
        reference = np.load(pathlib.Path(self.reference_path))
        in_contact = contact_mask(record.normal_forces, self.config.contact_threshold)
        return {
            "seed": self.seed,
            **force_figures(record.normal_forces, in_contact),
            "coverage_of_demonstration": coverage_of(grid, reference),
            "covered_fraction": float(grid.mean()),
            "surface_error": record.seen_error.tolist(),
        }
