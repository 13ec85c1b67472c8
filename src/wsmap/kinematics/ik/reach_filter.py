"""Sound reach pre-filters of the numerical search: tests that prove a target out of reach before any LM.

A target that fails them cannot be confirmed by any configuration, so the search
(`wsmap.kinematics.ik.search`) marks it unreachable without running LM: they change no
result, only the time.

* `reach_filter` — the wrist point (the origin of the last revolute joint's frame, fixed by
  the tool pose) farther from the base than the links can stretch, or outside the set the joints
  before it can sweep it through (a ball cut by a slab carried back from the wrist joint by joint,
  then turned about joint 0; `_wrist_orbit`, exact for the PUMA560 at a fixed orientation);
* `position_filter` — the tool origin farther than the links can stretch (position-only
  search);
* `limit_filter` — three numbers of the last joint's axis that joints 0 and n-1 do not change
  (distances from a point of the first axis) outside the intervals the other joints reach inside
  their limits (a branch and bound per arm, `limit_bounds`); the map search's `limit_bound`.

The first two measure from `first_axis_point`, a point no joint moves. Lengths in metres.
"""

from __future__ import annotations

import numpy as np

from .. import lm_compiled
from ..chain import PRISMATIC, SerialChain
from .memo import Memo, content_key

__all__ = ["reach_filter", "position_filter", "first_axis_point", "limit_filter", "limit_bounds", "joint_box_and_radius", "limit_geometry",
           "through_point"]

_ORBITS = Memo()


def _lengths_strokes(chain: SerialChain):
    """`(lengths (..., n+1), stroke (...,))`: the length of each fixed transform's translation,
    and the most the prismatic joints can add together (a slide moves by `q + offset` along its
    unit axis, `q` within its limits)."""
    lengths = np.linalg.norm(chain.fixed[..., :3, 3], axis=-1)
    pris = np.array([k == PRISMATIC for k in chain.kinds])
    stroke = np.zeros(chain.batch_shape)
    if pris.any():
        ends = chain.limits[..., pris, :] + np.asarray(chain.offset)[..., pris, None]
        stroke = np.abs(ends).max(axis=-1).sum(axis=-1)
    return lengths, stroke


def reach_filter(chain: SerialChain, T, margin, wrist_orbit: bool = True):
    """A sound test (…,) bool: False where no configuration puts the tool within `margin` of `T`.

    If the last joint is revolute, the origin of its frame (the "wrist point") is fixed by the tool
    pose: `T · G⁻¹` with `G = F_n · tool`; it is at most `Σ_{i<n} |t(F_i)| - used` (plus the
    strokes of prismatic joints) from the first joint's axis point (`first_axis_point`),
    which no joint moves.
    Otherwise the tool origin itself is bounded by the lengths of the later fixed transforms and the
    tool. A pose within `margin` in position and
    rotation angle of a reachable one moves the wrist point by at most `margin·(1 + |t(G)|)`.

    `wrist_orbit` (arms of revolute joints): also the wrist point's orbit about joint 0 must meet
    the set the joints `1 .. n-2` sweep it through (`_wrist_orbit`, `_orbit_test`);
    for the PUMA560 at a fixed orientation this leaves exactly the reachable poses.
    """
    n = chain.n
    F = chain.fixed
    lengths, stroke = _lengths_strokes(chain)
    if chain.kinds[-1] != PRISMATIC:
        G = F[..., n, :, :]
        if chain.tool is not None:
            G = G @ chain.tool
        Ginv_t = -np.einsum("...ji,...j->...i", G[..., :3, :3], G[..., :3, 3])  # translation of G⁻¹
        point = T[..., :3, 3] + _rotate(T[..., :3, :3], Ginv_t)
        reach = lengths[..., :n].sum(axis=-1) + stroke
        slack = margin * (1.0 + np.linalg.norm(G[..., :3, 3], axis=-1))
    else:
        point = T[..., :3, 3]
        reach = lengths.sum(axis=-1) + stroke + (0.0 if chain.tool is None else np.linalg.norm(chain.tool[:3, 3]))
        slack = margin
    centre, used = first_axis_point(chain)
    dist = np.linalg.norm(point - centre, axis=-1)
    ok = dist <= (reach - used) * (1.0 + 1e-12) + slack + 1e-12
    if chain.kinds[-1] != PRISMATIC and wrist_orbit and n >= 2:
        orbit = _ORBITS.get(content_key(chain.fixed, chain.axes, chain.kinds), lambda: _wrist_orbit(chain))
        if orbit is not None:
            a0, c, r, u, w = orbit
            # the wrist point in the frame after F_0 (base folded in)
            F0 = F[..., 0, :, :] if chain.base is None else chain.base @ F[..., 0, :, :]
            tiny = 1e-9 * (1.0 + lengths.sum(axis=-1))  # rounding of the bound's arithmetic
            if chain.batch_shape == () and ok.shape == point.shape[:-1]:
                # one arm: only the points the first test kept
                ok = np.array(ok, dtype=bool)
                idx = np.flatnonzero(ok)
                local = (point.reshape(-1, 3)[idx] - F0[:3, 3]) @ F0[:3, :3]
                ok.reshape(-1)[idx] = _orbit_test(a0, c, r, u, w, local, slack + tiny)
            else:
                local = _rotate(np.swapaxes(F0[..., :3, :3], -1, -2), point - F0[..., :3, 3])
                ok &= _orbit_test(a0, c, r, u, w, local, slack + tiny)
    return ok


def _rotate(R, v):
    """`R @ v` for rotations `R` (..., 3, 3) and vectors `v` (..., 3), broadcast: three
    multiply-adds over whole arrays (a broadcast einsum over a batch of arms times nodes is several
    times slower)."""
    return R[..., 0] * v[..., None, 0] + R[..., 1] * v[..., None, 1] + R[..., 2] * v[..., None, 2]


def _wrist_orbit(chain: SerialChain):
    """A bound, per arm, of where the wrist point (the origin of the frame after `F_{n-1}`) can be,
    in the frame after `F_0` (base folded in) before joint 0 turns it: joint 0 turns it about
    `a0` (3,) within `{x : |x - c| <= r, |(x - c)·u| <= w}` (a ball cut by a slab).

    Built from the wrist point back (joints `n-2 .. 1`, their limits ignored, so a superset): a
    fixed transform moves the set rigidly; a revolute joint turning a ball ∩ slab `(c, r, u, w)`
    about its axis `a` (through the origin) sweeps a set inside the ball about `(c·a) a` of radius
    `ρ + r` (`ρ` the distance of `c` from the axis) cut by the slab normal to `a` of half-width
    `e = min(r, min(w, r)·|u·a| + r·sqrt(1 - (u·a)²))` (the set's extent along `a`, unchanged by
    the turn). Returns `(a0, c, r, u, w)` with batch shapes `(..., 3)` and `(...)`, or None
    for an arm with a prismatic joint.
    """
    if any(k == PRISMATIC for k in chain.kinds):
        return None
    n = chain.n
    F = np.array(chain.fixed, dtype=np.float64)
    batch = F.shape[:-3]
    c = np.zeros(batch + (3,))
    u = np.zeros(batch + (3,))
    u[..., 2] = 1.0
    r = np.zeros(batch)
    w = np.zeros(batch)
    for k in range(n - 1, 0, -1):
        # through F_k into the frame after joint k-1, then joint k-1's turn (for k >= 2)
        R, t = F[..., k, :3, :3], F[..., k, :3, 3]
        c = t + np.einsum("...ij,...j->...i", R, c)
        u = np.einsum("...ij,...j->...i", R, u)
        if k == 1:
            break
        a = chain.axes[k - 1]
        h = c @ a
        rho = np.linalg.norm(c - h[..., None] * a, axis=-1)
        ua = np.clip(np.abs(u @ a), 0.0, 1.0)
        e = np.minimum(r, np.minimum(w, r) * ua + r * np.sqrt(1.0 - ua * ua))
        c = h[..., None] * a
        u = np.broadcast_to(a, c.shape).copy()
        r, w = rho + r, e
    return chain.axes[0], c, r, u, w


def _orbit_test(a, c, r, u, w, p, slack):
    """Whether some turn of the points `p` (..., 3) about the axis `a` (through the origin) puts
    them within `slack` of the set `{x : |x - c| <= r, |(x - c)·u| <= w}` (a necessary condition,
    exact up to rounding): the turned point runs on a circle; its distance to `c` is least at the
    circle's point nearest `c` if that point is inside the slab, else at an end of the arcs of
    the circle inside the slab (where `(x - c)·u = ±w`)."""
    r, w = np.asarray(r + slack, dtype=np.float64), np.asarray(w + slack, dtype=np.float64)
    shape = np.broadcast_shapes(p.shape[:-1], np.shape(c)[:-1], np.shape(u)[:-1], r.shape, w.shape)

    def rows(x, k=()):
        return np.ascontiguousarray(np.broadcast_to(x, shape + k), dtype=np.float64).reshape((-1,) + k)

    a = np.ascontiguousarray(a, dtype=np.float64)
    ref = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e0 = np.cross(a, ref)
    e0 /= np.linalg.norm(e0)
    return lm_compiled.orbit_test(a, e0, rows(c, (3,)), rows(r), rows(u, (3,)), rows(w), rows(p, (3,))).reshape(shape)


def first_axis_point(chain: SerialChain) -> tuple[np.ndarray, np.ndarray]:
    """A point no joint moves, and how much of the lengths it uses: `(centre (…, 3), used (…,))`.

    The first joint turns (or slides) about its axis `a` through the origin of `base · F_0`;
    the part of `t(F_1)` along `a` is not turned by it (a shoulder height such as the Panda's
    d1 = 0.333 m), so `centre = base · F_0 · ((t(F_1)·a) a)` is fixed, and everything after it
    is within `|t(F_1)⊥|` (the part across the axis) plus the later lengths:
    `used = |t(F_0)| + |t(F_1)| - |t(F_1)⊥|` is what the reach bounds subtract from the sum of
    all the lengths. A slide along the same axis keeps this sound: its stroke is added anyway."""
    F = chain.fixed
    t0 = F[..., 0, :3, 3]
    t1 = F[..., 1, :3, 3]
    a = chain.axes[0]  # unit, in the frame of F_0
    along = t1 @ a  # (...,)
    centre = t0 + np.einsum("...ij,j->...i", F[..., 0, :3, :3], a) * along[..., None]
    perp = np.linalg.norm(t1 - along[..., None] * a, axis=-1)
    used = np.linalg.norm(t0, axis=-1) + np.linalg.norm(t1, axis=-1) - perp
    if chain.base is not None:
        centre = centre @ chain.base[:3, :3].T + chain.base[:3, 3]
    return centre, used


def position_filter(chain: SerialChain, p, margin):
    """A sound test (B, N) or (N,) bool: False where no configuration puts the tool origin within
    `margin` of the positions `p` (N, 3): farther from a point of the first joint's axis
    (`first_axis_point`) than the lengths of the fixed transforms after it, the tool and the
    prismatic strokes together."""
    lengths, stroke = _lengths_strokes(chain)
    lengths = lengths.sum(axis=-1) + stroke  # (...,)
    if chain.tool is not None:
        lengths = lengths + np.linalg.norm(chain.tool[:3, 3])
    centre, used = first_axis_point(chain)
    dist = np.linalg.norm(np.asarray(p) - centre[..., None, :], axis=-1)  # (..., N)
    reach = np.asarray(lengths - used)[..., None] * (1.0 + 1e-12) + margin + 1e-12
    return dist <= reach  # (N,) or (B, N)


# --------------------------------------------------------------------------- the joint-limit bound
#: Tolerance of the branch and bound of `limit_bounds` (metres): each interval is wider than the
#: exact range by at most this much, or a little more where the cell budget ran out (sound either way).
LIMIT_BOUND_EPS = 1e-3
#: Cells a branch and bound evaluates at most (then it stops with the sound bound it has), and how
#: many of the highest it splits per round. Measured on the 21³ tool-down maps (LM iterations, the
#: maps identical): 2^14 builds the Panda's bound in 0.23 s (iterations 1.52 M against 5.46 M without
#: it), 2^16 in 0.73 s for the same; 2^17 halves the iiwa14's and Gen3's again (0.42 M to 0.15 M,
#: 1.26 M to 0.77 M) for 1.9-3.3 s of building; 2^12 leaves the Panda 2.17 M.
LIMIT_BOUND_EVALS = 1 << 14
LIMIT_BOUND_BATCH = 1 << 10

_LIMIT_BOUNDS = Memo()


def _nearest_on_line(p0, a, p1, b):
    """The point of the line `p0 + t a` nearest to the line `p1 + s b` (unit directions; metres);
    `p0` where the lines are parallel."""
    w = p0 - p1
    ab = float(a @ b)
    den = 1.0 - ab * ab
    if den < 1e-12:
        return np.array(p0, dtype=np.float64)
    t = (ab * float(b @ w) - float(a @ w)) / den
    return p0 + t * a


def limit_geometry(chain: SerialChain):
    """The points `limit_bounds` measures between, for one arm of revolute joints: `S` (3,),
    the point of joint 0's axis nearest joint 1's axis (world frame, base included; no joint moves
    it); `w_loc` (3,), the point of the last joint's axis nearest joint n-2's axis, in the last
    joint's frame (no joint after n-2 moves it within that frame); the frames at `q = 0` (n, 4, 4)."""
    n = chain.n
    frames, _ = chain.joint_frames(np.zeros(n))
    a0 = frames[0, :3, :3] @ chain.axes[0]
    a1 = frames[1, :3, :3] @ chain.axes[1]
    S = _nearest_on_line(frames[0, :3, 3], a0, frames[1, :3, 3], a1)
    # joint n-2's axis in the frame of joint n-1 (before its motion; the points of its axis are the same after)
    F = chain.fixed[n - 1]
    Rinv = F[:3, :3].T
    w_loc = _nearest_on_line(np.zeros(3), chain.axes[n - 1], -Rinv @ F[:3, 3], Rinv @ chain.axes[n - 2])
    return S, w_loc, frames


def _invariant_cells(chain, S, a0, w_loc, dims, centre, hw, radius):
    """The three invariants at cell centres and bounds of them over the cells.

    `centre`, `hw` (K, n) radians: the cells' centres and half-widths in joint space (`hw` 0 off
    `dims`). Returns `values`, `lower`, `upper` (3, K): `d = |W - S|`, `g = (W - S)·z` and
    `h = (W - S)·a0` (metres; `W` the point `w_loc` of the last axis, `z` its direction,
    `a0` joint 0's axis, all in the chain's frame). The bounds
    are second-order Taylor bounds: `W(c + δ) = W(c) + Jδ + r` with `|r| <= Σ_ij H_ij hw_i hw_j / 2`,
    `H_ij = radius[max(i, j)]` (`∂²W/∂q_i∂q_j` is a double cross product with `W`'s offset from
    joint `max(i, j)`'s axis, at most `radius` (n,) m, the lengths after that joint); likewise
    `z` with `H_ij = 1`, `s = Σ hw`."""
    n = chain.n
    frames, _ = chain.joint_frames(centre)
    last = frames[:, n - 1]
    W = last[:, :3, :3] @ w_loc + last[:, :3, 3]
    z = last[:, :3, :3] @ chain.axes[n - 1]
    u = W - S
    du = np.linalg.norm(u, axis=-1)
    A = np.zeros(len(centre))  # bound of |Jδ|
    Bz = np.zeros(len(centre))  # bound of |Kδ| (the first-order change of z)
    uJ = np.zeros(len(centre))  # bound of |u·Jδ|
    lin_g = np.zeros(len(centre))  # bound of the first-order change of g
    lin_h = np.zeros(len(centre))  # bound of the first-order change of h
    for j in dims:
        aj = frames[:, j, :3, :3] @ chain.axes[j]
        Jj = np.cross(aj, W - frames[:, j, :3, 3])
        Kj = np.cross(aj, z)
        h = hw[:, j]
        A += np.linalg.norm(Jj, axis=-1) * h
        Bz += np.linalg.norm(Kj, axis=-1) * h
        uJ += np.abs(np.einsum("ki,ki->k", u, Jj)) * h
        lin_g += np.abs(np.einsum("ki,ki->k", u, Kj) + np.einsum("ki,ki->k", Jj, z)) * h
        lin_h += np.abs(Jj @ a0) * h
    s = hw.sum(axis=-1)
    # Σ_ij r_max(i,j) hw_i hw_j = Σ_j r_j hw_j (hw_j + 2 Σ_{i<j} hw_i)
    before = np.cumsum(hw, axis=-1) - hw
    rW = 0.5 * (radius * hw * (hw + 2.0 * before)).sum(axis=-1)
    rz = 0.5 * s * s
    g = np.einsum("ki,ki->k", u, z)
    rem_g = lin_g + A * Bz + rW * (1.0 + Bz + rz) + (du + A) * rz
    # |u + Jδ|² = |u|² + 2 u·Jδ + |Jδ|², then the remainder
    hh = u @ a0
    upper = np.stack([np.sqrt(du * du + 2.0 * uJ + A * A) + rW, g + rem_g, hh + lin_h + rW])
    lower = np.stack([np.sqrt(np.maximum(du * du - 2.0 * uJ, 0.0)) - rW, g - rem_g, hh - lin_h - rW])
    return np.stack([du, g, hh]), lower, upper


def _branch_and_bound(chain, S, a0, w_loc, which, dims, box, radius, sign):
    """A sound bound (m) of `max` (`sign` 1) or `min` (-1) of invariant `which` (0: `d`,
    1: `g`, 2: `h`; `_invariant_cells`) over the joint box `box` (n, 2) rad, splitting the
    joints `dims`, best first: each round splits the `LIMIT_BOUND_BATCH` cells of the highest
    bounds in two across the joint that moves `W` most; a cell is dropped once its bound cannot
    beat the best centre value by more than `LIMIT_BOUND_EPS`. It stops there, or after
    `LIMIT_BOUND_EVALS` cells, with the highest bound of the cells left (sound either way)."""
    n = chain.n
    centre = box.mean(axis=-1)[None].copy()
    hw = np.zeros((1, n))
    hw[0, dims] = 0.5 * (box[dims, 1] - box[dims, 0])
    values, lower, upper = _invariant_cells(chain, S, a0, w_loc, dims, centre, hw, radius)
    ub = upper[which] if sign > 0 else -lower[which]
    best = float((sign * values[which]).max())
    evals = 1
    while dims and evals < LIMIT_BOUND_EVALS:
        keep = ub > best + LIMIT_BOUND_EPS
        centre, hw, ub = centre[keep], hw[keep], ub[keep]
        if not len(ub):
            break
        top = np.argsort(-ub)[:LIMIT_BOUND_BATCH]
        rest = np.ones(len(ub), dtype=bool)
        rest[top] = False
        c, h = centre[top], hw[top].copy()
        j = np.argmax(h * (radius + 0.1), axis=-1)
        rows = np.arange(len(top))
        h[rows, j] *= 0.5
        left, right = c.copy(), c.copy()
        left[rows, j] -= h[rows, j]
        right[rows, j] += h[rows, j]
        kids, kid_hw = np.concatenate([left, right]), np.concatenate([h, h])
        values, lower, upper = _invariant_cells(chain, S, a0, w_loc, dims, kids, kid_hw, radius)
        evals += len(kids)
        best = max(best, float((sign * values[which]).max()))
        kid_ub = upper[which] if sign > 0 else -lower[which]
        centre = np.concatenate([centre[rest], kids])
        hw = np.concatenate([hw[rest], kid_hw])
        ub = np.concatenate([ub[rest], kid_ub])
    # the cells dropped had bounds within eps of a best value at the time, never above the final best + eps
    return sign * max(best + LIMIT_BOUND_EPS, float(ub.max()) if len(ub) else -np.inf)


def through_point(chain, frames, point):
    """Joints `1 ..` whose axes, in an unbroken run from joint 1, pass through `point` at
    `q = 0`: a turn of such a joint keeps the next one through the point, so it turns
    everything after it rigidly about the point."""
    out = []
    for j in range(1, chain.n):
        a = frames[j, :3, :3] @ chain.axes[j]
        r = point - frames[j, :3, 3]
        if np.linalg.norm(r - (r @ a) * a) > 1e-12:
            break
        out.append(j)
    return out


def limit_bounds(chain: SerialChain):
    """The joint-limit bound's numbers for one arm of revolute joints (memoised by content), or None
    (a batch, a prismatic joint, fewer than 3 joints).

    Three numbers of the last joint's axis are unchanged by joint 0 (they are measured from a point
    `S` of its axis, along its direction `a0`) and by joint n-1 (they use a point `W` of its
    axis and its direction `z`): `d = |W - S|`, `g = (W - S)·z` and `h = (W - S)·a0` (metres).
    So they depend on joints `1 .. n-2` only, and
    inside the limits each lies in an interval `[lo, hi]`, found by a branch and bound over those
    joints' box (`_branch_and_bound`; sound, at most `LIMIT_BOUND_EPS` wider than the
    exact range where its cell budget lasts). Joints whose axes pass through `S` in an unbroken
    run from joint 1 (the Panda's and the iiwa's shoulders) turn `W - S` and `z` rigidly about
    `S`, change neither `d` nor `g`, and are not split for them; `|g|, |h| <= d` tightens
    those two. Unlike `reach_filter`'s bounds these use
    the limits (a revolute range of a turn or more, or none, counts as a full turn). `S` is the point
    of joint 0's axis nearest joint 1's; `W` the point of the last axis nearest joint n-2's.

    Returns `dict(S (3,), a0 (3,), w_loc (3,), lo (3,), hi (3,))` (`d`, `g`, `h`): `S` and
    joint 0's axis `a0` in the chain's frame without its base (so the numbers do not depend on
    the base or the tool), `w_loc` in the last joint's frame. Building it takes 0.1-0.4 s per
    arm (once per process and arm; most of it `h`, over joints 1 .. n-2 all)."""
    if chain.batch_shape != () or chain.n < 3 or any(k == PRISMATIC for k in chain.kinds):
        return None
    # in the chain's own frame (no base, no tool): an arm moved around a cell keeps its numbers
    key = content_key(chain.fixed, chain.axes, chain.kinds, np.asarray(chain.offset), chain.qlim)
    return _LIMIT_BOUNDS.get(key, lambda: _make_limit_bounds(chain.replace(base=None, tool=None)))


def joint_box_and_radius(chain: SerialChain, w_loc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The joints' box `(n, 2)` (rad) a sound bound must cover and how far `W` can be from each
    joint's frame origin, `radius (n,)` (m; joints 1 .. n-2, else 0), for one arm of revolute
    joints: the limits widened by 1e-9 rad, because the search confirms a solution up to that far
    outside a limit (`lm_compiled._confirm`), and a full turn where the range is a turn or more
    (every angle is some `q + 2πk`) or unlimited; `W` is at most the later fixed translations plus
    `w_loc` (its offset in the last joint's frame) from joint `j`'s origin."""
    n = chain.n
    lim = np.array(chain.limits, dtype=np.float64)
    full = ~np.isfinite(lim).all(axis=-1) | (lim[:, 1] - lim[:, 0] >= 2.0 * np.pi)
    box = np.where(full[:, None], np.array([-np.pi, np.pi]), lim + np.array([-1e-9, 1e-9]))
    lengths = np.linalg.norm(chain.fixed[:, :3, 3], axis=-1)
    radius = np.zeros(n)
    for j in range(1, n - 1):
        radius[j] = float(lengths[j + 1:n].sum() + np.linalg.norm(w_loc)) * (1.0 + 1e-12)
    return box, radius


def _make_limit_bounds(chain: SerialChain):
    n = chain.n
    S, w_loc, frames = limit_geometry(chain)
    box, radius = joint_box_and_radius(chain, w_loc)
    skip = set(through_point(chain, frames, S))
    dims = [j for j in range(1, n - 1) if j not in skip]
    a0 = frames[0, :3, :3] @ chain.axes[0]
    dims_h = list(range(1, n - 1))
    lo = np.array([_branch_and_bound(chain, S, a0, w_loc, k, dims if k < 2 else dims_h, box, radius, -1) for k in range(3)])
    hi = np.array([_branch_and_bound(chain, S, a0, w_loc, k, dims if k < 2 else dims_h, box, radius, 1) for k in range(3)])
    # |h| <= d and |g| <= d: the tighter of the two bounds
    lo[1:] = np.maximum(lo[1:], -hi[0])
    hi[1:] = np.minimum(hi[1:], hi[0])
    return dict(S=S, a0=a0, w_loc=w_loc, lo=lo, hi=hi)


def limit_filter(chain: SerialChain, T, margin):
    """A sound test (...,) bool of one arm and target poses `T` (..., 4, 4): False where no
    configuration inside the limits puts the tool within `margin` (m in position, rad in rotation
    angle) of `T`, because `d`, `g` or `h` of `limit_bounds` lies outside its interval. All
    True where the arm has no such bound (a batch, a prismatic joint, fewer than 3 joints)."""
    T = np.asarray(T, dtype=np.float64)
    b = limit_bounds(chain)
    if b is None:
        return np.ones(T.shape[:-2], dtype=bool)
    n = chain.n
    G = chain.fixed[n] if chain.tool is None else chain.fixed[n] @ chain.tool
    # the last joint's frame is T·G⁻¹: W and z in the tool frame
    v = G[:3, :3].T @ (b["w_loc"] - G[:3, 3])
    zt = G[:3, :3].T @ chain.axes[n - 1]
    if chain.base is not None:  # the targets in the chain's frame
        Bi = np.linalg.inv(chain.base)
        T = Bi @ T
    R = T[..., :3, :3]
    u = T[..., :3, 3] + R @ v - b["S"]
    z = R @ zt
    d = np.linalg.norm(u, axis=-1)
    g = np.einsum("...i,...i->...", u, z)
    # a pose within margin of T moves W by at most margin·(1 + |v|), z by margin
    sW = margin * (1.0 + float(np.linalg.norm(v)))
    tiny = 1e-9 * (1.0 + float(np.linalg.norm(chain.fixed[:, :3, 3], axis=-1).sum() + np.linalg.norm(v)))
    sg = sW + margin * (d + sW) + tiny
    ok = ((d <= b["hi"][0] + sW + tiny) & (d >= b["lo"][0] - sW - tiny)
          & (g <= b["hi"][1] + sg) & (g >= b["lo"][1] - sg))
    h = u @ b["a0"]
    return ok & (h <= b["hi"][2] + sW + tiny) & (h >= b["lo"][2] - sW - tiny)
