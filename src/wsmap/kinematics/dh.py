"""Serial revolute arms in standard (distal) Denavit–Hartenberg form, batched over arms.

Conventions (as in Corke's Robotics Toolbox and the paper):

* link transform `A_i = Rz(q_i) · Tz(d_i) · Tx(a_i) · Rx(alpha_i)`, `T = A_1 ··· A_n · tool`;
* lengths in metres, angles in radians, float64 throughout;
* every array may carry leading batch dimensions, which broadcast against each other:
  a `DHRobot` whose `d` has shape `(B, 6)` is a batch of `B` arms, and `fkine(q)` with
  `q` of shape `(N, 1, 6)` gives poses of shape `(N, B, 4, 4)`.

Forward kinematics and Jacobians only; inverse kinematics is `wsmap.kinematics.ik`
(`ikine_LM` is the paper's).
"""

from __future__ import annotations

import numpy as np

from .arms import ArmBatch
from .transforms import as_real_array, check_finite, check_rigid
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap._typing import ArrayLike

__all__ = ["DHRobot", "arm_batch", "angle_in_range", "link_frames"]


class DHRobot(ArmBatch):
    """A serial arm (or a batch of arms) of revolute joints in standard DH form.

    Parameters
    ----------
    d, a, alpha : array_like, shape (..., n)
        Link offsets (m), link lengths (m) and twists (rad). Leading dimensions are a batch of
        arms and must broadcast against each other.
    qlim : array_like, shape (n, 2) or (..., n, 2), optional
        Joint limits `[lo, hi]` in radians. `None` (the paper's setting) means unlimited.
    tool : array_like, shape (4, 4), optional
        Fixed transform from the last link frame to the tool frame.
    name : str, optional
    """

    def __init__(self, d: ArrayLike, a: ArrayLike, alpha: ArrayLike, qlim: ArrayLike | None = None,
                 tool: ArrayLike | None = None, name: str | None = None):
        d, a, alpha = (as_real_array(f"DH column {k}", x) for k, x in (("d", d), ("a", a), ("alpha", alpha)))
        for label, x in (("d", d), ("a", a), ("alpha", alpha)):
            if x.ndim == 0:
                raise ValueError(f"DH column {label} must have at least one dimension (one entry per joint)")
            check_finite(f"DH column {label}", x)
        n = {d.shape[-1], a.shape[-1], alpha.shape[-1]}
        if len(n) != 1:
            raise ValueError(
                f"DH columns disagree on the number of joints: d {d.shape}, a {a.shape}, alpha {alpha.shape}"
            )
        try:
            shape = np.broadcast_shapes(d.shape, a.shape, alpha.shape)
        except ValueError:
            raise ValueError(
                f"DH columns have batch shapes that do not broadcast: d {d.shape}, a {a.shape}, alpha {alpha.shape}"
            ) from None
        self.d, self.a, self.alpha = (np.broadcast_to(x, shape) for x in (d, a, alpha))
        self.n = shape[-1]
        if qlim is not None:
            qlim = as_real_array("qlim", qlim)
            if qlim.shape[-2:] != (self.n, 2):
                raise ValueError(f"qlim must have shape (..., {self.n}, 2), got {qlim.shape}")
            if np.any(np.isnan(qlim)):
                raise ValueError("qlim contains NaN")
            if np.any(qlim[..., 0] > qlim[..., 1]):
                raise ValueError("qlim has a lower limit above its upper limit")
        self.qlim = qlim
        if tool is not None:
            tool = as_real_array("tool", tool)
            if tool.shape != (4, 4):
                raise ValueError(f"tool must be a 4x4 homogeneous transform, got shape {tool.shape}")
            check_rigid("tool", tool)
        self.tool = tool
        self.name = name

    # ---------------------------------------------------------------- shape and indexing
    @property
    def batch_shape(self) -> tuple[int, ...]:
        """Leading dimensions of the DH arrays: `()` for one arm."""
        return self.d.shape[:-1]

    def _select(self, idx) -> "DHRobot":
        qlim = self.qlim
        if qlim is not None and qlim.ndim > 2:
            qlim = qlim[idx]
        return DHRobot(self.d[idx], self.a[idx], self.alpha[idx], qlim=qlim, tool=self.tool, name=self.name)

    @property
    def dh(self) -> np.ndarray:
        """DH table `(..., n, 3)` with columns `[d, a, alpha]`."""
        return np.stack([self.d, self.a, self.alpha], axis=-1)

    def __repr__(self):
        name = f"{self.name!r}, " if self.name else ""
        return f"DHRobot({name}n={self.n}, batch_shape={self.batch_shape}, qlim={'yes' if self.qlim is not None else 'no'})"

    # ---------------------------------------------------------------- kinematics
    def link_frames(self, q: ArrayLike) -> np.ndarray:
        """Frames of every link: `(..., n + 1, 4, 4)`; index 0 is the base, n the flange (no tool)."""
        q = self._check_q(q)
        return link_frames(self.d, self.a, self.alpha, q)

    def fkine(self, q: ArrayLike) -> np.ndarray:
        """Forward kinematics: tool pose in the base frame, shape `(..., 4, 4)`."""
        T = self.link_frames(q)[..., -1, :, :]
        return T @ self.tool if self.tool is not None else T

    def jacob0(self, q: ArrayLike) -> np.ndarray:
        """Geometric Jacobian in the base frame, shape `(..., 6, n)`: rows `[v; omega]`."""
        q = self._check_q(q)
        return _jacob0(self.d, self.a, self.alpha, q, self.tool)[0]

    def within_limits(self, q: ArrayLike) -> np.ndarray:
        """True where every joint angle, up to a multiple of 2·pi, lies inside its limits.

        Without limits every configuration is within them. Shape: `q.shape[:-1]` broadcast with
        the limits' batch shape.
        """
        q = self._check_q(q)
        if self.qlim is None:
            return np.ones(q.shape[:-1], dtype=bool)
        return np.all(angle_in_range(q, self.qlim[..., 0], self.qlim[..., 1]), axis=-1)


def angle_in_range(q: ArrayLike, lo: ArrayLike, hi: ArrayLike) -> np.ndarray:
    """Whether a revolute joint angle lies inside its limits up to a whole number of turns.

    Parameters
    ----------
    q : array_like
        Joint angles (rad), any shape.
    lo, hi : array_like
        Lower and upper limits (rad), broadcastable against `q`; `lo <= hi`.

    Returns
    -------
    ndarray of bool
        The broadcast shape of `q`, `lo` and `hi`: True where some `q + 2·pi·k` (`k` an
        integer) lies in `[lo − 1e-12, hi + 1e-12]` (a slack on both sides, so that an angle
        on a limit is not lost to rounding, and limits moved by a whole turn hold the same
        angles); a range at least 2·pi wide holds every angle.
    """
    two_pi = 2.0 * np.pi
    # the smallest 2·pi-equivalent of q that is >= lo, and whether q sits just below lo
    r = np.mod(q - lo, two_pi)
    return (lo + r <= hi + 1e-12) | (r >= two_pi - 1e-12) | ((hi - lo) >= two_pi)


def link_frames(d: ArrayLike, a: ArrayLike, alpha: ArrayLike, q: ArrayLike) -> np.ndarray:
    """Every link frame of standard-DH arms, without checks (`DHRobot.link_frames` checks `q`).

    Parameters
    ----------
    d, a, alpha : ndarray, shape (..., n)
        DH offsets (m), lengths (m) and twists (rad).
    q : ndarray, shape (..., n)
        Joint angles (rad); leading dimensions broadcast against the DH arrays'.

    Returns
    -------
    ndarray, shape (..., n + 1, 4, 4)
        Frame `i` is `A_1 ··· A_i` in the base frame (`A_i = Rz(q_i) Tz(d_i) Tx(a_i) Rx(alpha_i)`):
        index 0 the base (identity), index n the flange (no tool).
    """
    shape = np.broadcast_shapes(d.shape, q.shape)
    n = shape[-1]
    ct, st = np.cos(q), np.sin(q)
    ca, sa = np.cos(alpha), np.sin(alpha)
    A = np.zeros(shape + (4, 4))
    # A_i = Rz(q) Tz(d) Tx(a) Rx(alpha), written out
    A[..., 0, 0] = ct
    A[..., 0, 1] = -st * ca
    A[..., 0, 2] = st * sa
    A[..., 0, 3] = a * ct
    A[..., 1, 0] = st
    A[..., 1, 1] = ct * ca
    A[..., 1, 2] = -ct * sa
    A[..., 1, 3] = a * st
    A[..., 2, 1] = sa
    A[..., 2, 2] = ca
    A[..., 2, 3] = d
    A[..., 3, 3] = 1.0
    frames = np.empty(shape[:-1] + (n + 1, 4, 4))
    frames[..., 0, :, :] = np.eye(4)
    for i in range(n):  # a loop over joints, not over arms or targets
        frames[..., i + 1, :, :] = frames[..., i, :, :] @ A[..., i, :, :]
    return frames


def _jacob0(d, a, alpha, q, tool):
    """Base-frame geometric Jacobian `(..., 6, n)` and the tool pose `(..., 4, 4)`."""
    frames = link_frames(d, a, alpha, q)
    T = frames[..., -1, :, :]
    if tool is not None:
        T = T @ tool
    z = frames[..., :-1, :3, 2]  # joint axes z_{i-1}, (..., n, 3)
    o = frames[..., :-1, :3, 3]  # joint origins, (..., n, 3)
    pe = T[..., None, :3, 3]
    Jv = np.cross(z, pe - o)
    J = np.concatenate([Jv, z], axis=-1)  # (..., n, 6)
    return np.swapaxes(J, -1, -2), T


def arm_batch(arm: DHRobot) -> DHRobot:
    """One arm (batch shape `()`) as a batch of one, as the dataset functions take; a batch is
    returned unchanged."""
    if arm.batch_shape:
        return arm
    return DHRobot(arm.d[None], arm.a[None], arm.alpha[None], qlim=arm.qlim, tool=arm.tool, name=arm.name)
