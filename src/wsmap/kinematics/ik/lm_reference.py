"""The numpy reference of the LM iteration: the same iteration as the compiled kernel
(`wsmap.kinematics.lm_compiled`), written as vectorised numpy over rows of targets.

It is not used by the library's solvers; the tests compare the compiled kernel with it
(`ikine_search_reference` against `ikine_search`,
`ikine_LM_reference` against `ikine_LM`): the same arithmetic
per target, so answers agree up to the rounding of `sin`/`cos` and of sums (which can, rarely,
send an iteration down another path near a branch point). The iteration and its two modes are
described in `wsmap.kinematics.ik.search` (the search: rotation-vector error, limits inside
the iteration, forward-kinematics confirmation, several starts) and `wsmap.kinematics.ik.lm`
(the paper's: Corke's `tr2delta` error, no limits, one start).

Layout: every per-target quantity is a column (last axis) of length `M` (the active targets);
finished targets leave the active set. Units: metres and radians.
"""

from __future__ import annotations

import numpy as np

from ..chain import PRISMATIC, SerialChain, as_chain
from ..dh import DHRobot
from ..transforms import check_rigid
from .kernel import mix, pose_keys, start_box, unsolved
from .reach_filter import reach_filter
from .search import (DEFAULT_ILIMIT, DEFAULT_RLIMIT, DEFAULT_STARTS, FK_CONFIRM_TOL, broadcast_targets,
                     check_search, search_solution, with_joint_limits)
from .solution import IKSolution, failure_reasons

__all__ = ["ikine_search_reference", "ikine_LM_reference"]

_TWO_PI = 2.0 * np.pi
_EPS = np.finfo(np.float64).eps

# termination codes of one LM run (as the compiled kernel's)
_SUCCESS, _REJECTIONS, _ILIMIT, _STAGNATED, _AT_START = 1, 2, 3, 4, 5


def _uniform(keys, k, n: int) -> np.ndarray:
    """`(K, n)` uniform numbers in `[0, 1)` for starts `k` (K,) of targets with `keys` (K,)."""
    k = np.asarray(k, dtype=np.uint64).reshape(-1, 1)
    ctr = mix(k * np.uint64(1 << 16) + np.arange(1, n + 1, dtype=np.uint64)[None, :])  # (K or 1, n)
    bits = mix(keys[:, None] + ctr)
    return (bits >> np.uint64(11)).astype(np.float64) * (1.0 / (1 << 53))


# --------------------------------------------------------------------------- projection onto the limits
def _project(q, lo, hi, revolute):
    """`q` (..., n) projected onto `[lo, hi]` (broadcasting): a revolute joint outside is first
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

    Rotations are `(3, 3[, M])` (row, column), translations `(3[, M])`; the base is folded into
    the first fixed transform and the tool into the last. `per_target`: the arrays carry a last
    axis of targets (a batch of arms), else they are shared.
    """

    def __init__(self, chain: SerialChain, arm_index=None):
        if chain.coupling is not None:  # the reference of lm_compiled: one variable per joint
            raise ValueError("the numpy reference search takes chains without coupled joints; "
                             "a coupled chain's search is wsmap.kinematics.ikine_search")
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
        """`(lo, hi)`: the limits, as `(n, 1)` (shared) or `(n, M)` arrays."""
        return self._cols(self.lo, self.hi)

    def lm_bounds(self):
        """`(lo, hi, clipped)` that the LM projects onto, `(n, 1)` or `(n, M)`."""
        return self._cols(self.clo, self.chi, self.clipped)

    def unlimited(self):
        """Revolute joints without limits, `(n, 1)` or `(n, M)`."""
        lo, hi = self.bounds()
        return self.revolute[:, None] & np.isinf(lo) & np.isinf(hi)

    def fk(self, q):
        """Forward kinematics of `q` (n, W): tool rotation `R` (3, 3, W), position `p` (3, W),
        joint axes `w` (n, 3, W) and joint origins `o` (n, 3, W) in the world frame."""
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
        """Geometric Jacobian (6, n, W): column j is `[w_j × (p − o_j); w_j]` (revolute) or `[w_j; 0]`."""
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
    """`A @ B` per target for (3, 3, W) arrays (B may be (3, 3, 1)), summed in a fixed order."""
    P = A[:, :, None, :] * B[None, :, :, :]  # (row, m, col, W)
    return P[:, 0] + P[:, 1] + P[:, 2]


def _pose_error(R, p, Rt, pt, rotvec=True):
    """Pose error (6, W) `[pt − p; θ·a]` and its norm (W,), with `θ·a` the rotation vector of
    `Rt·Rᵀ` (the rotation from the current to the target orientation, base frame); without
    `rotvec`, `sin θ·a` (Corke's `tr2delta`, the paper's LM).

    Corke's `tr2delta` (the paper's, `wsmap.kinematics.pose_error`) has `sin θ·a` in its
    place, which vanishes at a half turn as well as at the target: from a random start, LM descends
    into that false zero about as often as into the target. `θ·a` vanishes only at the target,
    agrees with `tr2delta` to `O(θ³)` near it, and is the angular velocity that the geometric
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
    if not rotvec:
        sq = e[0] * e[0]
        for r in range(1, 6):
            sq = sq + e[r] * e[r]
        return e, np.sqrt(sq)
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
    """`JᵀJ` (n, n, W) and `Jᵀe` (n, W), summed over the 6 rows in a fixed order."""
    A = J[0][:, None, :] * J[0][None, :, :]
    g = J[0] * e[0]
    for r in range(1, 6):
        A = A + J[r][:, None, :] * J[r][None, :, :]
        g = g + J[r] * e[r]
    return A, g


def _solve(A, g, l2, held):
    """`(A + λ² I)⁻¹ g` per target by Gaussian elimination without pivoting (symmetric positive
    definite for λ > 0); joints where `held` (n, W) get row and column of the identity and 0."""
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
def _lm(arm: _Arm, Rt, pt, q, ilimit, rlimit, tol, lam0, constrained=True, rotvec=True):
    """LM from `q` (n, M) towards the targets `(Rt (3, 3, M), pt (3, M))`, inside the limits
    if `constrained` (else ignoring them); the rotation error a rotation vector (`rotvec`, the
    search's) or Corke's `tr2delta` (the paper's).

    Returns `q` (n, M), the termination code (M,) (`_SUCCESS`, `_AT_START` where converged),
    iterations (M,), consecutive rejections at the end (M,), residual (M,), and `touched` (M,):
    the limits changed a trial step at least once (without that, the run is the unconstrained run
    from the same start, bit for bit).
    """
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        return _lm_run(arm, Rt, pt, q, ilimit, rlimit, tol, lam0, constrained and arm.limited, rotvec)


def _held_joints(cur, q, g):
    """`(lo, hi, held)`: the limits of the active targets' arms `cur` and the joints on a limit
    that the gradient `g` pushes outward, held for this step (None where there is none)."""
    lo, hi, clipped = cur.lm_bounds()
    held = clipped & (((q <= lo) & (g < 0)) | ((q >= hi) & (g > 0)))
    return lo, hi, (held if held.any() else None)


def _mark_stagnated(code, rej, lam, g, A, q):
    """Set `code` to `_STAGNATED` (in place) where a target still running after a rejection can
    no longer move `q` by a bit: λ so large that the bound on |dq| of lm_compiled's loop is
    below an eighth of the spacing of every joint value."""
    n = q.shape[0]
    cand = np.flatnonzero((code == 0) & (rej > 0))
    if cand.size:
        mu = lam[cand] * lam[cand]
        gc, Ac = g[:, cand], A[..., cand]
        g2, trace = gc[0] * gc[0], Ac[0, 0]
        for j in range(1, n):
            g2 = g2 + gc[j] * gc[j]
            trace = trace + Ac[j, j]
        bound = (np.abs(gc) + (trace / mu + 64.0 * n * _EPS) * np.sqrt(g2)) / mu
        stuck = np.all(bound <= 0.125 * np.spacing(np.abs(q[:, cand])), axis=0)
        code[cand[stuck]] = _STAGNATED


def _lm_run(arm, Rt, pt, q, ilimit, rlimit, tol, lam0, limited, rotvec):
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
    code_out = np.zeros(M, dtype=np.int64)
    it_out = np.zeros(M, dtype=np.int64)
    rej_out = np.zeros(M, dtype=np.int64)
    res_out = np.empty(M)
    R, p, w, o = arm.fk(q)
    e, na = _pose_error(R, p, Rt, pt, rotvec)
    A, g = _normal_equations(arm.jacobian(p, w, o), e)
    lam = np.full(M, float(lam0))
    rej = np.zeros(M)
    it = np.zeros(M, dtype=np.int64)
    idx = np.arange(M)
    cur = arm  # the arm numbers of the active targets
    touched = touched_out.copy()

    def finish(mask, code):
        nonlocal q, e, na, A, g, lam, rej, it, idx, Rt, pt, cur, touched
        k = idx[mask]
        q_out[:, k] = q[:, mask]
        code_out[k] = code[mask] if isinstance(code, np.ndarray) else code
        it_out[k] = it[mask]
        rej_out[k] = rej[mask]
        res_out[k] = na[mask]
        touched_out[k] = touched[mask]
        keep = ~mask
        touched = touched[keep]
        q, e, na, A, g = q[:, keep], e[:, keep], na[keep], A[..., keep], g[:, keep]
        lam, rej, it, idx = lam[keep], rej[keep], it[keep], idx[keep]
        Rt, pt = Rt[..., keep], pt[:, keep]
        cur = cur.take(keep)

    done = na <= tol
    if done.any():
        finish(done, _AT_START)
    if ilimit == 0 and idx.size:
        finish(np.ones(idx.size, dtype=bool), _ILIMIT)
    while idx.size:
        held = None
        if limited:
            lo, hi, held = _held_joints(cur, q, g)
            if held is not None:
                touched |= held.any(axis=0)
        dq = _solve(A, g, lam * lam, held)
        qt = q + dq
        if limited:
            qp = _project(qt, lo, hi, rev)
            touched |= np.any(qp != qt, axis=0)
            qt = qp
        Rn, pn, wn, on = cur.fk(qt)
        en, nn = _pose_error(Rn, pn, Rt, pt, rotvec)
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
        # the first that holds, in the compiled kernel's order
        code = np.where(better & (na <= tol), _SUCCESS,
                        np.where(rej > rlimit, _REJECTIONS, np.where(it >= ilimit, _ILIMIT, 0)))
        # exact stagnation: once λ is so large that no later step can move q by a bit (the bound
        # on |dq| of lm_compiled's loop), every later trial is rejected
        _mark_stagnated(code, rej, lam, g, A, q)
        if code.any():
            finish(code != 0, code)
    return q_out, code_out, it_out, rej_out, res_out, touched_out


# --------------------------------------------------------------------------- checks
def _rotation_angle(Ra, Rb):
    """Angle (rad) of `Raᵀ Rb` for (..., 3, 3) rotations, accurate near 0 and pi."""
    v = 0.5 * np.cross(Ra, Rb, axis=-2).sum(axis=-1)  # sin(θ)·axis
    cos = 0.5 * (np.einsum("...ij,...ij->...", Ra, Rb) - 1.0)
    return np.arctan2(np.linalg.norm(v, axis=-1), cos)


def _confirm(chain: SerialChain, q, T, atol):
    """`fkine(q)` within `atol` of `T` (position m, rotation angle rad) and `q` inside the limits."""
    Tq = chain.fkine(q)
    dp = np.linalg.norm(Tq[..., :3, 3] - T[..., :3, 3], axis=-1)
    ang = _rotation_angle(Tq[..., :3, :3], T[..., :3, :3])
    return (dp <= atol) & (ang <= atol) & chain.within_limits(q)


def _runs(chain, arm, Rt, pt, qs, T, arm_index, settings, confirm_tol):
    """One start per column of `qs` (n, P): the constrained run, then (limited arms, where it
    failed and the limits changed it) the free run; successes confirmed by forward kinematics.

    Returns `q` (P, n) (the solution where `ok`), `ok` (P,), iterations (P,) of both passes,
    the residual (P,) (of the successful pass where `ok`, else of the constrained run) and the end
    point `qc` (P, n) of the constrained run.
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
        q, code, it, _, res, touched = _lm(sub, Rt[..., rest], pt[:, rest], qs[:, rest], ilimit, rlimit, tol, lam,
                                           constrained)
        conv = (code == _SUCCESS) | (code == _AT_START)
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


# --------------------------------------------------------------------------- the two solvers
def ikine_search_reference(robot, T, *, starts: int = DEFAULT_STARTS, seed=0, q0=None, tol: float = 1e-10,
                           ilimit: int = DEFAULT_ILIMIT, rlimit: int = DEFAULT_RLIMIT, lam: float = 0.1,
                           joint_limits: bool = True, confirm_tol: float = FK_CONFIRM_TOL) -> IKSolution:
    """`wsmap.kinematics.ik.search.ikine_search` in numpy (the same arguments, checks, starts,
    pre-filter and result; no `position_only`), one start at a time on the targets not yet solved."""
    chain = with_joint_limits(as_chain(robot), joint_limits)
    T = check_rigid("target poses", T)
    starts, ilimit, rlimit, seed, q0 = check_search(chain, starts, ilimit, rlimit, tol, lam, confirm_tol, seed, q0)
    n = chain.n
    batch = chain.batch_shape
    shape, count, Tf, Q0, arm_of = broadcast_targets(chain, T, q0)

    q_out, ok_out, it_out, res_out, start_out = unsolved(count, n)
    possible = reach_filter(chain, np.broadcast_to(T, shape + (4, 4)), confirm_tol).reshape(-1)
    todo = np.flatnonzero(possible)
    arm = _Arm(chain, arm_of[todo] if batch else None)
    Rt = np.ascontiguousarray(Tf[todo, :3, :3].transpose(1, 2, 0))
    pt = np.ascontiguousarray(Tf[todo, :3, 3].T)
    keys = pose_keys(seed, Tf[todo])
    blo, bhi = start_box(np.stack(np.broadcast_arrays(*arm.bounds()), axis=-1))
    live = np.arange(todo.size)  # positions in todo of the unsolved targets
    for k in range(starts):
        if not live.size:
            break
        if k == 0:
            qs = Q0[todo[live]].T
        else:
            box_lo, box_hi = (blo[:, live], bhi[:, live]) if arm.per_target else (blo, bhi)
            qs = box_lo + _uniform(keys[live], k, n).T * (box_hi - box_lo)
        q, ok, it, res, qc = _runs(chain, arm.take(live), Rt[..., live], pt[:, live], qs, Tf[todo[live]],
                                   arm_of[todo[live]] if batch else None, (ilimit, rlimit, tol, lam), confirm_tol)
        tg = todo[live]
        it_out[tg] += it
        improve = ~ok & (res < res_out[tg])
        q_out[tg[ok]], res_out[tg[ok]] = q[ok], res[ok]
        q_out[tg[improve]], res_out[tg[improve]] = qc[improve], res[improve]
        ok_out[tg[ok]] = True
        start_out[tg[ok]] = k
        live = live[~ok]
    return search_solution(shape, q_out, ok_out, it_out, res_out, start_out, possible)


def ikine_LM_reference(robot: DHRobot, T, q0=None, *, ilimit: int = 500, rlimit: int = 100, tol: float = 1e-10,
                       lam: float = 0.1, check_limits: bool = False) -> IKSolution:
    """`wsmap.kinematics.ik.lm.ikine_LM` in numpy: the paper's iteration (`tr2delta` error,
    no limits inside it, one start) and its iteration count (1 for a start already on the target,
    `it + 1` for a success at iteration `it`, as the Appendix's loop tests success at the top of
    the next iteration; a stagnated run counted to where its rejections would have ended it)."""
    if not isinstance(robot, DHRobot):
        raise TypeError(f"ikine_LM takes a DHRobot (the paper's arms), got {type(robot).__name__}")
    T = check_rigid("target poses", T)
    n = robot.n
    q0 = np.zeros(n) if q0 is None else robot._check_q(q0)
    shape = np.broadcast_shapes(T.shape[:-2], robot.batch_shape, q0.shape[:-1])
    Tf = np.broadcast_to(T, shape + (4, 4)).reshape(-1, 4, 4)
    qf = np.broadcast_to(q0, shape + (n,)).reshape(-1, n)
    batch = robot.batch_shape
    arm_of = np.broadcast_to(np.arange(int(np.prod(batch, dtype=np.int64))).reshape(batch), shape).reshape(-1)
    arm = _Arm(as_chain(robot).replace(qlim=None), arm_of if batch else None)
    Rt = np.ascontiguousarray(Tf[:, :3, :3].transpose(1, 2, 0))
    pt = np.ascontiguousarray(Tf[:, :3, 3].T)
    q, code, it, rej, res, _ = _lm(arm, Rt, pt, np.array(qf.T), int(ilimit), int(rlimit), float(tol), float(lam),
                                   constrained=False, rotvec=False)
    stagnated = np.minimum(it + 1 + (rlimit - rej), ilimit)
    its = np.select([code == _AT_START, code == _SUCCESS, code == _REJECTIONS, code == _STAGNATED],
                    [np.minimum(1, ilimit), np.minimum(it + 1, ilimit), it, stagnated], ilimit).astype(np.int64)
    q = q.T.reshape(shape + (n,))
    converged = ((code == _SUCCESS) | (code == _AT_START)).reshape(shape)
    ok = converged
    if check_limits and robot.qlim is not None:
        ok = converged & robot.within_limits(q)
    return IKSolution(q, ok, its.reshape(shape), res.reshape(shape), failure_reasons(ok, outside_limits=converged))
