"""Forward and inverse kinematics of the Panda in base_link, for anyone who plans arm motions (the skills).

It uses its own pybullet DIRECT client holding only the arm, mounted like on the mobile base, so it never disturbs
a running simulation. Poses are the TCP (panda_grasptarget, 0.105 m beyond panda_hand) in base_link.
"""

import numpy as np
import pybullet

from teleteach.control import panda
from teleteach.control.impedance import orientation_error
from teleteach.core.scene import load_site

DAMPING = 0.02  # damped least squares regularisation [m]
NULLSPACE_GAIN = 0.05  # pull toward the seed posture per iteration [-]
MAX_STEP = 0.2  # largest joint change per iteration [rad]


class IKError(RuntimeError):
    """No joint solution reaches the pose within the tolerance."""


class PandaKinematics:
    """FK / IK / Jacobian of the Panda TCP in base_link.

    Args:
        mount_height: panda_link0 above base_link [m]; default: the scene file's.
    """

    def __init__(self, mount_height=None):
        if mount_height is None:
            mount_height = load_site().robot.mount_height
        self.mount_height = float(mount_height)
        self._client = pybullet.connect(pybullet.DIRECT)
        self._robot = panda.load_panda(self._client, [0.0, 0.0, self.mount_height], [0.0, 0.0, 0.0, 1.0])

    def close(self):
        """Release the pybullet client."""
        if self._client is not None:
            pybullet.disconnect(self._client)
            self._client = None

    def _set(self, joint_positions):
        for index, value in zip(panda.ARM_INDICES, joint_positions):
            pybullet.resetJointState(self._robot, index, float(value), physicsClientId=self._client)

    def forward(self, joint_positions):
        """TCP pose for the seven arm joint positions [rad]: (position [m], quaternion (x, y, z, w))."""
        self._set(joint_positions)
        link = pybullet.getLinkState(
            self._robot, panda.TCP_LINK, computeForwardKinematics=True, physicsClientId=self._client
        )
        return np.array(link[4]), np.array(link[5])

    def jacobian(self, joint_positions):
        """6x7 geometric Jacobian of the TCP (linear rows first) in base_link."""
        joints = [*joint_positions, 0.0, 0.0]
        zeros = [0.0] * 9
        linear, angular = pybullet.calculateJacobian(
            self._robot, panda.TCP_LINK, [0.0, 0.0, 0.0], joints, zeros, zeros, physicsClientId=self._client
        )
        return np.vstack([np.array(linear)[:, :7], np.array(angular)[:, :7]])

    def inverse(self, position, quaternion, seed=None, tolerance=1e-4, max_iterations=300):
        """Joint positions [rad] that put the TCP at position [m] with orientation quaternion (x, y, z, w).

        Damped least squares on the TCP Jacobian from the seed (default: the ready posture), with a weak pull
        toward the seed in the nullspace so the redundancy stays near it; joint limits are respected.

        Raises:
            IKError: the pose is not reached within tolerance ([m] and [rad]).
        """
        seed = np.array(seed if seed is not None else load_site().robot.ready_joint_positions, dtype=float)
        target = np.asarray(position, dtype=float)
        joints = np.clip(seed, panda.LOWER_LIMITS, panda.UPPER_LIMITS)
        error = np.full(6, np.inf)
        for _ in range(max_iterations):
            reached_position, reached_quaternion = self.forward(joints)
            error = np.concatenate([target - reached_position, orientation_error(quaternion, reached_quaternion)])
            if np.all(np.abs(error[:3]) < tolerance) and np.all(np.abs(error[3:]) < tolerance):
                return joints
            jacobian = self.jacobian(joints)
            step = jacobian.T @ np.linalg.solve(jacobian @ jacobian.T + DAMPING**2 * np.eye(6), error)
            projector = np.eye(7) - np.linalg.pinv(jacobian) @ jacobian
            step += projector @ (NULLSPACE_GAIN * (seed - joints))
            scale = min(1.0, MAX_STEP / max(np.max(np.abs(step)), 1e-12))
            joints = np.clip(joints + scale * step, panda.LOWER_LIMITS, panda.UPPER_LIMITS)
        raise IKError(
            f"IK did not reach {target.tolist()} (error {np.linalg.norm(error[:3]):.4f} m, "
            f"{np.linalg.norm(error[3:]):.4f} rad) within {tolerance}"
        )
