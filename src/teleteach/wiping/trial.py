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
import pathlib
from typing import Callable, Optional, Sequence

import numpy as np
import pybullet
import yaml
from scipy.spatial.transform import Rotation

from teleteach.control import panda
from teleteach.core.frames import Transform
from teleteach.core.parameters import from_mapping
from teleteach.core.paths import config_file
from teleteach.core.scene import Scene, Surface
from teleteach.shared_control.operators import minimum_jerk
from teleteach.sim.robot_sim import IMPEDANCE, TRAJECTORY, RobotSim
from teleteach.sim.uncertainty import UncertaintySettings

DEFAULT_WIPING_FILE = config_file("wiping.yaml")
TOOL_DOWN = Rotation.from_euler("x", math.pi)  # the TCP's z into the surface, its x along u


class WipingError(ValueError):
    """A wipe cannot be done as asked (bad settings, a surface the arm cannot reach); nothing was wiped."""


@dataclasses.dataclass(frozen=True)
class WipingConfig:
    """The wiping task's settings (config/wiping.yaml: units and reasons there)."""

    rate: float
    contact_force: float
    contact_threshold: float
    approach_height: float
    approach_time: float
    settle_time: float
    retract_time: float
    coverage_resolution: float

    def __post_init__(self):
        values = dataclasses.asdict(self)
        if not all(math.isfinite(value) and value > 0.0 for value in values.values()):
            raise WipingError(f"every wiping setting must be finite and > 0: {values}")

    @property
    def dt(self) -> float:
        """The pattern's cycle [s]."""
        return 1.0 / self.rate


def load_wiping_config(path: Optional[str] = None) -> WipingConfig:
    """The wiping settings (default: config/wiping.yaml)."""
    path = pathlib.Path(path or DEFAULT_WIPING_FILE)
    return from_mapping(WipingConfig, yaml.safe_load(path.read_text()), str(path), WipingError)


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
    """What one wipe did, one row per cycle of the pattern (times [s] from the pattern's start).

    Attributes:
        times: cycle times [s].
        targets: the pattern's point of each cycle in the perceived surface's frame (u, v) [m].
        positions: the tool's contact face in the true surface's frame (u, v) [m], at the end of each cycle.
        heights: the face's height above the true surface [m] (negative: pressed into the felt).
        yaws: the face's turn about the true normal [rad].
        normal_forces: the surface's push on the tool along its true normal, mean over the cycle [N].
        tangential_forces: the surface's drag on the tool along the face, mean over the cycle [N].
        seen_error: where perception put the surface: its frame in the true one (u, v, n [m], tilt about u, v [rad]).
    """

    times: np.ndarray
    targets: np.ndarray
    positions: np.ndarray
    heights: np.ndarray
    yaws: np.ndarray
    normal_forces: np.ndarray
    tangential_forces: np.ndarray
    seen_error: np.ndarray


class SurfaceWiper:
    """The arm pressing the mounted tool on a surface it perceives, following in-plane targets.

    Args:
        sim: the simulated robot, its base standing where it wipes from, the tool not yet mounted.
        kinematics: Panda kinematics (its IK puts the arm over the pattern's start).
        surface: the true surface (the world's); the wiper sees it only through ``sim``'s perception.
        config: the wiping settings.
    """

    def __init__(self, sim: RobotSim, kinematics, surface: Surface, config: WipingConfig):
        self.sim, self.config, self.truth = sim, config, surface
        self.seen = sim.perceived_surface(surface.name)
        base = Transform.from_planar(*sim.world.base_pose).inverse()
        self.seen_in_base = base * self.seen.frame
        self.true_in_base = base * surface.frame
        self.tool_quaternion = (self.seen_in_base.rotation * TOOL_DOWN).as_quat()
        self.reach = sim.scene.wiping_tool.reach
        self._kinematics = kinematics
        self._stiffness: Optional[SurfaceStiffness] = None

    def seen_error(self) -> np.ndarray:
        """The perceived surface's frame in the true one: (u, v, n) [m] and the tilt about u and v [rad]."""
        error = self.truth.frame.inverse() * self.seen.frame
        return np.concatenate([error.position, error.rotation.as_rotvec()[:2]])

    def _tcp_at(self, point, height: float) -> np.ndarray:
        """The TCP's position in base_link that puts the tool's face at (u, v) and height above the perceived face."""
        return self.seen_in_base.apply_point([point[0], point[1], height + self.reach])

    def start_over(self, point: Sequence[float]) -> None:
        """Put the arm over the point at the approach height, mount the tool, and hold it there by impedance.

        Raises:
            WipingError: the arm cannot reach the pose (nothing was mounted then).
        """
        from teleteach.control.kinematics import IKError

        sim = self.sim
        target = self._tcp_at(point, self.config.approach_height)
        try:
            joints = self._kinematics.inverse(target, self.tool_quaternion)
        except IKError as error:
            raise WipingError(f"the surface {self.truth.name} is out of the arm's reach: {error}") from None
        world = sim.world
        for index, value in zip(panda.ARM_INDICES, joints):
            pybullet.resetJointState(world.robot, index, value, physicsClientId=world.client)
        if sim.manager.running != TRAJECTORY:
            sim.switch_controllers([TRAJECTORY], [sim.manager.running] if sim.manager.running else [], 2)
        sim.command_trajectory(panda.ARM_JOINTS, [(list(joints), [0.0] * 7, 0.05)], stamp=sim.time)
        world.mount_tool(sim.scene.wiping_tool)
        sim.run(0.1)
        ok, message = sim.switch_controllers([IMPEDANCE], [TRAJECTORY], 2)
        if not ok:
            raise WipingError(f"cannot start the impedance controller: {message}")
        self._equilibrium(point, self.config.approach_height, np.zeros(2))

    def set_stiffness(self, stiffness: SurfaceStiffness) -> None:
        """The translational stiffness, its axes the perceived surface's (the robot knows no other)."""
        self._stiffness = stiffness
        self.sim.command_eigenvalues(stiffness.eigenvalues().tolist(), stamp=self.sim.time)
        self.sim.command_eigenvectors(self.seen_in_base.rotation.as_quat().tolist(), stamp=self.sim.time)

    def pressing_height(self) -> float:
        """Where the equilibrium lies along the perceived normal so that K_n asks for contact_force [m]."""
        return -self.config.contact_force / self._stiffness.normal

    def _equilibrium(self, point, height: float, velocity) -> None:
        sim = self.sim
        sim.command_equilibrium(
            "base_link", self._tcp_at(point, height).tolist(), self.tool_quaternion.tolist(), sim.time
        )
        linear = self.seen_in_base.rotation.apply([velocity[0], velocity[1], 0.0])
        sim.command_equilibrium_twist("base_link", linear.tolist(), [0.0, 0.0, 0.0], sim.time)

    def _move_height(self, point, start: float, end: float, duration: float) -> None:
        """The equilibrium from one height over point to another, minimum jerk, then held."""
        steps = int(round(duration * self.config.rate))
        for k in range(1, steps + 1):
            height = start + (end - start) * float(minimum_jerk(np.array(k / steps)))
            self._equilibrium(point, height, np.zeros(2))
            self.sim.run(self.config.dt)

    def press(self, point) -> None:
        """From the approach height down to the pressing equilibrium, then still for the settle time."""
        self._move_height(point, self.config.approach_height, self.pressing_height(), self.config.approach_time)
        self.sim.run(self.config.settle_time)

    def retract(self, point) -> None:
        """Back up to the approach height, off the surface."""
        self._move_height(point, self.pressing_height(), self.config.approach_height, self.config.retract_time)

    def _tool_in_surface(self):
        """The tool's face in the true surface's frame: (u, v), height [m], yaw about the normal [rad]."""
        world = self.sim.world
        position, quaternion = world.tool_face()
        face = self.truth.frame.inverse() * Transform(np.array(position), Rotation.from_quat(quaternion))
        along = face.rotation.apply([1.0, 0.0, 0.0])
        return face.position[:2], float(face.position[2]), math.atan2(along[1], along[0])

    def follow(self, targets: np.ndarray, stiffness: Optional[Callable[[int], SurfaceStiffness]] = None) -> WipeRecord:
        """Press along the targets (N x 2, one per cycle, in the perceived surface's frame), recording each cycle.

        ``stiffness(k)``, when given, sets cycle k's stiffness (a taught profile); the depth follows its K_n.
        """
        sim, config = self.sim, self.config
        ticks = int(round(config.dt / sim.world.time_step))
        normal_in_base = self.true_in_base.rotation.apply([0.0, 0.0, 1.0])
        rows = []
        velocities = np.gradient(targets, config.dt, axis=0) if len(targets) > 1 else np.zeros_like(targets)
        for k, (point, velocity) in enumerate(zip(targets, velocities)):
            if stiffness is not None:
                self.set_stiffness(stiffness(k))
            self._equilibrium(point, self.pressing_height(), velocity)
            force = np.zeros(3)
            for _ in range(ticks):
                sim.tick()
                force += sim.world.external_wrench()[0]
            force /= ticks
            normal = float(force @ normal_in_base)
            tangential = float(np.linalg.norm(force - normal * normal_in_base))
            uv, height, yaw = self._tool_in_surface()
            rows.append((k * config.dt, *point, *uv, height, yaw, normal, tangential))
        table = np.array(rows)
        return WipeRecord(
            times=table[:, 0],
            targets=table[:, 1:3],
            positions=table[:, 3:5],
            heights=table[:, 5],
            yaws=table[:, 6],
            normal_forces=table[:, 7],
            tangential_forces=table[:, 8],
            seen_error=self.seen_error(),
        )


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
    targets: np.ndarray,
    stiffness: SurfaceStiffness,
) -> WipeRecord:
    """One wipe in a fresh world: the base where MoveBase stops for base_pose, perception with the seed's errors.

    Raises:
        WipingError: the surface is out of reach (nothing was wiped).
    """
    sim = RobotSim(wiping_scene(scene, surface), uncertainty=uncertainty.with_overrides(seed=seed))
    try:
        sim.place_base(scene.base_poses[base_pose])
        wiper = SurfaceWiper(sim, kinematics, surface, config)
        wiper.set_stiffness(stiffness)
        wiper.start_over(targets[0])
        wiper.press(targets[0])
        record = wiper.follow(np.asarray(targets, dtype=float))
        wiper.retract(targets[-1])
        return record
    finally:
        sim.close()
