"""The Franka Panda of pybullet_data: joint names, indices and limits, and how to load it into a pybullet client."""

import pathlib

import numpy as np
import pybullet
import pybullet_data

PANDA_URDF = pathlib.Path(pybullet_data.getDataPath()) / "franka_panda" / "panda.urdf"

ARM_JOINTS = tuple(f"panda_joint{index}" for index in range(1, 8))
FINGER_JOINTS = ("panda_finger_joint1", "panda_finger_joint2")
ARM_INDICES = tuple(range(7))
FINGER_INDICES = (9, 10)
MOVABLE_INDICES = ARM_INDICES + FINGER_INDICES
HAND_LINK = 8  # panda_hand
TCP_LINK = 11  # panda_grasptarget: the tool centre point, 0.105 m along panda_hand's z
TCP_OFFSET = 0.105  # [m] from panda_hand to the TCP
LOWER_LIMITS = np.array([-2.9671, -1.8326, -2.9671, -3.1416, -2.9671, -0.0873, -2.9671])  # [rad]
UPPER_LIMITS = np.array([2.9671, 1.8326, 2.9671, 0.0, 2.9671, 3.8223, 2.9671])  # [rad]
EFFORT_LIMITS = np.array([87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0])  # [Nm]
MAX_FINGER_WIDTH = 0.08  # [m] both fingers together
FINGER_COUPLING_FORCE = 100.0  # [N] the gear between the fingers holds against up to this


def load_panda(client, base_position, base_orientation):
    """Load the Panda (fixed base at panda_link0's pose) and make its arm torque-controllable.

    The default velocity motors are switched off (a controller must hold the arm), link damping is removed so the
    impedance law alone shapes the dynamics. The fingers are geared to each other, as the Franka Hand's single drive
    moves both symmetrically (pybullet ignores the URDF's mimic joint): a grasp centres the product between them.
    """
    robot = pybullet.loadURDF(
        str(PANDA_URDF),
        base_position,
        base_orientation,
        useFixedBase=True,
        physicsClientId=client,
    )
    for index in range(pybullet.getNumJoints(robot, physicsClientId=client)):
        pybullet.changeDynamics(robot, index, linearDamping=0.0, angularDamping=0.0, physicsClientId=client)
    pybullet.setJointMotorControlArray(
        robot, ARM_INDICES, pybullet.VELOCITY_CONTROL, forces=[0.0] * 7, physicsClientId=client
    )
    coupling = pybullet.createConstraint(
        robot,
        FINGER_INDICES[0],
        robot,
        FINGER_INDICES[1],
        pybullet.JOINT_GEAR,
        [1.0, 0.0, 0.0],
        [0.0, 0.0, 0.0],
        [0.0, 0.0, 0.0],
        physicsClientId=client,
    )
    pybullet.changeConstraint(coupling, gearRatio=-1.0, erp=0.1, maxForce=FINGER_COUPLING_FORCE, physicsClientId=client)
    return robot
