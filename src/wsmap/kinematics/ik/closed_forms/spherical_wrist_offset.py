"""Closed-form inverse kinematics of spherical-wrist arms with a shoulder offset, from their
geometry: registered as `"spherical_wrist_offset"`.

The family (industrial arms with an orthogonal–parallel base and a spherical wrist: PUMA with its
shoulder offset, ABB IRB 140, the KUKA KR series, and any description of them): 6 revolute joints,
axis 2 parallel to axis 3, axis 1 not parallel to axis 2, and axes 4, 5, 6 meeting in one point
(the wrist centre) with neither 4 ∥ 5 nor 5 ∥ 6. Offsets between axes 1 and 2 (`a1`), lateral
offsets along the parallel axes (PUMA's `d3`) and a forearm pitched against the wrist centre
(`a3` with `d4`) are all part of the geometry, not special cases. It is recognised on the
joint axes as lines in the base frame at `q = 0` (`wsmap.kinematics.ik.geometry.joint_lines`),
so a URDF whose joints turn about `y` (or a modified-DH table, or any frames) is recognised as
well as a DH table; the paper's DH family, a subset, is solved by `.spherical_wrist` first.

The solution is the product of exponentials `T(q) = exp(ξ1·q1) ··· exp(ξ6·q6) · M` split into
Paden–Kahan subproblems, as EAIK's decomposition does (all in the base frame, `w_j`, `p_j` the
axes at `q = 0`, `W` the wrist centre at `q = 0`, `c = T · M⁻¹ · W` the target's):

* **shoulder** (two solutions): rotations about the parallel axes 2 and 3 keep a point's height
  along `w2` over axis 2, so `w2 · (R(w1, −q1)(c − p1) + p1 − p2) = w2 · (W − p2)`, an equation
  `A cos q1 + B sin q1 = h`;
* **elbow** (two solutions): the distance of the wrist centre from axis 2 fixes `q3` (subproblem
  3, the planar two-link arm of joints 2 and 3), then `q2` rotates it onto the target
  (subproblem 1);
* **wrist** (two solutions): `R4·R5·w6 = (R1·R2·R3)ᵀ·R·R_Mᵀ·w6` gives `q4, q5` (subproblem 2, two
  rotations about intersecting axes), then `q6` (subproblem 1).

Branch `k = 4·shoulder + 2·wrist + elbow` (the bits of `wsmap.kinematics.ik.registry`, on this
family's own angles): shoulder 0 takes `+acos` in the shoulder equation, 1 `−acos`; elbow 0 and
1 the two subproblem-3 angles (`+` and `−` the law-of-cosines angle); wrist 0 and 1 the two
intersection points `±γ` of subproblem 2. Every branch is confirmed by the chain's own forward
kinematics (within `atol`), so a degenerate pose (the wrist centre on axis 1, a stretched elbow)
can only lose a branch, never give a wrong one. Vectorised over arms and targets, float64; metres
and radians.
"""

from __future__ import annotations

import numpy as np

from ...arms import ArmBatch
from ...chain import PRISMATIC, as_chain
from ...chain import flatten_arms as _flat_arms
from ...dh import angle_in_range
from ...transforms import check_rigid
from ..geometry import joint_lines
from ..registry import ClosedForm, register, within_limits
from ..solution import IKReason, IKSolution

__all__ = ["is_spherical_wrist_offset", "require_spherical_wrist_offset", "ikine_spherical_wrist_offset",
           "spherical_wrist_offset_reachable"]

# |sin| of the angle between two axes below which they are parallel, and above which (for the
# axes that must not be parallel) they are safely apart
_PARALLEL = 1e-9
_APART = 1e-6


def _dot(a, b):
    return np.sum(a * b, axis=-1)


def _sp1(w, a, b):
    """Subproblem 1: the angle that turns `a` onto `b` about the unit axis `w` (through the
    origin), from their components perpendicular to `w` (0 where either vanishes)."""
    ap = a - _dot(a, w)[..., None] * w
    bp = b - _dot(b, w)[..., None] * w
    return np.arctan2(_dot(w, np.cross(ap, bp)), _dot(ap, bp))


def _rot(w, q):
    """Rotation matrices `R(w, q)` (Rodrigues), `w` (..., 3) unit, `q` (...)."""
    K = np.zeros(w.shape[:-1] + (3, 3))
    K[..., 0, 1], K[..., 0, 2], K[..., 1, 2] = -w[..., 2], w[..., 1], -w[..., 0]
    K[..., 1, 0], K[..., 2, 0], K[..., 2, 1] = w[..., 2], -w[..., 1], w[..., 0]
    s, c = np.sin(q)[..., None, None], np.cos(q)[..., None, None]
    return np.eye(3) + s * K + (1.0 - c) * (K @ K)


def _closest(p1, w1, p2, w2):
    """Closest points of two non-parallel lines: `(x1, x2)`, each (..., 3)."""
    r = p2 - p1
    c = _dot(w1, w2)
    den = 1.0 - c * c
    t1 = (_dot(r, w1) - c * _dot(r, w2)) / den
    t2 = (c * _dot(r, w1) - _dot(r, w2)) / den
    return p1 + t1[..., None] * w1, p2 + t2[..., None] * w2


def _geometry(robot, atol):
    """`(chain, ok, why, w, p, M, W)`: `ok` (batch) the family test, `why` a function of an
    arm index wording its first failure, and the geometry (`W` the wrist centre at `q = 0`)."""
    chain = as_chain(robot)
    batch = chain.batch_shape
    none = np.zeros(batch, dtype=bool)
    if chain.n != 6:
        return chain, none, lambda idx: f"it has {chain.n} joints, the family has 6", None, None, None, None
    if PRISMATIC in chain.kinds:
        j = chain.kinds.index(PRISMATIC)
        return chain, none, lambda idx: f"joint {j + 1} is prismatic, the family has 6 revolute joints", \
            None, None, None, None
    w, p, M = joint_lines(chain)
    sin = lambda i, k: np.linalg.norm(np.cross(w[..., i, :], w[..., k, :]), axis=-1)  # noqa: E731
    s45, s56 = sin(3, 4), sin(4, 5)
    with np.errstate(invalid="ignore", divide="ignore"):
        x4, x5 = _closest(p[..., 3, :], w[..., 3, :], p[..., 4, :], w[..., 4, :])
        W = 0.5 * (x4 + x5)
        gap45 = np.linalg.norm(x4 - x5, axis=-1)
        r6 = W - p[..., 5, :]
        off6 = np.linalg.norm(r6 - _dot(r6, w[..., 5, :])[..., None] * w[..., 5, :], axis=-1)
    checks = [
        (sin(1, 2) <= _PARALLEL, lambda idx: f"axes 2 and 3 are not parallel (sin {sin(1, 2)[idx]:.3g})"),
        (sin(0, 1) >= _APART, lambda idx: "axes 1 and 2 are parallel"),
        (s45 >= _APART, lambda idx: "axes 4 and 5 are parallel"),
        (s56 >= _APART, lambda idx: "axes 5 and 6 are parallel"),
        (gap45 <= atol, lambda idx: f"axes 4 and 5 do not meet ({gap45[idx]:.3g} m apart): no spherical wrist"),
        (off6 <= atol, lambda idx: f"axis 6 misses the point where axes 4 and 5 meet by {off6[idx]:.3g} m: "
                                   "no spherical wrist"),
    ]
    ok = np.ones(batch, dtype=bool)
    for good, _ in checks:
        ok &= good  # NaN distances (parallel axes) compare False

    def why(idx):
        for good, msg in checks:
            if not good[idx]:
                return msg(idx)
        return "it is of the family"

    return chain, ok, why, w, p, M, W


def is_spherical_wrist_offset(robot, atol: float = 1e-9) -> np.ndarray:
    """True for each arm of the batch (shape `robot.batch_shape`) of the family (module notes):
    6 revolute joints, axes 2 ∥ 3, axis 1 ∦ 2, axes 4, 5, 6 meeting within `atol` (m) in one
    point, 4 ∦ 5 and 5 ∦ 6; tested on the geometry at `q = 0`, whatever frames describe the arm.
    All False for anything that is not an arm."""
    if not isinstance(robot, ArmBatch):
        return np.zeros((), dtype=bool)
    return _geometry(robot, atol)[1]


def require_spherical_wrist_offset(robot, atol: float = 1e-9) -> None:
    """Raise `ValueError` naming the first arm and what differs from the family."""
    if not isinstance(robot, ArmBatch):
        raise ValueError(f"not an arm: {type(robot).__name__}")
    chain, ok, why, *_ = _geometry(robot, atol)
    if not np.all(ok):
        bad = np.argwhere(~np.atleast_1d(ok))
        idx = tuple(int(i) for i in bad[0]) if chain.batch_shape else ()
        arm = f"arm {idx}: " if chain.batch_shape else ""
        raise ValueError(f"not a spherical-wrist arm with a shoulder offset (axes 2 ∥ 3, wrist axes 4, 5, 6 "
                         f"meeting in a point): {arm}{why(idx)}")


def _elbow_angles(v, q1, w1, w2, w3, p1, p2, p3, W):
    """Joints 2 and 3 of both elbows per shoulder `q1` (..., 2), `v` the wrist centre from
    `p1`: `(q2, q3)` (..., 2 shoulder, 2 elbow) and the elbow's cosine before clipping."""
    R1 = _rot(w1[..., None, :], q1)  # (..., 2, 3, 3)
    cp = np.einsum("...sji,...j->...si", R1, v) + p1[..., None, :]  # R1ᵀ v
    s3 = np.sign(_dot(w2, w3))[..., None]  # w3 = s3·w2
    W2, P2, P3 = w2[..., None, :], p2[..., None, :], p3[..., None, :]
    perp = lambda x: x - _dot(x, W2)[..., None] * W2  # noqa: E731
    u = perp(np.broadcast_to((W - p3)[..., None, :], cp.shape))
    vv = perp(np.broadcast_to((p2 - p3)[..., None, :], cp.shape))
    delta2 = _dot(perp(cp - P2), perp(cp - P2))
    nu, nv = np.linalg.norm(u, axis=-1), np.linalg.norm(vv, axis=-1)
    den = 2.0 * nu * nv
    deg3 = den < 1e-12
    cphi_raw = np.where(deg3, 1.0, (nu * nu + nv * nv - delta2) / np.where(deg3, 1.0, den))
    cphi = np.clip(cphi_raw, -1.0, 1.0)
    phi = np.arccos(cphi)
    alpha_u = np.arctan2(_dot(W2, np.cross(vv, u)), _dot(vv, u))
    theta = np.stack([phi - alpha_u, -phi - alpha_u], axis=-1)  # (..., 2 sh, 2 el), about w2
    q3 = s3[..., None] * theta
    # q2: turn the wrist centre after joint 3 onto c' about axis 2
    R3 = _rot(np.broadcast_to(w2[..., None, None, :], theta.shape + (3,)), theta)
    a_vec = np.einsum("...ij,...j->...i", R3, u[..., None, :] + 0.0 * theta[..., None]) \
        + (P3 - P2)[..., None, :] + (_dot(W - p3, w2)[..., None, None, None] * w2[..., None, None, :])
    # (the component along w2 of W - p3 is kept by the rotation)
    b_vec = (cp - P2)[..., None, :]
    q2 = _sp1(np.broadcast_to(w2[..., None, None, :], a_vec.shape), a_vec, np.broadcast_to(b_vec, a_vec.shape))
    return q2, q3, cphi_raw


def _wrist_angles(w, T, RM, q1e, q2, q3):
    """Joints 4-6 of both wrists per (shoulder, elbow): lists (wrist 0, wrist 1) of `q4`, `q5`,
    `q6` (..., 2 shoulder, 2 elbow) and the squared `γ` of the wrist's subproblem."""
    w1, w2, w3 = w[..., 0, :], w[..., 1, :], w[..., 2, :]
    Rb = (_rot(np.broadcast_to(w1[..., None, None, :], q2.shape + (3,)), q1e)
          @ _rot(np.broadcast_to(w2[..., None, None, :], q2.shape + (3,)), q2)
          @ _rot(np.broadcast_to(w3[..., None, None, :], q2.shape + (3,)), q3))
    Rrel = np.swapaxes(Rb, -1, -2) @ (T[..., :3, :3] @ np.swapaxes(RM, -1, -2))[..., None, None, :, :]
    w4, w5, w6 = (np.broadcast_to(w[..., j, None, None, :], q2.shape + (3,)) for j in (3, 4, 5))
    qv = np.einsum("...ij,...j->...i", Rrel, w6)
    k45 = _dot(w4, w5)
    den2 = k45 * k45 - 1.0
    al = (k45 * _dot(w5, w6) - _dot(w4, qv)) / den2
    be = (k45 * _dot(w4, qv) - _dot(w5, w6)) / den2
    cr = np.cross(w4, w5)
    g2 = (1.0 - al * al - be * be - 2.0 * al * be * k45) / _dot(cr, cr)
    gam = np.sqrt(np.maximum(g2, 0.0))
    q4s, q5s, q6s = [], [], []
    for sg in (1.0, -1.0):
        cv = al[..., None] * w4 + be[..., None] * w5 + (sg * gam)[..., None] * cr
        q5 = _sp1(w5, w6, cv)
        q4 = _sp1(w4, cv, qv)
        R6 = np.swapaxes(_rot(w4, q4) @ _rot(w5, q5), -1, -2) @ Rrel
        n6 = np.cross(w6, np.where(np.abs(w6[..., :1]) < 0.9, np.array([1.0, 0, 0]), np.array([0, 1.0, 0])))
        q6 = _sp1(w6, n6, np.einsum("...ij,...j->...i", R6, n6))
        q4s.append(q4), q5s.append(q5), q6s.append(q6)
    return q4s, q5s, q6s, g2


def _confirmation(chain, q, T, cand):
    """The largest entry of `|fkine(q) − T|` of each candidate branch (`cand`, (..., 8)) by the
    chain's own forward kinematics; `inf` elsewhere."""
    shape = cand.shape[:-1]
    err = np.full(shape + (8,), np.inf)
    if cand.any():
        arm_index = np.broadcast_to(np.arange(max(1, int(np.prod(chain.batch_shape, dtype=np.int64))))
                                    .reshape(chain.batch_shape or ()), shape)
        idx = np.nonzero(cand)
        flat = chain if not chain.batch_shape else _flat_arms(chain)
        sel = flat if not chain.batch_shape else flat[arm_index[idx[:-1]]]
        Tq = sel.fkine(q[idx])
        err[idx] = np.abs(Tq - T[idx[:-1]]).max(axis=(-2, -1))
    return err


def _branch_angles(q1e, q2, q3, q4s, q5s, q6s, shape):
    """The joint angles of the 8 branches, `shape + (8, 6)` in `(-pi, pi]` (0 where not finite),
    from the arm's (..., 2 shoulder, 2 elbow) and the wrists' (lists of wrist 0, wrist 1)."""
    # (..., 2 shoulder, 2 wrist, 2 elbow, 6)
    arm = np.stack([q1e, q2, q3], axis=-1)[..., :, None, :, :]
    wrist = np.stack([np.stack(q4s, axis=-2), np.stack(q5s, axis=-2), np.stack(q6s, axis=-2)], axis=-1)
    arm = np.broadcast_to(arm, wrist.shape)
    q = np.concatenate([arm, wrist], axis=-1).reshape(shape + (8, 6))
    q = np.where(np.isfinite(q), q, 0.0)
    q = np.mod(q + np.pi, 2 * np.pi) - np.pi
    return np.where(q <= -np.pi, q + 2 * np.pi, q)


@within_limits
def ikine_spherical_wrist_offset(robot, T, atol: float = 1e-9) -> IKSolution:
    """All 8 closed-form solutions of an arm of the family (module notes).

    Parameters
    ----------
    robot : SerialChain or DHRobot of the family (`is_spherical_wrist_offset`), one arm or a batch
    T : array_like, shape (..., 4, 4)
        Target tool poses in the robot's world frame (`robot.fkine` convention, metres),
        broadcasting with the robot's batch shape; rigid (else `ValueError`).
    atol : float
        The structure test's tolerance (m) and that of the confirmation: a branch succeeds where
        the chain's forward kinematics of its `q` is within `atol` of `T` in every matrix
        entry (metres for the position).

    Returns
    -------
    `IKSolution` with a branch axis: `q` (..., 8, 6) in
    `(-pi, pi]` (rad; a succeeding branch's moved by whole turns into the robot's limits,
    `wsmap.kinematics.ik.registry.within_limits`), branch `k = 4·shoulder + 2·wrist + elbow`
    (module notes); `success` (..., 8): confirmed and, where the robot has limits, inside them
    up to multiples of 2·pi;
    `reason` `OUT_OF_REACH` where the branch does not reach the pose, `OUTSIDE_LIMITS` where
    it does outside the limits; `iterations` 0; `residual` the largest entry of
    `|fkine(q) − T|` (`inf` for a branch whose cosines are out of range, not evaluated).
    """
    require_spherical_wrist_offset(robot, atol)
    chain, _, _, w, p, M, W = _geometry(robot, atol)
    T = check_rigid("target poses", T)
    shape = np.broadcast_shapes(T.shape[:-2], chain.batch_shape)
    T = np.broadcast_to(T, shape + (4, 4))
    g = lambda x: np.broadcast_to(x, shape + x.shape[len(chain.batch_shape):])  # noqa: E731
    w, p, M, W = g(w), g(p), g(M), g(W)
    w1, w2, w3 = w[..., 0, :], w[..., 1, :], w[..., 2, :]
    p1, p2, p3 = p[..., 0, :], p[..., 1, :], p[..., 2, :]
    # the wrist centre of the target: W in the tool frame at q = 0, carried by T
    RM, tM = M[..., :3, :3], M[..., :3, 3]
    Wt = np.einsum("...ji,...j->...i", RM, W - tM)
    c = np.einsum("...ij,...j->...i", T[..., :3, :3], Wt) + T[..., :3, 3]

    with np.errstate(invalid="ignore", divide="ignore"):
        # ---- shoulder: A cos q1 + B sin q1 = h − C
        v = c - p1
        k12 = _dot(w1, w2)
        A = _dot(w2, v) - k12 * _dot(w1, v)
        B = -_dot(w2, np.cross(w1, v))
        C = k12 * _dot(w1, v)
        h = _dot(w2, W - p2) - _dot(w2, p1 - p2)
        rho = np.hypot(A, B)
        free1 = rho < 1e-12  # the wrist centre on axis 1: q1 free, 0 and pi taken
        cos_raw = np.where(free1, 1.0, (h - C) / np.where(free1, 1.0, rho))
        cos_s = np.clip(cos_raw, -1.0, 1.0)
        base = np.where(free1, np.pi / 2, np.arctan2(B, A))  # free: q1 = pi and 0
        ds = np.where(free1, np.pi / 2, np.arccos(cos_s))
        q1 = np.stack([base + ds, base - ds], axis=-1)  # (..., 2 shoulder)

        # ---- elbow, per shoulder: c' = R(w1, −q1)(c − p1) + p1
        q2, q3, cphi_raw = _elbow_angles(v, q1, w1, w2, w3, p1, p2, p3, W)

        # ---- wrist, per (shoulder, elbow): R4 R5 R6 = (R1 R2 R3)ᵀ R R_Mᵀ
        q1e = np.broadcast_to(q1[..., None], q2.shape)
        q4s, q5s, q6s, g2 = _wrist_angles(w, T, RM, q1e, q2, q3)
    q = _branch_angles(q1e, q2, q3, q4s, q5s, q6s, shape)

    # candidates: branches whose cosines and subproblem-2 radius are in range up to rounding (a
    # margin far above it: a pose out of reach by more fails the confirmation anyway)
    with np.errstate(invalid="ignore"):
        slack = 1e-6
        # (..., shoulder, wrist, elbow): the shoulder and elbow cosines per shoulder, γ² per (shoulder, elbow)
        cand = ((np.abs(cos_raw) <= 1.0 + slack)[..., None] & (np.abs(cphi_raw) <= 1.0 + slack))[..., :, None, None] \
            & (g2 >= -slack)[..., :, None, :]
    cand = np.broadcast_to(cand, shape + (2, 2, 2)).reshape(shape + (8,))
    # the confirmation: the chain's own forward kinematics of the candidates
    err = _confirmation(chain, q, T, cand)
    reach = err <= atol
    valid = reach
    if chain.qlim is not None:
        lim = np.broadcast_to(chain.qlim, chain.batch_shape + (6, 2))[..., None, :, :]
        valid = reach & np.all(angle_in_range(q, lim[..., 0], lim[..., 1]), axis=-1)
    reason = np.where(valid, IKReason.SOLVED, np.where(reach, IKReason.OUTSIDE_LIMITS, IKReason.OUT_OF_REACH))
    return IKSolution(q=q, success=valid, iterations=np.zeros(valid.shape, dtype=np.int64), residual=err,
                      reason=reason.astype(np.int8))


def spherical_wrist_offset_reachable(robot, T, atol: float = 1e-9) -> np.ndarray:
    """Some branch of `ikine_spherical_wrist_offset` succeeds: bool, `T.shape[:-2]`
    broadcast with the robot's batch shape."""
    return ikine_spherical_wrist_offset(robot, T, atol).success.any(axis=-1)


register(ClosedForm(name="spherical_wrist_offset",
                    description="the spherical-wrist family with a shoulder offset",
                    recognise=is_spherical_wrist_offset, require=require_spherical_wrist_offset,
                    solve=ikine_spherical_wrist_offset, reachable=spherical_wrist_offset_reachable, priority=20))
