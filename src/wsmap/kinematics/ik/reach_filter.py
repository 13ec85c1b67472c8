"""Sound reach pre-filters of the numerical search: tests that prove a target out of reach before any LM.

A target that fails them cannot be confirmed by any configuration, so the search
(:mod:`wsmap.kinematics.ik.search`) marks it unreachable without running LM: they change no
result, only the time.

* :func:`reach_filter` — the wrist point (the origin of the last revolute joint's frame, fixed by
  the tool pose) farther from the base than the links can stretch, or outside the set the joints
  before it can sweep it through (a ball cut by a slab carried back from the wrist joint by joint,
  then turned about joint 0; :func:`_wrist_orbit`, exact for the PUMA560 at a fixed orientation);
* :func:`position_filter` — the tool origin farther than the links can stretch (position-only
  search).

Both measure from :func:`first_axis_point`, a point no joint moves. Lengths in metres.
"""

from __future__ import annotations

import numpy as np

from .. import lm_compiled
from ..chain import PRISMATIC, SerialChain
from .memo import Memo, content_key

__all__ = ["reach_filter", "position_filter", "first_axis_point"]

_ORBITS = Memo()


def _lengths_strokes(chain: SerialChain):
    """``(lengths (..., n+1), stroke (...,))``: the length of each fixed transform's translation,
    and the most the prismatic joints can add together (a slide moves by ``q + offset`` along its
    unit axis, ``q`` within its limits)."""
    lengths = np.linalg.norm(chain.fixed[..., :3, 3], axis=-1)
    pris = np.array([k == PRISMATIC for k in chain.kinds])
    stroke = np.zeros(chain.batch_shape)
    if pris.any():
        ends = chain.limits[..., pris, :] + np.asarray(chain.offset)[..., pris, None]
        stroke = np.abs(ends).max(axis=-1).sum(axis=-1)
    return lengths, stroke


def reach_filter(chain: SerialChain, T, margin, wrist_orbit: bool = True):
    """A sound test (…,) bool: False where no configuration puts the tool within ``margin`` of ``T``.

    If the last joint is revolute, the origin of its frame (the "wrist point") is fixed by the tool
    pose: ``T · G⁻¹`` with ``G = F_n · tool``; it is at most ``Σ_{i<n} |t(F_i)| - used`` (plus the
    strokes of prismatic joints) from the first joint's axis point (:func:`first_axis_point`),
    which no joint moves.
    Otherwise the tool origin itself is bounded by the lengths of the later fixed transforms and the
    tool. A pose within ``margin`` in position and
    rotation angle of a reachable one moves the wrist point by at most ``margin·(1 + |t(G)|)``.

    ``wrist_orbit`` (arms of revolute joints): also the wrist point's orbit about joint 0 must meet
    the set the joints ``1 .. n-2`` sweep it through (:func:`_wrist_orbit`, :func:`_orbit_test`);
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
    """``R @ v`` for rotations ``R`` (..., 3, 3) and vectors ``v`` (..., 3), broadcast: three
    multiply-adds over whole arrays (a broadcast einsum over a batch of arms times nodes is several
    times slower)."""
    return R[..., 0] * v[..., None, 0] + R[..., 1] * v[..., None, 1] + R[..., 2] * v[..., None, 2]


def _wrist_orbit(chain: SerialChain):
    """A bound, per arm, of where the wrist point (the origin of the frame after ``F_{n-1}``) can be,
    in the frame after ``F_0`` (base folded in) before joint 0 turns it: joint 0 turns it about
    ``a0`` (3,) within ``{x : |x - c| <= r, |(x - c)·u| <= w}`` (a ball cut by a slab).

    Built from the wrist point back (joints ``n-2 .. 1``, their limits ignored, so a superset): a
    fixed transform moves the set rigidly; a revolute joint turning a ball ∩ slab ``(c, r, u, w)``
    about its axis ``a`` (through the origin) sweeps a set inside the ball about ``(c·a) a`` of radius
    ``ρ + r`` (``ρ`` the distance of ``c`` from the axis) cut by the slab normal to ``a`` of half-width
    ``e = min(r, min(w, r)·|u·a| + r·sqrt(1 - (u·a)²))`` (the set's extent along ``a``, unchanged by
    the turn). Returns ``(a0, c, r, u, w)`` with batch shapes ``(..., 3)`` and ``(...)``, or None
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
    """Whether some turn of the points ``p`` (..., 3) about the axis ``a`` (through the origin) puts
    them within ``slack`` of the set ``{x : |x - c| <= r, |(x - c)·u| <= w}`` (a necessary condition,
    exact up to rounding): the turned point runs on a circle; its distance to ``c`` is least at the
    circle's point nearest ``c`` if that point is inside the slab, else at an end of the arcs of
    the circle inside the slab (where ``(x - c)·u = ±w``)."""
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
    """A point no joint moves, and how much of the lengths it uses: ``(centre (…, 3), used (…,))``.

    The first joint turns (or slides) about its axis ``a`` through the origin of ``base · F_0``;
    the part of ``t(F_1)`` along ``a`` is not turned by it (a shoulder height such as the Panda's
    d1 = 0.333 m), so ``centre = base · F_0 · ((t(F_1)·a) a)`` is fixed, and everything after it
    is within ``|t(F_1)⊥|`` (the part across the axis) plus the later lengths:
    ``used = |t(F_0)| + |t(F_1)| - |t(F_1)⊥|`` is what the reach bounds subtract from the sum of
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
    ``margin`` of the positions ``p`` (N, 3): farther from a point of the first joint's axis
    (:func:`first_axis_point`) than the lengths of the fixed transforms after it, the tool and the
    prismatic strokes together."""
    lengths, stroke = _lengths_strokes(chain)
    lengths = lengths.sum(axis=-1) + stroke  # (...,)
    if chain.tool is not None:
        lengths = lengths + np.linalg.norm(chain.tool[:3, 3])
    centre, used = first_axis_point(chain)
    dist = np.linalg.norm(np.asarray(p) - centre[..., None, :], axis=-1)  # (..., N)
    reach = np.asarray(lengths - used)[..., None] * (1.0 + 1e-12) + margin + 1e-12
    return dist <= reach  # (N,) or (B, N)
