"""The pybullet world: the supermarket scene, and the Panda on a kinematic mobile base.

Physics runs at 1 kHz. The arm takes either joint torques or joint position targets (pybullet's motors); the
fingers are position-controlled; the base is moved kinematically toward a goal at a capped speed. A grasp assist
fixes a product to the hand while both fingers squeeze it (the pybullet counterpart of Gazebo's grasp fix plugin
that Gazebo pick-and-place setups use), so products do not slip out while the base drives.
"""

import math

import numpy as np
import pybullet
import pybullet_data

from teleteach.control.impedance import JointCommand, RobotState
from teleteach.rotations import yaw_quaternion
from teleteach.sim import panda
from teleteach.sim.scene import BasePose, Scene

BASE_LINK_COLOUR = (0.25, 0.25, 0.3, 1.0)
SHELF_COLOUR = (0.55, 0.4, 0.25, 1.0)
TABLE_COLOUR = (0.5, 0.5, 0.5, 1.0)
PRODUCT_COLOUR = (0.8, 0.2, 0.2, 1.0)
_ORIGIN = [0.0, 0.0, 0.0]
_ZEROS9 = [0.0] * 9


class SupermarketWorld:
    """The simulated world.

    Args:
        scene: the scene description (teleteach.sim.scene.load_scene()).
        gui: open pybullet's own window instead of running headless (DIRECT).
        time_step: physics step [s].
        position_gain: pybullet motor position gain of the position-controlled arm [-].
        velocity_gain: pybullet motor velocity gain [-].
        finger_force: force of each finger [N] when a command gives none.
        finger_speed: opening-width rate [m/s] (each finger half of it) when a command gives none.
        base_speed: maximum linear speed of the mobile base [m/s].
        base_turn_rate: maximum yaw rate of the mobile base [rad/s].
        grasp_assist: fix a squeezed product to the hand.
        solver_residual_threshold: pybullet's contact solver stops iterating below this residual [-].
    """

    def __init__(
        self,
        scene: Scene,
        gui=False,
        time_step=0.001,
        position_gain=0.3,
        velocity_gain=1.0,
        finger_force=20.0,
        finger_speed=0.2,
        base_speed=0.5,
        base_turn_rate=1.0,
        grasp_assist=True,
        solver_residual_threshold=1e-4,
    ):
        self.scene = scene
        self.time_step = time_step
        self.position_gain = position_gain
        self.velocity_gain = velocity_gain
        self.finger_force = finger_force
        self.finger_speed = finger_speed
        self.base_speed = base_speed
        self.base_turn_rate = base_turn_rate
        self.grasp_assist = grasp_assist
        self.client = pybullet.connect(pybullet.GUI if gui else pybullet.DIRECT)
        self._call = {"physicsClientId": self.client}
        pybullet.setGravity(0.0, 0.0, -9.81, **self._call)
        pybullet.setTimeStep(time_step, **self._call)
        pybullet.setPhysicsEngineParameter(solverResidualThreshold=solver_residual_threshold, **self._call)
        self.floor = pybullet.loadURDF(str(pybullet_data.getDataPath()) + "/plane.urdf", **self._call)
        pybullet.changeDynamics(self.floor, -1, lateralFriction=scene.floor_friction, **self._call)
        self.static_bodies = {
            part.name: self._add_box(part.center, part.size, 0.0, part.friction, SHELF_COLOUR) for part in scene.shelf
        }
        table = scene.pick_table
        self.static_bodies[table.name] = self._add_box(table.center, table.size, 0.0, table.friction, TABLE_COLOUR)
        self.products = {
            product.name: self._add_box(
                product.position, product.size, product.mass, product.friction, PRODUCT_COLOUR, product.yaw
            )
            for product in scene.products
        }
        self.product_sizes = {product.name: product.size for product in scene.products}
        start = scene.base_poses["start"]
        self.base_pose = np.array([start.x, start.y, start.yaw])
        self.base_goal = self.base_pose.copy()
        self._driving = False
        size = scene.robot.base_size
        self.mobile_base = self._add_box((start.x, start.y, size[2] / 2.0), size, 0.0, 0.5, BASE_LINK_COLOUR)
        self.robot = panda.load_panda(self.client, *self._panda_base_pose())
        for index, value in zip(panda.ARM_INDICES, scene.robot.ready_joint_positions):
            pybullet.resetJointState(self.robot, index, value, **self._call)
        self.gripper_width = scene.robot.start_gripper_width
        for index in panda.FINGER_INDICES:
            pybullet.resetJointState(self.robot, index, self.gripper_width / 2.0, **self._call)
        self.set_gripper_width(self.gripper_width)
        self.grasped = None
        self._grasp_constraint = None
        self._arm_mode = None
        self._tcp_world = (0.0, 0.0, 0.0)
        self._pending_force = None
        self.ticks = 0
        self.time = 0.0

    def close(self):
        """Disconnect pybullet."""
        if self.client is not None:
            pybullet.disconnect(self.client)
            self.client = None

    def _add_box(self, center, size, mass, friction, colour, yaw=0.0):
        half = [value / 2.0 for value in size]
        shape = pybullet.createCollisionShape(pybullet.GEOM_BOX, halfExtents=half, **self._call)
        visual = pybullet.createVisualShape(pybullet.GEOM_BOX, halfExtents=half, rgbaColor=colour, **self._call)
        body = pybullet.createMultiBody(mass, shape, visual, center, yaw_quaternion(yaw), **self._call)
        pybullet.changeDynamics(body, -1, lateralFriction=friction, **self._call)
        if mass > 0.0:
            # Resting products sleep (a touch wakes them): a shelf full of awake boxes costs 3x the physics time.
            pybullet.changeDynamics(body, -1, activationState=pybullet.ACTIVATION_STATE_ENABLE_SLEEPING, **self._call)
        return body

    # ----------------------------------------------------------------------------------------------- base frame
    def _panda_base_pose(self):
        x, y, yaw = self.base_pose
        return [x, y, self.scene.robot.mount_height], yaw_quaternion(yaw)

    def base_to_world(self, position):
        """A point [m] in base_link expressed in world."""
        x, y, yaw = self.base_pose
        c, s = math.cos(yaw), math.sin(yaw)
        return np.array([x + c * position[0] - s * position[1], y + s * position[0] + c * position[1], position[2]])

    def _rotation_base(self):
        yaw = self.base_pose[2]
        c, s = math.cos(yaw), math.sin(yaw)
        return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])

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
        world_position, (qx, qy, qz, qw) = link[4], link[5]
        self._tcp_world = world_position
        x, y, yaw = self.base_pose
        c, s = math.cos(yaw), math.sin(yaw)
        dx, dy = world_position[0] - x, world_position[1] - y
        # conj(yaw) * q: the orientation in base_link
        hs, hc = math.sin(-yaw / 2.0), math.cos(-yaw / 2.0)
        # pybullet expresses the Jacobian of a fixed-base body in its base frame: panda_link0, parallel to base_link
        linear, angular = pybullet.calculateJacobian(self.robot, panda.TCP_LINK, _ORIGIN, q9, dq9, _ZEROS9, **call)
        return RobotState(
            time=self.time,
            q=np.array(q9[:7]),
            dq=np.array(dq9[:7]),
            position=np.array((c * dx + s * dy, -s * dx + c * dy, world_position[2])),
            quaternion=np.array((hc * qx - hs * qy, hc * qy + hs * qx, hc * qz + hs * qw, hc * qw - hs * qz)),
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
        contacts = [
            contact
            for contact in pybullet.getContactPoints(bodyA=self.robot, **self._call)
            if contact[3] >= panda.HAND_LINK and contact[2] != self.products.get(self.grasped)
        ]
        if self.grasped is not None:
            held = self.products[self.grasped]
            contacts += [
                contact for contact in pybullet.getContactPoints(bodyA=held, **self._call) if contact[2] != self.robot
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
        self.base_goal = np.array([x, y, math.atan2(math.sin(yaw), math.cos(yaw))])
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
        if self.grasp_assist and self.ticks % 10 == 0:
            self._update_grasp()
        pybullet.stepSimulation(**self._call)

    def _drive_base(self):
        if not self._driving:
            return
        delta = self.base_goal - self.base_pose
        delta[2] = math.atan2(math.sin(delta[2]), math.cos(delta[2]))
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
        if self._grasp_constraint is not None:
            # The held product moves with the hand (the constraint alone would lag behind a teleported arm).
            hand = pybullet.getLinkState(self.robot, panda.HAND_LINK, computeForwardKinematics=True, **self._call)
            offset_position, offset_orientation = self._grasp_offset
            position, orientation = pybullet.multiplyTransforms(hand[0], hand[1], offset_position, offset_orientation)
            pybullet.resetBasePositionAndOrientation(self.products[self.grasped], position, orientation, **self._call)

    def _update_grasp(self):
        if self.grasped is not None:
            if self.gripper_width > self._grasp_width + 0.005:
                pybullet.removeConstraint(self._grasp_constraint, **self._call)
                self.grasped, self._grasp_constraint = None, None
            return
        touching = []
        for finger in panda.FINGER_INDICES:
            bodies = {
                contact[2] for contact in pybullet.getContactPoints(bodyA=self.robot, linkIndexA=finger, **self._call)
            }
            touching.append(bodies)
        common = touching[0] & touching[1]
        for name, body in self.products.items():
            if body in common and self.gripper_width < min(self.product_sizes[name][:2]):
                self._attach(name, body)
                return

    def _attach(self, name, body):
        hand = pybullet.getLinkState(self.robot, panda.HAND_LINK, computeForwardKinematics=True, **self._call)
        product_position, product_orientation = pybullet.getBasePositionAndOrientation(body, **self._call)
        # Constraint frames are relative to the hand's centre of mass (hand[0], hand[1]).
        inverse_position, inverse_orientation = pybullet.invertTransform(hand[0], hand[1])
        self._grasp_offset = pybullet.multiplyTransforms(
            inverse_position, inverse_orientation, product_position, product_orientation
        )
        self._grasp_constraint = pybullet.createConstraint(
            self.robot,
            panda.HAND_LINK,
            body,
            -1,
            pybullet.JOINT_FIXED,
            [0.0, 0.0, 0.0],
            self._grasp_offset[0],
            [0.0, 0.0, 0.0],
            self._grasp_offset[1],
            [0.0, 0.0, 0.0, 1.0],
            **self._call,
        )
        pybullet.changeConstraint(self._grasp_constraint, maxForce=200.0, **self._call)
        self.grasped = name
        self._grasp_width = self.gripper_width
