"""Closed-form inverse kinematics of the UR family: three parallel axes (Universal Robots' geometry).

All 8 branches (shoulder × wrist × elbow), vectorised over arms and targets in float64; joint limits
honoured up to multiples of 2·pi. Units: metres and radians.

The family, in UR's standard DH convention (link ``i`` is ``Rz(θ_i) Tz(d_i) Tx(a_i) Rx(α_i)``)::

    j:      1      2    3     4      5     6
    d:     d1     d2   d3    d4     d5    d6
    a:     a1     a2   a3     0      0    (flange)
    alpha: ±pi/2   0    0    ±pi/2  ±pi/2 (flange)

Joints 2, 3 and 4 turn about parallel axes, perpendicular to joint 1. What the solver accepts
beyond UR's published tables (each handled exactly, not approximated):

* ``d2`` and ``d3`` translate along the parallel axes, so only ``d2 + d3 + d4`` matters; it is
  reported as ``d4``;
* ``a1`` (a shoulder offset along the arm plane);
* either sign of ``alpha`` at joints 1, 4 and 5: ``Rx(-pi/2) = Rz(pi)·Rx(pi/2)·Rz(pi)``, so a
  mirrored twist is UR's twist with a half turn added to that joint and the next (and ``a``
  negated, which only concerns ``a1``);
* joint axes ``+z`` or ``-z`` and any joint offsets (``θ = ±(q + offset)``);
* anything before joint 1 (the chain's ``base`` and ``F_0``) and after joint 6 (``F_6`` beyond its
  translation along the joint-6 axis, which is ``d6``, and the chain's ``tool``): targets are
  mapped with ``T' = base⁻¹ · T · flange⁻¹``.

The geometry (frame ``k`` is the frame after link ``k``, with axes ``xk``, ``yk``, ``zk``; ``y1``
is the base ``z`` axis and ``z1`` the direction of the parallel axes): the wrist point ``p5 = p − d6·z6`` lies at height ``d4``
along ``z1`` (shoulder, two solutions), the cosine of ``θ5`` is ``z6·z1`` (wrist, two signs of
``θ5``), the frame-4 origin is ``p5 − d5·z4`` with ``z4 ⟂ z1, z6`` (its direction gives
``θ2 + θ3 + θ4``), and joints 2 and 3 form a planar two-link arm reaching the frame-4 origin in
the arm plane (elbow, two solutions). ``θ6`` is solved from the frames already fixed, so the
rotation is exact even close to the wrist singularity.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .chain import PRISMATIC, SerialChain, from_dh
from .dh import DHRobot, _angle_in_range
from .transforms import as_real_array, check_rigid

__all__ = ["UR_ALPHA", "URParameters", "ur_parameters", "is_ur_type", "require_ur_type", "ikine_ur",
           "ur_reachable"]

#: UR's twists ``alpha`` (rad) of joints 1..6 (standard DH); joint 6's twist is part of the flange.
UR_ALPHA = np.array([np.pi / 2, 0.0, 0.0, np.pi / 2, -np.pi / 2, 0.0])

_TWO_PI = 2.0 * np.pi
# |z6 projected on the arm plane| below this: the wrist is singular (z6 = ±z1) and θ2+θ3+θ4 is
# free. Treating a nearly singular pose as singular costs a rotation error of at most this, in rad.
_SINGULAR = 1e-12
# Targets per block of the solver (see ikine_ur).
_BLOCK = 2048
# Rigid-transform tolerance of the target check, as wsmap.kinematics.transforms.check_rigid.
_RIGID_TOL = 1e-6
_EYE3 = np.eye(3)[:, :, None]
_SIGN = np.array([1.0, -1.0])[:, None]  # the two branches of a choice, broadcast over targets
_BOTTOM = np.array([0.0, 0.0, 0.0, 1.0])[:, None]


class URParameters(NamedTuple):
    """A UR-type arm (or batch of arms) in the canonical form the solver uses.

    Lengths ``d1, a1, a2, a3, d4, d5, d6`` (m) have the robot's batch shape and are UR's standard DH
    values with ``alpha = UR_ALPHA`` exactly (``d4`` includes ``d2 + d3``; ``a1`` is 0 for UR's
    arms). Joint angles of the canonical table ``θ`` (rad) relate to the robot's joint coordinates
    ``q`` by ``q = sign · θ − shift`` (``sign``, ``shift``: ``(..., 6)``). The robot's flange pose
    is ``T = base · T_UR(θ) · flange``, with ``T_UR`` UR's forward kinematics from the frame of
    joint 1 (z along joint 1) to the frame after ``Tz(d6)``; ``base``, ``flange``: ``(..., 4, 4)``.
    ``qlim``: the robot's limits ``(..., 6, 2)`` (rad) or ``None``.
    """

    d1: np.ndarray
    a1: np.ndarray
    a2: np.ndarray
    a3: np.ndarray
    d4: np.ndarray
    d5: np.ndarray
    d6: np.ndarray
    sign: np.ndarray
    shift: np.ndarray
    base: np.ndarray
    flange: np.ndarray
    qlim: np.ndarray | None


def _as_chain(robot) -> SerialChain:
    if isinstance(robot, SerialChain):
        return robot
    if isinstance(robot, DHRobot):
        return from_dh(robot.d, robot.a, robot.alpha, qlim=robot.qlim, tool=robot.tool, name=robot.name)
    raise TypeError(f"robot must be a SerialChain or a DHRobot, got {type(robot).__name__}")


def _wrap(x):
    """``x`` moved by a multiple of 2·pi into ``[-pi, pi]`` (rint is far cheaper than mod)."""
    return x - _TWO_PI * np.rint(x * (1.0 / _TWO_PI))


def _wrap_in_place(x):
    """:func:`_wrap` overwriting ``x``."""
    t = x * (1.0 / _TWO_PI)
    np.rint(t, out=t)
    t *= _TWO_PI
    x -= t


def _fmt(x) -> str:
    return f"{float(x):.6g}"


def _inspect(robot, atol: float):
    """Check the structure of every arm of the batch.

    Returns ``(chain, ok, why, values)``: ``ok`` (batch) bool; ``why(idx)`` the first difference of
    arm ``idx`` from the UR type (a sentence naming the joint); ``values`` the extracted DH numbers
    (``None`` when the joint count, kinds or axes already rule every arm out).
    """
    chain = _as_chain(robot)
    batch = chain.batch_shape
    none = np.zeros(batch, dtype=bool)
    if chain.n != 6:
        return chain, none, lambda idx: f"it has {chain.n} joints, the UR type has 6", None
    for j, k in enumerate(chain.kinds):
        if k == PRISMATIC:
            return chain, none, lambda idx, j=j: f"joint {j + 1} is prismatic, the UR type has 6 revolute joints", None
    for j, ax in enumerate(chain.axes):
        if abs(ax[0]) > atol or abs(ax[1]) > atol:
            return (chain, none, lambda idx, j=j, ax=ax: f"joint {j + 1}: axis ({', '.join(_fmt(x) for x in ax)}), "
                    f"the UR type turns about the z axis of the joint frame", None)

    F = np.broadcast_to(chain.fixed, batch + (7, 4, 4))
    L = F[..., 1:6, :, :]  # the links after joints 1..5, which must be Tz(d)·Tx(a)·Rx(alpha)
    form = np.max(np.abs(np.stack([L[..., 0, 0] - 1.0, L[..., 1, 0], L[..., 2, 0], L[..., 0, 1], L[..., 0, 2],
                                   L[..., 1, 3]], axis=-1)), axis=-1)  # (..., 5)
    d, a = L[..., 2, 3], L[..., 0, 3]
    alpha = np.arctan2(L[..., 2, 1], L[..., 1, 1])
    checks = []  # (joint index, ok (batch), message(idx))
    for j in range(5):
        checks.append((j, form[..., j] <= atol, lambda idx, j=j: (
            f"joint {j + 1}: the fixed transform after it is not of the form Tz(d)·Tx(a)·Rx(alpha) "
            f"(off by {_fmt(form[idx + (j,)])})")))
        if j in (0, 3, 4):
            ok_al = np.abs(np.abs(alpha[..., j]) - np.pi / 2) <= atol
            checks.append((j, ok_al, lambda idx, j=j: (
                f"joint {j + 1}: alpha {_fmt(alpha[idx + (j,)])} rad, the UR type has ±pi/2")))
        else:
            checks.append((j, np.abs(alpha[..., j]) <= atol, lambda idx, j=j: (
                f"joint {j + 1}: alpha {_fmt(alpha[idx + (j,)])} rad, the UR type has 0")))
        if j in (3, 4):
            checks.append((j, np.abs(a[..., j]) <= atol, lambda idx, j=j: (
                f"joint {j + 1}: a {_fmt(a[idx + (j,)])} m, the UR type has 0")))
    ok = np.ones(batch, dtype=bool)
    for _, good, _ in checks:
        ok &= good

    def why(idx):
        for _, good, msg in sorted(checks, key=lambda c: c[0]):
            if not good[idx]:
                return msg(idx)
        return "it is of the UR type"

    return chain, ok, why, (F, d, a, alpha)


def is_ur_type(robot, atol: float = 1e-9) -> np.ndarray:
    """True for each arm of the batch (shape ``robot.batch_shape``) that :func:`ikine_ur` solves.

    ``robot``: a :class:`SerialChain` or :class:`DHRobot`. The test is on the numbers (``atol`` on
    matrix entries, metres and radians): 6 revolute joints about ``±z`` of their frames, the fixed
    transforms after joints 1..5 of the form ``Tz(d)·Tx(a)·Rx(alpha)`` with ``alpha`` ±pi/2, 0, 0,
    ±pi/2, ±pi/2 and ``a4 = a5 = 0``. Base, ``F_0``, ``F_6`` and tool are free (see the module doc).
    """
    return _inspect(robot, atol)[1]


def require_ur_type(robot, atol: float = 1e-9) -> None:
    """Raise ``ValueError`` naming the first arm and joint that differ from the UR type."""
    chain, ok, why, _ = _inspect(robot, atol)
    if not np.all(ok):
        bad = np.argwhere(~ok)
        idx = tuple(int(i) for i in bad[0]) if bad.size else ()
        arm = f"arm {idx}: " if chain.batch_shape else ""
        raise ValueError(f"not an arm of the UR type (three parallel axes): {arm}{why(idx)}")


def _rigid_inverse(T):
    R = np.swapaxes(T[..., :3, :3], -1, -2)
    out = np.zeros(T.shape)
    out[..., :3, :3] = R
    out[..., :3, 3] = -np.einsum("...ij,...j->...i", R, T[..., :3, 3])
    out[..., 3, 3] = 1.0
    return out


def ur_parameters(robot, atol: float = 1e-9) -> URParameters:
    """The canonical UR numbers of a UR-type arm (see :class:`URParameters`); ``ValueError`` otherwise.

    ``robot``: a :class:`SerialChain` (e.g. ``wsmap.robots.load("ur5e")``) or :class:`DHRobot`, one
    arm or a batch. ``base = chain.base · F_0`` (the identity for a :class:`DHRobot`);
    ``flange = Tz(−d6) · F_6 · chain.tool`` with ``d6 = F_6[2, 3]``, the translation of ``F_6``
    along joint 6 (it commutes with joint 6, so any split is exact).
    """
    require_ur_type(robot, atol)
    chain, _, _, (F, d, a, alpha) = _inspect(robot, atol)
    batch = chain.batch_shape
    # mirrored twists at joints 1, 4, 5: a half turn on that joint and the next (module doc)
    flip = (alpha[..., [0, 3, 4]] * UR_ALPHA[[0, 3, 4]] < 0).astype(float)  # (..., 3)
    zero = np.zeros(batch)
    f1, f4, f5 = flip[..., 0], flip[..., 1], flip[..., 2]
    half_turns = np.stack([f1, f1, zero, f4, f4 + f5, f5], axis=-1) * np.pi
    sign = np.broadcast_to(np.sign(chain.axes[:, 2]), batch + (6,)).copy()
    # the chain turns Rz(sign·(q + offset)); canonical θ = sign·(q + offset) + half_turns
    shift = sign * half_turns + np.broadcast_to(chain.offset, batch + (6,))
    d6 = F[..., 6, 2, 3]
    tz = np.broadcast_to(np.eye(4), batch + (4, 4)).copy()
    tz[..., 2, 3] = -d6
    flange = tz @ F[..., 6, :, :]
    if chain.tool is not None:
        flange = flange @ chain.tool
    base = F[..., 0, :, :] if chain.base is None else chain.base @ F[..., 0, :, :]
    qlim = chain.qlim
    return URParameters(d1=d[..., 0], a1=a[..., 0] * (1.0 - 2.0 * f1), a2=a[..., 1], a3=a[..., 2],
                        d4=d[..., 1] + d[..., 2] + d[..., 3], d5=d[..., 4], d6=d6, sign=sign, shift=shift,
                        base=base, flange=flange, qlim=qlim)


def _target_components(T, T_given):
    """``T`` (m, 4, 4) → its entries row by row, (16, m) contiguous; rigid checked (an error names
    the first offending index of the targets as given, ``T_given``)."""
    C = T.reshape(-1, 16).T.copy()  # C order, and our own: _solve overwrites it
    R = C[:12].reshape(3, 4, -1)[:, :3]  # R[i, c]: row i of column c
    # check_rigid's conditions (RᵀR = I, det R = +1, bottom row) without its batched matmul and
    # det, which would cost as much as the whole solve: a quarter of its tolerance on RᵀR − I and
    # on a − n × o implies its own bounds, so what passes here passes there; what fails here goes
    # to check_rigid, which decides and words the error
    G = np.einsum("icb,idb->cdb", R, R)
    G -= _EYE3
    n, o = R[:, 0], R[:, 1]
    cross = n[[1, 2, 0]] * o[[2, 0, 1]]
    cross -= n[[2, 0, 1]] * o[[1, 2, 0]]
    cross -= R[:, 2]
    tol = 0.25 * _RIGID_TOL
    if not ((np.abs(G) <= tol).all() and (np.abs(cross) <= tol).all()
            and (np.abs(C[12:] - _BOTTOM) <= tol).all()):  # NaN fails too
        check_rigid("target poses", T_given)
    return C


def ikine_ur(robot, T, atol: float = 1e-9):
    """All 8 closed-form solutions of a UR-type arm (shoulder × wrist × elbow).

    Parameters
    ----------
    robot : SerialChain or DHRobot of the UR type (:func:`is_ur_type`), or its :class:`URParameters`
        (from :func:`ur_parameters`, to skip the structure check on repeated calls).
    T : array_like, shape (..., 4, 4)
        Target tool poses in the robot's world frame (``robot.fkine`` convention: base → tool,
        metres), broadcasting with the robot's batch shape; rigid (else ``ValueError``).
    atol : float
        Reach tolerance in metres: the wrist point may lie up to ``atol`` inside the shoulder
        cylinder ``r >= |d4|`` and the frame-4 origin up to ``atol`` outside the elbow annulus
        ``||a2| − |a3|| <= ρ <= |a2| + |a3|``; such a branch is the nearest configuration, with a
        position error of at most about ``atol``. Also the tolerance of the structure check.

    Returns
    -------
    q : (..., 8, 6) float64
        Joint coordinates (rad) in ``[-pi, pi]``, ``...`` the broadcast of ``T.shape[:-2]`` and the
        robot's batch shape. Branch ``k = 4·i + 2·j + l``, defined on the canonical angles ``θ``
        (UR's table, ``q = sign·θ − shift``, :class:`URParameters`; for UR's own arms ``θ = q``):
        shoulder ``i``: ``θ1 = φ + asin(d4/r)`` (``i = 0``) or ``φ + pi − asin(d4/r)`` (``i = 1``),
        with ``(r, φ)`` the polar coordinates of the wrist point ``p − d6·z`` in the joint-1 frame;
        wrist ``j``: ``sin θ5 >= 0`` (0) or ``<= 0`` (1); elbow ``l``: ``sin θ3 >= 0`` (0) or
        ``<= 0`` (1). Entries of branches that are not valid are finite but meaningless.
    valid : (..., 8) bool
        The branch reaches the pose (tolerance ``atol``) and, if the robot has joint limits, every
        joint lies inside them up to a multiple of 2·pi (``q`` itself is not moved into the range).

    Notes
    -----
    Singular wrist (``z6 = ±z1``, ``sin θ5 = 0``): only ``θ2 + θ3 + θ4`` and ``θ6`` together are
    determined; the free angle is chosen so that the elbow is as close to a right angle as the
    position allows (the two wrist branches take the two mirror choices), which reaches the pose
    whenever any choice does. A free ``θ1`` (wrist point on the joint-1 axis with ``d4 = 0``)
    takes 0 and pi. In these one-parameter families the limits are checked on the chosen member only.
    """
    prm = robot if isinstance(robot, URParameters) else ur_parameters(robot, atol)
    T = as_real_array("target poses", T)
    if T.ndim < 2 or T.shape[-2:] != (4, 4):
        raise ValueError(f"target poses must have shape (..., 4, 4), got {T.shape}")
    batch = prm.d1.shape
    shape = np.broadcast_shapes(T.shape[:-2], batch, prm.base.shape[:-2], prm.flange.shape[:-2])
    M = int(np.prod(shape, dtype=np.int64))
    T_given = T
    T = np.broadcast_to(T, shape + (4, 4))

    # mount and flange: T' = base⁻¹ · T · flange⁻¹, skipped when they are exactly the identity (UR's
    # own tables); a flange that is a pure translation along z is folded into d6 instead
    d6 = prm.d6
    base, flange = prm.base, prm.flange
    if not np.all(base == np.eye(4)):
        T = _rigid_inverse(base) @ T
    if not np.all(flange == np.eye(4)):
        fz = flange.copy()
        fz[..., 2, 3] = 0.0
        if np.all(fz == np.eye(4)):
            d6 = d6 + flange[..., 2, 3]
        else:
            T = T @ _rigid_inverse(flange)
    T = np.broadcast_to(T, shape + (4, 4)).reshape(M, 4, 4)

    def flat(x):  # a per-arm number as a scalar (one arm) or (M,) aligned with the targets
        x = np.asarray(x, dtype=np.float64)
        return float(x) if x.ndim == 0 else np.broadcast_to(x, shape).reshape(M)

    lengths = [flat(x) for x in (prm.d1, prm.a1, prm.a2, prm.a3, prm.d4, prm.d5, d6)]
    sign = np.broadcast_to(prm.sign, batch + (6,))
    shift = np.broadcast_to(prm.shift, batch + (6,))
    lim = None if prm.qlim is None else np.broadcast_to(prm.qlim, batch + (6, 2))
    # per joint: (sign, shift) unless they are +1 and 0 for every arm; limits unless a full turn or more
    # (then every angle has an equivalent inside and the check is moot)
    joint_map = [None if np.all(sign[..., j] == 1.0) and np.all(shift[..., j] == 0.0)
                 else (flat(sign[..., j]), flat(shift[..., j])) for j in range(6)]
    joint_lim = [None if lim is None or not np.any(lim[..., j, 1] - lim[..., j, 0] < _TWO_PI)
                 else (flat(lim[..., j, 0]), flat(lim[..., j, 1])) for j in range(6)]

    q = np.empty((M, 2, 2, 2, 6))
    valid = np.empty((M, 2, 2, 2), dtype=bool)
    # Blocks of targets keep the temporaries small (in cache, and reused by the allocator):
    # whole-map temporaries (0.6 MB each for 9261 targets) come as fresh pages, whose faults cost
    # more than the arithmetic.
    for m0 in range(0, M, _BLOCK):  # a loop over blocks of targets; each block is vectorised
        blk = slice(m0, min(m0 + _BLOCK, M))
        part = [x if np.ndim(x) == 0 else x[blk] for x in lengths]
        # (shoulder, wrist, elbow, joint, target) views: the branch arrays, targets last and
        # contiguous, are written in one pass each (a transposing copy of whole blocks is slower)
        qv = q[blk].transpose(1, 2, 3, 4, 0)
        vv = valid[blk].transpose(1, 2, 3, 0)
        in_range = []

        def put(j, x):
            """Joint j's canonical angles x (broadcasting to (2, 2, 2, b)) → q, limits → valid."""
            if joint_map[j] is not None:
                s, c = (y if np.ndim(y) == 0 else y[blk] for y in joint_map[j])
                x = _wrap(s * x - c)
            elif j in (1, 3):  # θ2, θ4 are sums of angles; the others are in [-pi, pi] already
                _wrap_in_place(x)
            if joint_lim[j] is not None:
                lo, hi = (y[blk] if np.ndim(y) else y for y in joint_lim[j])
                in_range.append(_angle_in_range(x, lo, hi))
            qv[..., j, :] = x

        vv[...] = _solve(_target_components(T[blk], T_given), *part, atol, put)
        for ok in in_range:
            vv &= ok
    return q.reshape(shape + (8, 6)), valid.reshape(shape + (8,))


def _solve(C, d1, a1, a2, a3, d4, d5, d6, atol, put):
    """The closed form on a block of targets and canonical parameters (scalars or (b,) arrays).

    ``C`` (16, b): the targets' entries row by row (``C[4·i + k] = T[i, k]``), this block's own
    copy (overwritten). Arrays are laid out (shoulder, wrist, elbow, b) with the targets last and
    contiguous: numpy's inner loops then run over the targets, and every quantity is computed at
    the level of the branches it depends on (shoulder terms once for the 4 branches that share
    them, and so on). Calls ``put(j, θ_j)`` for the six canonical angles (broadcastable to
    (2, 2, 2, b)) and returns the geometric reach (2, 2, 1, b).
    """
    # ---- shoulder: the wrist point's component along z1 = (s1, −c1, 0) is d4
    C[3::4] -= d6 * C[2::4]  # the wrist point p − d6·z6 in place of p (rows 3, 7, 11)
    wx, wy, wz, nz, az = C[3], C[7], C[11], C[8], C[10]
    r2 = wx * wx
    r2 += wy * wy
    r = np.sqrt(r2)
    reach_sh = r >= np.abs(d4) - atol
    on_axis = r2 < 1e-200  # wrist point on the joint-1 axis: take the direction (1, 0)
    r += on_axis
    ux, uy = wx / r, wy / r
    ux += on_axis
    sd = np.clip(d4 / r, -1.0, 1.0)  # sin(θ1 − φ); clipped, the branch is the nearest reach
    cd = np.sqrt(1.0 - sd * sd)
    # θ1 = φ + δ and φ + pi − δ: cos δ = ±cd
    c1 = _SIGN * (ux * cd) - uy * sd  # (2, b)
    s1 = _SIGN * (uy * cd) + ux * sd
    put(0, np.arctan2(s1, c1)[:, None, None, :])

    # ---- wrist: z1 seen from the flange gives θ5; z6 seen from frame 1 gives θ2+θ3+θ4 (= ψ).
    # Computed for sin θ5 >= 0; the other wrist branch is θ5 → −θ5, ψ → ψ + pi, θ6 → θ6 + pi.
    # Rows 0..3 of C are the x components of n, o, a and the wrist point, rows 4..7 their y.
    c1_, s1_ = c1[:, None, :], s1[:, None, :]
    on_x1 = C[0:4] * c1_  # (2, 4, b): n, o, a, wrist point · x1
    on_x1 += C[4:8] * s1_
    on_z1 = C[0:3] * s1_  # (2, 3, b): n, o, a · z1
    on_z1 -= C[4:7] * c1_
    u, v, w = on_z1[:, 0], on_z1[:, 1], on_z1[:, 2]  # w = cos θ5
    nx1, ax1 = on_x1[:, 0], on_x1[:, 2]
    s5 = np.sqrt(u * u + v * v)
    th5 = np.arctan2(s5, w)
    m = np.sqrt(ax1 * ax1 + az * az)  # = |sin θ5|, from the other side
    sing = m < _SINGULAR
    m += sing
    # z6 = −sin θ5 · x4 + cos θ5 · z1  →  (cos ψ, sin ψ) = −(a·x1, a_z) / sin θ5
    cp = ax1 / m
    np.negative(cp, out=cp)
    cp += sing
    sp = az / m
    np.negative(sp, out=sp)
    # θ6 from frames 4 and 5 as fixed above: exact for whatever ψ (also near the singularity)
    x4n = cp * nx1
    x4n += sp * nz
    z4n = cp * nz
    z4n -= sp * nx1
    x4n *= w
    x4n += s5 * u
    th6 = np.empty((2, 2, r.shape[0]))
    np.arctan2(z4n, x4n, out=th6[:, 0])
    np.subtract(th6[:, 0], np.copysign(np.pi, th6[:, 0]), out=th6[:, 1])  # + pi, in [-pi, pi]
    psi = np.empty((2, 2, r.shape[0]))
    np.arctan2(sp, cp, out=psi[:, 0])
    np.add(psi[:, 0], np.pi, out=psi[:, 1])
    X0 = on_x1[:, 3]  # the wrist point in the arm plane (frame 1)
    X0 -= a1
    Y0 = wz - d1
    sp *= d5
    cp *= d5
    # the frame-4 origin p5 − d5·z4 in the arm plane, z4 = ±(sin ψ · x1 − cos ψ · y1)
    X = X0[:, None, :] - _SIGN * sp[:, None, :]  # (2, 2, b)
    Y = _SIGN * cp[:, None, :]
    Y += Y0
    if np.any(sing):
        _singular_wrist(sing, psi, th6, X, Y, X0, Y0, s5, u, w, nx1, nz, a2, a3, d5)
    th5 = th5[:, None, None, :] * _SIGN[:, :, None]
    put(4, th5)
    put(5, th6[:, :, None, :])

    # ---- elbow: a planar two-link arm (a2, a3) to (X, Y)
    rho2 = X * X
    rho2 += Y * Y
    L1, L2 = np.abs(a2), np.abs(a3)
    lo, hi = np.maximum(np.abs(L1 - L2) - atol, 0.0), L1 + L2 + atol
    reach = rho2 >= lo * lo
    reach &= rho2 <= hi * hi
    reach &= reach_sh
    den = 2.0 * a2 * a3
    free = den == 0.0  # a2 or a3 zero: θ3 is free (or fixed by reach alone); take θ3 = 0
    k1 = np.where(free, 0.0, 1.0 / np.where(free, 1.0, den))
    c3 = rho2
    c3 -= a2 * a2 + a3 * a3
    c3 *= k1
    c3 += free
    np.clip(c3, -1.0, 1.0, out=c3)
    s3 = c3 * c3
    np.subtract(1.0, s3, out=s3)
    np.sqrt(s3, out=s3)
    gam = np.arctan2(Y, X)
    th3 = np.arctan2(s3, c3)
    s3 *= a3
    c3 *= a3
    c3 += a2
    beta = np.arctan2(s3, c3)
    # elbow branches: the sign of sin θ3
    th = np.empty((2, 2, 2, r.shape[0]))
    np.subtract(gam, beta, out=th[:, :, 0])
    np.add(gam, beta, out=th[:, :, 1])
    put(1, th)
    th = np.empty((2, 2, 2, r.shape[0]))
    th[:, :, 0] = th3
    np.negative(th3, out=th[:, :, 1])
    put(2, th)
    psi -= gam
    beta -= th3
    th = np.empty((2, 2, 2, r.shape[0]))
    np.add(psi, beta, out=th[:, :, 0])
    np.subtract(psi, beta, out=th[:, :, 1])
    put(3, th)
    return reach[:, :, None, :]


def _singular_wrist(sing, psi, th6, X, Y, X0, Y0, s5, u, w, nx1, nz, a2, a3, d5):
    """Choose ψ where the wrist is singular; ``psi``, ``th6``, ``X``, ``Y`` (2, 2, b) in place.

    The frame-4 origin ``o = P + d5·e`` (``P`` the wrist point in the arm plane, ``e = (−sin ψ,
    cos ψ)``) then runs round a circle; the elbow reaches ``|o|`` in an annulus around the shoulder
    that contains ``a2² + a3²`` (a right-angled elbow). Aiming ``|o|²`` at that value, clipped to
    what the circle offers, lands in the annulus whenever the circle meets it. The two wrist
    branches take the two points of the circle with that ``|o|``.
    """
    ii, mm = np.nonzero(sing)
    pick = (lambda x: x if np.ndim(x) == 0 else x[mm])
    Px, Py = X0[ii, mm], Y0[mm]
    A2, A3, D5 = pick(a2), pick(a3), pick(d5)
    pn = np.hypot(Px, Py)
    tiny = (pn < 1e-150) | (np.abs(D5) < 1e-150)
    pn_s = np.where(tiny, 1.0, pn)
    ex, ey = np.where(tiny, 1.0, Px / pn_s), np.where(tiny, 0.0, Py / pn_s)  # P̂
    k = (A2 * A2 + A3 * A3 - pn * pn - D5 * D5) / np.where(tiny, 1.0, 2.0 * D5 * pn_s)
    kappa = np.where(tiny, 0.0, np.clip(k, -1.0, 1.0))
    perp = np.sqrt(1.0 - kappa * kappa)
    S5, U, W, NX1, NZ = s5[ii, mm], u[ii, mm], w[ii, mm], nx1[ii, mm], nz[mm]
    for jw, sgn in ((0, 1.0), (1, -1.0)):
        e_x = kappa * ex - sgn * perp * ey
        e_y = kappa * ey + sgn * perp * ex
        cp, sp = e_y, -e_x
        psi[ii, jw, mm] = np.arctan2(sp, cp)
        th6[ii, jw, mm] = np.arctan2(cp * NZ - sp * NX1, W * (cp * NX1 + sp * NZ) + sgn * S5 * U)
        X[ii, jw, mm] = Px + D5 * e_x
        Y[ii, jw, mm] = Py + D5 * e_y


def ur_reachable(robot, T, atol: float = 1e-9) -> np.ndarray:
    """True where some branch of :func:`ikine_ur` is valid: bool, shape ``T.shape[:-2]`` broadcast
    with the robot's batch shape."""
    return ikine_ur(robot, T, atol)[1].any(axis=-1)
