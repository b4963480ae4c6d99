"""Runs one skill at a time on a robot and turns everything that can happen into an outcome (never an exception)."""

import threading
from dataclasses import dataclass
from typing import Dict, Optional

import yaml

from teleteach.core import skill_file
from teleteach.core.scene import Site
from teleteach.core.wiping import WipingConfig, load_wiping_config
from teleteach.skills.config import MotionConfig
from teleteach.skills.motion import InverseKinematics, Motion
from teleteach.skills.predefined import CONDITIONS, PREDEFINED_SKILLS, WorldView, create_skills
from teleteach.skills.replay import PlaceTaught, StiffnessReplay, load_replay
from teleteach.skills.robot import Execution, PreemptedError, Robot, SkillError
from teleteach.skills.wipe import SurfaceReplay

REPLAY_SKILL = "ReplaySkill"
PLACE_TAUGHT = "PlaceTaught"
SKILL_NAMES = (*PREDEFINED_SKILLS, *CONDITIONS, REPLAY_SKILL, PLACE_TAUGHT)


@dataclass
class Outcome:
    """How a skill ended: success, the message for the action result, and whether it was preempted."""

    success: bool
    message: str
    preempted: bool = False


def parse_settings(parameters: str) -> Dict[str, str]:
    """A predefined skill's goal parameters: empty, or a yaml mapping overriding its settings (product, base_pose)."""
    try:
        values = yaml.safe_load(parameters or "")
    except yaml.YAMLError as error:
        raise SkillError(f"parameters are not valid yaml: {error}") from None
    if values is None:
        return {}
    if not isinstance(values, dict) or not all(isinstance(value, str) for value in values.values()):
        raise SkillError(
            f"parameters must be a yaml mapping of names, e.g. {{product: product_pick_2}}, got {values!r}"
        )
    return {str(key): value for key, value in values.items()}


class SkillRunner:
    """The skills over one robot; one skill runs at a time (the arm has one owner).

    Args:
        robot: the robot interface.
        config: the motion configuration.
        site: the named base poses and the mounted wiping tool (teleteach.core.scene.Site; the whole Scene will do).
        kinematics: Panda forward kinematics and Jacobian in base_link (teleteach.control.kinematics.PandaKinematics).
        wiping: the wiping settings a surface skill is replayed with (default: config/wiping.yaml).
    """

    def __init__(
        self, robot: Robot, config: MotionConfig, site: Site, kinematics, wiping: Optional[WipingConfig] = None
    ):
        self.robot = robot
        self.config = config
        self.site = site
        self.ik = InverseKinematics(kinematics, tolerance=config.arm.ik_tolerance)
        self.skills = create_skills(config)
        self.replay = StiffnessReplay()
        self.place_taught = PlaceTaught(self.replay)
        tool = site.wiping_tool
        self.wipe = SurfaceReplay(wiping or load_wiping_config(), tool) if tool is not None else None
        self._lock = threading.Lock()
        self.running = None

    def execute(self, name: str, parameters: str = "", execution: Execution = None) -> Outcome:
        """Run skill name to its end; the outcome says whether the world is now as the skill promises."""
        execution = execution or Execution()
        if name not in SKILL_NAMES:
            return Outcome(False, f"unknown skill '{name}'; known: {', '.join(SKILL_NAMES)}")
        if not self._lock.acquire(blocking=False):
            return Outcome(False, f"cannot run {name}: {self.running} is running")
        self.running = name
        motion = Motion(self.robot, self.config, self.ik, execution)
        try:
            if name == REPLAY_SKILL:
                message = self._replay(WorldView(motion, self.site), parameters)
            elif name == PLACE_TAUGHT:
                message = self.place_taught.run(WorldView(motion, self.site), self.robot.taught_skills())
            else:
                skill = self.skills[name]
                settings = parse_settings(parameters)
                if settings:
                    skill = type(skill)(name, {**skill.settings, **settings})
                if skill.moves:
                    motion.ensure_position_control()
                message = skill.run(WorldView(motion, self.site))
            execution.complete("done")
            return Outcome(True, message)
        except PreemptedError:
            self._stop(motion)
            return Outcome(False, f"{name} preempted: the arm holds where it was", preempted=True)
        except SkillError as error:
            self._stop(motion)
            return Outcome(False, str(error))
        except Exception as error:  # a broken robot link must not take the server down
            self._stop(motion)
            return Outcome(False, f"{name} failed: {error}")
        finally:
            self.running = None
            self._lock.release()

    def _replay(self, world: WorldView, parameters: str) -> str:
        """ReplaySkill: a skill taught on a surface wipes the surface perceived now, any other places the product."""
        request, skill = load_replay(parameters)
        if skill.target is None or skill.target.kind != skill_file.SURFACE:
            return self.replay.run(world, request, skill)
        if self.wipe is None:
            raise SkillError(f"{skill.name} wipes a surface, but the site has no wiping tool (scene file: wiping_tool)")
        return self.wipe.run(world, skill, request.target)

    @staticmethod
    def _stop(motion: Motion) -> None:
        try:
            motion.hold()
        except Exception:  # nothing more to do: the robot itself is unreachable
            pass
