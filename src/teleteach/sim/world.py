"""The pybullet world: the supermarket scene, and the Panda on a kinematic mobile base.

Physics runs at 1 kHz. The arm takes either joint torques or joint position targets (pybullet's motors); the fingers are
position-controlled and coupled like the Franka Hand's (one drive, both fingers symmetric); the base is moved
kinematically toward a goal at a capped speed. A product is held by the fingers through contact and friction alone, with
the force of the grasp command: pushed hard enough it slips or turns in the hand (the finger pads' friction is in
config/controllers.yaml). Only the base's kinematic drive needs help: it moves the arm by resetting its pose, which
friction cannot follow, so whatever both fingers touch is carried by the same rigid motion (a real base accelerates at
under 1 m/s^2, far less than a grip that holds the product's weight).
"""

import math

import numpy as np
import pybullet
import pybullet_data

from teleteach.control import panda
from teleteach.control.impedance import JointCommand, RobotState
from teleteach.core.rotations import unyawed_quaternion, wrap_angle, yaw_matrix, yaw_quaternion
from teleteach.core.scene import BasePose, Scene, Surface, WipingTool

BASE_LINK_COLOUR = (0.25, 0.25, 0.3, 1.0)
SHELF_COLOUR = (0.55, 0.4, 0.25, 1.0)
TABLE_COLOUR = (0.5, 0.5, 0.5, 1.0)
PRODUCT_COLOUR = (0.8, 0.2, 0.2, 1.0)
BOARD_COLOUR = (0.95, 0.95, 0.95, 1.0)
TOOL_COLOUR = (0.2, 0.3, 0.8, 1.0)
GRAVITY = 9.81  # [m/s^2]
CORNER_SEGMENTS = 4  # straight pieces per rounded corner of a product's outline
HULL_MARGIN = 0.001  # [m] pybullet's collision margin around a convex mesh
TOOL_JOINT_FORCE = 2000.0  # [N] the fixed joint holding a mounted tool (far above any wiping force)
_ORIGIN = [0.0, 0.0, 0.0]
_ZEROS9 = [0.0] * 9


def rounded_box_vertices(size, radius, segments=CORNER_SEGMENTS) -> np.ndarray:
    """Vertices of a box of size (x, y, z) [m] whose vertical edges are rounded with radius [m] (a convex hull).

    pybullet wraps a convex hull in a collision margin: the vertices lie that much inside, so that the product
    collides with its nominal size (and rests on a board at its nominal height).
    """
    half_x, half_y, half_z = (value / 2.0 - HULL_MARGIN for value in size)
    radius = max(radius - HULL_MARGIN, 0.0)
    outline = []
    for centre_x, centre_y, start in (
        (half_x - radius, half_y - radius, 0.0),
        (-half_x + radius, half_y - radius, 0.5 * math.pi),
        (-half_x + radius, -half_y + radius, math.pi),
        (half_x - radius, -half_y + radius, 1.5 * math.pi),
    ):
        for angle in np.linspace(start, start + 0.5 * math.pi, segments + 1):
            outline.append((centre_x + radius * math.cos(angle), centre_y + radius * math.sin(angle)))
    return np.array([(x, y, z) for z in (-half_z, half_z) for x, y in outline])


class SupermarketWorld:
    """The simulated world.

    Args:
        scene: the scene description (teleteach.core.scene.load_scene()).
        gui: open pybullet's own window instead of running headless (DIRECT).
        time_step: physics step [s].
        position_gain: pybullet motor position gain of the position-controlled arm [-].
        velocity_gain: pybullet motor velocity gain [-].
        finger_force: force of each finger [N] when a command gives none.
        finger_speed: opening-width rate [m/s] (each finger half of it) when a command gives none.
        base_speed: maximum linear speed of the mobile base [m/s].
        base_turn_rate: maximum yaw rate of the mobile base [rad/s].
        pad_friction: lateral friction coefficient of the finger pads [-] (pybullet multiplies it with the
            product's).
        pad_spinning_friction: torsional friction of the finger pads [m]: the torque a pad resists about its contact
            normal per newton of grip, times the product's friction.
        solver_residual_threshold: pybullet's contact solver stops iterating below this residual [-].
    """

    def __init__(
        self,
        scene: Scene,
        gui: bool,
        *,
        time_step: float,
        position_gain: float,
        velocity_gain: float,
        finger_force: float,
        finger_speed: float,
        base_speed: float,
        base_turn_rate: float,
        pad_friction: float,
        pad_spinning_friction: float,
        solver_residual_threshold: float,
    ):
        self.scene = scene
        self.time_step = time_step
        self.position_gain = position_gain
        self.velocity_gain = velocity_gain
        self.finger_force = finger_force
        self.finger_speed = finger_speed
        self.base_speed = base_speed
        self.base_turn_rate = base_turn_rate
        self._connect(gui, time_step, solver_residual_threshold)
        self._add_fixtures(scene)
        self._add_products(scene)
        self._add_robot(scene, pad_friction, pad_spinning_friction)
        self.tool = None
        self._arm_mode = None
        self._tcp_world = (0.0, 0.0, 0.0)
        self._pending_force = None
        self.ticks = 0
        self.time = 0.0

    def _connect(self, gui: bool, time_step: float, solver_residual_threshold: float) -> None:
        """Start this world's own pybullet server (a window or headless) with its gravity, step and contact solver."""
        self.client = pybullet.connect(pybullet.GUI if gui else pybullet.DIRECT)
        self._call = {"physicsClientId": self.client}
        pybullet.setGravity(0.0, 0.0, -GRAVITY, **self._call)
        pybullet.setTimeStep(time_step, **self._call)
        pybullet.setPhysicsEngineParameter(solverResidualThreshold=solver_residual_threshold, **self._call)

    def _add_fixtures(self, scene: Scene) -> None:
        """Add what never moves: the floor, the shelf, the pick table and the surfaces to wipe."""
        self.floor = pybullet.loadURDF(str(pybullet_data.getDataPath()) + "/plane.urdf", **self._call)
        pybullet.changeDynamics(self.floor, -1, lateralFriction=scene.floor_friction, **self._call)
        self.static_bodies = {
            part.name: self._add_box(part.center, part.size, 0.0, part.friction, SHELF_COLOUR, part.yaw)
            for part in scene.shelf
        }
        table = scene.pick_table
        self.static_bodies[table.name] = self._add_box(table.center, table.size, 0.0, table.friction, TABLE_COLOUR)
        for surface in scene.surfaces.values():
            self._add_surface(surface)

    def _add_products(self, scene: Scene) -> None:
        """Add the products on the shelf, keeping their bodies and sizes by name."""
        self.products = {
            product.name: self._add_box(
                product.position,
                product.size,
                product.mass,
                product.friction,
                PRODUCT_COLOUR,
                product.yaw,
                product.corner_radius,
            )
            for product in scene.products
        }
        self.product_sizes = {product.name: product.size for product in scene.products}

    def _add_robot(self, scene: Scene, pad_friction: float, pad_spinning_friction: float) -> None:
        """Add the mobile base at its start pose and the Panda on it, arm ready, gripper at its start width."""
        start = scene.base_poses["start"]
        self.base_pose = np.array([start.x, start.y, start.yaw])
        self.base_goal = self.base_pose.copy()
        self._driving = False
        size = scene.robot.base_size
        self.mobile_base = self._add_box((start.x, start.y, size[2] / 2.0), size, 0.0, 0.5, BASE_LINK_COLOUR)
        self.robot = panda.load_panda(self.client, *self._panda_base_pose())
        for finger in panda.FINGER_INDICES:
            pybullet.changeDynamics(
                self.robot, finger, lateralFriction=pad_friction, spinningFriction=pad_spinning_friction, **self._call
            )
        for index, value in zip(panda.ARM_INDICES, scene.robot.ready_joint_positions):
            pybullet.resetJointState(self.robot, index, value, **self._call)
        self.gripper_width = scene.robot.start_gripper_width
        for index in panda.FINGER_INDICES:
            pybullet.resetJointState(self.robot, index, self.gripper_width / 2.0, **self._call)
        self.set_gripper_width(self.gripper_width)

    def close(self):
        """Disconnect pybullet."""
        if self.client is not None:
            pybullet.disconnect(self.client)
            self.client = None

    def _add_box(self, center, size, mass, friction, colour, yaw=0.0, corner_radius=0.0):
        half = [value / 2.0 for value in size]
        if corner_radius > 0.0:
            vertices = rounded_box_vertices(size, corner_radius).tolist()
            shape = pybullet.createCollisionShape(pybullet.GEOM_MESH, vertices=vertices, **self._call)
        else:
            shape = pybullet.createCollisionShape(pybullet.GEOM_BOX, halfExtents=half, **self._call)
        visual = pybullet.createVisualShape(pybullet.GEOM_BOX, halfExtents=half, rgbaColor=colour, **self._call)
        body = pybullet.createMultiBody(mass, shape, visual, center, yaw_quaternion(yaw), **self._call)
        pybullet.changeDynamics(body, -1, lateralFriction=friction, **self._call)
        if mass > 0.0:
            # Resting products sleep from the start (a touch wakes them): a shelf of awake products costs many times
            # the physics time of the arm alone.
            pybullet.changeDynamics(body, -1, activationState=pybullet.ACTIVATION_STATE_ENABLE_SLEEPING, **self._call)
            pybullet.changeDynamics(body, -1, activationState=pybullet.ACTIVATION_STATE_SLEEP, **self._call)
        return body

    def _add_surface(self, surface: Surface):
        """The board (its top face at the surface's frame) on a stand from the floor to the board's lowest edge."""
        frame = surface.frame
        thickness = surface.size[2]
        centre = frame.apply_point([0.0, 0.0, -thickness / 2.0])
        half = [value / 2.0 for value in surface.size]
        shape = pybullet.createCollisionShape(pybullet.GEOM_BOX, halfExtents=half, **self._call)
        visual = pybullet.createVisualShape(pybullet.GEOM_BOX, halfExtents=half, rgbaColor=BOARD_COLOUR, **self._call)
        quaternion = frame.rotation.as_quat().tolist()
        board = pybullet.createMultiBody(0.0, shape, visual, centre.tolist(), quaternion, **self._call)
        pybullet.changeDynamics(board, -1, lateralFriction=surface.friction, **self._call)
        self.static_bodies[surface.name] = board
        corners = [frame.apply_point([su * half[0], sv * half[1], -thickness]) for su in (-1, 1) for sv in (-1, 1)]
        lowest = min(corner[2] for corner in corners)
        if lowest > 0.0:
            yaw = surface.rpy[2]
            footprint = [surface.size[0] * 0.8, surface.size[1] * 0.8, lowest]
            stand = self._add_box((centre[0], centre[1], lowest / 2.0), footprint, 0.0, 0.6, TABLE_COLOUR, yaw)
            self.static_bodies[surface.name + "_stand"] = stand

    def mount_tool(self, tool: WipingTool):
        """Mount the wiping tool in the hand: fixed to the TCP, its contact face ``tool.reach`` beyond it.

        The fingers close on it and a fixed joint holds it, as a tool changer would (a wiping load would make a
        friction grasp slip). Its weight is compensated as a Franka's configured end-effector load is.
        """
        if self.tool is not None:
            raise ValueError("a tool is mounted already")
        half = [value / 2.0 for value in tool.size]
        offset = [0.0, 0.0, tool.reach - half[2]]
        tcp = pybullet.getLinkState(self.robot, panda.TCP_LINK, computeForwardKinematics=True, **self._call)
        centre, orientation = pybullet.multiplyTransforms(tcp[4], tcp[5], offset, [0.0, 0.0, 0.0, 1.0])
        shape = pybullet.createCollisionShape(pybullet.GEOM_BOX, halfExtents=half, **self._call)
        visual = pybullet.createVisualShape(pybullet.GEOM_BOX, halfExtents=half, rgbaColor=TOOL_COLOUR, **self._call)
        body = pybullet.createMultiBody(tool.mass, shape, visual, centre, orientation, **self._call)
        pybullet.changeDynamics(
            body,
            -1,
            lateralFriction=tool.friction,
            contactStiffness=tool.contact_stiffness,
            contactDamping=tool.contact_damping,
            **self._call,
        )
        for link in range(-1, pybullet.getNumJoints(self.robot, **self._call)):
            pybullet.setCollisionFilterPair(self.robot, body, link, -1, 0, **self._call)
        joint = pybullet.createConstraint(
            self.robot, panda.TCP_LINK, body, -1, pybullet.JOINT_FIXED, _ORIGIN, offset, _ORIGIN, **self._call
        )
        pybullet.changeConstraint(joint, maxForce=TOOL_JOINT_FORCE, **self._call)
        self.tool = body
        self._tool_weight = [0.0, 0.0, tool.mass * GRAVITY]
        self._tool_face = [0.0, 0.0, half[2]]  # the contact face in the tool's frame
        self.set_gripper_width(tool.size[0])

    def tool_face(self):
        """The tool's contact face: its centre [m] and orientation (x, y, z, w) in world (z out of the face)."""
        position, orientation = pybullet.getBasePositionAndOrientation(self.tool, **self._call)
        return pybullet.multiplyTransforms(position, orientation, self._tool_face, [0.0, 0.0, 0.0, 1.0])

    # ----------------------------------------------------------------------------------------------- base frame
    def _panda_base_pose(self):
        x, y, yaw = self.base_pose
        return [x, y, self.scene.robot.mount_height], yaw_quaternion(yaw)

    def _rotation_base(self):
        return yaw_matrix(self.base_pose[2])

    # ---------------------------------------------------------------------------------------------------- state
    def _joint_lists(self):
        states = pybullet.getJointStates(self.robot, panda.MOVABLE_INDICES, **self._call)
        return [state[0] for state in states], [state[1] for state in states]

    def read_state(self) -> RobotState:
        """The arm's state in base_link (what a controller reads)."""
        call = self._call
        states = pybullet.getJointStates(self.robot, panda.MOVABLE_INDICES, **call)
        q9 = [state[0] for state in states]
        dq9 = [state[1] for state in states]
        link = pybullet.getLinkState(self.robot, panda.TCP_LINK, computeForwardKinematics=True, **call)
        world_position, world_orientation = link[4], link[5]
        self._tcp_world = world_position
        x, y, yaw = self.base_pose
        offset = (world_position[0] - x, world_position[1] - y, world_position[2])
        # pybullet expresses the Jacobian of a fixed-base body in its base frame: panda_link0, parallel to base_link
        linear, angular = pybullet.calculateJacobian(self.robot, panda.TCP_LINK, _ORIGIN, q9, dq9, _ZEROS9, **call)
        return RobotState(
            time=self.time,
            q=np.array(q9[:7]),
            dq=np.array(dq9[:7]),
            position=yaw_matrix(yaw).T @ offset,
            quaternion=unyawed_quaternion(world_orientation, yaw),
            jacobian=np.array(linear + angular)[:, :7],
            model_torque=np.array(pybullet.calculateInverseDynamics(self.robot, q9, dq9, _ZEROS9, **call)[:7]),
            mass_matrix=lambda: np.array(pybullet.calculateMassMatrix(self.robot, q9, **call))[:7, :7],
        )

    def joint_states(self):
        """Positions [rad, m], velocities and applied efforts of panda_joint1..7 and both fingers."""
        states = pybullet.getJointStates(self.robot, panda.MOVABLE_INDICES, **self._call)
        return [s[0] for s in states], [s[1] for s in states], [s[3] for s in states]

    def product_poses(self):
        """Name -> (position [m], quaternion (x, y, z, w)) in world."""
        poses = {}
        for name, body in self.products.items():
            position, quaternion = pybullet.getBasePositionAndOrientation(body, **self._call)
            poses[name] = (np.array(position), np.array(quaternion))
        return poses

    def external_wrench(self):
        """Contact wrench on the hand, fingers and held product: force [N] and torque [Nm] about the TCP.

        Summed from pybullet's contact points (the wrench the environment applies), in base_link.
        """
        force, torque = np.zeros(3), np.zeros(3)
        held = set(self._held_bodies()) | ({self.tool} if self.tool is not None else set())
        contacts = [
            contact
            for contact in pybullet.getContactPoints(bodyA=self.robot, **self._call)
            if contact[3] >= panda.HAND_LINK and contact[2] not in held
        ]
        for body in held:
            contacts += [
                contact for contact in pybullet.getContactPoints(bodyA=body, **self._call) if contact[2] != self.robot
            ]
        for contact in contacts:
            contact_force = (
                contact[9] * np.array(contact[7])
                + contact[10] * np.array(contact[11])
                + contact[12] * np.array(contact[13])
            )
            force += contact_force
            torque += np.cross(np.array(contact[5]) - np.array(self._tcp_world), contact_force)
        rotation = self._rotation_base().T
        return rotation @ force, rotation @ torque

    # ------------------------------------------------------------------------------------------------- commands
    def set_gripper_width(self, width, speed=None, force=None):
        """Drive the fingers toward width [m] (0 .. 0.08) at speed [m/s] of the width, force [N] per finger.

        speed and force default to finger_speed and finger_force. A product between the fingers stops them: they
        squeeze it.
        """
        self.gripper_width = float(np.clip(width, 0.0, panda.MAX_FINGER_WIDTH))
        for index in panda.FINGER_INDICES:
            pybullet.setJointMotorControl2(
                self.robot,
                index,
                pybullet.POSITION_CONTROL,
                targetPosition=self.gripper_width / 2.0,
                force=self.finger_force if force is None else float(force),
                maxVelocity=(self.finger_speed if speed is None else float(speed)) / 2.0,
                **self._call,
            )

    def finger_width(self):
        """The measured opening of both fingers together [m]."""
        states = pybullet.getJointStates(self.robot, panda.FINGER_INDICES, **self._call)
        return float(states[0][0] + states[1][0])

    @property
    def base_moving(self):
        """Whether the base is still driving toward its goal."""
        return self._driving

    def set_base_goal(self, x, y, yaw):
        """Drive the base to (x [m], y [m], yaw [rad]) in world."""
        self.base_goal = np.array([x, y, wrap_angle(yaw)])
        self._driving = True

    def stop_base(self):
        """Stop the base where it is (its goal becomes its pose)."""
        self.base_goal = self.base_pose.copy()
        self._driving = False

    def teleport_base(self, pose: BasePose):
        """Put the base at a pose at once (tests and set-up only; the base normally drives)."""
        self.base_goal = np.array([pose.x, pose.y, pose.yaw])
        self.base_pose = self.base_goal.copy()
        self._driving = False
        self._place_base()

    def apply_tcp_force(self, force):
        """Push the TCP with force [N] (base_link) during the next physics step."""
        self._pending_force = self._rotation_base() @ np.asarray(force, dtype=float)

    def _apply_arm(self, command: JointCommand):
        if command.effort is not None:
            if self._arm_mode != "effort":
                pybullet.setJointMotorControlArray(
                    self.robot, panda.ARM_INDICES, pybullet.VELOCITY_CONTROL, forces=[0.0] * 7, **self._call
                )
                self._arm_mode = "effort"
            pybullet.setJointMotorControlArray(
                self.robot, panda.ARM_INDICES, pybullet.TORQUE_CONTROL, forces=command.effort.tolist(), **self._call
            )
        else:
            self._arm_mode = "position"
            pybullet.setJointMotorControlArray(
                self.robot,
                panda.ARM_INDICES,
                pybullet.POSITION_CONTROL,
                targetPositions=command.position.tolist(),
                targetVelocities=command.velocity.tolist(),
                forces=panda.EFFORT_LIMITS.tolist(),
                positionGains=[self.position_gain] * 7,
                velocityGains=[self.velocity_gain] * 7,
                **self._call,
            )

    # ----------------------------------------------------------------------------------------------------- step
    def step(self, command):
        """Advance one time step; physics runs only while a command (a controller) holds the arm."""
        self.time += self.time_step
        self.ticks += 1
        self._drive_base()
        if command is None:
            self._pending_force = None
            return
        self._apply_arm(command)
        if self.tool is not None:
            position = pybullet.getBasePositionAndOrientation(self.tool, **self._call)[0]
            pybullet.applyExternalForce(self.tool, -1, self._tool_weight, position, pybullet.WORLD_FRAME, **self._call)
        if self._pending_force is not None:
            pybullet.applyExternalForce(
                self.robot,
                panda.TCP_LINK,
                self._pending_force.tolist(),
                list(self._tcp_world),
                pybullet.WORLD_FRAME,
                **self._call,
            )
            self._pending_force = None
        pybullet.stepSimulation(**self._call)

    def _drive_base(self):
        if not self._driving:
            return
        delta = self.base_goal - self.base_pose
        delta[2] = wrap_angle(delta[2])
        distance = math.hypot(delta[0], delta[1])
        max_step = self.base_speed * self.time_step
        if distance > max_step:
            delta[:2] *= max_step / distance
        max_turn = self.base_turn_rate * self.time_step
        delta[2] = max(-max_turn, min(max_turn, delta[2]))
        self.base_pose = self.base_pose + delta
        if distance <= max_step and abs(delta[2]) < max_turn:
            self.base_pose = self.base_goal.copy()
            self._driving = False
        self._place_base()

    def _place_base(self):
        carried = self._offsets_in_hand()
        x, y, yaw = self.base_pose
        height = self.scene.robot.base_size[2]
        pybullet.resetBasePositionAndOrientation(
            self.mobile_base, [x, y, height / 2.0], yaw_quaternion(yaw), **self._call
        )
        position, orientation = self._panda_base_pose()
        # pybullet places a base by its centre of mass, not by its URDF frame
        inertial = pybullet.getDynamicsInfo(self.robot, -1, **self._call)
        position, orientation = pybullet.multiplyTransforms(position, orientation, inertial[3], inertial[4])
        pybullet.resetBasePositionAndOrientation(self.robot, position, orientation, **self._call)
        if carried:
            hand = pybullet.getLinkState(self.robot, panda.HAND_LINK, computeForwardKinematics=True, **self._call)
            for body, (offset_position, offset_orientation) in carried.items():
                position, orientation = pybullet.multiplyTransforms(
                    hand[4], hand[5], offset_position, offset_orientation
                )
                pybullet.resetBasePositionAndOrientation(body, position, orientation, **self._call)

    # -------------------------------------------------------------------------------------------------- grasp
    def _held_bodies(self):
        """Product bodies that both fingers touch."""
        touching = [
            {contact[2] for contact in pybullet.getContactPoints(bodyA=self.robot, linkIndexA=finger, **self._call)}
            for finger in panda.FINGER_INDICES
        ]
        return [body for body in self.products.values() if body in touching[0] & touching[1]]

    @property
    def grasped(self):
        """The product both fingers touch (the one in the hand), or None."""
        held = self._held_bodies()
        names = {body: name for name, body in self.products.items()}
        return names[held[0]] if held else None

    def _offsets_in_hand(self):
        """Each held product's (and the mounted tool's) pose in the hand's frame (URDF link frame)."""
        bodies = self._held_bodies() + ([self.tool] if self.tool is not None else [])
        if not bodies:
            return {}
        hand = pybullet.getLinkState(self.robot, panda.HAND_LINK, computeForwardKinematics=True, **self._call)
        inverse_position, inverse_orientation = pybullet.invertTransform(hand[4], hand[5])
        offsets = {}
        for body in bodies:
            position, orientation = pybullet.getBasePositionAndOrientation(body, **self._call)
            offsets[body] = pybullet.multiplyTransforms(inverse_position, inverse_orientation, position, orientation)
        return offsets
