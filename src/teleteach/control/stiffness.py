"""The stiffness ellipsoid maths of the thesis (section II-C, eqs 1-7), in one place.

Translational stiffness from the principal stiffnesses and the orientation of the principal axes (eq 1, eq 2),
the full 6x6 stiffness (eq 3) with the rotated predefined rotational stiffness (eq 4), and two damping designs:
the thesis' eq 7 (which assumes a unit mass) and a mass-aware one that uses the Cartesian inertia.
"""

import numpy as np
from scipy.spatial.transform import Rotation

TRANSLATIONAL = slice(0, 3)
ROTATIONAL = slice(3, 6)
MAX_TRANSLATIONAL_INERTIA = 50.0  # [kg] cap of the Cartesian inertia near singularities (Panda: 1-10 kg elsewhere)
MAX_ROTATIONAL_INERTIA = 5.0  # [kg m^2] (Panda: 0.01-0.5 kg m^2 elsewhere)


def rotation_from_quaternion(quaternion):
    """Rotation matrix of a unit quaternion given as (x, y, z, w)."""
    return Rotation.from_quat(quaternion).as_matrix()


def clamp_eigenvalues(eigenvalues, max_stiffness):
    """Principal stiffnesses clamped per axis to [0, max_stiffness] [N/m]."""
    return np.clip(np.asarray(eigenvalues, dtype=float), 0.0, max_stiffness)


def translational_stiffness(eigenvalues, eigenvectors):
    """Eq 1: K_T = V Sigma V^T.

    Args:
        eigenvalues: the three principal stiffnesses Sigma [N/m].
        eigenvectors: V, a 3x3 rotation matrix (columns = principal axes), a quaternion (x, y, z, w) of
            R = Rz(psi) Ry(theta) Rx(phi) (eq 2), which is V, or a scipy Rotation.
    """
    rotation = as_rotation(eigenvectors)
    return rotation @ np.diag(np.asarray(eigenvalues, dtype=float)) @ rotation.T


def rotational_stiffness(eigenvectors, rotational_stiffness_diagonal):
    """Eq 4: K_R^new = V K_R V^T with the predefined diagonal rotational stiffness K_R [Nm/rad]."""
    rotation = as_rotation(eigenvectors)
    k_rot = np.broadcast_to(np.asarray(rotational_stiffness_diagonal, dtype=float), (3,))
    return rotation @ np.diag(k_rot) @ rotation.T


def stiffness_matrix(eigenvalues, eigenvectors, rotational_stiffness_diagonal):
    """Eq 3: the 6x6 stiffness, block diagonal of K_T^new (eq 1) and K_R^new (eq 4)."""
    stiffness = np.zeros((6, 6))
    stiffness[TRANSLATIONAL, TRANSLATIONAL] = translational_stiffness(eigenvalues, eigenvectors)
    stiffness[ROTATIONAL, ROTATIONAL] = rotational_stiffness(eigenvectors, rotational_stiffness_diagonal)
    return stiffness


def damping_unit_mass(stiffness, damping_ratios):
    """Eqs 6-7: D = 2 Q D_xi sqrt(K0) Q^T from the eigendecomposition K = Q K0 Q^T.

    The thesis' form: it renders the ratios in D_xi only for a unit mass (measured: 15-45 % overshoot on the Panda).
    The translational and rotational blocks are decomposed separately, so D_xi holds one ratio per block's principal
    axis.

    Args:
        stiffness: 6x6 block-diagonal symmetric positive semi-definite stiffness [N/m, Nm/rad].
        damping_ratios: six ratios (three translational, three rotational), or a scalar.
    """
    ratios = np.broadcast_to(np.asarray(damping_ratios, dtype=float), (6,))
    damping = np.zeros((6, 6))
    for block in (TRANSLATIONAL, ROTATIONAL):
        principal, axes = np.linalg.eigh(stiffness[block, block])
        root = np.sqrt(np.clip(principal, 0.0, None))
        damping[block, block] = 2.0 * (axes * (ratios[block] * root)) @ axes.T
    return damping


def damping_mass_aware(stiffness, cartesian_inertia_blocks, damping_ratios):
    """Damping that renders the ratios D_xi for the arm's real Cartesian inertia (double diagonalisation).

    Eq 7 with Q from the generalised eigenproblem K q = w Lambda q instead of K alone: Q Q^T = Lambda and
    Q W Q^T = K, so D = 2 Q D_xi sqrt(W) Q^T. With Lambda = I this is exactly eq 7.

    Args:
        stiffness: 6x6 block-diagonal stiffness [N/m, Nm/rad].
        cartesian_inertia_blocks: (Lambda_v, Lambda_w), the 3x3 translational [kg] and rotational [kg m^2]
            Cartesian inertia, each symmetric positive definite.
        damping_ratios: six ratios (three translational, three rotational), or a scalar.
    """
    ratios = np.broadcast_to(np.asarray(damping_ratios, dtype=float), (6,))
    damping = np.zeros((6, 6))
    for block, inertia in zip((TRANSLATIONAL, ROTATIONAL), cartesian_inertia_blocks):
        lower = np.linalg.cholesky(inertia)
        lower_inv = np.linalg.inv(lower)
        principal, axes = np.linalg.eigh(lower_inv @ stiffness[block, block] @ lower_inv.T)
        modes = lower @ axes
        root = np.sqrt(np.clip(principal, 0.0, None))
        damping[block, block] = 2.0 * (modes * (ratios[block] * root)) @ modes.T
    return damping


def cartesian_inertia_blocks(jacobian, mass_matrix, max_inertia=(MAX_TRANSLATIONAL_INERTIA, MAX_ROTATIONAL_INERTIA)):
    """Translational [kg] and rotational [kg m^2] blocks of the Cartesian inertia Lambda = (J M^-1 J^T)^-1.

    The blocks of the full 6x6 Lambda are the inertia felt along one kind of axis while the other kind is held
    (the impedance holds both); (J_v M^-1 J_v^T)^-1 would be the inertia with a free wrist, several times smaller.
    Near a singularity Lambda grows without bound along the lost direction; its principal values are capped at
    max_inertia so the damping built on it stays finite.
    """
    inverse_inertia = jacobian @ np.linalg.solve(mass_matrix, jacobian.T)
    principal, axes = np.linalg.eigh(inverse_inertia)
    inertia = (axes / np.maximum(principal, 1e-12)) @ axes.T
    blocks = []
    for block, cap in zip((TRANSLATIONAL, ROTATIONAL), max_inertia):
        values, vectors = np.linalg.eigh(inertia[block, block])
        blocks.append((vectors * np.minimum(values, cap)) @ vectors.T)
    return tuple(blocks)


def translational_stiffnesses(eigenvalues, eigenvectors) -> np.ndarray:
    """Eq 1 for a series: K_T = V Sigma V^T for each row, as an (N, 3, 3) array.

    Args:
        eigenvalues: (N, 3) principal stiffnesses [N/m].
        eigenvectors: the N V's: (N, 4) quaternions (x, y, z, w), (N, 3, 3) matrices or a scipy Rotation of N.
    """
    values = np.asarray(eigenvalues, dtype=float).reshape(-1, 3)
    if isinstance(eigenvectors, Rotation):
        rotations = eigenvectors.as_matrix().reshape(-1, 3, 3)
    else:
        rotations = np.asarray(eigenvectors, dtype=float)
        if rotations.ndim == 2 and rotations.shape[1:] == (4,):
            rotations = Rotation.from_quat(rotations).as_matrix().reshape(-1, 3, 3)
    if rotations.shape != (values.shape[0], 3, 3):
        raise ValueError(
            f"eigenvectors must be {values.shape[0]} quaternions (x, y, z, w) or 3x3 matrices, got shape "
            f"{np.shape(eigenvectors)}"
        )
    return rotations @ (values[:, :, None] * np.swapaxes(rotations, 1, 2))


def as_rotation(eigenvectors):
    """V as a 3x3 matrix from a quaternion (x, y, z, w), a 3x3 matrix or a scipy Rotation."""
    if isinstance(eigenvectors, Rotation):
        return eigenvectors.as_matrix()
    matrix = np.asarray(eigenvectors, dtype=float)
    if matrix.shape == (4,):
        return rotation_from_quaternion(matrix)
    if matrix.shape != (3, 3):
        raise ValueError(f"eigenvectors must be a quaternion (x, y, z, w) or a 3x3 matrix, got shape {matrix.shape}")
    return matrix
