"""The predefined pick-and-place skills of the thesis' behaviour tree (Appendix B.2), on the position controller.

Each skill is a short sequence of motions (:mod:`teleteach.skills.motion`) and ends by checking the world: a skill
succeeds only when the products, the gripper and the base are where the skill was meant to put them.
"""

import math
from dataclasses import dataclass
from typing import Dict, Optional, Tuple

import numpy as np
from scipy.spatial.transform import Rotation

from teleteach.core import placement
from teleteach.core.observed import ObservedBox, ObservedScene, table_on
from teleteach.core.placement import Placement
from teleteach.core.rotations import yaw_rotation
from teleteach.core.scene import Gap, SceneError, Site
from teleteach.skills.config import MotionConfig
from teleteach.skills.motion import TOP_DOWN, Motion, world_to_base
from teleteach.skills.robot import SkillError

# The skills of the predefined tree, in the order the tree runs them.
PREDEFINED_SKILLS = (
    "LookToShelf",
    "PickItem",
    "MoveBase",
    "PlaceItem",
    "DropItem",
    "MoveBaseToStart",
    "LookToShelfAgain",
    "PickItem2",
    "MoveBase2",
    "Idle",
)

# Conditions: checks of the world that move nothing (library kind "condition").
CONDITIONS = ("ProductInHand", "ProductInGap")

HOLD_LOOKS = 3  # product_in_hand: how many times to look before saying the hand is empty
HOLD_LOOK_INTERVAL = 0.2  # [s] robot time between two looks
POSTURE_TOLERANCE = 0.05  # [rad] closer than this to a posture = already there


def up(height):
    """A vertical offset of height [m]."""
    return np.array([0.0, 0.0, height])


def across_fingers(size, grasp_yaw) -> float:
    """Width [m] between the fingers of an upright box of size (x, y, z) [m]: its extent across y turned by the yaw."""
    return float(abs(math.cos(grasp_yaw)) * size[1] + abs(math.sin(grasp_yaw)) * size[0])


@dataclass
class WorldView:
    """What the skills ask about the world: its perception, joints and base, and the site's named base poses.

    Products, gaps and tables come only from the robot's perception (teleteach/scene: teleteach.perception).

    Args:
        motion: the running skill's motions (robot, kinematics, config).
        site: the named base poses (a teleteach.core.scene.Site, or the whole Scene).
    """

    motion: Motion
    site: Site

    def perceived(self) -> ObservedScene:
        """The scene as the robot perceives it now."""
        return self.motion.robot.observed_scene()

    def product_box(self, name) -> ObservedBox:
        """Product name as perceived now (pose and size), or SkillError when the scene does not report it."""
        try:
            return self.perceived().product(name)
        except KeyError:
            raise SkillError(f"{name} is not in the scene") from None

    def gap(self, name) -> Gap:
        """The perceived gap called name, or SkillError naming the gaps the scene reports."""
        try:
            return self.perceived().gap(name)
        except SceneError as error:
            raise SkillError(str(error)) from None

    @property
    def config(self) -> MotionConfig:
        """The motion configuration."""
        return self.motion.config

    def product_position(self, name) -> np.ndarray:
        """Where product name is now (world) [m], or SkillError when the scene does not report it."""
        return self.product_box(name).position.copy()

    def on_table(self, name) -> bool:
        """Whether product name stands on a pick table of the scene."""
        scene = self.perceived()
        if name not in scene.products:
            return False
        return table_on(scene, scene.product(name), self.config.grasp.table_tolerance) is not None

    def expected_in_hand(self) -> np.ndarray:
        """Where a held product's centre should be (world) [m]: height_above_center along the TCP's z (down)."""
        position, rotation = self.motion.tcp_world()
        return position + rotation.apply([0.0, 0.0, self.config.grasp.height_above_center])

    def nearest_to_hold(self) -> Tuple[Optional[str], float]:
        """The product nearest the place a held one would be, and its distance from there [m] (None, inf: none)."""
        expected = self.expected_in_hand()
        distances = {
            name: float(np.linalg.norm(np.asarray(position) - expected))
            for name, position in self.motion.robot.product_positions().items()
        }
        if not distances:
            return None, math.inf
        name = min(distances, key=distances.get)
        return name, distances[name]

    def held_product(self) -> Tuple[Optional[str], float]:
        """The product the fingers hold (name or None) and its distance from the expected place in the hand [m]."""
        width = self.motion.robot.gripper_width()
        if not 0.005 < width < self.config.gripper.open_width - 0.005:
            return None, math.inf
        name, distance = self.nearest_to_hold()
        if distance > self.config.grasp.hold_tolerance:
            return None, distance
        return name, distance

    def product_in_hand(self) -> Tuple[Optional[str], float]:
        """:meth:`held_product`, looked at again (HOLD_LOOKS times, HOLD_LOOK_INTERVAL apart) while it sees none.

        The scene, the base's transform and the joint states come on different topics: right after a motion they can
        disagree for a moment (a loaded machine), and a carried product then looks centimetres away from the hold.
        Use it where an empty hand is a failure.
        """
        for _ in range(HOLD_LOOKS - 1):
            held = self.held_product()
            if held[0] is not None:
                return held
            self.motion.robot.sleep(HOLD_LOOK_INTERVAL)
        return self.held_product()

    def placement(self, product, before: Dict[str, np.ndarray], gap: Optional[str] = None) -> Placement:
        """Where product ended relative to gap (default: the nearest gap), its neighbours compared with ``before``.

        Raises:
            SkillError: the product is not in the scene, or the scene has no such gap.
        """
        poses = self.motion.robot.product_poses()
        if product not in poses:
            raise SkillError(f"{product} is not in the scene")
        final = {name: position for name, (position, _) in poses.items()}
        try:
            return placement.judge(self.perceived(), product, poses[product], before, final, gap)
        except SceneError as error:
            raise SkillError(str(error)) from None

    def into_shelf(self, gap: Gap) -> np.ndarray:
        """Horizontal unit vector in base_link pointing into the shelf at gap (the gap's x axis)."""
        return yaw_rotation(gap.yaw - self.motion.robot.base_pose()[2]).apply([1.0, 0.0, 0.0])

    def gap_near_hand(self) -> Gap:
        """The gap closest to the hand: the one a product in the hand is being put into."""
        position, _ = self.motion.tcp_world()
        try:
            return self.perceived().nearest_gap(position)
        except SceneError as error:
            raise SkillError(str(error)) from None

    def top_down(self, yaw_world) -> Rotation:
        """TCP orientation in base_link pointing down, rotated by yaw_world [rad] (world) about the vertical."""
        base_yaw = self.motion.robot.base_pose()[2]
        return yaw_rotation(yaw_world - base_yaw + self.config.grasp.yaw) * TOP_DOWN


class PredefinedSkill:
    """A predefined skill: run() does the motions and returns the success message, or raises SkillError.

    ``moves`` is False for conditions: they only read the world, so the runner leaves the controllers as they are.

    Args:
        name: the skill's name (its action server is /skills/<name>).
        settings: the skill's entry in config/skills_motion.yaml `skills` (product, base_pose).
    """

    moves = True

    def __init__(self, name: str, settings: Dict[str, str]):
        self.name = name
        self.settings = dict(settings)

    def run(self, world: WorldView) -> str:
        """Execute the skill."""
        raise NotImplementedError


class LookToShelf(PredefinedSkill):
    """Open the gripper and raise the hand to look ahead (thesis: look at the shelf before picking)."""

    def run(self, world: WorldView) -> str:
        """Open the gripper, then move to the look posture."""
        motion = world.motion
        motion.execution.phase("open gripper", 0.2)
        motion.gripper(world.config.gripper.open_width)
        motion.execution.phase("look posture", 0.8)
        motion.move_joints(world.config.postures["look"])
        return "looking at the shelf, gripper open"


class PickItem(PredefinedSkill):
    """Pick the configured product from the table: approach from above, grasp, lift, tuck the arm in."""

    def run(self, world: WorldView) -> str:
        """Pick the product; succeed only when it is held above the table."""
        product = self.settings.get("product")
        if not product:
            raise SkillError(f"{self.name} has no product configured")
        motion, grasp = world.motion, world.config.grasp
        if not world.on_table(product):
            raise SkillError(f"{product} is not on the table")
        held, _ = world.held_product()
        if held is not None:
            raise SkillError(f"the gripper already holds {held}")
        box = world.product_box(product)
        centre = world_to_base(motion.robot.base_pose(), box.position)
        orientation = world.top_down(box.yaw)
        grasp_point = centre + up(grasp.height_above_center)
        expected = across_fingers(box.size, grasp.yaw)
        motion.execution.phase("open gripper", 0.1)
        motion.gripper(world.config.gripper.open_width)
        motion.execution.phase("approach", 0.25)
        motion.move_to_pose(grasp_point + up(grasp.approach_height), orientation)
        motion.execution.phase("descend", 0.15)
        motion.move_linear(grasp_point, orientation)
        motion.execution.phase("grasp", 0.1)
        grasped, width, said = motion.grasp(expected)
        if not grasped:
            raise SkillError(f"the grasp of {product} ({1000.0 * expected:.0f} mm wide) failed: {said}")
        motion.execution.phase("lift", 0.15)
        motion.move_linear(grasp_point + up(grasp.lift_height), orientation)
        motion.execution.phase("carry posture", 0.25)
        motion.move_joints(world.config.postures["carry"])
        held, distance = world.product_in_hand()
        if held != product:
            raise SkillError(
                f"{product} is not in the gripper after grasping (finger opening {width:.3f} m, "
                f"nearest product {distance:.3f} m from the fingers)"
            )
        return f"{product} picked ({1000.0 * distance:.1f} mm from its place between the fingers)"


class MoveBase(PredefinedSkill):
    """Tuck the arm in and drive the base to the configured pose of the scene."""

    def run(self, world: WorldView) -> str:
        """Drive; succeed when TF puts base_link at the pose."""
        name = self.settings.get("base_pose", "")
        if name not in world.site.base_poses:
            raise SkillError(f"{self.name}: unknown base pose '{name}' (the site has {sorted(world.site.base_poses)})")
        target = world.site.base_poses[name]
        motion = world.motion
        carry = np.asarray(world.config.postures["carry"])
        motion.execution.phase("carry posture", 0.2)
        if np.abs(motion.robot.joint_positions() - carry).max() > POSTURE_TOLERANCE:
            motion.move_joints(carry)
        motion.execution.phase(f"drive to {name}", 0.8)
        motion.move_base(target.x, target.y, target.yaw)
        return f"base at {name} ({target.x:.2f}, {target.y:.2f}, {target.yaw:.2f})"


class PlaceItem(PredefinedSkill):
    """Slide the held product straight into the configured gap, just above the board, and set it down (still held)."""

    def run(self, world: WorldView) -> str:
        """Place; succeed when the held product stands upright in the gap."""
        motion, place = world.motion, world.config.place
        try:
            gap = world.gap(self.settings.get("gap", ""))
        except SkillError as error:
            raise SkillError(f"{self.name}: {error}") from None
        product, _ = world.product_in_hand()
        if product is None:
            raise SkillError("no product in the gripper to place")
        before = motion.robot.product_positions()
        base_pose = motion.robot.base_pose()
        tcp_position, tcp_rotation = motion.tcp_world()
        in_hand = tcp_rotation.inv().apply(world.product_position(product) - tcp_position)
        orientation = world.top_down(gap.yaw)
        placed = world_to_base(base_pose, gap.position) - orientation.apply(in_hand)
        direction = world.into_shelf(gap)
        inserted = placed + up(place.clearance)
        motion.execution.phase("approach the gap", 0.4)
        motion.move_to_pose(inserted - place.approach_distance * direction, orientation)
        motion.execution.phase("insert", 0.4)
        motion.move_linear(inserted, orientation)
        motion.execution.phase("set down", 0.2)
        motion.move_linear(placed, orientation)
        result = world.placement(product, before, gap.name)
        problems = result.problems(gap.name)
        if problems:
            raise SkillError("; ".join(problems))
        return f"{product} placed in {gap.name} ({1000.0 * result.distance_m:.1f} mm from its centre)"


class DropItem(PredefinedSkill):
    """Release the held product, pull the hand straight back out of the shelf and tuck the arm in."""

    def run(self, world: WorldView) -> str:
        """Release; succeed when the product stays upright in the gap and the hand is away from it."""
        product, _ = world.product_in_hand()
        if product is None:
            raise SkillError("no product in the gripper to drop")
        before = world.motion.robot.product_positions()
        result = release(world, product, before, progress=1.0)
        return f"released {product} on the shelf in {result.gap}, {1000.0 * result.distance_m:.1f} mm from its centre"


def release(
    world: WorldView, product: str, before: Dict[str, np.ndarray], progress: float, only_in_gap: bool = False
) -> Placement:
    """Let the product go, pull the hand clear of it and out of the shelf, tuck the arm in, and judge the placement.

    The gripper opens, the hand lifts clear of the product, pulls straight back and tucks in. The product is judged
    against the gap nearest to the hand when it lets go: the one it was being put into.

    Args:
        world: the running skill's view of the world.
        product: the product in the hand.
        before: every product's position [m] before it was placed (for the neighbours).
        progress: the share of the skill's progress these four phases take.
        only_in_gap: keep the product in the hand unless it already stands in the gap (a placement that missed
            must not drop it in front of the shelf).

    Raises:
        SkillError: the product is still held, or does not stand upright in a gap, or pushed a neighbour.
    """
    motion, place = world.motion, world.config.place
    gap = world.gap_near_hand()
    if only_in_gap:
        held = world.placement(product, before, gap.name)
        if held.gap is None:
            raise SkillError(f"{held.problems(gap.name)[0]}; it is still in the hand")
    motion.execution.phase("release", 0.2 * progress)
    motion.gripper(world.config.gripper.release_width)
    tcp, orientation = motion.tcp_pose()
    motion.execution.phase("lift", 0.15 * progress)
    lifted = tcp + up(place.release_lift)
    motion.move_linear(lifted, orientation)
    motion.execution.phase("retreat", 0.3 * progress)
    motion.move_linear(lifted - place.retreat_distance * world.into_shelf(gap), orientation)
    motion.execution.phase("carry posture", 0.35 * progress)
    motion.move_joints(world.config.postures["carry"])
    if world.held_product()[0] == product:
        raise SkillError(f"{product} is still in the gripper after releasing it")
    result = world.placement(product, before, gap.name)
    problems = result.problems(gap.name)
    if problems:
        raise SkillError("; ".join(problems))
    return result


class Idle(PredefinedSkill):
    """Hold the arm where it is (the tree's last leaf: nothing left to do)."""

    def run(self, world: WorldView) -> str:
        """Hold the current posture."""
        world.motion.execution.phase("idle", 1.0)
        world.motion.hold()
        return "idle: holding the arm"


class ProductInHand(PredefinedSkill):
    """Condition: the gripper holds a product (``product`` setting: that one), judged like the placing skills do."""

    moves = False

    def run(self, world: WorldView) -> str:
        """Succeed when a product is held; the failure says what the hand has."""
        held, distance = world.product_in_hand()
        wanted = self.settings.get("product")
        if held is not None and (not wanted or held == wanted):
            return f"{held} is in the hand ({1000.0 * distance:.1f} mm from its place between the fingers)"
        nearest, distance = world.nearest_to_hold()
        seen = f"{nearest} is {100.0 * distance:.1f} cm from the hand's hold" if nearest else "no product in the scene"
        opening = 1000.0 * world.motion.robot.gripper_width()
        what = f"{wanted} is not" if wanted else "no product is"
        raise SkillError(f"{what} in the hand ({seen}, the gripper {opening:.0f} mm open)")


class ProductInGap(PredefinedSkill):
    """Condition: a product stands upright in the ``gap`` setting's gap of the shelf (the placement judge's view)."""

    moves = False

    def run(self, world: WorldView) -> str:
        """Succeed when some product is in the gap; the failure names the nearest one."""
        gap = self.settings.get("gap", "")
        try:
            world.gap(gap)
        except SkillError as error:
            raise SkillError(f"{self.name}: {error}") from None
        now = world.motion.robot.product_positions()
        placements = [world.placement(product, now, gap) for product in now]
        inside = [result for result in placements if not result.problems(gap)]
        if inside:
            return f"{inside[0].product} stands in {gap}"
        if not placements:
            raise SkillError(f"no product in {gap}: the scene reports no products")
        nearest = min(placements, key=lambda result: result.distance_m)  # distances from this gap's target
        raise SkillError(f"no product in {gap} (nearest: {nearest.problems(gap)[0]})")


SKILL_CLASSES = {
    "LookToShelf": LookToShelf,
    "PickItem": PickItem,
    "MoveBase": MoveBase,
    "PlaceItem": PlaceItem,
    "DropItem": DropItem,
    "MoveBaseToStart": MoveBase,
    "LookToShelfAgain": LookToShelf,
    "PickItem2": PickItem,
    "MoveBase2": MoveBase,
    "Idle": Idle,
    "ProductInHand": ProductInHand,
    "ProductInGap": ProductInGap,
}


def create_skills(config: MotionConfig) -> Dict[str, PredefinedSkill]:
    """The predefined skills by name, each with its settings from the motion configuration."""
    return {name: SKILL_CLASSES[name](name, config.skills.get(name, {})) for name in (*PREDEFINED_SKILLS, *CONDITIONS)}
