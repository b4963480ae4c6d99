"""A taught wipe replayed alone on the surface the robot perceives now: ReplaySkill of a skill taught on a surface.

The skill was learned from a wipe (the pattern the operator made through the shared controller and the stiffness
taught with it, in the wiped surface's frame: teleteach.wiping.skill). Like a placement relative to the gap, it is
played relative to the surface as perception reports it now (T_base^tcp = T_base^surface T_surface^tcp, the stiffness
turned with it): in position control over its start at the approach height, under impedance down onto the face, the
pattern with its stiffness, and back off. Judged from the robot's own sensors, as a user's robot can: the force along
the perceived normal (/force_torque_ext) says when the tool touched, the TCP (/cartesian_pose) where its face was.
The wipe succeeds when the tool kept contact for ``min_contact`` of the pattern and swept at least ``min_coverage``
of the area its demonstration swept (config/wiping.yaml): the skill's tool path (its ``cartesian_pose``), which lags
the equilibrium by friction over stiffness as the replay does, not the equilibrium's path, which no tool sweeps whole.
"""

from typing import Tuple

import numpy as np
from scipy.spatial.transform import Rotation

from teleteach.core import skill_file
from teleteach.core.frames import Transform
from teleteach.core.scene import WipingTool
from teleteach.core.trajectories import minimum_jerk
from teleteach.core.wiping import (
    ARM_REACH,
    WipingConfig,
    contact_mask,
    coverage_of,
    covered_area,
    force_figures,
    off_surface,
)
from teleteach.skills.motion import Motion
from teleteach.skills.predefined import WorldView
from teleteach.skills.replay import ReplayPlan, plan_replay
from teleteach.skills.robot import SkillError


def surface_in_base(world: WorldView, skill: skill_file.Skill, requested) -> Tuple[str, Transform]:
    """The perceived surface a surface skill wipes (the requested one, else the one it was taught at), in base_link.

    Raises:
        SkillError: perception reports no such surface (the message lists the ones it reports).
    """
    name = requested or skill.target.name
    surfaces = world.perceived().surfaces
    if name not in surfaces:
        raise SkillError(
            f"{skill.name} (taught on {skill.target.name}) cannot wipe {name}: perception reports no such surface "
            f"(it reports {', '.join(sorted(surfaces)) or 'none'})"
        )
    seen = surfaces[name]
    base = Transform.from_planar(*world.motion.robot.base_pose())
    return name, base.inverse() * Transform(seen.position, Rotation.from_quat(seen.quaternion))


class SurfaceReplay:
    """Wipes a perceived surface with a taught wiping skill, and judges the wipe from the force and the TCP.

    Args:
        settings: the wiping settings (rate, approach and retract, contact threshold, what counts as success).
        tool: the tool mounted in the hand (its face ``reach`` beyond the TCP, its contact patch).
    """

    def __init__(self, settings: WipingConfig, tool: WipingTool):
        self.settings, self.tool = settings, tool

    def run(self, world: WorldView, skill: skill_file.Skill, requested) -> str:
        """Wipe with ``skill`` on the surface named ``requested`` (None: the one it was taught on)."""
        name, surface = surface_in_base(world, skill, requested)
        plan = plan_replay(skill.in_base(surface), self.settings.rate)
        self._check_reach(skill, name, plan, world.site.robot.mount_height)
        normal = surface.rotation.apply([0.0, 0.0, 1.0])
        first, last = plan.positions[0], plan.positions[-1]
        over_first, over_last = (self._off(surface, position) for position in (first, last))
        motion, robot = world.motion, world.motion.robot
        motion.ensure_position_control()
        motion.execution.phase("over the surface", 0.2)
        motion.move_to_pose(over_first, Rotation.from_quat(plan.orientations[0]))
        motion.execution.phase("switch to impedance control", 0.05)
        now = robot.now()
        robot.command_stiffness(plan.eigenvalues[0], plan.eigenvectors[0], now)
        robot.command_equilibrium(*robot.cartesian_pose(), now)
        robot.switch_controllers([motion.config.impedance_controller], [motion.config.position_controller])
        try:
            self._glide(motion, plan, 0, over_first, first, self.settings.approach_time)
            robot.sleep(self.settings.settle_time)
            forces, poses = self._play(motion, plan, normal)
            self._glide(motion, plan, -1, last, over_last, self.settings.retract_time)
            robot.sleep(self.settings.settle_time)  # a compliant normal follows the lift late: off before switching
        finally:
            robot.command_equilibrium(*robot.cartesian_pose(), robot.now())
            robot.switch_controllers([motion.config.position_controller], [motion.config.impedance_controller])
            motion.hold()
        return self._judge(skill, name, plan, surface, forces, poses)

    def _off(self, surface: Transform, position) -> np.ndarray:
        """Where the TCP holds the face off the surface over a pose of the pattern (base_link)."""
        return off_surface(surface, self.tool, self.settings, surface.inverse().apply_point(position))

    def _check_reach(self, skill, name: str, plan: ReplayPlan, mount_height: float) -> None:
        """SkillError (before anything moves) when a pose of the pattern lies beyond the arm's reach."""
        farthest = float(np.max(np.linalg.norm(plan.positions - np.array([0.0, 0.0, mount_height]), axis=1)))
        if farthest > ARM_REACH:
            raise SkillError(
                f"{skill.name} cannot wipe {name} from here: the pattern reaches {farthest:.2f} m from the arm's "
                f"shoulder (> {ARM_REACH} m); move the base closer"
            )

    def _glide(self, motion: Motion, plan: ReplayPlan, index: int, start, end, duration: float) -> None:
        """The equilibrium from start to end (base_link) along minimum jerk, one step a cycle, the plan's stiffness."""
        robot, dt = motion.robot, self.settings.dt
        steps = max(int(round(duration / dt)), 1)
        for step in range(1, steps + 1):
            motion.execution.check()
            stamp = robot.now()
            robot.command_stiffness(plan.eigenvalues[index], plan.eigenvectors[index], stamp)
            position = start + (end - start) * float(minimum_jerk(np.array(step / steps)))
            robot.command_equilibrium(position, plan.orientations[index], stamp)
            robot.sleep(dt)

    def _play(self, motion: Motion, plan: ReplayPlan, normal) -> Tuple[np.ndarray, np.ndarray]:
        """The pattern, one sample a cycle: the force along the normal [N] and the TCP pose (base_link) each cycle."""
        robot, execution, dt = motion.robot, motion.execution, self.settings.dt
        execution.phase("wipe", 0.6)
        forces, poses = [], []
        for index in range(len(plan.times)):
            execution.check()
            stamp = robot.now()
            robot.command_stiffness(plan.eigenvalues[index], plan.eigenvectors[index], stamp)
            robot.command_equilibrium(plan.positions[index], plan.orientations[index], stamp)
            robot.sleep(dt)
            forces.append(float(robot.contact_force() @ normal))
            poses.append(np.concatenate(robot.cartesian_pose()))
            execution.report(index / max(len(plan.times) - 1, 1))
        return np.array(forces), np.array(poses)

    def _judge(self, skill, name: str, plan: ReplayPlan, surface: Transform, forces, poses) -> str:
        """The wipe's message when it kept contact and swept its demonstration's area; else SkillError saying why."""
        settings, footprint = self.settings, self.tool.size[:2]
        to_surface = surface.inverse()
        demonstrated = to_surface.apply_poses(skill.in_base(surface).cartesian_pose)
        planned, planned_yaws = faces_on(demonstrated)
        wiped, wiped_yaws = faces_on(to_surface.apply_poses(poses))
        margin = max(footprint)
        low, high = planned.min(axis=0) - margin, planned.max(axis=0) + margin
        area, resolution = (low[0], low[1], high[0], high[1]), settings.coverage_resolution
        everywhere = np.ones(len(planned), dtype=bool)
        meant = covered_area(planned, planned_yaws, everywhere, footprint, area, resolution)["grid"]
        in_contact = contact_mask(forces, settings.contact_threshold)
        swept = covered_area(wiped, wiped_yaws, in_contact, footprint, area, resolution)["grid"]
        coverage = coverage_of(swept, meant)
        figures = force_figures(forces, in_contact)
        said = (
            f"wiped {name} with {skill.name} ({skill.kind}, taught on {skill.target.name}): {len(plan.times)} cycles "
            f"over {plan.duration:.1f} s, in contact {figures['contact_fraction']:.0%} of them, force "
            f"{figures['force_mean_n']:.1f} N mean, {figures['peak_force_n']:.1f} N peak; swept {coverage:.0%} of "
            f"the area its demonstration swept"
        )
        if figures["contact_fraction"] < settings.min_contact or coverage < settings.min_coverage:
            raise SkillError(
                f"{said}: short of the {settings.min_contact:.0%} contact and {settings.min_coverage:.0%} of the area "
                f"a wipe must reach (is the tool mounted? is the surface where perception sees it?)"
            )
        return said


def faces_on(poses_in_surface: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """Where a square tool's face is for TCP poses in the surface's frame: (u, v) [m], the TCP x's yaw [rad]."""
    along = Rotation.from_quat(poses_in_surface[:, 3:]).apply([1.0, 0.0, 0.0])
    return poses_in_surface[:, :2], np.arctan2(along[:, 1], along[:, 0])
