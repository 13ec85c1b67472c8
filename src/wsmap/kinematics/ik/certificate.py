"""Certified unreachability: a sound proof, per target pose, that no configuration inside the joint
limits puts the tool there (within a margin).

Three certificates, tried cheapest first (`certify`):

* the sound pre-filters of `wsmap.kinematics.ik.reach_filter` (`reach_filter`: the wrist point
  beyond the links' reach or outside the set the joints before it sweep it through;
  `limit_filter`: one of three invariants of the last joint's axis outside the interval the limits
  allow);
* `joint_certificate` (arms of revolute joints, n >= 3): a branch and bound over the box of joints
  `1 .. n-2` that checks invariants of the last joint's axis *jointly* — the distance `d`,
  the projections `g` (on the axis) and `h` (on joint 0's axis) of the point `W` of the last
  axis from a point `S` of joint 0's axis, the cosine `k` between the last axis and joint 0's
  axis, and the signed `m = a0·((W - S) × z)`. Joint 0 turns `W - S` and the last axis rigidly
  about its axis and joint n-1 turns about the last axis, so none of the five depends on either: a
  configuration reaching the pose must have joints `1 .. n-2` where all five equal the pose's. A box
  of those joints is discarded when a sound bound of one invariant, or of a combination of their
  linear forms, over it (second-order Taylor, `_box_bounds`, `_combination_dead`) excludes the
  pose's value by more than the margin, or when the turn of joint 0 or of joint n-1 that the pose
  needs from that box lies outside its limits (`_ends_dead`); the pose is certified when every box
  is discarded, and not certified (the answer "not found") when the cell budget runs out. Near an
  aligned last axis the tilt of `z` across `a0` adds two linear forms (`_tilt_rows`); a spherical
  shoulder's joints are split last (`SHOULDER_FIRST_WIDTH`); a joint whose axis nearly passes
  through `S` counts as a turn about `S` plus a shift in the first pass (`NEAR_RIGID_MAX`);
* `closed_form_certificate` (arms of a closed-form family): every branch the closed form enumerates
  fails, and the enumeration is complete there (no branch singular, see the function).

The proof obligations are written out in `docs/maps.md` ("Certified unreachable"). Lengths in
metres, angles in radians; target poses `(..., 4, 4)` in the arm's world frame (base included).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ..chain import PRISMATIC, SerialChain, as_chain
from .memo import Memo, content_key
from .reach_filter import joint_box_and_radius, limit_filter, limit_geometry, reach_filter, through_point
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap.kinematics.chain import Arm

__all__ = ["CERTIFY_MARGIN", "CELL_BUDGET", "CELL_DEPTH", "GIVE_UP_NEAR", "SINGULAR_SIGMA", "TILT_MAX",
           "SHOULDER_FIRST_WIDTH", "NEAR_RIGID_MAX", "certify", "joint_certificate",
           "filter_certificate",
           "closed_form_certificate"]

#: The certificates' default margin (m in position, rad in rotation angle): a pose this close to a
#: reachable one is never certified. It equals the search's forward-kinematics confirmation
#: tolerance, so a node the search confirms is never certified.
CERTIFY_MARGIN = 1e-6
#: Boxes `joint_certificate` bounds per pose before it gives up (the pose is then "not found").
CELL_BUDGET = 5_000
#: Splits deep a box of `joint_certificate` may lie (its stack's size) before the pose gives up.
CELL_DEPTH = 160
#: `joint_certificate` gives up at a box centre whose invariants all lie this close (m, or the
#: cosine) to the pose's: the pose is most likely reachable, and no box budget would prove otherwise.
GIVE_UP_NEAR = 1e-4
#: The least smallest singular value (m or rad per rad) of a real branch's Jacobian at which
#: `closed_form_certificate` counts it regular.
SINGULAR_SIGMA = 1e-3
#: The tests `joint_certificate` applies to a box beside the four invariants' intervals, a bit mask:
#: 1, the limits of joints 0 and n-1 (`_ends_dead`); 2, the signed invariant `m` and the
#: combinations of the invariants' linear forms (`_combination_dead`); 4, the split across the joint
#: that adds most to that combination's bound (`_split_by_effect`; else the joint that moves `W` and
#: `z` most); 8, the box narrowed to the offsets the linear forms allow before it is split
#: (`_contract`; a box narrowed below 0.7 of a half-width is bounded again first). 0 is the
#: certificate before them (`benchmarks/maps/bench_certificates.py --compare` measures both side by
#: side); 16, the tilt of the last axis across joint 0's (`_tilt_rows`: two more linear forms, used
#: where the pose's tilt is below `TILT_MAX`); 32, the shoulder first (`SHOULDER_FIRST_WIDTH`);
#: 64, the near joint of the first pass (`NEAR_RIGID_MAX`). 15 is the certificate of before these three.
BOX_TESTS = 127
#: The pose's tilt `|z⊥|` (the sine of the angle between the last axis and joint 0's) below which
#: `joint_certificate` adds the two tilt forms: near an aligned last axis (tool down, `R = I` on
#: the named arms) `k = z·a0` is at its extreme ±1 and its linear form is flat there, while the
#: two components of `z⊥` are not.
TILT_MAX = 0.3
#: With a spherical shoulder (joints 1 and 2 both turn `W - S` and `z` rigidly about `S`, as on the
#: Panda and the iiwa), `joint_certificate` splits the joints after the shoulder first, until each
#: half-width is below this (rad); `d` and `g` depend on those joints only and discard most boxes
#: once they are narrow (measured in `docs/maps.md`). 0: off.
SHOULDER_FIRST_WIDTH = 0.15
#: The largest distance (m) of `S` from the axis of the joint after the rigid run at which the first
#: pass (`d` and `g` alone) bounds that joint's effect as a turn about `S` plus a shift (the Gen3's
#: joint 2, 11.8 mm) rather than by its Taylor form.
NEAR_RIGID_MAX = 0.05
#: Reweighted directions `_combination_dead` tries after the first. 0: with the narrowing on, two
#: rounds certified no more of the named arms' tool-down nodes and fewer of the Gen3's at 20000
#: boxes (7698 against 7718 of 7775), at 1.1-1.6 times the time.
COMBINATION_ROUNDS = 0

_GEOMETRY = Memo()


def filter_certificate(robot: Arm, T, margin: float = CERTIFY_MARGIN) -> np.ndarray:
    """`(...,)` True where `reach_filter` or `limit_filter` proves the poses `T` `(..., 4, 4)`
    out of reach within `margin` (one arm or a batch for `reach_filter`; `limit_filter` on one
    arm with limits)."""
    chain = as_chain(robot)
    T = np.asarray(T, dtype=np.float64)
    out = ~np.asarray(reach_filter(chain, T, margin), dtype=bool)
    if chain.qlim is not None and chain.batch_shape == ():
        out |= ~np.asarray(limit_filter(chain, T, margin), dtype=bool)
    return out


def _geometry(chain: SerialChain):
    """The branch and bound's numbers for one arm of revolute joints (chain without base and tool),
    memoised by content; None where it does not apply (fewer than 3 joints, a prismatic joint)."""
    if chain.n < 3 or any(k == PRISMATIC for k in chain.kinds):
        return None
    key = content_key(chain.fixed, chain.axes, chain.kinds, np.asarray(chain.offset), chain.qlim)
    return _GEOMETRY.get(key, lambda: _make_geometry(chain.replace(base=None, tool=None)))


def _make_geometry(chain: SerialChain):
    n = chain.n
    S, w_loc, frames = limit_geometry(chain)
    box, radius = joint_box_and_radius(chain, w_loc)
    a0 = frames[0, :3, :3] @ chain.axes[0]
    rigid = np.zeros(n, dtype=np.bool_)
    rigid[[j for j in through_point(chain, frames, S) if j < n - 1]] = True
    # the joint after the rigid run, where its axis passes within NEAR_RIGID_MAX of S: its turn moves
    # W - S by a turn about a line through S plus at most 2 sin(δ/2)·ε (ε its axis's distance from S,
    # the same at every turn of the joints before it, which all turn about lines through S)
    near = np.zeros(n)
    j = int(rigid.sum()) + 1
    if rigid.any() and j < n - 1:
        aj = frames[j, :3, :3] @ chain.axes[j]
        r = S - frames[j, :3, 3]
        eps = float(np.linalg.norm(r - (r @ aj) * aj))
        if eps <= NEAR_RIGID_MAX:
            near[j] = eps * (1.0 + 1e-9) + 1e-15
    # the limits of joints 0 and n-1: a basis of joint 0's normal plane, a unit vector e_loc across the
    # last axis (in its frame) and the one a quarter turn on, the half-widths and the last box's centre
    b1 = _across(a0)
    zl = chain.axes[n - 1]
    e_loc = _across(zl)
    half = 0.5 * (box[:, 1] - box[:, 0])
    ends = np.concatenate([b1, np.cross(a0, b1), e_loc, np.cross(zl, e_loc),
                           [half[0], 0.5 * (box[n - 1, 0] + box[n - 1, 1]) + float(np.broadcast_to(chain.offset, (n,))[n - 1]),
                            half[n - 1]]])
    return dict(chain=chain, S=S, a0=a0, w_loc=w_loc, box=box, radius=radius, rigid=rigid, near=near, ends=ends,
                e_loc=e_loc,
                scale=float(np.linalg.norm(chain.fixed[:, :3, 3], axis=-1).sum() + np.linalg.norm(w_loc)))


def _across(a):
    """A unit vector (3,) perpendicular to the unit vector `a`."""
    ref = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    b = np.cross(a, ref)
    return b / np.linalg.norm(b)


def _pose_invariants(chain: SerialChain, geo, T, margin):
    """The five invariants `(N, 6)` (`d, g, h, k, m`, then the tilt `|z⊥|`, the length of the last
    axis across joint 0's) of the poses `T` `(N, 4, 4)`, how far `(N, 5)` a pose within `margin` of
    them moves each of the five (with the rounding of this arithmetic; the tilt moves as `k`), and
    the vectors `(N, 11)` of `_ends_dead`: `u = W - S`, `z`, the last joint frame's `e_loc` after
    its turn, the slacks of `u` (m) and of the unit vectors."""
    n = chain.n
    G = chain.fixed[n] if chain.tool is None else chain.fixed[n] @ chain.tool
    # the last joint's frame is T·G⁻¹: W and the last axis z in the tool frame
    v = G[:3, :3].T @ (geo["w_loc"] - G[:3, 3])
    zt = G[:3, :3].T @ chain.axes[n - 1]
    et = G[:3, :3].T @ geo["e_loc"]
    if chain.base is not None:
        T = np.linalg.inv(chain.base) @ T
    R = T[:, :3, :3]
    u = T[:, :3, 3] + R @ v - geo["S"]
    z = R @ zt
    a0 = geo["a0"]
    d = np.linalg.norm(u, axis=-1)
    m = np.cross(u, z) @ a0
    # the tilt |z⊥|: joint 0 turns z⊥ about a0, so its length is the pose's
    tilt = np.linalg.norm(z - np.outer(z @ a0, a0), axis=-1)
    values = np.stack([d, np.einsum("ni,ni->n", u, z), u @ a0, z @ a0, m, tilt], axis=-1)
    # a pose within margin of T moves W by at most margin·(1 + |v|) and z by margin (a turn of
    # margin rad moves a unit vector by at most margin); g and m are products of the two
    sW = margin * (1.0 + float(np.linalg.norm(v)))
    tiny = 1e-9 * (1.0 + geo["scale"] + float(np.linalg.norm(v)))
    sg = sW + margin * (d + sW) + tiny
    slack = np.stack([np.full_like(d, sW + tiny), sg, np.full_like(d, sW + tiny), np.full_like(d, margin + 1e-12), sg],
                     axis=-1)
    pv = np.concatenate([u, z, R @ et, np.full((len(d), 1), sW + tiny), np.full((len(d), 1), margin + 1e-12)], axis=-1)
    return values, slack, pv


def joint_certificate(robot: Arm, T, margin: float = CERTIFY_MARGIN, *, budget: int = CELL_BUDGET,
                      depth: int = CELL_DEPTH) -> np.ndarray:
    """`(N,)` True where a branch and bound over joints `1 .. n-2` proves that no configuration
    inside the limits puts the tool within `margin` of the pose `T[i]` (`T` `(N, 4, 4)`, one arm).

    Every pose starts with one box, the limits of joints `1 .. n-2` (a full turn where a range is
    a turn or more; 1e-9 rad wider, the search's own slack). Depth first, each box's five
    invariants are bounded (`_box_bounds`); a box whose bounds, or a combination of them
    (`_combination_dead`), exclude the pose's values by more than the margin's effect
    (`_pose_invariants`), or that needs joint 0 or joint n-1 outside its limits (`_ends_dead`), is
    discarded; any other is narrowed to the offsets its linear forms allow (`_contract`) and split
    in two (`BOX_TESTS` says across which joint). A pose is certified
    when every box is discarded; it gives up (False: "not found") after `budget` boxes, deeper than
    `depth` splits, or at a box centre whose invariants all lie within `GIVE_UP_NEAR` of the pose's
    and inside the limits of joints 0 and n-1 (a pose that is most likely reachable). All False for an arm it does not apply to (prismatic joints, fewer
    than 3 joints, a batch). Compiled (numba), poses in parallel; each pose's answer is its own.
    """
    chain = as_chain(robot)
    T = np.asarray(T, dtype=np.float64).reshape(-1, 4, 4)
    N = len(T)
    out = np.zeros(N, dtype=np.int8)
    if chain.batch_shape != () or N == 0:
        return out.astype(bool)
    geo = _geometry(chain)
    if geo is None:
        return out.astype(bool)
    values, slack, pv = _pose_invariants(chain, geo, T, margin)
    c = geo["chain"]
    args = (np.ascontiguousarray(c.fixed, dtype=np.float64), np.ascontiguousarray(c.axes, dtype=np.float64),
            np.ascontiguousarray(np.broadcast_to(c.offset, (c.n,)), dtype=np.float64), geo["S"], geo["a0"],
            geo["w_loc"], geo["radius"], geo["rigid"], geo["box"])
    values, slack, pv = np.ascontiguousarray(values), np.ascontiguousarray(slack), np.ascontiguousarray(pv)
    todo = np.arange(N)
    tests = int(BOX_TESTS)
    # the shoulder first where joints 1 and 2 are both rigid (a spherical shoulder with joint 0)
    shoulder = float(SHOULDER_FIRST_WIDTH) if tests & 32 and geo["rigid"][1:3].sum() == 2 else 0.0
    if geo["rigid"].any():
        # first d and g alone, over the joints that change them (fewer dimensions, far fewer boxes)
        near = geo["near"] if tests & 64 else np.zeros(c.n)
        _certify_boxes(*args, True, values, slack, pv, geo["ends"], tests, int(COMBINATION_ROUNDS), GIVE_UP_NEAR,
                       float(TILT_MAX), shoulder, near, int(budget), int(depth), out)
        todo = np.flatnonzero(out == 0)
    if todo.size:
        part = np.zeros(todo.size, dtype=np.int8)
        _certify_boxes(*args, False, values[todo], slack[todo], pv[todo], geo["ends"], tests, int(COMBINATION_ROUNDS),
                       GIVE_UP_NEAR, float(TILT_MAX), shoulder, np.zeros(c.n), int(budget), int(depth), part)
        out[todo] = part
    return out.astype(bool)


def _with_qlim(robot, qlim):
    """The same arm with other limits (`None`: none)."""
    if isinstance(robot, SerialChain):
        return robot.replace(qlim=qlim)
    return type(robot)(robot.d, robot.a, robot.alpha, qlim=qlim, tool=robot.tool, name=robot.name)


def closed_form_certificate(robot: Arm, T, margin: float = CERTIFY_MARGIN) -> np.ndarray:
    """`(...,)` True where the registered closed form of one arm proves the poses `T` `(..., 4, 4)`
    unreachable; all False for an arm without a closed form (or a batch of arms).

    The closed form solves the pose for every branch it enumerates. It is certified here when

    1. no branch succeeds with its reach tolerance widened to `margin` (so a pose within rounding
       of the reach boundary is never certified) and the limits widened by `margin` rad, and
    2. every branch that is real without limits (its reach tests pass) is regular: the smallest
       singular value of its 6 x n Jacobian is at least `SINGULAR_SIGMA` (m or rad per rad).

    Why (2): each closed form enumerates the solutions of a regular pose exactly (two roots of each
    shoulder and elbow equation, the wrist's two roots: the 8 branches of a 6R arm), but at a
    singular pose a joint is free (the wrist centre on joint 0's axis, an aligned wrist, a
    degenerate elbow) and the closed form returns one value of a continuum; with limits another value
    may lie inside them. A continuum of solutions is singular (its tangent is in the Jacobian's null
    space), so a pose whose every real branch is regular has only those branches as solutions, each
    isolated, and a branch outside the widened limits has no solution inside the limits near it
    (its angle error is about the pose error over the smallest singular value, far below `margin`).
    """
    from .registry import closed_form_for  # the registry imports the closed forms lazily

    T = np.asarray(T, dtype=np.float64)
    cf = closed_form_for(robot)
    shape = T.shape[:-2]
    if cf is None or robot.batch_shape != ():
        return np.zeros(shape, dtype=bool)
    atol = max(margin, 1e-9)
    qlim = getattr(robot, "qlim", None)
    if qlim is not None:
        wide = _with_qlim(robot, np.asarray(qlim, dtype=np.float64) + np.array([-margin, margin]))
        limited = np.asarray(cf.solve(wide, T, atol=atol).success).any(axis=-1)
        free = _with_qlim(robot, None)
    else:
        limited = None
        free = robot
    sol = cf.solve(free, T, atol=atol)
    real = np.asarray(sol.success, dtype=bool)  # (..., branches)
    found = real.any(axis=-1) if limited is None else limited
    cert = ~found
    if qlim is None or not cert.any():
        return np.broadcast_to(cert, shape).copy()
    # poses where real branches exist but all leave the limits: each real branch must be regular
    q = np.asarray(sol.q, dtype=np.float64)
    idx = np.nonzero(cert[..., None] & real)
    if len(idx[0]):
        J = robot.jacob0(q[idx])
        sigma = np.linalg.svd(J, compute_uv=False)[..., -1]
        bad = sigma < SINGULAR_SIGMA
        cert = cert.copy()
        cert[tuple(i[bad] for i in idx[:-1])] = False
    return np.broadcast_to(cert, shape).copy()



def certify(robot: Arm, T, margin: float = CERTIFY_MARGIN, *, method: str = "numerical",
            budget: int = CELL_BUDGET, depth: int = CELL_DEPTH) -> np.ndarray:
    """`(...,)` True where the poses `T` `(..., 4, 4)` are certified unreachable (within `margin`)
    for one arm: the sound pre-filters, then (on the poses they leave) the closed form's certificate
    (`method="exact"`) or `joint_certificate`; both for an exact arm when `method="both"`.
    A chain with coupled joints is certified through its relaxation (`SerialChain.uncoupled`, the
    joints free in their own limits), whose reachable set contains the coupled chain's."""
    robot = robot.uncoupled() if isinstance(robot, SerialChain) else robot
    T = np.asarray(T, dtype=np.float64)
    shape = T.shape[:-2]
    flat = T.reshape(-1, 4, 4)
    out = filter_certificate(robot, flat, margin).reshape(-1)
    if method in ("exact", "both"):
        left = np.flatnonzero(~out)
        if left.size:
            out[left] = closed_form_certificate(robot, flat[left], margin)
    if method in ("numerical", "both"):
        left = np.flatnonzero(~out)
        if left.size:
            out[left] = joint_certificate(robot, flat[left], margin, budget=budget, depth=depth)
    return out.reshape(shape)


# --------------------------------------------------------------------------- the compiled box loop
@njit(cache=True, inline="always")
def _centre_frames(fixed, axes, offset, n, c, F, Z):
    """The frames of joints `0 .. n-1` at `c` (n,) into `F` (n, 12): rotation row-major (9),
    origin (3); the chain without its base (`fixed[0]` first); `Z` (7, 9) scratch."""
    # the frames of joints 0 .. n-1 at the centre (chain without base: fixed[0] first)
    R, t, Rn, Q, RQ = Z[0], Z[1], Z[2], Z[3], Z[4]
    for r in range(3):
        for k in range(3):
            R[3 * r + k] = fixed[0, r, k]
        t[r] = fixed[0, r, 3]
    for i in range(n):
        for k in range(9):
            F[i, k] = R[k]
        for k in range(3):
            F[i, 9 + k] = t[k]
        if i == n - 1:
            break
        th = c[i] + offset[i]
        cs, sn = math.cos(th), math.sin(th)
        cc = 1.0 - cs
        x, y, z = axes[i, 0], axes[i, 1], axes[i, 2]
        # Rodrigues: the joint's turn, then the next fixed transform
        Q[0] = cs + x * x * cc
        Q[1] = x * y * cc - z * sn
        Q[2] = x * z * cc + y * sn
        Q[3] = y * x * cc + z * sn
        Q[4] = cs + y * y * cc
        Q[5] = y * z * cc - x * sn
        Q[6] = z * x * cc - y * sn
        Q[7] = z * y * cc + x * sn
        Q[8] = cs + z * z * cc
        for r in range(3):
            for k in range(3):
                RQ[3 * r + k] = R[3 * r] * Q[k] + R[3 * r + 1] * Q[3 + k] + R[3 * r + 2] * Q[6 + k]
        M = fixed[i + 1]
        for r in range(3):
            for k in range(3):
                Rn[3 * r + k] = RQ[3 * r] * M[0, k] + RQ[3 * r + 1] * M[1, k] + RQ[3 * r + 2] * M[2, k]
            t[r] = t[r] + RQ[3 * r] * M[0, 3] + RQ[3 * r + 1] * M[1, 3] + RQ[3 * r + 2] * M[2, 3]
        for k in range(9):
            R[k] = Rn[k]


@njit(cache=True)
def _box_bounds(fixed, axes, offset, S, a0, w_loc, radius, rigid, n, c, hw, F, Z, lo, hi, G, R):
    """Sound bounds of `d`, `g`, `h`, `k` over the box `c ± hw` (n,) rad (`hw` 0 off joints
    `1 .. n-2`), into `lo[:4]`, `hi` (4,); the centre's invariants `d, g, h, k, m` into `lo[4:9]`,
    the joint to split into `lo[9]`, bounds of how far `u = W - S` and `z` move over the box into
    `lo[10]`, `lo[11]` (m, and a unit vector's chord), `Σ hw` into `lo[12]`.

    The linear form of the five invariants `f = (d², g, h, k, m)` (`m = a0·(u × z)`, the signed
    part the four others miss: a pose and its mirror image in a plane through joint 0's axis share
    `d, g, h, k`): `G` (5, n) the derivatives at the centre, `R` (5,) with
    `|f_i(c + δ) - f_i(c) - G_i·δ| <= R_i` over the box.

    `W(c + δ) = W(c) + Jδ + r` with `|r| <= Σ_ij radius[max(i, j)] hw_i hw_j / 2` (each second
    derivative of `W` is a double cross product of unit axes with `W`'s offset from the later
    joint's axis, at most `radius` m); `z(c + δ) = z(c) + Kδ + r_z`, `|r_z| <= (Σ hw)² / 2`. Then
    `d = |u|` (`u = W - S`) lies within `sqrt(|u|² ± 2 Σ|u·J_j| hw_j + (Σ|J_j| hw_j)²) ± |r|`,
    `h = u·a0` within `Σ|J_j·a0| hw_j + |r|` of its centre value, `k = z·a0` within
    `Σ|K_j·a0| hw_j + r_z`, and `g = u·z` within its first-order change plus the products of the
    remainders. Joints in `rigid` (an unbroken run from joint 1 whose axes pass through `S`) turn
    `u` and `z` rigidly about `S` and change neither `d` nor `g`: those two sum over the other
    joints only. Scratch: `F` (n, 14), the joint frames' rotations (row-major, 9) and origins (3);
    `Z` (7, 9). No fastmath: each operation rounds once, far inside the margin's slack."""
    _centre_frames(fixed, axes, offset, n, c, F, Z)
    W, zz = Z[5], Z[6]
    # W and z of the last joint's frame
    L = n - 1
    for r in range(3):
        W[r] = F[L, 3 * r] * w_loc[0] + F[L, 3 * r + 1] * w_loc[1] + F[L, 3 * r + 2] * w_loc[2] + F[L, 9 + r]
        zz[r] = F[L, 3 * r] * axes[L, 0] + F[L, 3 * r + 1] * axes[L, 1] + F[L, 3 * r + 2] * axes[L, 2]
    u0, u1, u2 = W[0] - S[0], W[1] - S[1], W[2] - S[2]
    du = math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
    # z × a0 and a0 × u: m's derivative a0·(J×z + u×K) = J·(z×a0) + K·(a0×u)
    za0, za1, za2 = zz[1] * a0[2] - zz[2] * a0[1], zz[2] * a0[0] - zz[0] * a0[2], zz[0] * a0[1] - zz[1] * a0[0]
    au0, au1, au2 = a0[1] * u2 - a0[2] * u1, a0[2] * u0 - a0[0] * u2, a0[0] * u1 - a0[1] * u0
    # d and g: the joints not in `rigid` (a rigid joint turns W - S and z about S: d and g unchanged);
    # h, k and m: every joint
    A = 0.0
    Bz = 0.0
    A_all = 0.0
    Bz_all = 0.0
    uJ = 0.0
    lin_g = 0.0
    lin_h = 0.0
    lin_k = 0.0
    best = -1.0
    split = 1
    for j in range(n):
        for i in range(5):
            G[i, j] = 0.0
    for j in range(1, n - 1):
        h = hw[j]
        F[j, 12] = 0.0
        F[j, 13] = 0.0
        if h == 0.0:
            continue
        aj0 = F[j, 0] * axes[j, 0] + F[j, 1] * axes[j, 1] + F[j, 2] * axes[j, 2]
        aj1 = F[j, 3] * axes[j, 0] + F[j, 4] * axes[j, 1] + F[j, 5] * axes[j, 2]
        aj2 = F[j, 6] * axes[j, 0] + F[j, 7] * axes[j, 1] + F[j, 8] * axes[j, 2]
        p0, p1, p2 = W[0] - F[j, 9], W[1] - F[j, 10], W[2] - F[j, 11]
        J0, J1, J2 = aj1 * p2 - aj2 * p1, aj2 * p0 - aj0 * p2, aj0 * p1 - aj1 * p0
        K0, K1, K2 = aj1 * zz[2] - aj2 * zz[1], aj2 * zz[0] - aj0 * zz[2], aj0 * zz[1] - aj1 * zz[0]
        nJ = math.sqrt(J0 * J0 + J1 * J1 + J2 * J2)
        nK = math.sqrt(K0 * K0 + K1 * K1 + K2 * K2)
        F[j, 12] = nJ  # W's distance from joint j's axis at the centre
        F[j, 13] = nK  # the sine of the angle between joint j's axis and z at the centre
        Gh = J0 * a0[0] + J1 * a0[1] + J2 * a0[2]
        Gk = K0 * a0[0] + K1 * a0[1] + K2 * a0[2]
        G[2, j] = Gh
        G[3, j] = Gk
        G[4, j] = J0 * za0 + J1 * za1 + J2 * za2 + K0 * au0 + K1 * au1 + K2 * au2
        lin_h += abs(Gh) * h
        lin_k += abs(Gk) * h
        A_all += nJ * h
        Bz_all += nK * h
        # the split: the joint whose box width moves W and z most here (and bounds the remainder)
        lever = (nJ + nK + radius[j] * h) * h
        if lever > best:
            best = lever
            split = j
        if rigid[j]:
            continue
        uj = u0 * J0 + u1 * J1 + u2 * J2
        gj = u0 * K0 + u1 * K1 + u2 * K2 + J0 * zz[0] + J1 * zz[1] + J2 * zz[2]
        G[0, j] = 2.0 * uj
        G[1, j] = gj
        A += nJ * h
        Bz += nK * h
        uJ += abs(uj) * h
        lin_g += abs(gj) * h
    # second-order remainders: the (i, j) second derivative of W is bounded by W's distance from
    # the axis of joint m = max(i, j) somewhere in the box, at most its centre value plus how far
    # the later joints move W (Σ_{k>m} radius_k hw_k), and never above radius_m; of z likewise by
    # the sine of the angle between axis m and z, at most its centre value plus Σ_{k>m} hw_k, and 1
    rW = 0.0
    rz = 0.0
    rW_d = 0.0
    rz_d = 0.0
    sufW = 0.0
    sufZ = 0.0
    for m in range(n - 2, 0, -1):
        h = hw[m]
        if h == 0.0:
            continue
        rho = min(radius[m], F[m, 12] + sufW)
        kap = min(1.0, F[m, 13] + sufZ)
        # Σ_{i,j} B_max(i,j) hw_i hw_j = Σ_m B_m hw_m (hw_m + 2 Σ_{i<m} hw_i)
        before = 0.0
        before_d = 0.0
        for i in range(1, m):
            before += hw[i]
            if not rigid[i]:
                before_d += hw[i]
        rW += rho * h * (h + 2.0 * before)
        rz += kap * h * (h + 2.0 * before)
        if not rigid[m]:
            rW_d += rho * h * (h + 2.0 * before_d)
            rz_d += kap * h * (h + 2.0 * before_d)
        sufW += radius[m] * h
        sufZ += h
    rW *= 0.5
    rz *= 0.5
    rW_d *= 0.5
    rz_d *= 0.5
    g = u0 * zz[0] + u1 * zz[1] + u2 * zz[2]
    rem_g = lin_g + A * Bz + rW_d * (1.0 + Bz + rz_d) + (du + A) * rz_d
    hh = u0 * a0[0] + u1 * a0[1] + u2 * a0[2]
    kk = zz[0] * a0[0] + zz[1] * a0[1] + zz[2] * a0[2]
    hi[0] = math.sqrt(du * du + 2.0 * uJ + A * A) + rW_d
    lo[0] = math.sqrt(max(du * du - 2.0 * uJ, 0.0)) - rW_d
    hi[1] = g + rem_g
    lo[1] = g - rem_g
    hi[2] = hh + lin_h + rW
    lo[2] = hh - lin_h - rW
    hi[3] = kk + lin_k + rz
    lo[3] = kk - lin_k - rz
    # the centre's own values (the give-up test, the linear forms), in the slots 4 .. 8
    lo[4] = du
    lo[5] = g
    lo[6] = hh
    lo[7] = kk
    lo[8] = a0[0] * (u1 * zz[2] - u2 * zz[1]) + a0[1] * (u2 * zz[0] - u0 * zz[2]) + a0[2] * (u0 * zz[1] - u1 * zz[0])
    lo[9] = split
    lo[10] = A_all + rW
    lo[11] = Bz_all + rz
    lo[12] = sufZ
    # the remainders of the linear forms: u' = u + Jδ + r_W, z' = z + Kδ + r_z (z' a unit vector)
    R[0] = 2.0 * du * rW_d + (A + rW_d) * (A + rW_d)
    R[1] = (du + A) * rz_d + A * Bz + rW_d
    R[2] = rW
    R[3] = rz
    R[4] = (du + A_all) * rz + A_all * Bz_all + rW


@njit(cache=True)
def _solve_direction(e, G, hw, Rs, k, n, M, lam, wt):
    """`lam` (k,) solving `(Σ_j wt_j hw_j² G_j G_jᵀ + diag(wt_{n+a} Rs_a²)) λ = e` (Cholesky, in
    `M`); False where the matrix is not positive (then `lam` is not set)."""
    for a in range(k):
        for b in range(a + 1):
            s = 0.0
            for j in range(n):
                s += wt[j] * hw[j] * hw[j] * G[a, j] * G[b, j]
            M[a, b] = s
        M[a, a] += wt[n + a] * Rs[a] * Rs[a]
    for a in range(k):
        for b in range(a + 1):
            s = M[a, b]
            for t in range(b):
                s -= M[a, t] * M[b, t]
            if a == b:
                if not s > 0.0:
                    return False
                M[a, a] = math.sqrt(s)
            else:
                M[a, b] = s / M[b, b]
    for a in range(k):
        s = e[a]
        for t in range(a):
            s -= M[a, t] * lam[t]
        lam[a] = s / M[a, a]
    for a in range(k - 1, -1, -1):
        s = lam[a]
        for t in range(a + 1, k):
            s -= M[t, a] * lam[t]
        lam[a] = s / M[a, a]
    return True


@njit(cache=True)
def _combination_dead(e, G, hw, Rs, k, n, M, lam, wt, rounds):
    """Whether one combination `λ·f` of the first `k` invariants proves the box empty: for any `λ`,
    `λ·f(c + δ)` lies within `Σ_j |λ·G_j| hw_j + Σ_i |λ_i| R_i` of `λ·f(c)`, and the pose's within
    `Σ_i |λ_i| s_i` of `λ·v`; `e = v - f(c)` (k,), `Rs = R + s` (k,). The `λ` tried first solves
    `(Σ_j hw_j² G_j G_jᵀ + diag(Rs²)) λ = e` (the least-squares direction in which the box's
    linear image is thinnest relative to the gap; near a border it is the border's normal), then
    `rounds` reweighted ones (each term weighted by one over its size at the last `λ`, towards the
    direction of the least sum of absolute values). Any `λ` is sound; the choice only decides how
    often a box is discarded. `wt` (n + 5,) scratch."""
    for j in range(n + k):
        wt[j] = 1.0
    for it in range(rounds + 1):
        if not _solve_direction(e, G, hw, Rs, k, n, M, lam, wt):
            return False
        gap = 0.0
        size = 0.0
        for a in range(k):
            gap += lam[a] * e[a]
            size += abs(lam[a] * e[a])
        bound = 0.0
        for a in range(k):
            t = abs(lam[a]) * Rs[a]
            bound += t
            wt[n + a] = 1.0 / max(t, 1e-300)
        for j in range(n):
            if hw[j] == 0.0:
                continue
            s = 0.0
            for a in range(k):
                s += lam[a] * G[a, j]
            t = abs(s) * hw[j]
            bound += t
            wt[j] = 1.0 / max(t, 1e-3 * bound / n + 1e-300)
        # the sums round by a few ulps of their terms; Rs holds each invariant's own rounding slack
        if abs(gap) > bound + 1e-12 * (size + bound):
            return True
        # normalise the weights (the next solve's scale)
        top = 0.0
        for j in range(n + k):
            top = max(top, wt[j])
        for j in range(n + k):
            wt[j] /= top
    return False


@njit(cache=True)
def _contract_row(a, r, rad, hw, n, L, H):
    """Narrow the box's offsets `δ_j ∈ [L_j, H_j]` (rad) to those where `a·δ` can lie within
    `rad` of `r` (`a` (n,), zero off the box's joints): each `δ_j` is bounded by the row less the
    extremes of the other terms. False where some range becomes empty (no solution in the box)."""
    tmin = 0.0
    tmax = 0.0
    for j in range(n):
        if hw[j] == 0.0 or a[j] == 0.0:
            continue
        x, y = a[j] * L[j], a[j] * H[j]
        tmin += min(x, y)
        tmax += max(x, y)
    # the sums round by a few ulps of their terms: the slack below covers it
    pad = 1e-12 * (abs(tmin) + abs(tmax) + abs(r) + rad) + 1e-300
    lo_t, hi_t = r - rad - pad, r + rad + pad
    if tmax < lo_t or tmin > hi_t:
        return False
    for j in range(n):
        if hw[j] == 0.0 or a[j] == 0.0:
            continue
        x, y = a[j] * L[j], a[j] * H[j]
        omin, omax = tmin - min(x, y), tmax - max(x, y)
        lo_j, hi_j = (lo_t - omax - pad) / a[j], (hi_t - omin + pad) / a[j]
        if a[j] < 0.0:
            lo_j, hi_j = hi_j, lo_j
        # a relative widening for the division's rounding
        w = 1e-12 * (abs(lo_j) + abs(hi_j))
        L[j] = max(L[j], lo_j - w)
        H[j] = min(H[j], hi_j + w)
        if L[j] > H[j]:
            return False
    return True


@njit(cache=True)
def _contract(e, G, Rs, lam, k, n, hw, L, H, row):
    """Narrow the box `c ± hw` to the offsets `[L, H]` (n,) that the linear forms allow: each
    invariant's (`G_i·δ` within `Rs_i` of `e_i`) and the combination `λ`'s (`(λᵀG)·δ` within
    `Σ|λ_i| Rs_i` of `λ·e`), twice over. Sound for any `λ`: every solution in the box satisfies
    each row. False where the box holds no solution. `row` (n,) scratch."""
    for j in range(n):
        L[j] = -hw[j]
        H[j] = hw[j]
    for sweep in range(2):
        for a in range(k + 1):
            if a < k:
                for j in range(n):
                    row[j] = G[a, j]
                r, rad = e[a], Rs[a]
            else:
                r = 0.0
                rad = 0.0
                for i in range(k):
                    r += lam[i] * e[i]
                    rad += abs(lam[i]) * Rs[i]
                for j in range(n):
                    t = 0.0
                    for i in range(k):
                        t += lam[i] * G[i, j]
                    row[j] = t
            if not _contract_row(row, r, rad, hw, n, L, H):
                return False
    return True


@njit(cache=True)
def _split_by_effect(G, hw, lam, k, n, radius, du, eps):
    """The joint whose half-width adds most to the combination's bound: its linear term
    `|λ·G_j| hw_j` plus its share of the second-order remainders (about `radius_j hw_j²` on `W`,
    `hw_j²` on `z`, weighted by how much each invariant's remainder carries them)."""
    wW = abs(lam[0]) * 2.0 * (du + 1.0) + abs(lam[1]) + (abs(lam[2]) + abs(lam[4]) if k > 2 else 0.0)
    wz = abs(lam[1]) * du + ((abs(lam[3]) + abs(lam[4]) * du) if k > 2 else 0.0)
    if k > 5:
        wz += abs(lam[5]) + abs(lam[6])
    best = -1.0
    split = 1
    for j in range(1, n - 1):
        h = hw[j]
        if h == 0.0:
            continue
        s = 0.0
        for a in range(k):
            s += lam[a] * G[a, j]
        score = abs(s) * h + (wW * radius[j] + wz) * h * h
        if eps[j] > 0.0:  # a near joint of the first pass: its shift of d and g
            score = (2.0 * abs(lam[0]) * du + abs(lam[1])) * eps[j] * h
        if score > best:
            best = score
            split = j
    return split


@njit(cache=True, inline="always")
def _wrap(x):
    """The angle `x` (rad) moved into [-π, π] by whole turns."""
    return x - 2.0 * math.pi * round(x / (2.0 * math.pi))


@njit(cache=True)
def _turn_about(vc, vT, rho, s, b1, b2, out):
    """The turn `φ` about joint 0's axis (basis `b1`, `b2` of its normal plane) that takes a vector
    within `rho` of `vc` to one within `s` of `vT`: `out[0]` its centre estimate (the azimuth of
    `vT` less that of `vc`, in [-π, π]), `out[1]` a sound half-width (asin of each radius over the
    projection's length, plus rounding). False where a projection is not longer than its radius."""
    xc = vc[0] * b1[0] + vc[1] * b1[1] + vc[2] * b1[2]
    yc = vc[0] * b2[0] + vc[1] * b2[1] + vc[2] * b2[2]
    xT = vT[0] * b1[0] + vT[1] * b1[1] + vT[2] * b1[2]
    yT = vT[0] * b2[0] + vT[1] * b2[1] + vT[2] * b2[2]
    nc = math.sqrt(xc * xc + yc * yc)
    nT = math.sqrt(xT * xT + yT * yT)
    if nc <= rho or nT <= s:
        return False
    out[0] = _wrap(math.atan2(yT, xT) - math.atan2(yc, xc))
    out[1] = math.asin(rho / nc) + math.asin(s / nT) + 1e-9
    return True


@njit(cache=True)
def _ends_dead(pv, W, S, z, RL, e_loc, y_loc, rho_u, rho_z, sum_hw, b1, b2, a0, w0, cL, wL, near, T2):
    """The limits of joints 0 and n-1 over a box (its centre's `u`, `z` (3,), the last joint's
    frame rotation `RL` (9,) row-major before its turn; `rho_u`, `rho_z` how far they move over
    the box, `sum_hw` the box's Σ hw). The pose `pv` (11,): its `u`, `z`, the direction `e_post`
    of the last joint's frame axis `e_loc` after the turn, and their slacks (m, chord).

    Joint 0 turns `u` and `z` about `a0` by `φ = q_0 - c_0` (`|φ| <= w0`): the turns that take
    the box's `u` and `z` to the pose's (`_turn_about`) must meet `[-w0, w0]` and each other.
    Joint n-1 turns `e_loc` by `ψ = q_{n-1} + offset` about the last axis, so
    `Rot(e, ψ) e_loc = RL(q)ᵀ Rot(a0, -φ) e_post`; with `v` the right side at the centre and the
    `φ` estimate, `|v - v*| <= Σ hw + |φ - φ_est| + slack = ε` (a product of turns by `δ_j` turns
    a unit vector by at most `Σ|δ_j|`), so `ψ` is within `asin ε` of `v`'s angle in the last
    joint's plane, and must lie in `cL ± wL` (offset included). Returns 0: no test failed and the
    centre is inside both limits (within `near`), 1: the box holds no solution, 2: the centre is
    outside a limit (the give-up test must not fire). `T2` (5,) scratch."""
    uT, zT, eT = pv[0:3], pv[3:6], pv[6:9]
    u = T2[2:5]
    for r in range(3):
        u[r] = W[r] - S[r]
    have_u = _turn_about(u, uT, rho_u, pv[9], b1, b2, T2)
    phi_u, dphi_u = T2[0], T2[1]
    have_z = _turn_about(z, zT, rho_z, pv[10], b1, b2, T2)
    phi_z, dphi_z = T2[0], T2[1]
    state = 0
    if have_u:
        gap = max(0.0, abs(phi_u) - w0)
        if gap > dphi_u:
            return 1
        if gap > near:
            state = 2
    if have_z and max(0.0, abs(phi_z) - w0) > dphi_z:
        return 1
    if have_u and have_z and abs(_wrap(phi_u - phi_z)) > dphi_u + dphi_z:
        return 1
    if wL >= math.pi:
        return state
    # the tightest enclosure of φ
    if have_u and (not have_z or dphi_u <= dphi_z):
        phi, dphi = phi_u, dphi_u
    elif have_z:
        phi, dphi = phi_z, dphi_z
    elif w0 < math.pi:
        phi, dphi = 0.0, w0
    else:
        return state
    eps = sum_hw + dphi + pv[10] + 1e-12
    if eps >= 1.0:
        return state
    # v = Rot(a0, -φ) e_post (Rodrigues)
    cs, sn = math.cos(phi), math.sin(phi)
    ad = a0[0] * eT[0] + a0[1] * eT[1] + a0[2] * eT[2]
    c0 = a0[1] * eT[2] - a0[2] * eT[1]
    c1 = a0[2] * eT[0] - a0[0] * eT[2]
    c2 = a0[0] * eT[1] - a0[1] * eT[0]
    v0 = eT[0] * cs - c0 * sn + a0[0] * ad * (1.0 - cs)
    v1 = eT[1] * cs - c1 * sn + a0[1] * ad * (1.0 - cs)
    v2 = eT[2] * cs - c2 * sn + a0[2] * ad * (1.0 - cs)
    # its coordinates along the last joint's e_loc and y_loc at the centre: v · (RL e_loc), v · (RL y_loc)
    x = 0.0
    y = 0.0
    for r in range(3):
        vr = v0 if r == 0 else (v1 if r == 1 else v2)
        x += vr * (RL[3 * r] * e_loc[0] + RL[3 * r + 1] * e_loc[1] + RL[3 * r + 2] * e_loc[2])
        y += vr * (RL[3 * r] * y_loc[0] + RL[3 * r + 1] * y_loc[1] + RL[3 * r + 2] * y_loc[2])
    gap = max(0.0, abs(_wrap(math.atan2(y, x) - cL)) - wL)
    if gap > math.asin(eps) + 1e-9:
        return 1
    if gap > near:
        state = 2
    return state


@njit(cache=True)
def _interval_test(e, g, hw, rs, n, near):
    """One linear form alone (`g` (n,), gap `e`, remainder and slack `rs`): 1 where `|e|` exceeds
    its first-order change over the box plus `rs`, else 0 (the gap within `near`) or 2."""
    lin = 0.0
    for j in range(n):
        lin += abs(g[j]) * hw[j]
    if abs(e) > lin + rs:
        return 1
    return 2 if abs(e) > near else 0


@njit(cache=True)
def _tilt_rows(F, axes, z, ends, n, hw, G, e, Rs, rz, rho):
    """The linear forms 5 and 6 (`G`, `e`, `Rs` rows 5, 6): the components `b·z` of the last axis
    along `b1`, `b2` (`ends[0:6]`, a basis of joint 0's normal plane), which a solution keeps within
    `rho` (the pose's tilt plus its slack) of 0: joint 0 turns `z⊥` about `a0`, so `|z⊥|` is the
    pose's. Derivatives `b·(a_j × z)` at the centre (`F`, `z` of `_box_bounds`), remainder `rz`
    (`|b·r_z| <= |r_z|`)."""
    for a in range(2):
        e[5 + a] = -(ends[3 * a] * z[0] + ends[3 * a + 1] * z[1] + ends[3 * a + 2] * z[2])
        Rs[5 + a] = rz + rho
        for j in range(n):
            G[5 + a, j] = 0.0
    for j in range(1, n - 1):
        if hw[j] == 0.0:
            continue
        aj0 = F[j, 0] * axes[j, 0] + F[j, 1] * axes[j, 1] + F[j, 2] * axes[j, 2]
        aj1 = F[j, 3] * axes[j, 0] + F[j, 4] * axes[j, 1] + F[j, 5] * axes[j, 2]
        aj2 = F[j, 6] * axes[j, 0] + F[j, 7] * axes[j, 1] + F[j, 8] * axes[j, 2]
        K0, K1, K2 = aj1 * z[2] - aj2 * z[1], aj2 * z[0] - aj0 * z[2], aj0 * z[1] - aj1 * z[0]
        for a in range(2):
            G[5 + a, j] = ends[3 * a] * K0 + ends[3 * a + 1] * K1 + ends[3 * a + 2] * K2


@njit(cache=True)
def _fill_forms(i, axes, only_dg, values, slack, ends, tests, tilt_max, shift, n, h, F, Z, lo, G, R, e, Rs):
    """The gaps `e` and radii `Rs` of the linear forms for pose `i` (`_judge_box`): `d², g` (the
    first pass), with `h, k, m`, and with the tilt forms where `tests & 16` and the pose's tilt is
    below `tilt_max` (`_tilt_rows`, which fills `G`'s rows 5 and 6). Returns how many (2, 5 or 7)."""
    k_used = 2 if only_dg else 5
    # d² of the pose: the interval [(d - s)², (d + s)²] as a centre and a half-width (s: the slack
    # and the near joints' shift)
    dlo = max(values[i, 0] - slack[i, 0] - shift, 0.0)
    dhi = values[i, 0] + slack[i, 0] + shift
    e[0] = 0.5 * (dhi * dhi + dlo * dlo) - lo[4] * lo[4]
    Rs[0] = R[0] + 0.5 * (dhi * dhi - dlo * dlo) + 1e-15 * (1.0 + dhi * dhi)
    for k in range(1, k_used):
        e[k] = values[i, k] - lo[4 + k]
        Rs[k] = R[k] + slack[i, k] + (shift if k == 1 else 0.0)
    if tests & 16 and not only_dg and values[i, 5] < tilt_max:
        # the tilt's slack is k's (the margin turns z by at most the margin)
        _tilt_rows(F, axes, Z[6], ends, n, h, G, e, Rs, R[3], values[i, 5] + slack[i, 3])
        k_used = 7
    return k_used


@njit(cache=True)
def _judge_box(i, axes, only_dg, values, slack, pv, ends, tests, rounds, near, tilt_max, shift, n, h, S, a0, radius,
               eps, F, Z, lo, hi, G, R, M, lam, wt, e, Rs, T2, CL, CH):
    """The verdict on one box already bounded (`_box_bounds`'s `lo`, `hi`, `G`, `R`) for pose `i`:
    1, it holds no solution; 0, it may, and its centre's invariants all lie within `near` of the
    pose's (inside the limits of joints 0 and n-1 too); 2, it may, its centre farther. Sets the
    joint to split (`lo[9]`) by the combination's effect when `tests & 4`, and the box's offsets
    narrowed by the linear forms (`_contract`) into `CL`, `CH` (n,) when `tests & 8` (else they
    are left as they are). With `tests & 16` and the pose's tilt below `tilt_max`, the two tilt
    forms (`_tilt_rows`) join the five."""
    close = True
    for k in range(2 if only_dg else 4):
        sl = slack[i, k] + (shift if k < 2 else 0.0)
        if values[i, k] < lo[k] - sl or values[i, k] > hi[k] + sl:
            return 1
        if abs(values[i, k] - lo[4 + k]) > near:
            close = False
    if tests & 2:
        k_used = _fill_forms(i, axes, only_dg, values, slack, ends, tests, tilt_max, shift, n, h, F, Z, lo, G, R, e, Rs)
        # m, then the tilt forms (whose gaps do not enter the give-up test: near = inf)
        for k in range(4, k_used):
            state = _interval_test(e[k], G[k], h, Rs[k], n, near if k == 4 else math.inf)
            if state == 1:
                return 1
            if state == 2:
                close = False
        if _combination_dead(e, G, h, Rs, k_used, n, M, lam, wt, rounds):
            return 1
        if tests & 4:
            lo[9] = _split_by_effect(G, h, lam, k_used, n, radius, lo[4], eps)
        if tests & 8 and not _contract(e, G, Rs, lam, k_used, n, h, CL, CH, wt):
            return 1
    if tests & 1 and not only_dg:
        state = _ends_dead(pv[i], Z[5], S, Z[6], F[n - 1, :9], ends[6:9], ends[9:12], lo[10], lo[11], lo[12],
                           ends[0:3], ends[3:6], a0, ends[12], ends[13], ends[14], near, T2)
        if state == 1:
            return 1
        if state == 2:
            close = False
    return 0 if close else 2


@njit(cache=True)
def _near_shift(eps, hw, n):
    """The most the near joints (`eps` (n,) m, 0 elsewhere) shift `d` and `g` over the box:
    `Σ 2 sin(hw_j/2) eps_j <= Σ min(hw_j, 2) eps_j` (m)."""
    t = 0.0
    for j in range(n):
        t += eps[j] * min(hw[j], 2.0)
    return t


@njit(cache=True, parallel=True)
def _certify_boxes(fixed, axes, offset, S, a0, w_loc, radius, rigid, box, only_dg, values, slack, pv, ends, tests,
                   rounds, near, tilt_max, shoulder, eps, budget, depth, out):
    """Depth-first branch and bound per pose (`values`, `slack` (N, 5): `d, g, h, k, m`; `pv`
    (N, 11), `_ends_dead`'s pose vectors): `out[i]` 1 where every box was discarded, 0 where it gave
    up (after `budget` boxes, deeper than `depth` splits, or a box centre whose invariants all lie
    within `near` of the pose's and inside the limits of joints 0 and n-1: most likely reachable).
    `ends` (15,): joint 0's axis basis `b1`, `b2`, the last joint's `e_loc`, `y_loc`, `w0`, `cL`
    (its box centre plus offset), `wL`. `tests`: a bit mask of the tests beside the four intervals
    (1: the limits of joints 0 and n-1, 2: `m` and the combinations of `_combination_dead` with
    `rounds` reweightings, 4: the split by the combination's effect, `_split_by_effect`, 8: the
    box narrowed by `_contract`, 16: the tilt forms where the pose's tilt is below `tilt_max`).
    `shoulder` > 0 (rad): the joints not in `rigid` are split first while one is wider than it.
    `eps` (n,): the first pass (`only_dg`) bounds a joint `j` with `eps_j > 0` as a turn about `S`
    (no change of `d`, `g`) plus a shift of at most `eps_j min(hw_j, 2)` (m)."""
    N = values.shape[0]
    n = axes.shape[0]
    # the joints _box_bounds keeps out of d and g: the rigid ones, and the near ones (eps > 0)
    rigid_b = rigid | (eps > 0.0)
    for i in prange(N):
        cs = np.empty((depth + 1, n))
        hs = np.empty((depth + 1, n))
        F = np.empty((n, 14))
        Z = np.empty((7, 9))
        lo = np.empty(13)
        hi = np.empty(4)
        G = np.empty((7, n))
        R = np.empty(5)
        M = np.empty((7, 7))
        lam = np.empty(7)
        e = np.empty(7)
        Rs = np.empty(7)
        T2 = np.empty(5)
        wt = np.empty(n + 7)
        CL = np.empty(n)
        CH = np.empty(n)
        for j in range(n):
            cs[0, j] = 0.5 * (box[j, 0] + box[j, 1])
            hs[0, j] = 0.5 * (box[j, 1] - box[j, 0]) if 0 < j < n - 1 and not (only_dg and rigid[j]) else 0.0
        top = 1
        evals = 0
        ok = 1
        while top > 0:
            top -= 1
            c = cs[top]
            h = hs[top]
            _box_bounds(fixed, axes, offset, S, a0, w_loc, radius, rigid_b, n, c, h, F, Z, lo, hi, G, R)
            shift = _near_shift(eps, h, n)
            evals += 1
            for j in range(n):
                CL[j] = -h[j]
                CH[j] = h[j]
            verdict = _judge_box(i, axes, only_dg, values, slack, pv, ends, tests, rounds, near, tilt_max, shift, n, h, S,
                                 a0, radius, eps, F, Z, lo, hi, G, R, M, lam, wt, e, Rs, T2, CL, CH)
            if verdict == 1:
                continue
            # the box narrowed to what the linear forms allow (no change without tests & 8)
            shrunk = False
            for j in range(n):
                if h[j] > 0.0:
                    width = 0.5 * (CH[j] - CL[j])
                    if width < 0.7 * h[j]:
                        shrunk = True
                    c[j] += 0.5 * (CL[j] + CH[j])
                    h[j] = width
            if verdict == 0 or evals >= budget or top + 2 > depth:
                ok = 0
                break
            if shrunk:
                top += 1  # bound the narrowed box again before splitting it
                continue
            jb = int(lo[9])  # the joint to split
            if shoulder > 0.0 and rigid[jb]:
                # a spherical shoulder: the widest joint after it first, while one is wider than `shoulder`
                widest = shoulder
                for j in range(n):
                    if not rigid[j] and h[j] > widest:
                        widest = h[j]
                        jb = j
            # the two halves replace the box on the stack (slot top, then top + 1)
            half = 0.5 * h[jb]
            mid = c[jb]
            for j in range(n):
                cs[top + 1, j] = c[j]
                hs[top + 1, j] = h[j]
            hs[top, jb] = half
            hs[top + 1, jb] = half
            cs[top, jb] = mid - half
            cs[top + 1, jb] = mid + half
            top += 2
        out[i] = ok
