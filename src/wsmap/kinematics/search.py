"""Reachability search: multi-start Levenberg–Marquardt for any serial arm, joint limits inside the search.

:func:`ikine_search` decides, per target pose, whether the arm reaches it, and returns a solution
where it does. It is the numerical path of :mod:`wsmap.workspace` (maps and
:func:`wsmap.workspace.reachable`). Per target:

* **Starts, in order, with early exit.** Start 0 is ``q0`` (default zeros); starts ``1 ..`` are
  drawn uniformly inside the limits (``[-pi, pi)`` for an unlimited revolute joint). Start ``k``
  runs only on the targets that starts ``0 .. k-1`` did not solve, so a run with ``k`` starts is
  the first ``k`` starts of a longer one. The random numbers of a target come from a counter-based
  hash (splitmix64) of ``seed``, the target pose's bits, the start and the joint: deterministic,
  independent between targets, and the same wherever the pose sits in a batch. Every target's
  arithmetic is elementwise over rows of targets (no reduction across targets), so results do not
  depend on ``chunk`` or on which targets share a call.
* **The iteration** is the paper's LM (Appendix; :func:`wsmap.kinematics.ikine_LM`)::

      dq = (JᵀJ + λ² I)⁻¹ Jᵀe,   q' = P(q + dq)
      accept if |e(q')| < |e(q)|: q = q', λ /= 2, r = 0;  else λ *= 2, r += 1 (fail when r > rlimit)

  with ``J`` the base-frame geometric Jacobian, and three changes. (1) The rotation part of ``e``
  is the rotation vector ``θ·a`` of ``R_target·Rᵀ`` rather than Corke's ``tr2delta``
  ``sin θ·a``, which also vanishes at a half turn: from random starts LM fell into that false zero
  about half the time. (2) ``P`` projects onto the limits: a revolute joint whose range is
  narrower than a turn and which leaves it is first moved by a multiple of 2·pi to the equivalent
  angle closest to the range (inside it when there is one), then clipped; a prismatic joint is
  clipped. And a joint on a limit that the gradient ``Jᵀe`` pushes outward is held for that step
  (its row and column replaced by the identity, as in Bertsekas' projected Newton), so the
  iteration slides along the limits instead of stalling against them. Joints without limits, or
  with a range of a turn or more, move freely and are brought into their range by a multiple of
  2·pi at the end. (3) Per-start limits ``ilimit = 100``, ``rlimit = 20`` (see
  :data:`DEFAULT_ILIMIT`).
* **Two passes per start on limited arms.** Where the constrained run fails and the limits did
  change it, LM runs again from the same start ignoring the limits, and its solution, moved into
  the range by multiples of 2·pi, counts if it lies inside the limits (a solution behind a limit
  that the constrained run could not walk around). Where the limits never changed the
  constrained run, the free run would be the same run, so it is skipped.
* **Success** = the error norm reached ``tol``, ``q`` lies inside the limits, and an independent
  forward kinematics (:meth:`SerialChain.fkine`) of the returned ``q`` puts the tool within
  ``confirm_tol`` of the target (metres in position, radians in rotation angle). A start whose
  check fails does not count, and the next start runs.
* **Sound pre-filter.** A target whose wrist point is farther from the base than the sum of the
  arm's link lengths (plus ``confirm_tol`` margins), or outside the set that the joints before it
  can sweep it through (a ball cut by a slab carried back from the wrist point joint by joint,
  then turned about joint 0: :func:`_wrist_orbit`, exact for the PUMA560), cannot be confirmed by
  any ``q``; it is marked unreachable without running LM. It changes no result, only the time.
* **Exact stagnation shortcut** (as in :mod:`.lm_kernel`): once λ is so large that no later step
  can move ``q`` by one bit, every later trial is rejected, so the start fails at once.

The paper's own one-start path, :func:`wsmap.kinematics.ikine_LM` (fast kernel, DH arms, limits
checked after convergence), is unchanged; the paper's pipeline keeps using it (in the maps:
``ik={"solver": "paper"}``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .chain import PRISMATIC, SerialChain, from_dh
from .dh import DHRobot
from .transforms import check_rigid

def _content_key(*parts):
    """A hashable key of arrays (by shape, dtype and bytes) and plain values, for the memos below."""
    return tuple((p.shape, p.dtype.str, p.tobytes()) if isinstance(p, np.ndarray) else p for p in parts)


class _Memo:
    """A small least-recently-used memo of pure functions of an arm's numbers, keyed by content (so
    an array changed in place is a new key); internal: callers must not change what it returns."""

    def __init__(self, size: int = 16):
        self.size = size
        self.items: dict = {}

    def get(self, key, make):
        if key in self.items:
            value = self.items.pop(key)
        else:
            value = make()
            if len(self.items) >= self.size:
                self.items.pop(next(iter(self.items)))
        self.items[key] = value
        return value


_CHAINS = _Memo()
_ORBITS = _Memo()
_ARM_ARRAYS = _Memo()


def _chain_key(chain: SerialChain):
    return _content_key(chain.fixed, chain.axes, chain.kinds, np.asarray(chain.offset), chain.qlim, chain.base,
                        chain.tool)


__all__ = ["BACKENDS", "MAP_SETTINGS", "map_search", "DEFAULT_ILIMIT", "DEFAULT_RLIMIT", "DEFAULT_STARTS", "FK_CONFIRM_TOL", "SearchResult", "as_chain",
           "ikine_search"]

#: Starts per target of :func:`ikine_search`, the maps' numerical path and ``reachable``. Measured
#: with ``benchmarks/bench_recall.py`` (21³ grid; PUMA560 with and without limits against the closed
#: form, UR5e against EAIK; R = I and tool down): the hardest case, PUMA560 with limits, needs 24
#: starts for recall >= 0.999 at seed 0 but 32 at seed 1 (24: 0.9986); 32 starts missed no node in
#: any case at seeds 0-4. No false positive at any count.
DEFAULT_STARTS = 32

#: Per-start iteration and consecutive-rejection limits. The paper's 500 and 100 spend most of a
#: failing start on rejections (a start that fails, fails slowly); 100 and 20 gave the same recall
#: at every count of starts in ``benchmarks/bench_recall.py`` (so did 60 and 10) at about half the time.
DEFAULT_ILIMIT = 100
DEFAULT_RLIMIT = 20

#: Tolerance of the forward-kinematics confirmation of every success (m and rad).
FK_CONFIRM_TOL = 1e-6

_TWO_PI = 2.0 * np.pi
_EPS = np.finfo(np.float64).eps


@dataclass
class SearchResult:
    """Result of :func:`ikine_search`; every field has the broadcast batch shape of targets and arms.

    q : (..., n) a confirmed solution where ``success`` (inside the limits); elsewhere the end point
        of the start with the smallest final error (inside the limits; NaN where LM was not run)
    success : (...,) bool, the target is reachable (a solution was found and confirmed)
    iterations : (...,) int, LM iterations over all starts tried
    residual : (...,) float, the error norm at ``q`` (``inf`` where LM was not run)
    start : (...,) int, index of the start that succeeded, -1 where none did
    """

    q: np.ndarray
    success: np.ndarray
    iterations: np.ndarray
    residual: np.ndarray
    start: np.ndarray


def as_chain(robot) -> SerialChain:
    """``robot`` as a :class:`SerialChain`: a chain is returned as is, a :class:`DHRobot` converted
    with :func:`from_dh` (standard DH, same limits and tool)."""
    if isinstance(robot, SerialChain):
        return robot
    if isinstance(robot, DHRobot):
        return from_dh(robot.d, robot.a, robot.alpha, qlim=robot.qlim, tool=robot.tool, name=robot.name)
    raise TypeError(f"robot must be a SerialChain or a DHRobot, got {type(robot).__name__}")


def flatten_arms(arms):
    """A batch of arms (:class:`SerialChain` or :class:`DHRobot`, batch shape ``(...)``) as a flat
    batch ``(B,)`` of the same arms, in C order."""
    n = arms.n
    if isinstance(arms, SerialChain):
        b = arms.batch_shape
        qlim = None if arms.qlim is None else np.broadcast_to(arms.qlim, b + (n, 2)).reshape(-1, n, 2)
        fshape = arms.fixed.shape[-3:]
        return arms.replace(fixed=np.broadcast_to(arms.fixed, b + fshape).reshape((-1,) + fshape),
                            offset=np.broadcast_to(arms.offset, b + (n,)).reshape(-1, n), qlim=qlim)
    qlim = arms.qlim
    if qlim is not None and qlim.ndim > 2:
        qlim = np.broadcast_to(qlim, arms.batch_shape + (n, 2)).reshape(-1, n, 2)
    return DHRobot(arms.d.reshape(-1, n), arms.a.reshape(-1, n), arms.alpha.reshape(-1, n), qlim=qlim, tool=arms.tool)


def _as_chain_memo(robot) -> SerialChain:
    """:func:`as_chain`, memoised by content for a :class:`DHRobot` (its conversion is the larger part
    of a small call's fixed cost); the result is shared, not to be changed."""
    if isinstance(robot, DHRobot):
        key = _content_key("dh", np.asarray(robot.d), np.asarray(robot.a), np.asarray(robot.alpha),
                           None if robot.qlim is None else np.asarray(robot.qlim),
                           None if robot.tool is None else np.asarray(robot.tool), robot.name)
        return _CHAINS.get(key, lambda: as_chain(robot))
    return as_chain(robot)


def _check_count(name, v, minimum):
    try:
        ok = not isinstance(v, bool) and np.isscalar(v) and np.isreal(v) and np.isfinite(v) and int(v) == v
    except (TypeError, ValueError, OverflowError):
        ok = False
    if not ok or v < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {v!r}")
    return int(v)


def _start_box(limits: np.ndarray):
    """Bounds ``(lo, hi)`` (..., n) that random starts are drawn in: the limits, ``[-pi, pi)`` where unlimited."""
    lo = np.where(np.isfinite(limits[..., 0]), limits[..., 0], -np.pi)
    hi = np.where(np.isfinite(limits[..., 1]), limits[..., 1], np.pi)
    # a half-open revolute range: one turn from its finite end
    lo = np.where(np.isfinite(limits[..., 1]) & ~np.isfinite(limits[..., 0]), hi - _TWO_PI, lo)
    hi = np.where(np.isfinite(limits[..., 0]) & ~np.isfinite(limits[..., 1]), lo + _TWO_PI, hi)
    return lo, hi


def _mix(z):
    """splitmix64's finaliser on uint64 arrays (wrapping arithmetic)."""
    z = z + np.uint64(0x9E3779B97F4A7C15)
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))


def _pose_keys(seed: int, T) -> np.ndarray:
    """A 64-bit key per target pose ``(K, 4, 4)``: the seed mixed with the bits of ``T[:3, :]``,
    so a pose gets the same random starts wherever it sits in a batch."""
    # + 0.0 turns -0.0 into 0.0, so that equal poses have equal keys
    words = np.ascontiguousarray(T[:, :3, :] + 0.0, dtype=np.float64).reshape(len(T), 12).view(np.uint64)
    from . import lm_compiled

    return lm_compiled.pose_keys(_mix(np.array([seed], dtype=np.uint64))[0], words)


def _uniform(keys, k, n: int) -> np.ndarray:
    """``(K, n)`` uniform numbers in ``[0, 1)`` for starts ``k`` (K,) of targets with ``keys`` (K,)."""
    k = np.asarray(k, dtype=np.uint64).reshape(-1, 1)
    ctr = _mix(k * np.uint64(1 << 16) + np.arange(1, n + 1, dtype=np.uint64)[None, :])  # (K or 1, n)
    bits = _mix(keys[:, None] + ctr)
    return (bits >> np.uint64(11)).astype(np.float64) * (1.0 / (1 << 53))


def _check_seed(seed):
    if seed is None:
        return int(np.random.default_rng().integers(0, 2**63))
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0 or seed >= 2**64:
        raise ValueError(f"seed must be a non-negative integer (or None for a random one), got {seed!r}")
    return int(seed)


def _check_settings(chain: SerialChain, tol, lam, confirm_tol, seed, q0):
    """The checks :func:`ikine_search` and :func:`map_search` share: ``tol``, ``lam`` and
    ``confirm_tol`` positive and finite with ``confirm_tol >= tol``; returns ``(seed, q0)`` checked
    (``q0`` default zeros, shape ``(..., n)``)."""
    for label, v in (("tol", tol), ("lam", lam), ("confirm_tol", confirm_tol)):
        if isinstance(v, bool) or not (np.isscalar(v) and np.isreal(v) and v > 0 and np.isfinite(v)):
            raise ValueError(f"{label} must be positive and finite, got {v!r}")
    if confirm_tol < tol:
        raise ValueError(f"confirm_tol ({confirm_tol}) must be at least tol ({tol})")
    seed = _check_seed(seed)
    q0 = np.zeros(chain.n) if q0 is None else chain._check_q(q0)
    return seed, q0


def _limited(chain: SerialChain, joint_limits: bool) -> SerialChain:
    """The chain, or without its revolute limits (prismatic joints keep their strokes)."""
    if joint_limits or chain.qlim is None:
        return chain
    pris = np.array([k == PRISMATIC for k in chain.kinds])
    if not pris.any():
        return chain.replace(qlim=None)
    qlim = np.array(chain.qlim, dtype=np.float64)
    qlim[..., ~pris, 0], qlim[..., ~pris, 1] = -np.inf, np.inf
    return chain.replace(qlim=qlim)


# --------------------------------------------------------------------------- projection onto the limits
def _project(q, lo, hi, revolute):
    """``q`` (..., n) projected onto ``[lo, hi]`` (broadcasting): a revolute joint outside is first
    moved by a multiple of 2·pi to the equivalent closest to the range, then clipped; a prismatic
    joint is clipped. A joint inside its range is returned unchanged (bit for bit)."""
    inside = (q >= lo) & (q <= hi)
    if inside.all():
        return q
    with np.errstate(invalid="ignore"):
        lo_f = np.isfinite(lo)
        # the equivalent of q in [lo, lo + 2pi) (finite lo), or in (hi - 2pi, hi] (lo = -inf)
        s = np.where(lo_f, lo + np.mod(q - lo, _TWO_PI), hi - np.mod(hi - q, _TWO_PI))
        # s beyond hi (a range narrower than a turn): the closer end, hi (from above) or lo (s - 2pi)
        over = s > hi
        s = np.where(over, np.where(s - hi <= lo + _TWO_PI - s, hi, lo), s)
        wrapped = np.where(revolute, s, np.clip(q, lo, hi))
    return np.where(inside, q, wrapped)


# --------------------------------------------------------------------------- kinematics on rows of targets
class _Arm:
    """A chain's numbers laid out for the solver: one column per target where they differ per arm.

    Rotations are ``(3, 3[, M])`` (row, column), translations ``(3[, M])``; the base is folded into
    the first fixed transform and the tool into the last. ``per_target``: the arrays carry a last
    axis of targets (a batch of arms), else they are shared.
    """

    def __init__(self, chain: SerialChain, arm_index=None):
        n = chain.n
        F = np.array(chain.fixed, dtype=np.float64)
        if chain.base is not None:
            F[..., 0, :, :] = chain.base @ F[..., 0, :, :]
        if chain.tool is not None:
            F[..., n, :, :] = F[..., n, :, :] @ chain.tool
        self.n = n
        self.kinds = chain.kinds
        self.revolute = np.array([k != PRISMATIC for k in chain.kinds])
        self.axes = chain.axes
        self.zaxis = [bool(a[0] == 0.0 and a[1] == 0.0) for a in chain.axes]
        batch = chain.batch_shape
        lim = chain.limits
        if batch == ():
            self.per_target = False
            self.R = np.ascontiguousarray(F[:, :3, :3])  # (n+1, 3, 3)
            self.t = np.ascontiguousarray(F[:, :3, 3])  # (n+1, 3)
            self.offset = np.asarray(chain.offset, dtype=np.float64)  # (n,)
            self.lo, self.hi = np.array(lim[:, 0]), np.array(lim[:, 1])  # (n,)
        else:
            # arm_index: flat index into the batch of arms, one per target
            Fb = np.broadcast_to(F, batch + F.shape[-3:]).reshape((-1,) + F.shape[-3:])[arm_index]
            self.per_target = True
            self.R = np.ascontiguousarray(np.moveaxis(Fb[:, :, :3, :3], 0, -1))  # (n+1, 3, 3, M)
            self.t = np.ascontiguousarray(np.moveaxis(Fb[:, :, :3, 3], 0, -1))  # (n+1, 3, M)
            off = np.broadcast_to(chain.offset, batch + (n,)).reshape(-1, n)[arm_index]
            self.offset = np.ascontiguousarray(off.T)  # (n, M)
            lb = np.broadcast_to(lim, batch + (n, 2)).reshape(-1, n, 2)[arm_index]
            self.lo, self.hi = np.ascontiguousarray(lb[:, :, 0].T), np.ascontiguousarray(lb[:, :, 1].T)
        # joints that the projection clips (prismatic, or revolute with a range narrower than a turn)
        width = self.hi - self.lo
        with np.errstate(invalid="ignore"):
            clip = np.where(self.revolute.reshape((n,) + (1,) * (width.ndim - 1)), width < _TWO_PI, True)
        self.clipped = clip & (np.isfinite(self.lo) | np.isfinite(self.hi))
        # the bounds the LM projects onto: the clipped joints' limits; the others move freely and are
        # brought into their (at least a turn wide) range by a multiple of 2·pi at the end
        self.clo = np.where(self.clipped, self.lo, -np.inf)
        self.chi = np.where(self.clipped, self.hi, np.inf)
        self.limited = bool(self.clipped.any())

    def take(self, cols) -> "_Arm":
        """The same arm numbers for a subset of the targets (a view where shared)."""
        if not self.per_target:
            return self
        out = object.__new__(_Arm)
        out.__dict__.update(self.__dict__)
        out.R, out.t = self.R[..., cols], self.t[..., cols]
        out.offset, out.lo, out.hi = self.offset[:, cols], self.lo[:, cols], self.hi[:, cols]
        out.clipped, out.clo, out.chi = self.clipped[:, cols], self.clo[:, cols], self.chi[:, cols]
        return out

    def _cols(self, *arrays):
        return arrays if self.per_target else tuple(a[:, None] for a in arrays)

    def bounds(self):
        """``(lo, hi)``: the limits, as ``(n, 1)`` (shared) or ``(n, M)`` arrays."""
        return self._cols(self.lo, self.hi)

    def lm_bounds(self):
        """``(lo, hi, clipped)`` that the LM projects onto, ``(n, 1)`` or ``(n, M)``."""
        return self._cols(self.clo, self.chi, self.clipped)

    def unlimited(self):
        """Revolute joints without limits, ``(n, 1)`` or ``(n, M)``."""
        lo, hi = self.bounds()
        return self.revolute[:, None] & np.isinf(lo) & np.isinf(hi)

    def fk(self, q):
        """Forward kinematics of ``q`` (n, W): tool rotation ``R`` (3, 3, W), position ``p`` (3, W),
        joint axes ``w`` (n, 3, W) and joint origins ``o`` (n, 3, W) in the world frame."""
        n, W = q.shape
        x = q + self.offset if self.per_target else q + self.offset[:, None]
        c, s = np.cos(x), np.sin(x)
        R = np.empty((3, 3, W))
        p = np.empty((3, W))
        R[...] = self.R[0] if self.per_target else self.R[0][..., None]
        p[...] = self.t[0] if self.per_target else self.t[0][:, None]
        w = np.empty((n, 3, W))
        o = np.empty((n, 3, W))
        for i in range(n):
            ax = self.axes[i]
            o[i] = p
            # world axis w = R·axis, summed in a fixed order
            if self.zaxis[i]:
                w[i] = R[:, 2] * ax[2]
            else:
                w[i] = R[:, 0] * ax[0] + R[:, 1] * ax[1] + R[:, 2] * ax[2]
            if self.kinds[i] == PRISMATIC:
                p = p + w[i] * x[i]
            elif self.zaxis[i]:
                ci, si = c[i], s[i] * ax[2]
                r0 = R[:, 0] * ci + R[:, 1] * si
                r1 = R[:, 1] * ci - R[:, 0] * si
                R[:, 0], R[:, 1] = r0, r1
            else:
                # Rodrigues: Rot = I + s K + (1 - c) K², columns via Rot[:, k] = e_k + s K e_k + (1 - c) K K e_k
                K = np.array([[0.0, -ax[2], ax[1]], [ax[2], 0.0, -ax[0]], [-ax[1], ax[0], 0.0]])
                K2 = K @ K
                Rot = np.eye(3)[:, :, None] + K[:, :, None] * s[i] + K2[:, :, None] * (1.0 - c[i])
                R = _matmul33(R, Rot)
            # the fixed transform after joint i
            Rf, tf = self.R[i + 1], self.t[i + 1]
            p = p + (R[:, 0] * tf[0] + R[:, 1] * tf[1] + R[:, 2] * tf[2])
            R = _matmul33(R, Rf if self.per_target else Rf[..., None])
        return R, p, w, o

    def jacobian(self, p, w, o):
        """Geometric Jacobian (6, n, W): column j is ``[w_j × (p − o_j); w_j]`` (revolute) or ``[w_j; 0]``."""
        n, _, W = w.shape
        J = np.empty((6, n, W))
        for j in range(n):
            if self.kinds[j] == PRISMATIC:
                J[0:3, j] = w[j]
                J[3:6, j] = 0.0
            else:
                d = p - o[j]
                wj = w[j]
                J[0, j] = wj[1] * d[2] - wj[2] * d[1]
                J[1, j] = wj[2] * d[0] - wj[0] * d[2]
                J[2, j] = wj[0] * d[1] - wj[1] * d[0]
                J[3:6, j] = wj
        return J


def _matmul33(A, B):
    """``A @ B`` per target for (3, 3, W) arrays (B may be (3, 3, 1)), summed in a fixed order."""
    P = A[:, :, None, :] * B[None, :, :, :]  # (row, m, col, W)
    return P[:, 0] + P[:, 1] + P[:, 2]


def _pose_error(R, p, Rt, pt):
    """Pose error (6, W) ``[pt − p; θ·a]`` and its norm (W,), with ``θ·a`` the rotation vector of
    ``Rt·Rᵀ`` (the rotation from the current to the target orientation, base frame).

    Corke's ``tr2delta`` (the paper's, :func:`wsmap.kinematics.pose_error`) has ``sin θ·a`` in its
    place, which vanishes at a half turn as well as at the target: from a random start, LM descends
    into that false zero about as often as into the target. ``θ·a`` vanishes only at the target,
    agrees with ``tr2delta`` to ``O(θ³)`` near it, and is the angular velocity that the geometric
    Jacobian maps joint rates to, held for unit time, that turns the tool onto the target.
    """
    W = p.shape[1]
    e = np.empty((6, W))
    e[0:3] = pt - p
    c, t = R, Rt
    # v = ½ Σ_k c_k × t_k = sin θ·a, and Σ_k c_k·t_k = 1 + 2 cos θ, summed in a fixed order
    for r, (a, b) in enumerate(((1, 2), (2, 0), (0, 1))):
        acc = c[a, 0] * t[b, 0] - c[b, 0] * t[a, 0]
        acc = acc + (c[a, 1] * t[b, 1] - c[b, 1] * t[a, 1])
        acc = acc + (c[a, 2] * t[b, 2] - c[b, 2] * t[a, 2])
        e[3 + r] = 0.5 * acc
    tr = c[0, 0] * t[0, 0]
    for a in range(3):
        for b in range(3):
            if a or b:
                tr = tr + c[a, b] * t[a, b]
    v = e[3:6]
    sin = np.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    cos = 0.5 * (tr - 1.0)
    theta = np.arctan2(sin, cos)
    tiny = sin <= 1e-9
    scale = np.where(tiny, 1.0, theta / np.where(tiny, 1.0, sin))
    v *= scale
    half = tiny & (cos < 0.0)
    if half.any():
        # a half turn: a·aᵀ = (Rt·Rᵀ + I) / 2; the axis from its largest diagonal entry's column
        h = np.flatnonzero(half)
        Rr = np.einsum("ikw,jkw->ijw", t[..., h], c[..., h])
        S = 0.5 * (Rr + np.eye(3)[:, :, None])
        jmax = np.argmax(np.stack([S[0, 0], S[1, 1], S[2, 2]]), axis=0)
        col = S[:, jmax, np.arange(h.size)]  # (3, H)
        axis = col / np.sqrt(np.maximum(col[jmax, np.arange(h.size)], 1e-300))
        v[:, h] = axis * theta[h]
    sq = e[0] * e[0]
    for r in range(1, 6):
        sq = sq + e[r] * e[r]
    return e, np.sqrt(sq)


def _normal_equations(J, e):
    """``JᵀJ`` (n, n, W) and ``Jᵀe`` (n, W), summed over the 6 rows in a fixed order."""
    A = J[0][:, None, :] * J[0][None, :, :]
    g = J[0] * e[0]
    for r in range(1, 6):
        A = A + J[r][:, None, :] * J[r][None, :, :]
        g = g + J[r] * e[r]
    return A, g


def _solve(A, g, l2, held):
    """``(A + λ² I)⁻¹ g`` per target by Gaussian elimination without pivoting (symmetric positive
    definite for λ > 0); joints where ``held`` (n, W) get row and column of the identity and 0."""
    n, W = g.shape
    H = np.empty((n, n + 1, W))
    H[:, :n] = A
    H[:, n] = g
    idx = np.arange(n)
    H[idx, idx] += l2
    if held is not None:
        hj = held
        H[:, :n] = np.where(hj[:, None, :] | hj[None, :, :], 0.0, H[:, :n])
        H[idx, idx] = np.where(hj, 1.0, H[idx, idx])
        H[:, n] = np.where(hj, 0.0, H[:, n])
    for j in range(n):
        H[j, j + 1 :] = H[j, j + 1 :] / H[j, j]
        if j + 1 < n:
            H[j + 1 :, j + 1 :] = H[j + 1 :, j + 1 :] - H[j + 1 :, j, None] * H[j, None, j + 1 :]
    x = H[:, n].copy()
    for j in range(n - 1, 0, -1):
        x[:j] = x[:j] - H[:j, j] * x[j]
    return x


# --------------------------------------------------------------------------- one start on a set of targets
def _lm(arm: _Arm, Rt, pt, q, ilimit, rlimit, tol, lam0, constrained=True):
    """LM from ``q`` (n, M) towards the targets ``(Rt (3, 3, M), pt (3, M))``, inside the limits
    if ``constrained`` (else ignoring them).

    Returns ``q`` (n, M), converged (|e| <= tol) (M,), iterations (M,), residual (M,), and
    ``touched`` (M,): the limits changed a trial step at least once (without that, the run is the
    unconstrained run from the same start, bit for bit).
    """
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        return _lm_run(arm, Rt, pt, q, ilimit, rlimit, tol, lam0, constrained and arm.limited)


def _lm_run(arm, Rt, pt, q, ilimit, rlimit, tol, lam0, limited):
    n, M = q.shape
    rev = arm.revolute[:, None]
    touched_out = np.zeros(M, dtype=bool)
    if limited:
        lo, hi, _ = arm.lm_bounds()
        q0 = q
        q = _project(q, lo, hi, rev)
        touched_out |= np.any(q != q0, axis=0)
    q = np.array(q, dtype=np.float64)
    q_out = np.empty((n, M))
    ok_out = np.zeros(M, dtype=bool)
    it_out = np.zeros(M, dtype=np.int64)
    res_out = np.empty(M)

    R, p, w, o = arm.fk(q)
    e, na = _pose_error(R, p, Rt, pt)
    A, g = _normal_equations(arm.jacobian(p, w, o), e)
    lam = np.full(M, float(lam0))
    rej = np.zeros(M)
    it = np.zeros(M, dtype=np.int64)
    idx = np.arange(M)
    cur = arm  # the arm numbers of the active targets

    touched = touched_out.copy()

    def finish(mask, success):
        nonlocal q, e, na, A, g, lam, rej, it, idx, Rt, pt, cur, touched
        k = idx[mask]
        q_out[:, k] = q[:, mask]
        ok_out[k] = success[mask] if isinstance(success, np.ndarray) else success
        it_out[k] = it[mask]
        res_out[k] = na[mask]
        touched_out[k] = touched[mask]
        keep = ~mask
        touched = touched[keep]
        q, e, na, A, g = q[:, keep], e[:, keep], na[keep], A[..., keep], g[:, keep]
        lam, rej, it, idx = lam[keep], rej[keep], it[keep], idx[keep]
        Rt, pt = Rt[..., keep], pt[:, keep]
        cur = cur.take(keep)

    done = na <= tol
    if ilimit == 0:
        finish(np.ones(M, dtype=bool), done)
    elif done.any():
        finish(done, True)
    while idx.size:
        held = None
        if limited:
            # a joint on a limit that the gradient pushes outward is held for this step
            lo, hi, clipped = cur.lm_bounds()
            held = clipped & (((q <= lo) & (g < 0)) | ((q >= hi) & (g > 0)))
            if held.any():
                touched |= held.any(axis=0)
            else:
                held = None
        dq = _solve(A, g, lam * lam, held)
        qt = q + dq
        if limited:
            qp = _project(qt, lo, hi, rev)
            touched |= np.any(qp != qt, axis=0)
            qt = qp
        Rn, pn, wn, on = cur.fk(qt)
        en, nn = _pose_error(Rn, pn, Rt, pt)
        better = nn < na
        it += 1
        acc = np.flatnonzero(better)
        if acc.size:
            q[:, acc] = qt[:, acc]
            e[:, acc] = en[:, acc]
            na[acc] = nn[acc]
            Ja = cur.take(acc).jacobian(pn[:, acc], wn[..., acc], on[..., acc])
            A[..., acc], g[:, acc] = _normal_equations(Ja, e[:, acc])
        lam = np.where(better, lam * 0.5, lam * 2.0)
        rej = np.where(better, 0.0, rej + 1.0)
        success = better & (na <= tol)
        fail = ~success & ((rej > rlimit) | (it >= ilimit))
        # exact stagnation: no later step can move q by a bit (see lm_kernel._Kernel.stagnated)
        cand = np.flatnonzero(~success & ~fail & (rej > 0))
        if cand.size:
            mu = lam[cand] * lam[cand]
            gc, Ac = g[:, cand], A[..., cand]
            g2, trace = gc[0] * gc[0], Ac[0, 0]
            for j in range(1, n):
                g2 = g2 + gc[j] * gc[j]
                trace = trace + Ac[j, j]
            bound = (np.abs(gc) + (trace / mu + 64.0 * n * _EPS) * np.sqrt(g2)) / mu
            fail[cand] = np.all(bound <= 0.125 * np.spacing(np.abs(q[:, cand])), axis=0)
        if success.any() or fail.any():
            finish(success | fail, success)
    return q_out, ok_out, it_out, res_out, touched_out


# --------------------------------------------------------------------------- checks
def _rotation_angle(Ra, Rb):
    """Angle (rad) of ``Raᵀ Rb`` for (..., 3, 3) rotations, accurate near 0 and pi."""
    v = 0.5 * np.cross(Ra, Rb, axis=-2).sum(axis=-1)  # sin(θ)·axis
    cos = 0.5 * (np.einsum("...ij,...ij->...", Ra, Rb) - 1.0)
    return np.arctan2(np.linalg.norm(v, axis=-1), cos)


def _confirm(chain: SerialChain, q, T, atol):
    """``fkine(q)`` within ``atol`` of ``T`` (position m, rotation angle rad) and ``q`` inside the limits."""
    Tq = chain.fkine(q)
    dp = np.linalg.norm(Tq[..., :3, 3] - T[..., :3, 3], axis=-1)
    ang = _rotation_angle(Tq[..., :3, :3], T[..., :3, :3])
    return (dp <= atol) & (ang <= atol) & chain.within_limits(q)


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


def _reach_filter(chain: SerialChain, T, margin, wrist_orbit: bool = True):
    """A sound test (…,) bool: False where no configuration puts the tool within ``margin`` of ``T``.

    If the last joint is revolute, the origin of its frame (the "wrist point") is fixed by the tool
    pose: ``T · G⁻¹`` with ``G = F_n · tool``; it is at most ``Σ_{i<n} |t(F_i)| - used`` (plus the
    strokes of prismatic joints) from the first joint's axis point (:func:`_first_axis_point`),
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
    centre, used = _first_axis_point(chain)
    dist = np.linalg.norm(point - centre, axis=-1)
    ok = dist <= (reach - used) * (1.0 + 1e-12) + slack + 1e-12
    if chain.kinds[-1] != PRISMATIC and wrist_orbit and n >= 2:
        orbit = _ORBITS.get(_content_key(chain.fixed, chain.axes, chain.kinds), lambda: _wrist_orbit(chain))
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
    from . import lm_compiled

    r, w = np.asarray(r + slack, dtype=np.float64), np.asarray(w + slack, dtype=np.float64)
    shape = np.broadcast_shapes(p.shape[:-1], np.shape(c)[:-1], np.shape(u)[:-1], r.shape, w.shape)

    def rows(x, k=()):
        return np.ascontiguousarray(np.broadcast_to(x, shape + k), dtype=np.float64).reshape((-1,) + k)

    a = np.ascontiguousarray(a, dtype=np.float64)
    ref = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e0 = np.cross(a, ref)
    e0 /= np.linalg.norm(e0)
    return lm_compiled.orbit_test(a, e0, rows(c, (3,)), rows(r), rows(u, (3,)), rows(w), rows(p, (3,))).reshape(shape)


def _first_axis_point(chain: SerialChain) -> tuple[np.ndarray, np.ndarray]:
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


def _position_filter(chain: SerialChain, p, margin):
    """A sound test (B, N) or (N,) bool: False where no configuration puts the tool origin within
    ``margin`` of the positions ``p`` (N, 3): farther from a point of the first joint's axis
    (:func:`_first_axis_point`) than the lengths of the fixed transforms after it, the tool and the
    prismatic strokes together."""
    lengths, stroke = _lengths_strokes(chain)
    lengths = lengths.sum(axis=-1) + stroke  # (...,)
    if chain.tool is not None:
        lengths = lengths + np.linalg.norm(chain.tool[:3, 3])
    centre, used = _first_axis_point(chain)
    dist = np.linalg.norm(np.asarray(p) - centre[..., None, :], axis=-1)  # (..., N)
    reach = np.asarray(lengths - used)[..., None] * (1.0 + 1e-12) + margin + 1e-12
    return dist <= reach  # (N,) or (B, N)


def _runs(chain, arm, Rt, pt, qs, T, arm_index, settings, confirm_tol):
    """One start per column of ``qs`` (n, P): the constrained run, then (limited arms, where it
    failed and the limits changed it) the free run; successes confirmed by forward kinematics.

    Returns ``q`` (P, n) (the solution where ``ok``), ``ok`` (P,), iterations (P,) of both passes,
    the residual (P,) (of the successful pass where ``ok``, else of the constrained run) and the end
    point ``qc`` (P, n) of the constrained run.
    """
    ilimit, rlimit, tol, lam = settings
    P, n = qs.shape[1], qs.shape[0]
    q_all = np.full((P, n), np.nan)
    ok = np.zeros(P, dtype=bool)
    its = np.zeros(P, dtype=np.int64)
    res_c = np.full(P, np.inf)
    q_c = np.full((P, n), np.nan)
    rest = np.arange(P)
    for constrained in (True, False) if arm.limited else (True,):
        if not rest.size:
            break
        sub = arm.take(rest)
        q, conv, it, res, touched = _lm(sub, Rt[..., rest], pt[:, rest], qs[:, rest], ilimit, rlimit, tol, lam,
                                        constrained)
        # into the limits by multiples of 2·pi (clipping what the free pass left outside); unlimited
        # revolute joints into [-pi, pi): what is confirmed is what is returned
        slo, shi = sub.bounds()
        q = _project(q, slo, shi, sub.revolute[:, None])
        q = np.where(sub.unlimited(), np.mod(q + np.pi, _TWO_PI) - np.pi, q).T
        its[rest] += it
        if constrained:
            res_c[rest], q_c[rest] = res, q
        good = conv.copy()
        if conv.any():
            c = np.flatnonzero(conv)
            ch = chain if arm_index is None else chain[np.unravel_index(arm_index[rest[c]], chain.batch_shape)]
            good[c] = _confirm(ch, q[c], T[rest[c]], confirm_tol)
        q_all[rest[good]] = q[good]
        res_c[rest[good]] = res[good]
        ok[rest[good]] = True
        # the free pass only where the limits changed the constrained run (else it is the same run)
        rest = rest[~good & touched]
    return q_all, ok, its, res_c, q_c


# --------------------------------------------------------------------------- the compiled backend
BACKENDS = ("compiled", "numpy")


def _check_backend(backend):
    if backend not in BACKENDS:
        raise ValueError(f"unknown backend {backend!r}; choose one of {', '.join(BACKENDS)}")


def arm_arrays(chain: SerialChain) -> dict:
    """The numbers of a chain (or a batch, flattened to ``B`` arms) as the compiled kernel reads them.

    ``Rf`` (B, n+1, 3, 3) and ``tf`` (B, n+1, 3): the fixed transforms with the base folded into the
    first and the tool into the last; ``off``, ``lo``, ``hi`` (B, n): offsets and limits (±inf where
    unlimited); ``clo``, ``chi``, ``clipped`` (B, n): the bounds the LM projects onto (see
    :class:`_Arm`); ``limited`` (B,): any joint clipped; ``unlimited`` (B, n): revolute without limits;
    ``blo``, ``bhi`` (B, n): the box random starts are drawn in; shared ``axes`` (n, 3), ``pris``
    and ``zax`` (n,) bool.
    """
    n = chain.n
    batch = chain.batch_shape
    B = int(np.prod(batch, dtype=np.int64))
    F = np.array(np.broadcast_to(chain.fixed, batch + (n + 1, 4, 4)), dtype=np.float64).reshape(B, n + 1, 4, 4)
    if chain.base is not None:
        F[:, 0] = chain.base @ F[:, 0]
    if chain.tool is not None:
        F[:, n] = F[:, n] @ chain.tool
    lim = np.broadcast_to(chain.limits, batch + (n, 2)).reshape(B, n, 2)
    lo, hi = np.ascontiguousarray(lim[..., 0]), np.ascontiguousarray(lim[..., 1])
    pris = np.array([k == PRISMATIC for k in chain.kinds])
    with np.errstate(invalid="ignore"):
        clipped = np.where(~pris, (hi - lo) < _TWO_PI, True) & (np.isfinite(lo) | np.isfinite(hi))
    blo, bhi = _start_box(lim)
    Rf = np.ascontiguousarray(F[:, :, :3, :3])
    # 0: identity, 1: a rotation about x (R[0] = e0, R[:, 0] = e0), 2: any; exact comparisons, so
    # the kernel's shortcuts drop only products with exact zeros and ones
    e0 = np.array([1.0, 0.0, 0.0])
    about_x = np.all(Rf[..., 0, :] == e0, axis=-1) & np.all(Rf[..., :, 0] == e0, axis=-1)
    rkind = np.where(np.all(Rf == np.eye(3), axis=(-2, -1)), 0, np.where(about_x, 1, 2)).astype(np.int8)
    return dict(
        Rf=Rf, tf=np.ascontiguousarray(F[:, :, :3, 3]), rkind=rkind,
        off=np.ascontiguousarray(np.broadcast_to(chain.offset, batch + (n,)).reshape(B, n), dtype=np.float64),
        axes=np.ascontiguousarray(chain.axes, dtype=np.float64), pris=pris,
        zax=np.array([a[0] == 0.0 and a[1] == 0.0 for a in chain.axes]),
        lo=lo, hi=hi, clo=np.where(clipped, lo, -np.inf), chi=np.where(clipped, hi, np.inf), clipped=clipped,
        limited=clipped.any(axis=1), unlimited=~pris & np.isinf(lo) & np.isinf(hi),
        blo=np.ascontiguousarray(blo), bhi=np.ascontiguousarray(bhi),
    )


def run_compiled(mode, aa: dict, arm, T, keys, qexp, nexp, k_first, k_last, ilimit, rlimit, tol, lam, confirm_tol,
                 gtol=0.0, free_pass=True):
    """Run :func:`wsmap.kinematics.lm_compiled.run_targets` on targets ``T`` (M, 4, 4) of arms
    ``arm`` (M,) (indices into ``aa``, from :func:`arm_arrays`). Returns ``q`` (M, n), ``ok``,
    ``iterations``, ``residual``, ``start`` (M,)."""
    from . import lm_compiled

    M, n = len(T), aa["axes"].shape[0]
    q = np.full((M, n), np.nan)
    ok = np.zeros(M, dtype=bool)
    it = np.zeros(M, dtype=np.int64)
    res = np.full(M, np.inf)
    start = np.full(M, -1, dtype=np.int64)
    if M:
        Rt = np.ascontiguousarray(T[:, :3, :3], dtype=np.float64)
        pt = np.ascontiguousarray(T[:, :3, 3], dtype=np.float64)
        with lm_compiled.threads_for(M, 64):
            lm_compiled.run_targets(
                mode, np.ascontiguousarray(arm, dtype=np.int64), Rt, pt, np.ascontiguousarray(keys, dtype=np.uint64),
                np.ascontiguousarray(qexp, dtype=np.float64), np.ascontiguousarray(nexp, dtype=np.int64),
                int(k_first), int(k_last), aa["Rf"], aa["tf"], aa["rkind"], aa["off"], aa["axes"], aa["pris"], aa["zax"],
                aa["lo"], aa["hi"], aa["clo"], aa["chi"], aa["clipped"], aa["limited"], aa["unlimited"], aa["blo"],
                aa["bhi"], int(ilimit), int(rlimit), float(tol), float(lam), float(gtol), float(confirm_tol),
                bool(free_pass), q, ok, it, res, start)
    return q, ok, it, res, start


# --------------------------------------------------------------------------- the solver
def ikine_search(
    robot,
    T,
    *,
    starts: int = DEFAULT_STARTS,
    seed=0,
    q0=None,
    tol: float = 1e-10,
    ilimit: int = DEFAULT_ILIMIT,
    rlimit: int = DEFAULT_RLIMIT,
    lam: float = 0.1,
    joint_limits: bool = True,
    confirm_tol: float = FK_CONFIRM_TOL,
    chunk: int = 16384,
    progress=None,
    backend: str = "compiled",
    position_only: bool = False,
) -> SearchResult:
    """Multi-start Levenberg–Marquardt reachability search with joint limits (see the module notes).

    Parameters
    ----------
    robot : SerialChain or DHRobot
        One arm or a batch; its batch shape broadcasts with the targets'.
    T : array_like, shape (..., 4, 4)
        Target tool poses in the base (world) frame; each must be a rigid transform.
    starts : int
        Start configurations per target, tried in order until one succeeds (1: only ``q0``).
    seed : int >= 0, or None
        Seed of the random starts 1.. (None: a fresh random seed, not reproducible).
    q0 : array_like, shape (n,) or (..., n), optional
        Start 0 (default zeros; projected into the limits).
    tol, ilimit, rlimit, lam :
        Per start: tolerance on the error norm (m and rad), iteration limit, consecutive-rejection
        limit, initial λ. Defaults 1e-10, 100, 20, 0.1 (the paper's LM: 1e-10, 500, 100, 0.1).
    joint_limits : bool
        Honour the arm's limits (default). False drops the revolute joints' limits.
    confirm_tol : float
        Forward-kinematics confirmation tolerance (m, rad); at least ``tol``.
    chunk : int
        Targets solved together (bounds memory; the result does not depend on it).
    progress : callable, optional
        Called with the number of targets finished after each chunk.
    backend : ``"compiled"`` (default; :mod:`.lm_compiled`, numba, threads from
        :func:`wsmap.kinematics.lm_compiled.set_threads`) or ``"numpy"`` (the reference kernel of
        this module). Both run the same iterations; answers agree up to rounding.
    position_only : reach the position of each ``T`` at any orientation (compiled backend only)
    """
    _check_backend(backend)
    if position_only and backend != "compiled":
        raise ValueError("position_only needs the compiled backend")
    chain = _limited(_as_chain_memo(robot), joint_limits)
    T = check_rigid("target poses", T)
    starts = _check_count("starts", starts, 1)
    ilimit = _check_count("ilimit", ilimit, 0)
    rlimit = _check_count("rlimit", rlimit, 0)
    chunk = _check_count("chunk", chunk, 1)
    seed, q0 = _check_settings(chain, tol, lam, confirm_tol, seed, q0)
    n = chain.n
    batch = chain.batch_shape
    shape = np.broadcast_shapes(T.shape[:-2], batch, q0.shape[:-1])
    count = int(np.prod(shape, dtype=np.int64))
    Tf = np.broadcast_to(T, shape + (4, 4)).reshape(-1, 4, 4)
    Q0 = np.broadcast_to(q0, shape + (n,)).reshape(-1, n)
    B = int(np.prod(batch, dtype=np.int64))
    arm_of = np.broadcast_to(np.arange(B).reshape(batch), shape).reshape(-1)

    q_out = np.full((count, n), np.nan)
    ok_out = np.zeros(count, dtype=bool)
    it_out = np.zeros(count, dtype=np.int64)
    res_out = np.full(count, np.inf)
    start_out = np.full(count, -1, dtype=np.int64)
    if position_only:
        pb = _position_filter(chain, np.broadcast_to(T, shape + (4, 4))[..., :3, 3].reshape(-1, 3), confirm_tol)
        possible = np.broadcast_to(pb, (count,)) if pb.ndim == 1 else None
        if possible is None:  # a batch of arms: the filter per target's arm
            possible = pb.reshape(B, count)[arm_of, np.arange(count)]
    else:
        possible = _reach_filter(chain, np.broadcast_to(T, shape + (4, 4)), confirm_tol).reshape(-1)

    if backend == "compiled":
        aa = _ARM_ARRAYS.get(_chain_key(chain), lambda: arm_arrays(chain))
        for s0 in range(0, count, chunk):
            todo = s0 + np.flatnonzero(possible[s0 : s0 + chunk])
            keys = _pose_keys(seed, Tf[todo])
            q, ok, it, res, st = run_compiled(2 if position_only else 0, aa, arm_of[todo], Tf[todo], keys,
                                              Q0[todo][:, None, :],
                                              np.ones(todo.size, dtype=np.int64), 1, starts, ilimit, rlimit, tol,
                                              lam, confirm_tol)
            q_out[todo], ok_out[todo], it_out[todo], res_out[todo], start_out[todo] = q, ok, it, res, st
            if progress is not None:
                progress(min(s0 + chunk, count) - s0)
        return SearchResult(q_out.reshape(shape + (n,)), ok_out.reshape(shape), it_out.reshape(shape),
                            res_out.reshape(shape), start_out.reshape(shape))

    for s0 in range(0, count, chunk):
        todo = s0 + np.flatnonzero(possible[s0 : s0 + chunk])
        arm = _Arm(chain, arm_of[todo] if batch else None)
        Rt = np.ascontiguousarray(Tf[todo, :3, :3].transpose(1, 2, 0))
        pt = np.ascontiguousarray(Tf[todo, :3, 3].T)
        keys = _pose_keys(seed, Tf[todo])
        lo, hi = arm.bounds()
        blo, bhi = _start_box(np.stack(np.broadcast_arrays(lo, hi), axis=-1))
        live = np.arange(todo.size)  # positions in todo of the unsolved targets
        k = 0
        while k < starts and live.size:
            # a block of starts k .. k + b - 1 runs at once on every unsolved target (1, 1, 2, 4, ...
            # starts, at most ``chunk`` runs): the same runs as one start at a time, as each run is
            # independent; a target keeps the first start (in order) that succeeds
            b = max(1, min(max(k, 1), starts - k, chunk // live.size))
            pos = np.repeat(live, b)  # (P,) positions in todo of the runs
            ks = np.tile(np.arange(k, k + b), live.size)
            if arm.per_target:
                box_lo, box_hi = blo[:, pos], bhi[:, pos]
            else:
                box_lo, box_hi = blo, bhi
            qs = box_lo + _uniform(keys[pos], ks, n).T * (box_hi - box_lo)
            if k == 0:
                qs[:, ks == 0] = Q0[todo[pos[ks == 0]]].T
            q, ok, it, res, qc = _runs(chain, arm.take(pos), Rt[..., pos], pt[:, pos], qs, Tf[todo[pos]],
                                       arm_of[todo[pos]] if batch else None, (ilimit, rlimit, tol, lam), confirm_tol)
            # per target: the runs up to and including its first success
            okb = ok.reshape(live.size, b)
            solved = okb.any(axis=1)
            first = np.where(solved, okb.argmax(axis=1), b)
            tried = np.arange(b)[None, :] <= np.minimum(first, b - 1)[:, None]
            tg = todo[live]
            it_out[tg] += np.where(tried, it.reshape(live.size, b), 0).sum(axis=1)
            resb = np.where(tried, res.reshape(live.size, b), np.inf)
            best = resb.argmin(axis=1)
            rows = np.arange(live.size)
            improve = ~solved & (resb[rows, best] < res_out[tg])
            pick = np.where(solved, first, best)
            run = rows * b + np.minimum(pick, b - 1)
            q_out[tg[solved]] = q[run[solved]]
            res_out[tg[solved]] = res[run[solved]]
            q_out[tg[improve]] = qc[run[improve]]
            res_out[tg[improve]] = resb[rows, best][improve]
            ok_out[tg[solved]] = True
            start_out[tg[solved]] = k + first[solved]
            live = live[~solved]
            k += b
        if progress is not None:
            progress(min(s0 + chunk, count) - s0)
    return SearchResult(q_out.reshape(shape + (n,)), ok_out.reshape(shape), it_out.reshape(shape),
                        res_out.reshape(shape), start_out.reshape(shape))


# --------------------------------------------------------------------------- maps: starts from neighbours
#: Defaults of :func:`map_search` for the maps, measured with ``benchmarks/bench_fast_maps.py``
#: (recall against the closed forms and a 64-start reference on the 21³ grid for PUMA560 with and
#: without limits, UR5e, Panda, iiwa14, Gen3): start 0 only in the first pass (a neighbour's solution
#: is a better start than a random one), two seeds per wave, four random retries next to solved
#: nodes; per start 60 iterations and 10 rejections, and the stationary-point test at 1e-4, which
#: cut the iterations spent on unreachable nodes by about half without a missed node; a neighbour's
#: solution is not rerun without the limits (the Panda index: 13 % less time, the same recall); a
#: hole in a solved region gets 16 retries (the iiwa14 from its URDF, tool down, missed 3 of 1768
#: nodes near its axis with 4).
MAP_SETTINGS = dict(starts=0, seeds=2, retry=4, hole_retry=16, ilimit=60, rlimit=10, gtol=1e-4, seed_free_pass=False)


def map_search(robot, T, neighbours, *, starts: int = MAP_SETTINGS["starts"], seeds: int = MAP_SETTINGS["seeds"],
               retry: int = MAP_SETTINGS["retry"], seed=0, q0=None, tol: float = 1e-10,
               ilimit: int = MAP_SETTINGS["ilimit"], rlimit: int = MAP_SETTINGS["rlimit"], lam: float = 0.1,
               joint_limits: bool = True, confirm_tol: float = FK_CONFIRM_TOL, gtol: float = MAP_SETTINGS["gtol"],
               q_init=None, position_only: bool = False, seed_free_pass: bool = MAP_SETTINGS["seed_free_pass"],
               hole_retry: int = MAP_SETTINGS["hole_retry"], progress=None) -> SearchResult:
    """Reachability of a map's nodes, each start of :func:`ikine_search`'s iteration, with starts taken
    from neighbouring nodes' solutions (continuation): the solution at a node is an excellent start
    at the next one, and an unreachable node costs a few failed starts instead of dozens.

    Parameters
    ----------
    robot : SerialChain or DHRobot, one arm or a batch of ``B`` arms (flattened)
    T : (N, 4, 4) the nodes' target poses (base frame), shared by the arms
    neighbours : (N, K) int, node indices of each node's neighbours, ``-1`` padding (e.g. from
        :func:`wsmap.workspace.grids.node_neighbours`)
    starts : random starts per node in the first pass, after start 0 (``q0``, default zeros)
    seeds : neighbours' solutions tried per node and wave
    retry : random starts per node for the nodes still unsolved when no wave solves any more and
        next to a solved node, after which the waves run again from what they found
    hole_retry : the random starts instead for such a node with at least half of its neighbours
        solved (a hole in a reachable region is most likely reachable)
    ilimit, rlimit, tol, lam, joint_limits, confirm_tol : per start, as :func:`ikine_search`
    gtol : the stationary-point test (:mod:`.lm_compiled`): a start fails once the gradient
        vanishes relative to ``|J|·|e|`` away from a solution; 0 turns it off
    q_init : optional ``(N, n)`` (or ``(B, N, n)``) starts tried first at each node, NaN rows where
        none (e.g. each node's solution at a neighbouring orientation, or a sampled configuration
        whose tool lies near the node)
    position_only : reach the position of ``T`` at any orientation (the error and the
        confirmation on the position alone)
    seed_free_pass : whether a neighbour's solution that fails inside the limits is also run
        without them (the second pass of :func:`ikine_search`'s starts)
    progress : called once with the number of targets when done

    Per arm, in passes: (1) every node: ``q0`` then ``starts`` random starts (the first ones of
    :func:`ikine_search`'s sequence) until one succeeds; (2) waves: every unsolved node with a solved
    neighbour whose solution it has not tried takes up to ``seeds`` of them, in neighbour order, as
    starts, until a wave solves nothing new; (3) the nodes left take ``retry`` more random starts,
    and (2) again. Every success is confirmed by forward kinematics inside the limits, so ``True``
    is never wrong; recall is measured in ``benchmarks/bench_fast_maps.py``. Deterministic; does not
    depend on the thread count.

    Returns a :class:`SearchResult` of shape ``(B, N)`` (``(N,)`` for one arm); ``start`` is the
    random start's index ``k`` (0 = ``q0``) that succeeded, ``-2`` where a neighbour's solution did,
    ``-1`` where none did.
    """
    chain = _limited(_as_chain_memo(robot), joint_limits)
    T = check_rigid("target poses", T)
    if T.ndim != 3:
        raise ValueError(f"target poses must have shape (N, 4, 4), got {T.shape}")
    N = T.shape[0]
    nb = np.asarray(neighbours)
    if nb.ndim != 2 or nb.shape[0] != N or not np.issubdtype(nb.dtype, np.integer):
        raise ValueError(f"neighbours must be an integer array of shape ({N}, K), got {nb.dtype} {nb.shape}")
    if nb.size and (nb.min() < -1 or nb.max() >= N):
        raise ValueError(f"neighbours must be node indices in [0, {N}) or -1 (none)")
    starts = _check_count("starts", starts, 0)
    seeds = _check_count("seeds", seeds, 0)
    retry = _check_count("retry", retry, 0)
    hole_retry = _check_count("hole_retry", hole_retry, 0)
    ilimit = _check_count("ilimit", ilimit, 0)
    rlimit = _check_count("rlimit", rlimit, 0)
    seed, q0 = _check_settings(chain, tol, lam, confirm_tol, seed, q0)
    n = chain.n
    if q0.shape != (n,):
        raise ValueError(f"q0 must have shape ({n},) for a map, got {q0.shape}")
    batch = chain.batch_shape
    B = int(np.prod(batch, dtype=np.int64))
    flat = chain if not batch else flatten_arms(chain)
    M = B * N
    arm_of = np.repeat(np.arange(B), N)
    node_of = np.tile(np.arange(N), B)
    Tb = T[None] if not batch else T[None, :]
    if position_only:
        # (N,) for one arm, (B, N) for a batch: target b·N + i
        possible = _position_filter(flat if batch else chain, T[:, :3, 3], confirm_tol).reshape(-1)
    else:
        possible = _reach_filter(flat if batch else chain, Tb if not batch else T[:, None], confirm_tol)
        possible = (possible.T if batch else possible).reshape(-1)
    mode = 2 if position_only else 0
    if q_init is not None:
        q_init = np.asarray(q_init, dtype=np.float64)
        if q_init.shape not in ((N, n), (B, N, n)):
            raise ValueError(f"q_init must have shape ({N}, {n}) or ({B}, {N}, {n}), got {q_init.shape}")
        q_init = np.broadcast_to(q_init, (B, N, n)).reshape(M, n)
    keys_node = _pose_keys(seed, T)
    aa = _ARM_ARRAYS.get(_chain_key(flat), lambda: arm_arrays(flat))
    settings = (ilimit, rlimit, tol, lam, confirm_tol, float(gtol))

    q = np.full((M, n), np.nan)
    ok = np.zeros(M, dtype=bool)
    its = np.zeros(M, dtype=np.int64)
    res = np.full(M, np.inf)
    start = np.full(M, -1, dtype=np.int64)

    def run(idx, qexp, nexp, k_first, k_last, seeded):
        if not idx.size:
            return 0
        qq, okk, it, rr, st = run_compiled(mode, aa, arm_of[idx], T[node_of[idx]], keys_node[node_of[idx]], qexp, nexp,
                                           k_first, k_last, *settings, free_pass=not seeded or seed_free_pass)
        its[idx] += it
        better = okk | (~ok[idx] & (rr < res[idx]))
        q[idx[better]] = qq[better]
        res[idx[better]] = rr[better]
        ok[idx] |= okk
        if seeded:
            start[idx[okk]] = -2
        else:
            # positions in the run's order (explicit q0 first) → random-start index k
            start[idx[okk]] = np.where(st[okk] < nexp[okk], 0, st[okk] - nexp[okk] + k_first)
        return int(okk.sum())

    K = nb.shape[1]
    tried = np.zeros((M, K), dtype=bool)

    def waves():
        # a wave: every unsolved node next to a node solved since the last wave tries up to
        # ``seeds`` of those fresh solutions; it ends when a wave solves nothing
        if not seeds or not K:
            return
        fresh = ok.copy()
        while fresh.any():
            cand = np.flatnonzero(~ok & possible)
            if not cand.size:
                return
            nbn = nb[node_of[cand]]  # (C, K) node indices
            nbt = arm_of[cand][:, None] * N + np.where(nbn >= 0, nbn, 0)
            usable = (nbn >= 0) & fresh[nbt] & ~tried[cand]
            pick = usable & (np.cumsum(usable, axis=1) <= seeds)
            count = pick.sum(axis=1)
            has = count > 0
            if not has.any():
                return
            cand, pick, nbt, count = cand[has], pick[has], nbt[has], count[has]
            tried[cand] |= pick
            qexp = np.zeros((cand.size, seeds, n))
            slot = np.cumsum(pick, axis=1) - 1
            r, c = np.nonzero(pick)
            qexp[r, slot[r, c]] = q[nbt[r, c]]
            before = ok.copy()
            run(cand, qexp, count, 0, 0, True)
            fresh = ok & ~before

    first = np.flatnonzero(possible)
    if q_init is None:
        run(first, np.broadcast_to(q0, (first.size, 1, n)), np.ones(first.size, dtype=np.int64), 1, 1 + starts, False)
    else:
        # the given start first where there is one, then q0 (start 0 counts for both)
        qexp = np.empty((first.size, 2, n))
        given = np.all(np.isfinite(q_init[first]), axis=1)
        qexp[:, 0] = np.where(given[:, None], q_init[first], q0)
        qexp[:, 1] = q0
        run(first, qexp, np.where(given, 2, 1).astype(np.int64), 1, 1 + starts, False)
    waves()
    if retry:
        # only next to solved nodes: a reachable node that the waves missed borders solved ones (a
        # pocket behind a joint limit, another branch), while nodes deep in an unreachable region
        # would spend every retry in vain. A hole (at least half of its neighbours solved) is most
        # likely reachable: it gets hole_retry starts instead
        left = ~ok & possible
        hole = np.zeros(M, dtype=bool)
        if K:
            # solved neighbours per target, one neighbour slot at a time: (B, N) arrays, never (B·N, K)
            valid = nb >= 0
            slot = np.where(valid, nb, 0)
            ok_bn = ok.reshape(B, N)
            solved_nb = np.zeros((B, N), dtype=np.int32)
            for k in range(K):
                solved_nb += ok_bn[:, slot[:, k]] & valid[:, k]
            left &= (solved_nb > 0).reshape(-1)
            hole = left & (2 * solved_nb >= valid.sum(axis=1)).reshape(-1)
        for group, count in ((left & ~hole, retry), (hole, max(retry, hole_retry))):
            idx = np.flatnonzero(group)
            run(idx, np.zeros((idx.size, 1, n)), np.zeros(idx.size, dtype=np.int64), 1 + starts, 1 + starts + count,
                False)
        waves()
    if progress is not None:
        progress(M)
    shape = (N,) if not batch else batch + (N,)
    return SearchResult(q.reshape(shape + (n,)), ok.reshape(shape), its.reshape(shape), res.reshape(shape),
                        start.reshape(shape))
