"""Elementary rigid transforms and pose checks (float64, radians, metres).

Every function takes leading batch dimensions: `rotx(theta)` with `theta` of shape `(...)`
gives `(..., 3, 3)`. Homogeneous transforms are `(..., 4, 4)` with bottom row `[0, 0, 0, 1]`.
"""

from __future__ import annotations

import numpy as np
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap._typing import ArrayLike, NDArray

__all__ = ["rotx", "roty", "rotz", "rpy2r", "transl", "pose_error", "check_finite", "check_rigid"]


def rotx(theta: float | ArrayLike) -> NDArray[np.float64]:
    """Rotation about x by `theta` (rad); shape `theta.shape + (3, 3)`."""
    theta = np.asarray(theta, dtype=np.float64)
    c, s = np.cos(theta), np.sin(theta)
    o, z = np.ones_like(theta), np.zeros_like(theta)
    return np.stack([o, z, z, z, c, -s, z, s, c], axis=-1).reshape(theta.shape + (3, 3))


def roty(theta: float | ArrayLike) -> NDArray[np.float64]:
    """Rotation about y by `theta` (rad); shape `theta.shape + (3, 3)`."""
    theta = np.asarray(theta, dtype=np.float64)
    c, s = np.cos(theta), np.sin(theta)
    o, z = np.ones_like(theta), np.zeros_like(theta)
    return np.stack([c, z, s, z, o, z, -s, z, c], axis=-1).reshape(theta.shape + (3, 3))


def rotz(theta: float | ArrayLike) -> NDArray[np.float64]:
    """Rotation about z by `theta` (rad); shape `theta.shape + (3, 3)`."""
    theta = np.asarray(theta, dtype=np.float64)
    c, s = np.cos(theta), np.sin(theta)
    o, z = np.ones_like(theta), np.zeros_like(theta)
    return np.stack([c, -s, z, s, c, z, z, z, o], axis=-1).reshape(theta.shape + (3, 3))


def rpy2r(rpy: ArrayLike) -> NDArray[np.float64]:
    """The paper's orientation angles `(r1, r2, r3)` → `Rx(r1) · Ry(r2) · Rz(r3)`.

    `rpy` has shape `(..., 3)` (rad); the result has shape `(..., 3, 3)`.
    """
    rpy = np.asarray(rpy, dtype=np.float64)
    if rpy.shape[-1:] != (3,):
        raise ValueError(f"orientation angles must have a last dimension of 3, got shape {rpy.shape}")
    return rotx(rpy[..., 0]) @ roty(rpy[..., 1]) @ rotz(rpy[..., 2])


def transl(p: ArrayLike) -> NDArray[np.float64]:
    """Pure translation: `p` of shape `(..., 3)` → homogeneous transform `(..., 4, 4)`."""
    p = np.asarray(p, dtype=np.float64)
    T = np.zeros(p.shape[:-1] + (4, 4))
    T[..., :3, :3] = np.eye(3)
    T[..., :3, 3] = p
    T[..., 3, 3] = 1.0
    return T



def check_finite(name, x):
    """Raise `ValueError` naming `name` if `x` has a NaN or infinite entry (or is complex)."""
    if np.iscomplexobj(x):
        raise ValueError(f"{name} must be real numbers, got complex values")
    if not np.all(np.isfinite(x)):
        raise ValueError(f"{name} contains NaN or infinite values")


def as_real_array(name, x) -> np.ndarray:
    """`x` as a float64 array; complex or non-numeric input is a `ValueError` naming `name`."""
    if np.iscomplexobj(x):
        raise ValueError(f"{name} must be real numbers, got complex values")
    try:
        return np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError, OverflowError) as exc:
        raise ValueError(f"{name} must be real numbers: {exc}") from None


def check_rigid(name: str, T: ArrayLike, atol: float = 1e-6) -> np.ndarray:
    """`T` as float64 `(..., 4, 4)` after checking that every entry is a rigid transform.

    A rigid transform has a rotation block `R` with `RᵀR = I` and `det R = +1` (each to
    `atol`) and the bottom row `[0, 0, 0, 1]`. Anything else (shear, scale, reflection, a
    projective row) is a `ValueError` naming `name` and the first offending index.
    """
    T = as_real_array(name, T)
    if T.ndim < 2 or T.shape[-2:] != (4, 4):
        raise ValueError(f"{name} must have shape (..., 4, 4), got {T.shape}")
    check_finite(name, T)
    # RᵀR and det R written out over the columns: for many small matrices several times faster
    # than a batched matmul and LU determinants
    c = [[T[..., r, k] for r in range(3)] for k in range(3)]  # c[k][r] = R[r, k]
    ortho = np.ones(T.shape[:-2], dtype=bool)
    for k in range(3):
        for m in range(k, 3):
            dot = c[k][0] * c[m][0] + c[k][1] * c[m][1] + c[k][2] * c[m][2]
            ortho &= np.abs(dot - (1.0 if k == m else 0.0)) <= atol
    det = (c[0][0] * (c[1][1] * c[2][2] - c[1][2] * c[2][1]) - c[0][1] * (c[1][0] * c[2][2] - c[1][2] * c[2][0])
           + c[0][2] * (c[1][0] * c[2][1] - c[1][1] * c[2][0]))
    proper = np.abs(det - 1.0) <= atol
    bottom = ((np.abs(T[..., 3, 0]) <= atol) & (np.abs(T[..., 3, 1]) <= atol) & (np.abs(T[..., 3, 2]) <= atol)
              & (np.abs(T[..., 3, 3] - 1.0) <= atol))
    ok = ortho & proper & bottom
    if not np.all(ok):
        bad = np.argwhere(~np.atleast_1d(ok))[0]
        where = "" if T.ndim == 2 else f" (first at index {tuple(int(i) for i in bad)})"
        if not np.all(bottom):
            why = "its bottom row is not [0, 0, 0, 1]"
        elif not np.all(ortho):
            why = "its rotation block is not orthonormal (RᵀR ≠ I: shear or scale)"
        else:
            why = "its rotation block is a reflection (det R = -1)"
        raise ValueError(f"{name} is not a rigid transform{where}: {why}")
    return T


def pose_error(T_current: ArrayLike, T_target: ArrayLike) -> np.ndarray:
    """Differential motion from `T_current` to `T_target` in the base frame, `(..., 6)`.

    Translation difference, then `0.5 · Σ_k c_k × t_k` over the rotation columns (Corke's
    `tr2delta` for small motions); it is zero exactly when the poses are equal.
    """
    dp = T_target[..., :3, 3] - T_current[..., :3, 3]
    dw = 0.5 * np.cross(T_current[..., :3, :3], T_target[..., :3, :3], axis=-2).sum(axis=-1)
    return np.concatenate([dp, dw], axis=-1)
