"""One wipe in-process, faster than real time, judged from the true world.

The robot stands where MoveBase stopped for the wiping pose, perceives the surface (config/uncertainty.yaml's surface
error: a few millimetres along the normal, about a degree of tilt), and presses the mounted tool on it under
Cartesian impedance control: every cycle of the pattern (50 Hz) the equilibrium is the pattern's point on the
perceived face, ``contact_force / K_n`` beyond it along the perceived normal, with the stiffness given in the perceived
surface's frame. The pattern is a list of in-plane targets, whoever made them (the operator's commands integrated:
direct control; the shared controller's executed states). What happened is read from the world: the force the surface
puts on the tool (the wrist's force sensor, averaged over each cycle as a 50 Hz filtered sensor reports it), and the
tool's contact face in the true surface's frame.
"""

import dataclasses
import math
from typing import Sequence, Tuple, Union

import numpy as np
import pybullet
from scipy.spatial.transform import Rotation

from teleteach.control import panda
from teleteach.control.stiffness import translational_stiffness
from teleteach.core.frames import Transform
from teleteach.core.scene import Scene, Surface
from teleteach.core.skill_file import SURFACE, TARGET_FRAME, Skill, Target
from teleteach.core.wiping import TOOL_DOWN, WipingConfig, WipingError, off_surface
from teleteach.shared_control.operators import minimum_jerk
from teleteach.shared_control.surface import pressing_depth
from teleteach.sim.robot_sim import IMPEDANCE, RobotSim
from teleteach.sim.uncertainty import UncertaintySettings
from teleteach.skills.replay import ReplayPlan, plan_replay


@dataclasses.dataclass(frozen=True)
class SurfaceStiffness:
    """A translational stiffness in the surface's frame [N/m]: along u, along v, along the normal."""

    along_u: float
    along_v: float
    normal: float

    def eigenvalues(self) -> np.ndarray:
        """The principal stiffnesses in the order of the surface frame's axes."""
        return np.array([self.along_u, self.along_v, self.normal])


@dataclasses.dataclass
class WipeRecord:
    """What one wipe did, one row per cycle (times [s] from the wipe's start).

    Attributes:
        times: cycle times [s].
        targets: where the equilibrium put the tool's face in the perceived surface's frame (u, v) [m].
        positions: the tool's contact face in the true surface's frame (u, v) [m], at the end of each cycle.
        heights: the face's height above the true surface [m] (negative: pressed into the felt).
        yaws: the face's turn about the true normal [rad].
        normal_forces: the surface's push on the tool along its true normal, mean over the cycle [N].
        stiffness: the commanded translational stiffness in base_link (N x 3 x 3) [N/m].
        equilibrium_poses: the commanded equilibrium (x, y, z, qx, qy, qz, qw) in base_link.
        tcp_poses: the measured TCP pose in base_link at the end of each cycle.
        seen_error: where perception put the surface: its frame in the true one (u, v, n [m], tilt about u, v [rad]).
    """

    times: np.ndarray
    targets: np.ndarray
    positions: np.ndarray
    heights: np.ndarray
    yaws: np.ndarray
    normal_forces: np.ndarray
    stiffness: np.ndarray
    equilibrium_poses: np.ndarray
    tcp_poses: np.ndarray
    seen_error: np.ndarray


class SurfaceWiper:
    """The arm pressing the mounted tool on a surface it perceives, playing a wiping skill in that surface's frame.

    A pattern (in-plane targets and a stiffness) becomes such a skill with :meth:`pattern_skill`; a demonstration's
    record becomes one with :meth:`demonstrated_skill`; either, or a skill learned from one, is played on the surface
    as perceived now (:meth:`execute`), as ReplaySkill plays a placement relative to the gap it perceives.

    Args:
        sim: the simulated robot, its base standing where it wipes from, the tool not yet mounted.
        kinematics: Panda kinematics (its IK puts the arm over the skill's start).
        surface: the true surface (the world's); the wiper sees it only through ``sim``'s perception.
        config: the wiping settings.
    """

    def __init__(self, sim: RobotSim, kinematics, surface: Surface, config: WipingConfig):
        self.sim, self.config, self.truth = sim, config, surface
        self.seen = sim.perceived_surface(surface.name)
        base = Transform.from_planar(*sim.world.base_pose).inverse()
        self.seen_in_base = base * self.seen.frame
        self.true_in_base = base * surface.frame
        self.reach = sim.scene.wiping_tool.reach
        self._kinematics = kinematics

    def seen_error(self) -> np.ndarray:
        """The perceived surface's frame in the true one: (u, v, n) [m] and the tilt about u and v [rad]."""
        error = self.truth.frame.inverse() * self.seen.frame
        return np.concatenate([error.position, error.rotation.as_rotvec()[:2]])

    def pattern_skill(
        self, targets: np.ndarray, stiffness: Union[SurfaceStiffness, Sequence[SurfaceStiffness]], name: str = "Pattern"
    ) -> Skill:
        """In-plane targets (one per cycle) pressed with ``stiffness`` (one, or one per cycle): a surface-frame skill.

        The TCP's equilibrium lies ``contact_force / K_n`` beyond the face along the normal, K_n each cycle's, the
        tool square to it.
        """
        targets = np.asarray(targets, dtype=float)
        stiffnesses = [stiffness] * len(targets) if isinstance(stiffness, SurfaceStiffness) else list(stiffness)
        if len(stiffnesses) != len(targets):
            raise WipingError(f"{len(stiffnesses)} stiffnesses for {len(targets)} targets: one each, or one for all")
        matrices = np.array([np.diag(each.eigenvalues()) for each in stiffnesses])
        heights = [self.reach - pressing_depth(self.config, matrix, (0, 0, 1)) for matrix in matrices]
        poses = np.column_stack([targets, heights, np.tile(TOOL_DOWN.as_quat(), (len(targets), 1))])
        times = self.config.dt * np.arange(len(targets))
        pose = tuple(float(value) for value in self.seen_in_base.as_pose())
        return Skill(
            name,
            "stiffness",
            times,
            matrices,
            poses,
            poses,
            frame=TARGET_FRAME,
            target=Target(self.truth.name, pose, SURFACE),
        )

    def demonstrated_skill(self, record: WipeRecord, name: str) -> Skill:
        """What a wipe demonstrated, as a skill in the perceived surface's frame.

        The equilibrium the arm was given, the TCP's measured pose and the stiffness, every cycle: the pattern as it
        was executed, whoever made it (the operator directly, the shared controller).
        """
        demonstrated = Skill(
            name, "stiffness", record.times, record.stiffness, record.equilibrium_poses, record.tcp_poses
        )
        return demonstrated.relative_to(self.truth.name, self.seen_in_base, SURFACE)

    def _tcp_quaternion(self) -> np.ndarray:
        return (self.seen_in_base.rotation * TOOL_DOWN).as_quat()

    def _hold(self, position, quaternion, velocity=(0.0, 0.0, 0.0)) -> None:
        sim = self.sim
        sim.command_equilibrium("base_link", list(position), list(quaternion), sim.time)
        sim.command_equilibrium_twist("base_link", list(velocity), [0.0, 0.0, 0.0], sim.time)

    def _stiffness(self, eigenvalues, eigenvectors) -> None:
        self.sim.command_eigenvalues(list(eigenvalues), stamp=self.sim.time)
        self.sim.command_eigenvectors(list(eigenvectors), stamp=self.sim.time)

    def _off(self, position) -> np.ndarray:
        """Where the TCP holds the face off the perceived surface over a pose of the pattern (base_link)."""
        point = self.seen_in_base.inverse().apply_point(position)
        return off_surface(self.seen_in_base, self.sim.scene.wiping_tool, self.config, point)

    def _move(self, start, end, quaternion, duration: float) -> None:
        """The equilibrium from one position to another, minimum jerk, one step a cycle."""
        steps = max(int(round(duration * self.config.rate)), 1)
        for k in range(1, steps + 1):
            self._hold(start + (end - start) * float(minimum_jerk(np.array(k / steps))), quaternion)
            self.sim.run(self.config.dt)

    def start_over(self, plan: ReplayPlan) -> None:
        """Put the arm over the plan's first pose at the approach height, mount the tool, hold it there by impedance.

        Raises:
            WipingError: the arm cannot reach the pose (nothing was mounted then).
        """
        from teleteach.control.kinematics import IKError

        sim = self.sim
        above = self._off(plan.positions[0])
        try:
            joints = self._kinematics.inverse(above, plan.orientations[0])
        except IKError as error:
            raise WipingError(f"the surface {self.truth.name} is out of the arm's reach: {error}") from None
        world = sim.world
        for index, value in zip(panda.ARM_INDICES, joints):
            pybullet.resetJointState(world.robot, index, value, physicsClientId=world.client)
        self._stiffness(plan.eigenvalues[0], plan.eigenvectors[0])
        running = [sim.manager.running] if sim.manager.running not in (None, IMPEDANCE) else []
        ok, message = sim.switch_controllers([IMPEDANCE], running, 2)  # it starts holding the pose it finds
        if not ok:
            raise WipingError(f"cannot start the impedance controller: {message}")
        self._hold(above, plan.orientations[0])
        world.mount_tool(sim.scene.wiping_tool)
        sim.run(0.1)

    def plan(self, skill: Skill) -> ReplayPlan:
        """The skill on the surface as perceived now, in base_link, one step a cycle."""
        return plan_replay(skill.in_base(self.seen_in_base), self.config.rate)

    def execute(self, skill: Skill) -> WipeRecord:
        """Approach, press and play the skill on the perceived surface, recording each cycle; then retract."""
        plan = self.plan(skill)
        self.start_over(plan)
        first, last = plan.positions[0], plan.positions[-1]
        self._move(self._off(first), first, plan.orientations[0], self.config.approach_time)
        self.sim.run(self.config.settle_time)
        record = self._play(plan)
        self._move(last, self._off(last), plan.orientations[-1], self.config.retract_time)
        return record

    def _play(self, plan: ReplayPlan) -> WipeRecord:
        sim, config = self.sim, self.config
        ticks = int(round(config.dt / sim.world.time_step))
        normal_in_base = self.true_in_base.rotation.apply([0.0, 0.0, 1.0])
        velocities = np.gradient(plan.positions, config.dt, axis=0) if len(plan.times) > 1 else np.zeros((1, 3))
        rows = []
        for k in range(len(plan.times)):
            self._stiffness(plan.eigenvalues[k], plan.eigenvectors[k])
            self._hold(plan.positions[k], plan.orientations[k], velocities[k])
            force = np.zeros(3)
            for _ in range(ticks):
                sim.tick()
                force += sim.world.external_wrench()[0]
            force /= ticks
            normal = float(force @ normal_in_base)
            rows.append((normal, *self._tool_in_surface(), *sim.state.position, *sim.state.quaternion))
        table = np.array(rows)
        stiffness = np.array(
            [
                translational_stiffness(values, quaternion)
                for values, quaternion in zip(plan.eigenvalues, plan.eigenvectors)
            ]
        )
        return WipeRecord(
            times=plan.times,
            targets=self.seen_in_base.inverse().apply_poses(np.column_stack([plan.positions, plan.orientations]))[
                :, :2
            ],
            positions=table[:, 1:3],
            heights=table[:, 3],
            yaws=table[:, 4],
            normal_forces=table[:, 0],
            stiffness=stiffness,
            equilibrium_poses=np.column_stack([plan.positions, plan.orientations]),
            tcp_poses=table[:, 5:12],
            seen_error=self.seen_error(),
        )

    def _tool_in_surface(self):
        """The tool's face in the true surface's frame: u, v, height [m], yaw about the normal [rad]."""
        position, quaternion = self.sim.world.tool_face()
        face = self.truth.frame.inverse() * Transform(np.array(position), Rotation.from_quat(quaternion))
        along = face.rotation.apply([1.0, 0.0, 0.0])
        return (*face.position, math.atan2(along[1], along[0]))


def wiping_scene(scene: Scene, surface: Surface) -> Scene:
    """The scene with only the surface to wipe and no products: nothing else can touch the tool, and each costs time."""
    return dataclasses.replace(
        scene.without_products([product.name for product in scene.products]), surfaces={surface.name: surface}
    )


def run_wipe(
    scene: Scene,
    kinematics,
    uncertainty: UncertaintySettings,
    config: WipingConfig,
    surface: Surface,
    base_pose: str,
    seed: int,
    pattern: Union[np.ndarray, Skill],
    stiffness: Union[None, SurfaceStiffness, Sequence[SurfaceStiffness]] = None,
) -> Tuple[WipeRecord, SurfaceWiper]:
    """One wipe in a fresh world: the base where MoveBase stops for base_pose, perception with the seed's errors.

    ``pattern`` is in-plane targets (one per cycle, pressed with ``stiffness``: one, or one per cycle) or a wiping
    skill in a surface's frame.
    Returns the record and the wiper (what it perceived; :meth:`SurfaceWiper.demonstrated_skill`).

    Raises:
        WipingError: the surface is out of reach (nothing was wiped).
    """
    sim = RobotSim(wiping_scene(scene, surface), uncertainty=uncertainty.with_overrides(seed=seed))
    try:
        sim.place_base(scene.base_poses[base_pose])
        wiper = SurfaceWiper(sim, kinematics, surface, config)
        skill = pattern if isinstance(pattern, Skill) else wiper.pattern_skill(pattern, stiffness)
        return wiper.execute(skill), wiper
    finally:
        sim.close()
