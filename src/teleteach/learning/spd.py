"""The manifold of symmetric positive definite (SPD) matrices with the affine-invariant metric.

Stiffness matrices live here. The maps follow Abu-Dakka & Kyrki, "Geometry-aware dynamic movement primitives"
(ICRA 2020), which the thesis' Appendix C (eqs C.6-C.7) uses:

- logarithmic map  Log_X(Y) = X^1/2 logm(X^-1/2 Y X^-1/2) X^1/2,
- exponential map  Exp_X(U) = X^1/2 expm(X^-1/2 U X^-1/2) X^1/2,
- distance         d(X, Y) = ||logm(X^-1/2 Y X^-1/2)||_F,
- parallel transport along the geodesic from X to Y: B_X->Y(U) = E U E^T with E = (Y X^-1)^1/2,
- Mandel vectorisation (diagonal, then sqrt(2) times the upper triangle), which keeps the Frobenius inner product.

Every function takes one matrix (m, m) or a stack (..., m, m) and broadcasts. All matrix functions are computed
once, here, from symmetric eigendecompositions (LAPACK ``syevd`` through ``numpy.linalg.eigh``, which batches
stacks; ``scipy.linalg.eigh`` is the same routine one matrix at a time). :func:`exp_map` returns B B^T with B
invertible, so its result is SPD by construction.
"""

import functools

import numpy as np

EIGENVALUE_FLOOR = 1e-300
"""Smallest eigenvalue accepted inside ``log`` (rounding can push a true 1e-17 to 0 when the condition number of
the congruence X^-1/2 Y X^-1/2 reaches 1e16, i.e. for two matrices of condition number 1e8 in different axes)."""


class SPDError(ValueError):
    """A matrix is not symmetric positive definite (or not finite); the message names the sample."""


def symmetric(matrices):
    """The symmetric part (A + A^T) / 2, removing rounding asymmetry."""
    matrices = np.asarray(matrices, dtype=float)
    return 0.5 * (matrices + matrices.swapaxes(-1, -2))


def check_spd(matrices, what: str = "matrix", tolerance: float = 1e-6):
    """Return ``matrices`` as a float array, or raise :class:`SPDError` naming the first bad sample.

    Args:
        matrices: (m, m) or (n, m, m).
        what: the name used in the error message.
        tolerance: accepted asymmetry relative to the largest entry.
    """
    array = np.asarray(matrices, dtype=float)
    if array.ndim < 2 or array.shape[-1] != array.shape[-2] or array.shape[-1] < 1:
        raise SPDError(f"{what} must be square matrices, got shape {array.shape}")
    stack = array.reshape((-1, *array.shape[-2:]))
    bad = np.flatnonzero(~np.isfinite(stack).all(axis=(1, 2)))
    if bad.size:
        raise SPDError(f"{what} sample {bad[0]} is not finite")
    scale = 1.0 + np.abs(stack).max(axis=(1, 2))
    bad = np.flatnonzero(np.abs(stack - np.swapaxes(stack, 1, 2)).max(axis=(1, 2)) > tolerance * scale)
    if bad.size:
        raise SPDError(f"{what} sample {bad[0]} is not symmetric")
    smallest = np.linalg.eigvalsh(symmetric(stack))[:, 0]
    bad = np.flatnonzero(~(smallest > 0.0))
    if bad.size:
        raise SPDError(f"{what} sample {bad[0]} is not positive definite (smallest eigenvalue {smallest[bad[0]]:.3g})")
    return array


def spectral_function(matrices, function):
    """f(A) = V f(w) V^T for symmetric A = V diag(w) V^T: the one place where matrix functions are evaluated.

    Like every eigendecomposition here, it reads the lower triangle only (LAPACK), i.e. it acts on the symmetric
    matrix that the lower triangle defines.
    """
    eigenvalues, vectors = np.linalg.eigh(matrices)
    return (vectors * function(eigenvalues)[..., None, :]) @ vectors.swapaxes(-1, -2)


def roots(matrices):
    """(X^1/2, X^-1/2) of SPD matrices from one eigendecomposition."""
    eigenvalues, vectors = np.linalg.eigh(matrices)
    root = np.sqrt(eigenvalues)
    transposed = vectors.swapaxes(-1, -2)
    return (vectors * root[..., None, :]) @ transposed, (vectors / root[..., None, :]) @ transposed


def _safe_log(eigenvalues):
    return np.log(np.maximum(eigenvalues, EIGENVALUE_FLOOR))


class Frame:
    """A base point X (or a stack) with X^1/2 and X^-1/2 computed once: the maps at X, written once.

    The public functions below are one-liners on a Frame; a DMP step builds one Frame per state and reuses it.
    """

    def __init__(self, base):
        self.root, self.inverse_root = roots(base)

    def congruence(self, matrices):
        """X^-1/2 A X^-1/2 (its lower triangle is what the eigendecompositions read)."""
        return self.inverse_root @ matrices @ self.inverse_root

    def log(self, point):
        """Log_X(Y)."""
        return symmetric(self.root @ spectral_function(self.congruence(point), _safe_log) @ self.root)

    def exp(self, tangent):
        """The exponential map at X as B B^T, B = X^1/2 V diag(e^(w/2)): SPD by construction."""
        eigenvalues, vectors = np.linalg.eigh(self.congruence(tangent))
        factor = self.root @ (vectors * np.exp(0.5 * np.minimum(np.maximum(eigenvalues, -700.0), 700.0))[..., None, :])
        return factor @ factor.swapaxes(-1, -2)

    def transport_factors(self, end):
        """(E, E^-1) with E = (Y X^-1)^1/2 = X^1/2 C^1/2 X^-1/2, C = X^-1/2 Y X^-1/2.

        B_X->Y(U) = E U E^T and B_Y->X(V) = E^-1 V E^-T, from one eigendecomposition.
        """
        eigenvalues, vectors = np.linalg.eigh(self.congruence(end))
        transposed = vectors.swapaxes(-1, -2)
        root = np.sqrt(np.maximum(eigenvalues, EIGENVALUE_FLOOR))[..., None, :]
        forward = self.root @ (vectors * root) @ transposed @ self.inverse_root
        backward = self.root @ (vectors / root) @ transposed @ self.inverse_root
        return forward, backward


def congruent(factor, tangent):
    """E U E^T (symmetrised): how a transport factor acts on a tangent vector."""
    return symmetric(factor @ tangent @ factor.swapaxes(-1, -2))


def log_map(base, point):
    """Log_X(Y): the tangent vector (symmetric matrix) at X pointing along the geodesic to Y, of length d(X, Y)."""
    return Frame(base).log(point)


def exp_map(base, tangent):
    """Exp_X(U): the point reached from X along the geodesic with initial velocity U in unit time (SPD)."""
    return Frame(base).exp(tangent)


def distance(first, second):
    """Affine-invariant Riemannian distance d(X, Y) = ||logm(X^-1/2 Y X^-1/2)||_F (dimensionless)."""
    eigenvalues = np.linalg.eigvalsh(Frame(first).congruence(second))
    return np.sqrt(np.sum(_safe_log(eigenvalues) ** 2, axis=-1))


def parallel_transport(start, end, tangent):
    """B_X->Y(U): move the tangent vector U at X to Y along their geodesic, keeping inner products."""
    forward, _ = Frame(start).transport_factors(end)
    return congruent(forward, tangent)


def inner_product(base, first, second):
    """<U, V>_X = tr(X^-1 U X^-1 V), the affine-invariant metric at X."""
    inverse = np.linalg.inv(base)
    return np.trace(inverse @ first @ inverse @ second, axis1=-2, axis2=-1)


def geodesic(first, second, fraction):
    """The point a ``fraction`` (0..1, broadcast) of the way along the geodesic from X to Y."""
    fraction = np.asarray(fraction, dtype=float)[..., None, None]
    return exp_map(first, fraction * log_map(first, second))


@functools.lru_cache(maxsize=None)
def _mandel_layout(size):
    """Index arrays of the Mandel layout of m x m matrices: (rows, columns, slot of each entry, scale of each entry)."""
    rows, columns = np.triu_indices(size, 1)
    rows = np.concatenate([np.arange(size), rows])
    columns = np.concatenate([np.arange(size), columns])
    slots = np.empty((size, size), dtype=int)
    slots[rows, columns] = np.arange(rows.size)
    slots[columns, rows] = np.arange(rows.size)
    scale = np.where(rows == columns, 1.0, np.sqrt(2.0))
    return rows, columns, slots, scale


def mandel(matrices):
    """Mandel vector of symmetric matrices: (a11, ..., amm, sqrt2 a12, sqrt2 a13, ..., sqrt2 a(m-1)m)."""
    matrices = np.asarray(matrices, dtype=float)
    rows, columns, _, scale = _mandel_layout(matrices.shape[-1])
    return matrices[..., rows, columns] * scale


def mandel_size(dimension: int) -> int:
    """Matrix size m of a Mandel vector of length m (m + 1) / 2."""
    size = int(round((np.sqrt(8 * dimension + 1) - 1) / 2))
    if size * (size + 1) // 2 != dimension:
        raise ValueError(f"{dimension} is not the length of a Mandel vector (m (m + 1) / 2)")
    return size


def unmandel(vectors):
    """Symmetric matrices from Mandel vectors (inverse of :func:`mandel`)."""
    vectors = np.asarray(vectors, dtype=float)
    _, _, slots, scale = _mandel_layout(mandel_size(vectors.shape[-1]))
    return vectors[..., slots] / scale[slots]


def karcher_mean(matrices, tolerance: float = 1e-10, max_iterations: int = 50):
    """Fréchet (Karcher) mean of SPD matrices under the affine-invariant metric, by Riemannian gradient descent.

    Starts from the log-Euclidean mean; each step moves to Exp_M(mean_k Log_M(X_k)).
    """
    matrices = np.asarray(matrices, dtype=float)
    mean = spectral_function(np.mean(spectral_function(matrices, _safe_log), axis=0), np.exp)
    for _ in range(max_iterations):
        step = np.mean(log_map(mean, matrices), axis=0)
        mean = exp_map(mean, step)
        if np.sqrt(inner_product(mean, step, step)) < tolerance:
            break
    return mean
