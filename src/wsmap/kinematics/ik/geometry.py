"""The geometry of a serial arm, whatever frames its description uses: joint axes as lines in the
base frame at the zero pose, and the standard-DH chain with the same kinematics.

A URDF (or any `SerialChain`) may turn its joints about `y` or
any other axis of frames placed anywhere; a closed form that recognises its family by the numbers
of a DH table would miss it. What does not depend on the description is the arm's geometry: the
lines of the joint axes in the base (world) frame at `q = 0` and the tool pose there
(`joint_lines`), from which the forward kinematics is the product of exponentials
`T(q) = exp(ξ1·q1) ··· exp(ξn·qn) · M`. `dh_equivalent` rewrites that geometry as a
standard-DH chain (fixed transforms `Tz(d)·Tx(a)·Rx(alpha)` between joints about `±z`, the DH
`θ` at the zero pose as joint offsets, everything before joint 1 and after joint `n` in the
first and last fixed transforms), the same joint coordinates and limits, checked against the
original's forward kinematics; closed forms that test DH numbers run their test on it.

Units: metres and radians; frames are right-handed; shapes carry the chain's batch shape `...`.
"""

from __future__ import annotations

import numpy as np

from ..chain import PRISMATIC, SerialChain, as_chain
from .memo import Memo, chain_key

__all__ = ["joint_lines", "dh_equivalent"]

# lines closer to parallel than this (|sin| of their angle), and feet of common normals closer
# than this (m), are parallel and intersecting
_PARALLEL = 1e-9
_MEET = 1e-12
# largest difference (matrix entries; m and unitless) between the forward kinematics of a chain
# and its DH equivalent at random configurations, above which the equivalent is rejected
_CHECK_TOL = 1e-9

_EQUIVALENTS = Memo()


def joint_lines(robot) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The joint axes at `q = 0` in the base (world) frame, and the tool pose there.

    Returns `(w, p, M)`: `w` (..., n, 3) unit directions (positive `q` turns right-handed
    about `w`; a prismatic joint moves along it), `p` (..., n, 3) a point of each axis (the
    origin of the joint's frame), `M` (..., 4, 4) the tool pose (`robot.fkine(0)`). `...` is
    the robot's batch shape.
    """
    chain = as_chain(robot)
    frames, M = chain.joint_frames(np.zeros(chain.n))
    w = np.einsum("...ij,...j->...i", frames[..., :3, :3], chain.axes)
    return w, frames[..., :3, 3].copy(), M


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _dot(a, b):
    return np.sum(a * b, axis=-1)


def _dh_link(d, a, alpha):
    """`Tz(d)·Tx(a)·Rx(alpha)`, (..., 4, 4)."""
    c, s = np.cos(alpha), np.sin(alpha)
    T = np.zeros(np.shape(d) + (4, 4))
    T[..., 0, 0] = 1.0
    T[..., 1, 1], T[..., 1, 2], T[..., 2, 1], T[..., 2, 2] = c, -s, s, c
    T[..., 0, 3], T[..., 2, 3] = a, d
    T[..., 3, 3] = 1.0
    return T


def _frame(x, z, o):
    """The frame with axes `x`, `z × x`, `z` and origin `o` (..., 4, 4)."""
    T = np.zeros(o.shape[:-1] + (4, 4))
    T[..., :3, 0], T[..., :3, 1], T[..., :3, 2], T[..., :3, 3] = x, np.cross(z, x), z, o
    T[..., 3, 3] = 1.0
    return T


def _inverse(T):
    out = np.zeros(T.shape)
    R = np.swapaxes(T[..., :3, :3], -1, -2)
    out[..., :3, :3] = R
    out[..., :3, 3] = -np.einsum("...ij,...j->...i", R, T[..., :3, 3])
    out[..., 3, 3] = 1.0
    return out


def _any_normal(z):
    """A unit vector perpendicular to `z` (..., 3): `z × e` with `e` the world axis least along `z`."""
    e = np.zeros(z.shape)
    k = np.argmin(np.abs(z), axis=-1)
    np.put_along_axis(e, k[..., None], 1.0, axis=-1)
    return _unit(np.cross(z, e))


def _build(chain: SerialChain):
    n = chain.n
    w, p, M = joint_lines(chain)
    batch = w.shape[:-2]
    # z along each axis; an axis anti-parallel to the one before is flipped (its joint then turns
    # about -z), so that parallel axes get alpha 0, not pi. The flips are shared by the batch (the
    # chain's axes are): the first arm's, and arms that would flip differently are not equivalent
    flat_w = w.reshape(-1, n, 3)
    sign = np.ones(n)
    ok = np.ones(batch, dtype=bool)
    z = np.empty(w.shape)
    z[..., 0, :] = w[..., 0, :]
    for j in range(1, n):
        anti = _dot(z[..., j - 1, :], w[..., j, :]) < -(1.0 - _PARALLEL)
        sign[j] = -1.0 if anti.reshape(-1)[0] else 1.0
        ok &= anti == (sign[j] < 0)
        z[..., j, :] = sign[j] * w[..., j, :]
    del flat_w
    # frame 0: on axis 1 at the point nearest the base origin, x the normal nearest world x
    o = p[..., 0, :] - _dot(p[..., 0, :], z[..., 0, :])[..., None] * z[..., 0, :]
    x = _any_normal(z[..., 0, :])
    ex = np.array([1.0, 0.0, 0.0])
    towards = ex - _dot(ex, z[..., 0, :])[..., None] * z[..., 0, :]
    x = np.where((np.linalg.norm(towards, axis=-1) > 1e-6)[..., None], _unit(towards), x)
    first = _frame(x, z[..., 0, :], o)
    fixed = np.empty(batch + (n + 1, 4, 4))
    fixed[..., 0, :, :] = first
    offset = np.zeros(batch + (n,))
    for j in range(n - 1):
        zj, zk, pk = z[..., j, :], z[..., j + 1, :], p[..., j + 1, :]
        c = np.cross(zj, zk)
        sc = np.linalg.norm(c, axis=-1)
        par = sc < _PARALLEL
        # feet of the common normal: on line j (through o along zj) and line j+1 (through pk along zk)
        r = pk - o
        cc = _dot(zj, zk)
        den = np.where(par, 1.0, 1.0 - cc * cc)
        tj = np.where(par, 0.0, (_dot(r, zj) - cc * _dot(r, zk)) / den)
        tk = np.where(par, -_dot(r, zk), (cc * _dot(r, zj) - _dot(r, zk)) / den)
        fj = o + tj[..., None] * zj
        fk = pk + tk[..., None] * zk
        gap = fk - fj
        dist = np.linalg.norm(gap, axis=-1)
        meet = dist < _MEET
        xn = np.where(meet[..., None], np.where(par[..., None], x, c / np.where(par, 1.0, sc)[..., None]),
                      gap / np.where(meet, 1.0, dist)[..., None])
        theta = np.arctan2(_dot(np.cross(x, xn), zj), _dot(x, xn))
        d = _dot(fj - o, zj)
        a = _dot(gap, xn)
        alpha = np.arctan2(_dot(np.cross(zj, zk), xn), _dot(zj, zk))
        fixed[..., j + 1, :, :] = _dh_link(d, a, alpha)
        offset[..., j] = sign[j] * theta
        x, o = xn, fk
    last = _frame(x, z[..., n - 1, :], o)
    fixed[..., n, :, :] = _inverse(last) @ M
    axes = np.zeros((n, 3))
    axes[:, 2] = sign
    eq = SerialChain(fixed, axes, chain.kinds, offset=offset, qlim=chain.qlim, name=chain.name,
                     source=chain.source, links=chain.links)
    # the check: the same forward kinematics at a few configurations
    q = np.random.default_rng(0).uniform(-np.pi, np.pi, (4,) + batch + (n,)) if batch else \
        np.random.default_rng(0).uniform(-np.pi, np.pi, (4, n))
    diff = np.abs(eq.fkine(q) - chain.fkine(q)).max(axis=(-2, -1)).max(axis=0)
    ok &= diff <= _CHECK_TOL
    return eq, ok


def dh_equivalent(robot) -> tuple[SerialChain | None, np.ndarray]:
    """The standard-DH chain with the kinematics of `robot`, whatever frames it is described in.

    Returns `(chain, ok)`: `chain` a `SerialChain` whose fixed transforms after joints
    `1 .. n-1` are `Tz(d)·Tx(a)·Rx(alpha)` (standard DH: frame `j` has `z` along joint
    `j + 1`'s axis and `x` along the common normal of axes `j` and `j + 1`), whose joints
    turn about `±z` of their frames (`-z` where an axis is anti-parallel to the one before, so
    that parallel axes have `alpha = 0`), with the DH angles `θ` at the zero pose as joint
    offsets, the base, `F_0` and everything before joint 1 in `F_0` and the tool in `F_n`;
    the same joint coordinates (rad) and limits as `robot`. Where axes are parallel, the normal
    passes through the previous frame's origin (`d = 0`). `ok` (batch shape) is False for an
    arm whose equivalent differs from it by more than 1e-9 in forward kinematics at random
    configurations (or whose axis flips differ from the first arm's). `(None, all False)` for a
    chain with a prismatic joint. Memoised by the chain's numbers; the result is shared, not to be
    changed.
    """
    chain = as_chain(robot)
    if PRISMATIC in chain.kinds or chain.n < 2:
        return None, np.zeros(chain.batch_shape, dtype=bool)
    return _EQUIVALENTS.get(chain_key(chain), lambda: _build(chain))
