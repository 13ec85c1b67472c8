"""Sets of orientations for reachability indices: spread over SO(3), or approach directions x rolls.

Every set is a float64 array `(K, 3, 3)` of rotation matrices (columns: the tool frame's axes in
the base frame). A target pose at node `p` with orientation `R` is `T = transl(p)·R` (the
standard convention).
"""

from __future__ import annotations

import numpy as np

from ..kinematics.transforms import as_real_array
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap._typing import ArrayLike

__all__ = ["MAX_ORIENTATIONS", "orientation_samples", "approach_orientations", "check_rotations", "rotation_angle",
           "continuation_order"]

# Super-Fibonacci spirals (Alexa, "Super-Fibonacci Spirals: Fast, Low-Discrepancy Sampling of SO(3)",
# CVPR 2022): the two irrational steps, sqrt(2) and the root psi of psi^4 = psi + 4
_PHI = np.sqrt(2.0)
_PSI = 1.533751168755204288118041


#: The most orientations a set may have: 100000 super-Fibonacci orientations lie a median 3.6° from
#: their nearest neighbour (22.8° at 1000, 7.6° at 20000), finer than any map needs, and every
#: orientation is one more IK solve per node; more is refused before anything is allocated.
MAX_ORIENTATIONS = 100_000


def _check_count(name, k, maximum: int | None = None):
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k <= 0:
        raise ValueError(f"{name} must be a positive integer, got {k!r}")
    if maximum is not None and k > maximum:
        raise ValueError(f"{name} must be at most {maximum} (neighbouring orientations are then 3.6° apart, and each "
                         f"one is another IK solve per node), got {k}")
    return int(k)


def _quat_to_matrix(q):
    """Unit quaternions (..., 4) as (w, x, y, z) → rotation matrices (..., 3, 3)."""
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], axis=-1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], axis=-1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=-1),
    ], axis=-2)


def _random_rotation(rng) -> np.ndarray:
    q = rng.standard_normal(4)
    return _quat_to_matrix(q / np.linalg.norm(q))


def orientation_samples(k: int, seed: int | None = 0) -> np.ndarray:
    """`k` rotations spread uniformly over SO(3): a super-Fibonacci spiral (Alexa 2022), `(k, 3, 3)`.

    Quaternion `i` of the spiral (`s = i + 1/2`) is `(√(s/k) sin α, √(s/k) cos α, √(1 − s/k) sin β,
    √(1 − s/k) cos β)` with `α = 2π s/√2`, `β = 2π s/ψ`: a low-discrepancy set on the unit
    quaternions, so its rotations cover SO(3) evenly with no clusters, for any `k` up to
    `MAX_ORIENTATIONS` (more is a `ValueError`). `seed`: the
    whole set is turned by one random rotation drawn from `numpy.random.default_rng(seed)` (every
    seed gives an equally even set; `None`: the spiral as it is).
    """
    k = _check_count("k (the number of orientations)", k, MAX_ORIENTATIONS)
    s = np.arange(k) + 0.5
    r, R = np.sqrt(s / k), np.sqrt(1.0 - s / k)
    a, b = 2 * np.pi * s / _PHI, 2 * np.pi * s / _PSI
    q = np.stack([r * np.sin(a), r * np.cos(a), R * np.sin(b), R * np.cos(b)], axis=-1)
    out = _quat_to_matrix(q / np.linalg.norm(q, axis=-1, keepdims=True))
    if seed is not None:
        out = _random_rotation(np.random.default_rng(seed)) @ out
    return out


def _fibonacci_sphere(n: int) -> np.ndarray:
    """`n` unit vectors spread evenly over the sphere (the golden-angle spiral), `(n, 3)`."""
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    phi = np.pi * (3.0 - np.sqrt(5.0)) * i
    rho = np.sqrt(1.0 - z * z)
    return np.stack([rho * np.cos(phi), rho * np.sin(phi), z], axis=-1)


def approach_orientations(directions: int, rolls: int = 1) -> np.ndarray:
    """Orientations whose tool z axis (the approach) points along `directions` directions spread
    over the sphere, each turned about that axis by `rolls` angles `2π j / rolls`: `(directions ·
    rolls, 3, 3)`, direction-major (Reuleaux's reachability spheres use this layout).

    The x axis at roll 0 is the world x (or y, for approaches near ±x) made perpendicular to the approach.
    """
    directions = _check_count("directions", directions)
    rolls = _check_count("rolls", rolls)
    z = _fibonacci_sphere(directions)
    ref = np.where(np.abs(z[:, :1]) < 0.9, np.array([[1.0, 0.0, 0.0]]), np.array([[0.0, 1.0, 0.0]]))
    x = ref - (ref * z).sum(axis=1, keepdims=True) * z
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    y = np.cross(z, x)
    base = np.stack([x, y, z], axis=-1)  # (D, 3, 3), columns x y z
    ang = 2 * np.pi * np.arange(rolls) / rolls
    c, s = np.cos(ang), np.sin(ang)
    Rz = np.zeros((rolls, 3, 3))
    Rz[:, 0, 0], Rz[:, 0, 1], Rz[:, 1, 0], Rz[:, 1, 1], Rz[:, 2, 2] = c, -s, s, c, 1.0
    return (base[:, None] @ Rz[None]).reshape(-1, 3, 3)


def check_rotations(name: str, R: ArrayLike, atol: float = 1e-6) -> np.ndarray:
    """`R` as float64 `(K, 3, 3)` (one `(3, 3)` becomes `K = 1`) after checking that it is a
    non-empty set of rotations: `RᵀR = I` and `det R = +1` to `atol`. Anything else is a
    `ValueError` naming `name` and the first offending index."""
    R = as_real_array(name, R)
    if R.shape == (3, 3):
        R = R[None]
    if R.ndim != 3 or R.shape[1:] != (3, 3):
        raise ValueError(f"{name} must have shape (K, 3, 3), got {R.shape}")
    if R.shape[0] == 0:
        raise ValueError(f"{name} is empty: give at least one orientation")
    if not np.all(np.isfinite(R)):
        raise ValueError(f"{name} contain NaN or infinite values")
    err = np.abs(np.swapaxes(R, 1, 2) @ R - np.eye(3)).max(axis=(1, 2))
    if np.any(err > atol):
        i = int(np.argmax(err > atol))
        raise ValueError(f"{name}[{i}] is not a rotation: RᵀR ≠ I (off by {err[i]:.3g}; shear or scale)")
    det = np.linalg.det(R)
    if np.any(np.abs(det - 1.0) > atol):
        i = int(np.argmax(np.abs(det - 1.0) > atol))
        raise ValueError(f"{name}[{i}] is not a rotation: det R = {det[i]:.3g} (a reflection)")
    return R


def rotation_angle(Ra, Rb) -> np.ndarray:
    """Angle (rad) of the rotation taking `Ra` to `Rb` (broadcast over leading dimensions)."""
    cos = 0.5 * (np.einsum("...ij,...ij->...", Ra, Rb) - 1.0)
    v = 0.5 * np.cross(Ra, Rb, axis=-2).sum(axis=-1)
    return np.arctan2(np.linalg.norm(v, axis=-1), cos)


#: Bytes of rotation_angle's temporaries per pair of orientations (its cross products and sums).
_ANGLE_BYTES = 160
#: The temporaries of one block of rows of `continuation_order`'s angles.
_BLOCK_BYTES = 64 * 2**20


def continuation_bytes(K: int) -> int:
    """Bytes `continuation_order` needs for `K` orientations: its `(K, K)` float64 angles and one
    block of rows' temporaries (counted by the index before any work: 80 GB at K = 100000)."""
    return 8 * K * K + min(_BLOCK_BYTES, _ANGLE_BYTES * K * K) + 64 * K


def continuation_order(R: ArrayLike) -> np.ndarray:
    """An order of the orientations `R` (K, 3, 3) in which each is close to one before it:
    greedy nearest neighbour from the first. Returns `(order (K,), parent (K,))`, `parent[i]`
    the earlier orientation (in the set's indexing) nearest to `order[i]` (-1 for the first)."""
    K = len(R)
    from .grids import check_fits

    check_fits(continuation_bytes(K), f"the continuation order of {K} orientations")
    # the K x K angles by blocks of rows: rotation_angle's (rows, K, 3, 3) temporaries stay near
    # _BLOCK_BYTES (the whole matrix at once took about 100 K^2 bytes: 1 TB at K = 100000)
    dist = np.empty((K, K))
    rows = max(1, _BLOCK_BYTES // (_ANGLE_BYTES * max(K, 1)))
    for i in range(0, K, rows):
        dist[i : i + rows] = rotation_angle(R[i : i + rows, None], R[None, :])
    order = [0]
    parent = [-1]
    left = np.ones(K, dtype=bool)
    left[0] = False
    best = dist[0].copy()
    near = np.zeros(K, dtype=np.int64)
    for _ in range(K - 1):
        cand = np.where(left, best, np.inf)
        j = int(np.argmin(cand))
        order.append(j)
        parent.append(int(near[j]))
        left[j] = False
        closer = dist[j] < best
        near = np.where(closer, j, near)
        best = np.minimum(best, dist[j])
    return np.array(order), np.array(parent)
