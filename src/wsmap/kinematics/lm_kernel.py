"""Fast batched Levenberg–Marquardt kernel behind :func:`wsmap.kinematics.ikine_LM`.

The iteration is the paper's Appendix, per target::

    e = pose_error(fkine(q0), T); i = 0
    loop: i += 1
          success if |e| <= tol;  failure if i > ilimit
          dq = solve(JᵀJ + λ² I, Jᵀ e)
          accept if |e(q + dq)| < |e|:  q += dq, λ /= 2, r = 0
          else                          λ *= 2, r += 1, failure if r > rlimit

with ``e`` the 6-vector pose error (metres, radians) and ``J`` the base-frame geometric Jacobian.
What makes it fast; each item keeps that iteration, up to floating-point rounding:

* structure of arrays: every per-target quantity is a row of length M (the active targets), so a
  numpy call handles a whole row; forward kinematics, pose error and Jacobian are written out
  column by column instead of as many small (M, 4, 4) matrix products;
* ``JᵀJ`` and ``Jᵀe`` are kept per target and recomputed only when a trial is accepted: a rejected
  trial changes only λ, so it needs the trial pose, not its Jacobian;
* the n x n system is solved by hand-vectorised Gaussian elimination on ``[JᵀJ + λ² I | Jᵀe]``
  (symmetric positive definite for λ > 0, so no pivoting is needed) instead of one LAPACK call per
  target;
* an exact stagnation shortcut: once λ is so large that no later trial can move ``q`` by a single
  bit, every later trial is rejected, and the failure and its iteration count are known in closed
  form (see :meth:`_Kernel.stagnated`);
* speculation over rejections while few targets are active: a rejected trial leaves ``q`` and the
  Jacobian as they were and only doubles λ, so the trials at λ, 2λ, 4λ, ... from the same ``q``
  can be evaluated together, and the first accepted one is exactly the sequential iteration's
  next state. That fills otherwise Python-bound loops and cuts their number;
* sine and cosine through torch's vectorised (SLEEF) kernels, several times faster than numpy's
  float64 ``sin``/``cos``;
* finished targets leave the active set by swapping the last active columns into their place.

Every target's arithmetic is independent of which other targets share a call (see
:func:`_width2`), so results do not depend on chunking, threads, speculation or the shortcut.

Worker threads are possible (``threads``) but off by default: each numpy call hands the GIL over,
and on the 2-core machine this was measured on, two threads made each thread's work 35-60 % more
expensive in CPU time and gained nothing in wall time for a 9261-target map (1.2x at 37k targets).
"""

from __future__ import annotations

import math
import os
import threading

import numpy as np

__all__ = ["lm_chunk", "default_threads"]

_EPS = np.finfo(np.float64).eps
# speculation fills a loop up to about this many trials (see _Kernel.depth_for)
_SPEC_WIDTH = 1024
_torch = None  # the torch module once imported, False if it is unavailable


def _get_torch():
    """torch, imported on first use (about 2 s, once per process), or None if unavailable or
    turned off with ``WSMAP_LM_TORCH=0`` (numpy's sin/cos are then used: same success, other
    rounding, about 10 % slower)."""
    global _torch
    if os.environ.get("WSMAP_LM_TORCH", "1") == "0":
        return None
    if _torch is None:
        try:
            import torch

            _torch = torch
        except Exception:  # pragma: no cover - torch is a declared dependency
            _torch = False
    return _torch or None


def default_threads() -> int:
    """Worker threads per chunk: ``WSMAP_LM_THREADS`` if set, else 1 (see the module notes)."""
    env = os.environ.get("WSMAP_LM_THREADS")
    return max(1, int(env)) if env else 1


class _Scratch:
    """Reusable contiguous work arrays (first-touch page faults of fresh large arrays are costly)."""

    def __init__(self):
        self.pool = {}

    def get(self, name, shape):
        size = math.prod(shape)
        buf = self.pool.get(name)
        if buf is None or buf.size < size:
            buf = np.empty(max(size, 64))
            self.pool[name] = buf
        return buf[:size].reshape(shape)


def _sincos(x, c, s, torch):
    """``c = cos(x)``, ``s = sin(x)`` (rad); ``c`` and ``s`` C-contiguous, all of one shape.

    ``torch`` is the torch module (its SLEEF kernels give the same bits whatever an element's
    position in the array) or None (numpy).
    """
    if torch is not None:
        tx = torch.from_numpy(x.reshape(-1))
        torch.cos(tx, out=torch.from_numpy(c.reshape(-1)))
        torch.sin(tx, out=torch.from_numpy(s.reshape(-1)))
    else:
        np.cos(x, out=c)
        np.sin(x, out=s)


def _width2(x):
    """``x`` with its last axis doubled when it has length 1.

    ``np.einsum`` sums in a different order when the target axis has length 1 (the summed axis
    becomes the inner loop); padding keeps each target's result independent of how many targets
    share the call, so that threads, speculation and the shortcut change no bit.
    """
    return np.concatenate([x, x], axis=-1) if x.shape[-1] == 1 else x


# --------------------------------------------------------------------------- state of a set of targets
def _layout(n, per_target_dh):
    """Row ranges of the state matrix; ``q, e, na`` and ``aug`` are contiguous so that one
    gather/scatter moves each group."""
    sizes = [
        ("q", n), ("e", 6), ("na", 1),  # joint angles (rad), pose error [dp (m); dw (rad)], |e|
        ("aug", n * (n + 1)),  # [JᵀJ | Jᵀe], row i of the n x (n+1) matrix at rows i(n+1)..
        ("lam", 1), ("rej", 1), ("it", 1), ("idx", 1),  # λ, consecutive rejections, iterations, index
        ("pt", 3), ("Rt", 15),  # target position (m); rotation, column k row r at 5k + r, rows x y z x y
    ]
    if per_target_dh:
        sizes += [("d", n), ("a", n), ("ca", n), ("sa", n)]
    out, r = {}, 0
    for name, k in sizes:
        out[name] = (r, r + k)
        r += k
    return out, r


class _Block:
    """Active targets of one chunk (or part of one), structure of arrays.

    ``S`` has one row per scalar of state (see :func:`_layout`) and one column per target; the
    active targets are its first ``M`` columns, finished ones are swapped out (see :meth:`drop`).
    """

    def __init__(self, n, per_target_dh, S):
        self.n = n
        self.per_target_dh = per_target_dh
        self.lay, _ = _layout(n, per_target_dh)
        self.S = S
        self.M = S.shape[1]
        self.max_it = 0.0  # an upper bound of the iterations of every target in the block
        self.loops = 0
        self.views()

    def views(self):
        """Named views of the active columns (recomputed whenever ``M`` changes)."""
        S, n, M, lay = self.S[:, : self.M], self.n, self.M, self.lay
        self.active = S
        self.q = S[lay["q"][0] : lay["q"][1]]
        self.qena = S[lay["q"][0] : lay["na"][1]]
        self.e = S[lay["e"][0] : lay["e"][1]]
        self.na = S[lay["na"][0]]
        self.aug = S[lay["aug"][0] : lay["aug"][1]].reshape(n, n + 1, M)
        self.lam = S[lay["lam"][0]]
        self.rej = S[lay["rej"][0]]
        self.it = S[lay["it"][0]]
        self.idx = S[lay["idx"][0]]
        self.pt = S[lay["pt"][0] : lay["pt"][1]]
        self.Rt = S[lay["Rt"][0] : lay["Rt"][1]].reshape(3, 5, M)
        if self.per_target_dh:
            self.dh = tuple(S[lay[k][0] : lay[k][1]] for k in ("d", "a", "ca", "sa"))
        else:
            self.dh = None

    def drop(self, mask):
        """Remove the targets where ``mask`` is True: the surviving targets among the last ones
        move into the holes, so the copy is proportional to the number removed."""
        M = self.M
        K = int(np.count_nonzero(mask))
        if K == 0:
            return
        M2 = M - K
        holes = mask[:M2].nonzero()[0]
        if holes.size:
            movers = M2 + (~mask[M2:]).nonzero()[0]
            self.S[:, holes] = self.S[:, movers]
        self.M = M2
        self.views()

    @staticmethod
    def merge(blocks):
        """One block of the active targets of ``blocks`` (a copy), or None if there are none."""
        blocks = [b for b in blocks if b.M]
        if not blocks:
            return None
        S = np.concatenate([b.active for b in blocks], axis=1)
        out = _Block(blocks[0].n, blocks[0].per_target_dh, S)
        out.max_it = max(b.max_it for b in blocks)
        return out


# --------------------------------------------------------------------------- the iteration
class _Kernel:
    """The Levenberg–Marquardt iteration on a :class:`_Block`; one instance per thread.

    A loop evaluates trials into the trial matrix ``TR`` (rows, W): ``q`` (n), ``e`` (6), ``|e|``
    (1) as in the state, then what the Jacobian needs, the joint axes ``Z`` and origins ``O``
    (n x 3 each, frames 0 .. n−1) and the tool position ``p`` (3). Accepted columns are taken out
    with one gather.
    """

    def __init__(self, n, plan, tool, params, out, shortcut, torch, max_depth):
        self.n = n
        self.plan = plan  # per-joint scalars (d, a, cos alpha, sin alpha), or None if per target
        self.tool = tool
        self.ilimit, self.rlimit, self.tol, self.lam0 = params
        self.out = out  # (q (m, n), success (m,), iterations (m,), residual (m,))
        self.shortcut = shortcut
        self.torch = torch  # the torch module for sin/cos, or None for numpy's
        self.max_depth = max_depth
        self.spec_width = _SPEC_WIDTH
        self.sc = _Scratch()
        z0 = n + 7
        self.rows_z = (z0, z0 + 3 * n)
        self.rows_o = (z0 + 3 * n, z0 + 6 * n)
        self.rows_p = (z0 + 6 * n, z0 + 6 * n + 3)
        self.trial_rows = z0 + 6 * n + 3

    # ---------------------------------------------------------------- kinematics
    def fk(self, q, dh, TR):
        """Forward kinematics of ``q`` (n, W) into the trial matrix ``TR`` (axes, origins, tool
        position, metres); returns the tool rotation as ``Rx`` (3 columns, 5 rows, W), the rows of
        each column being x y z x y."""
        n, W = q.shape
        sc, plan = self.sc, self.plan
        ct, st = sc.get("ct", (n, W)), sc.get("st", (n, W))
        _sincos(q, ct, st, self.torch)
        Z = TR[self.rows_z[0] : self.rows_z[1]].reshape(n, 3, W)
        O = TR[self.rows_o[0] : self.rows_o[1]].reshape(n, 3, W)
        P = TR[self.rows_p[0] : self.rows_p[1]]
        XY = sc.get("XY", (2, 2, 3, W))  # x and y axes of the current frame, two alternating slots
        Rx = sc.get("Rx", (3, 5, W))
        tmp, tmp2, v = sc.get("t1", (2, 3, W)), sc.get("t2", (2, 3, W)), sc.get("v", (3, W))
        if self.tool is not None:
            TL = sc.get("TL", (4, 3, W))  # the flange frame before the tool
        # frame 0, the base: z = (0, 0, 1), origin 0
        Z[0, 0:2] = 0.0
        Z[0, 2] = 1.0
        O[0] = 0.0
        for i in range(n):
            if plan is not None:
                d, a, ca, sa = plan[i]
            else:
                d, a, ca, sa = dh[0][i], dh[1][i], dh[2][i], dh[3][i]
            c, s = ct[i], st[i]
            if i + 1 < n:
                xd, yd = XY[(i + 1) % 2]
                zd, pd = Z[i + 1], O[i + 1]
            elif self.tool is None:
                xd, yd, zd, pd = Rx[0, 0:3], Rx[1, 0:3], Rx[2, 0:3], P
            else:
                xd, yd, zd, pd = TL
            if i == 0:
                # from the base frame: A_1 = Rz(q) Tz(d) Tx(a) Rx(alpha), written out
                xd[0] = c
                xd[1] = s
                xd[2] = 0.0
                np.multiply(s, -ca, out=yd[0])
                np.multiply(c, ca, out=yd[1])
                yd[2] = sa
                np.multiply(s, sa, out=zd[0])
                np.multiply(c, -sa, out=zd[1])
                zd[2] = ca
                np.multiply(xd, a, out=pd)
                pd[2] = d
                continue
            xys, zs, ps = XY[i % 2], Z[i], O[i]
            # new x axis u = c·x + s·y; w = c·y − s·x is y turned about z, before the twist
            np.multiply(xys, c, out=tmp)
            np.multiply(xys, s, out=tmp2)
            np.add(tmp[0], tmp2[1], out=xd)
            # twist about the new x axis: y' = ca·w + sa·z, z' = ca·z − sa·w. The exact cases
            # (sa = 0 and ca = 1, or sa = ±1) skip products whose value is known bit for bit.
            if plan is not None and sa == 0.0 and ca == 1.0:
                np.subtract(tmp[1], tmp2[0], out=yd)
                zd[...] = zs
            elif plan is not None and abs(sa) == 1.0:
                np.subtract(tmp[1], tmp2[0], out=v)
                np.multiply(v, ca, out=yd)
                np.multiply(zs, ca, out=zd)
                if sa > 0:
                    yd += zs
                    zd -= v
                else:
                    yd -= zs
                    zd += v
            else:
                np.subtract(tmp[1], tmp2[0], out=v)
                np.multiply(v, ca, out=yd)
                np.multiply(zs, sa, out=tmp[0])
                yd += tmp[0]
                np.multiply(zs, ca, out=zd)
                np.multiply(v, sa, out=tmp[0])
                zd -= tmp[0]
            # origin: p' = p + d·z + a·u (the exact d = 0 or a = 0 skip their products)
            if plan is not None and d == 0.0:
                if a == 0.0:
                    pd[...] = ps
                else:
                    np.multiply(xd, a, out=pd)
                    pd += ps
            else:
                np.multiply(zs, d, out=pd)
                pd += ps
                if not (plan is not None and a == 0.0):
                    np.multiply(xd, a, out=tmp[0])
                    pd += tmp[0]
        if self.tool is not None:
            Tl = self.tool
            for k in range(3):
                col = Rx[k, 0:3]
                np.multiply(TL[0], Tl[0, k], out=col)
                col += TL[1] * Tl[1, k]
                col += TL[2] * Tl[2, k]
            np.multiply(TL[0], Tl[0, 3], out=P)
            P += TL[1] * Tl[1, 3]
            P += TL[2] * Tl[2, 3]
            P += TL[3]
        Rx[:, 3:5] = Rx[:, 0:2]
        return Rx

    def pose_error(self, Rx, p, Rt, pt, e, norm):
        """``e`` (6, W) ← ``[pt − p; ½ Σ_k R[:, k] × Rt[:, k]]`` (Corke's ``tr2delta``), ``norm``
        (W,) ← |e|; returns ``norm``. ``p``, ``pt`` are positions (m), ``e`` is in m and rad.

        ``Rx`` and ``Rt`` hold the columns with rows x y z x y, so the rotated rows that the cross
        products need are slices, not copies: ``(c × t)_r = c_{r+1} t_{r+2} − c_{r+2} t_{r+1}``.
        """
        W = p.shape[1]
        np.subtract(pt, p, out=e[0:3])
        c1 = self.sc.get("c1", (3, 3, W))
        c2 = self.sc.get("c2", (3, 3, W))
        np.multiply(Rx[:, 1:4], Rt[:, 2:5], out=c1)
        np.multiply(Rx[:, 2:5], Rt[:, 1:4], out=c2)
        c1 -= c2
        np.add.reduce(c1, axis=0, out=e[3:6])
        e[3:6] *= 0.5
        if W == 1:
            e2 = _width2(e)
            norm[...] = np.sqrt(np.einsum("rw,rw->w", e2, e2))[:1]
        else:
            np.einsum("rw,rw->w", e, e, out=norm)
            np.sqrt(norm, out=norm)
        return norm

    def normal_equations(self, G):
        """``[JᵀJ | Jᵀe]`` (n, n + 1, K) for trial columns ``G`` (rows as ``TR``), with the
        base-frame geometric Jacobian ``J`` (6, n) whose column j is ``[z_j × (p − o_j); z_j]``."""
        K = G.shape[1]
        G = _width2(G)
        n, W = self.n, G.shape[1]
        sc = self.sc
        Z = G[self.rows_z[0] : self.rows_z[1]].reshape(n, 3, W)
        O = G[self.rows_o[0] : self.rows_o[1]].reshape(n, 3, W)
        p = G[self.rows_p[0] : self.rows_p[1]]
        e = G[n : n + 6]
        D = sc.get("D", (n, 3, W))
        np.subtract(p[None], O, out=D)
        J = sc.get("J", (n, 6, W))
        t = sc.get("Jt", (n, W))
        np.multiply(Z[:, 1], D[:, 2], out=J[:, 0])
        np.multiply(Z[:, 2], D[:, 1], out=t)
        J[:, 0] -= t
        np.multiply(Z[:, 2], D[:, 0], out=J[:, 1])
        np.multiply(Z[:, 0], D[:, 2], out=t)
        J[:, 1] -= t
        np.multiply(Z[:, 0], D[:, 1], out=J[:, 2])
        np.multiply(Z[:, 1], D[:, 0], out=t)
        J[:, 2] -= t
        J[:, 3:] = Z
        aug = sc.get("aug", (n, n + 1, W))
        np.einsum("jrk,lrk->jlk", J, J, out=aug[:, :n])
        np.einsum("jrk,rk->jk", J, e, out=aug[:, n])
        return aug[..., :K]

    def solve(self, aug_src, l2, depth):
        """``(JᵀJ + λ² I)⁻¹ Jᵀe`` for every target and every λ² in ``l2`` (depth, M) → (n, depth·M).

        Gaussian elimination without pivoting on the augmented matrix ``[JᵀJ + λ² I | Jᵀe]``:
        it is symmetric positive definite, for which elimination needs no pivoting. The first
        elimination step reads ``aug_src`` and writes the work matrix, which saves a copy.
        """
        n, _, M = aug_src.shape
        W = depth * M
        sc = self.sc
        H = sc.get("H", (n, n + 1, W))
        tmp = sc.get("Ht", (n * (n + 1), W))
        l2 = l2.reshape(W)
        if depth == 1:
            src = aug_src
        else:
            src = sc.get("Hsrc", (n, n + 1, W))
            for j in range(depth):
                src[..., j * M : (j + 1) * M] = aug_src
        # step 0: pivot a00 + λ², row 0 scaled, the trailing block updated into H
        piv = np.add(src[0, 0], l2, out=H[0, 0])
        np.divide(src[0, 1:], piv, out=H[0, 1:])
        if n > 1:
            t = tmp[: (n - 1) * n].reshape(n - 1, n, W)
            np.multiply(src[1:, 0, None], H[0, 1:][None], out=t)
            np.subtract(src[1:, 1:], t, out=H[1:, 1:])
            # the λ² of the diagonal entries 1 .. n−1
            H.reshape(n * (n + 1), W)[n + 2 : n * (n + 1) - 1 : n + 2] += l2
        for j in range(1, n):
            row = H[j, j + 1 :]
            row /= H[j, j]
            if j + 1 < n:
                k = n - j - 1
                t = tmp[: k * (k + 1)].reshape(k, k + 1, W)
                np.multiply(H[j + 1 :, j, None], row[None], out=t)
                H[j + 1 :, j + 1 :] -= t
        x = H[:, n]
        for j in range(n - 1, 0, -1):
            t = tmp[:j]
            np.multiply(H[:j, j], x[j], out=t)
            x[:j] -= t
        return x

    # ---------------------------------------------------------------- bookkeeping
    def finish(self, blk, mask, success, iters):
        """Record the targets in ``mask`` as finished and drop them from ``blk``."""
        cols = mask.nonzero()[0]
        idx = blk.idx[cols].astype(np.int64)
        q_out, ok_out, it_out, res_out = self.out
        q_out[idx] = blk.q[:, cols].T
        ok_out[idx] = success
        it_out[idx] = iters
        res_out[idx] = blk.na[cols]
        blk.drop(mask)

    def stagnated(self, blk):
        """Targets whose every later trial is bound to leave ``q`` unchanged bit for bit.

        With μ = λ² and A = JᵀJ ⪰ 0 the step is ``dq = (A + μI)⁻¹ g = (g − A(A + μI)⁻¹ g) / μ``
        and ``‖A(A + μI)⁻¹‖ ≤ tr(A)/μ``, so every component obeys
        ``|dq_j| ≤ (|g_j| + (tr(A)/μ) ‖g‖) / μ``, to which a generous bound of the solve's
        rounding, ``64 n ε ‖g‖ / μ``, is added. The bound only shrinks as λ doubles. Where it is
        below an eighth of the spacing of the floating-point numbers at ``q_j`` for every joint,
        ``q + dq`` rounds back to ``q`` now and at every later trial; the trial pose is then the
        current pose, its error is not smaller, and the trial is rejected. So the target fails
        after ``rlimit − r + 1`` more rejections or at the iteration limit, whichever comes first.
        """
        n = blk.n
        g = blk.aug[:, n]
        mu = blk.lam * blk.lam
        gnorm = np.sqrt(np.einsum("jm,jm->m", g, g))
        trace = np.einsum("jjm->m", blk.aug[:, :n])
        slack = (trace / mu + 64.0 * n * _EPS) * gnorm
        bound = np.abs(g)
        bound += slack
        bound /= mu
        return np.all(bound <= 0.125 * np.spacing(np.abs(blk.q)), axis=0)

    def init_block(self, blk):
        """Initial pose error, ``[JᵀJ | Jᵀe]`` and counters; finishes the targets that stop at
        the first iteration (already within tolerance, or ``ilimit = 0``)."""
        n, M = blk.n, blk.M
        blk.lam[:] = self.lam0
        blk.rej[:] = 0.0
        blk.it[:] = 0.0
        TR = self.sc.get("TR", (self.trial_rows, M))
        Rx = self.fk(blk.q, blk.dh, TR)
        self.pose_error(Rx, TR[self.rows_p[0] : self.rows_p[1]], blk.Rt, blk.pt, TR[n : n + 6], TR[n + 6])
        blk.e[:] = TR[n : n + 6]
        blk.na[:] = TR[n + 6]
        blk.aug[:] = self.normal_equations(TR)
        # iteration 1 stops with success where |e| <= tol, and fails everywhere if ilimit = 0
        done = blk.na <= self.tol
        if self.ilimit == 0:
            self.finish(blk, np.ones(M, dtype=bool), done, 0)
        elif done.any():
            self.finish(blk, done, True, 1)

    def depth_for(self, M):
        """Speculation depth: 1 while many targets share each numpy call, more when few do (a
        loop then costs mostly Python overhead, and the extra trials come almost free)."""
        return max(1, min(self.max_depth, self.spec_width // M))

    def run(self, blk, stop_below=0):
        """Iterate until no target is left, or until fewer than ``stop_below`` are (then the
        block is returned with its remaining targets)."""
        ilimit, rlimit, tol, n = self.ilimit, self.rlimit, self.tol, blk.n
        rp = self.rows_p
        sc = self.sc
        while blk.M:
            M = blk.M
            if M < stop_below:
                return blk
            blk.loops += 1
            if self.shortcut and blk.loops % 4 == 0:
                stag = self.stagnated(blk)
                if stag.any():
                    iters = np.minimum(blk.it[stag] + 1.0 + (rlimit - blk.rej[stag]), ilimit)
                    self.finish(blk, stag, False, iters)
                    continue
            depth = self.depth_for(M)
            W = depth * M
            lam = blk.lam
            if depth == 1:
                l2 = lam * lam
            else:
                # trial j (0-based) uses λ·2^j: the λ the iteration would reach after j rejections
                lamj = np.ldexp(lam[None], np.arange(depth)[:, None])
                l2 = lamj * lamj
            dq = self.solve(blk.aug, l2, depth)
            TR = sc.get("TR", (self.trial_rows, W))
            qn, en = TR[:n], TR[n : n + 6]
            if depth == 1:
                np.add(blk.q, dq, out=qn)
                Rx = self.fk(qn, blk.dh, TR)
                nn = self.pose_error(Rx, TR[rp[0] : rp[1]], blk.Rt, blk.pt, en, TR[n + 6])
            else:
                np.add(blk.q[:, None], dq.reshape(n, depth, M), out=qn.reshape(n, depth, M))
                dh = None if blk.dh is None else np.tile(np.stack(blk.dh), (1, 1, depth))
                Rx = self.fk(qn, dh, TR)
                Rt, pt = np.tile(blk.Rt, depth), np.tile(blk.pt, depth)
                nn = self.pose_error(Rx, TR[rp[0] : rp[1]], Rt, pt, en, TR[n + 6])
            if depth == 1:
                better = nn < blk.na
                acc = better.nonzero()[0]
                cols = acc
                # rejected: stiffen the damping and count; accepted: move and relax
                half = lam[acc] * 0.5
                lam *= 2.0
                lam[acc] = half
                blk.rej += 1.0
                blk.rej[acc] = 0.0
                blk.it += 1.0
            else:
                # the trials a sequential run reaches: before trial j come j rejections, which it
                # survives while r + j <= rlimit, at iterations it + 1 + j <= ilimit
                jmax = np.minimum(np.minimum(depth - 1.0, rlimit - blk.rej), ilimit - 1.0 - blk.it)
                better = nn.reshape(depth, M) < blk.na
                better &= np.arange(depth)[:, None] <= jmax
                anyb = better.any(axis=0)
                first = better.argmax(axis=0)  # the first accepted trial, where there is one
                acc = anyb.nonzero()[0]
                cols = first[acc] * M + acc
                # accepted at trial j: λ·2^j / 2, iteration it + 1 + j; none: λ·2^(jmax + 1)
                steps = np.where(anyb, first, jmax + 1.0)
                blk.it += steps
                blk.it[acc] += 1.0
                lam[:] = np.ldexp(lam, steps.astype(np.int64))
                lam[acc] *= 0.5
                blk.rej += steps
                blk.rej[acc] = 0.0
            blk.max_it += depth
            fin = None
            if acc.size:
                G = np.take(TR, cols, axis=1, out=sc.get("G", (self.trial_rows, acc.size)), mode="clip")
                blk.qena[:, acc] = G[: n + 7]
                blk.aug[..., acc] = self.normal_equations(G)
                # success is decided at the start of the next iteration
                done_acc = G[n + 6] <= tol
                if done_acc.any():
                    fin = np.zeros(M, dtype=bool)
                    fin[acc[done_acc]] = True
            done = fin
            failed = blk.rej > rlimit if blk.rej.max(initial=0.0) > rlimit else None
            over = None
            if blk.max_it >= ilimit:
                # the next iteration would exceed the limit: failure, counted as ilimit
                over = blk.it >= ilimit
                blk.max_it = float(blk.it.max(initial=0.0))
            if done is not None or failed is not None or (over is not None and over.any()):
                # one finishing step per loop; a success wins, then the rejection limit (reached
                # at iteration it), then the iteration limit
                fin = np.zeros(M, dtype=bool)
                for part in (done, failed, over):
                    if part is not None:
                        fin |= part
                iters = np.full(M, float(ilimit))
                if failed is not None:
                    iters[failed] = blk.it[failed]
                success = np.zeros(M, dtype=bool)
                if done is not None:
                    iters[done] = np.minimum(blk.it[done] + 1.0, ilimit)
                    success = done
                self.finish(blk, fin, success[fin], iters[fin])
        return blk


def lm_chunk(dh, T, q0, tool, ilimit, rlimit, tol, lam0, *, threads=None, shortcut=True,
             use_torch=True, max_depth=4, merge_below=None):
    """Solve one chunk of targets.

    Parameters
    ----------
    dh : (m, n, 3) DH columns ``[d (m), a (m), alpha (rad)]`` per target
    T : (m, 4, 4) target poses in the base frame
    q0 : (m, n) start configurations (rad)
    tool : (4, 4) or None
    ilimit, rlimit, tol, lam0 : as :func:`wsmap.kinematics.ikine_LM`
    threads : worker threads (default :func:`default_threads`)
    shortcut : use the exact stagnation shortcut (False only to test it)
    use_torch : compute sin/cos with torch (imported on first use) where available, else numpy
    max_depth : the most trials per target per loop (1 turns speculation off)
    merge_below : with several threads, merge their targets into one thread when fewer than this
        many are left in a thread

    Returns
    -------
    q (m, n) rad, success (m,) bool, iterations (m,) int64, residual (m,) error norm — as the
    reference iteration defines them.
    """
    dh = np.asarray(dh, dtype=np.float64)
    T = np.asarray(T, dtype=np.float64)
    q0 = np.asarray(q0, dtype=np.float64)
    m, n = q0.shape
    out = (np.empty((m, n)), np.zeros(m, dtype=bool), np.zeros(m, dtype=np.int64), np.empty(m))
    if m == 0:
        return out
    per_target = not bool(np.all(dh == dh[:1]))
    plan = None
    if not per_target:
        plan = [(float(d), float(a), float(np.cos(al)), float(np.sin(al))) for d, a, al in dh[0]]
    tool = None if tool is None else np.asarray(tool, dtype=np.float64)
    params = (int(ilimit), int(rlimit), float(tol), float(lam0))

    threads = default_threads() if threads is None else max(1, int(threads))
    merge_below = 1024 if merge_below is None else int(merge_below)

    lay, rows = _layout(n, per_target)
    S = np.empty((rows, m))
    S[slice(*lay["q"])] = q0.T
    S[slice(*lay["idx"])] = np.arange(m)
    S[slice(*lay["pt"])] = T[:, :3, 3].T
    Rt = S[slice(*lay["Rt"])].reshape(3, 5, m)
    Rt[:, 0:3] = T[:, :3, :3].transpose(2, 1, 0)  # [k, r] = R[r, k]
    Rt[:, 3:5] = Rt[:, 0:2]
    if per_target:
        S[slice(*lay["d"])] = dh[:, :, 0].T
        S[slice(*lay["a"])] = dh[:, :, 1].T
        S[slice(*lay["ca"])] = np.cos(dh[:, :, 2]).T
        S[slice(*lay["sa"])] = np.sin(dh[:, :, 2]).T

    torch = _get_torch() if use_torch else None  # imported here, not in a worker thread
    pinned = None
    if torch is not None and torch.get_num_threads() > 1:
        # torch would spread each sin/cos call over its intra-op threads, whose spin-waiting then
        # slows every numpy call in between (measured on 2 cores: 9 % slower, CPU time doubled);
        # so one intra-op thread for the duration of the call, restored afterwards
        pinned = torch.get_num_threads()
        torch.set_num_threads(1)
    try:
        _run_chunk(S, n, per_target, plan, tool, params, out, shortcut, torch, max_depth, threads, merge_below)
    finally:
        if pinned is not None:
            torch.set_num_threads(pinned)
    return out


def _run_chunk(S, n, per_target, plan, tool, params, out, shortcut, torch, max_depth, threads, merge_below):
    """Run the kernel on the state ``S`` of a chunk, in one thread or several (see lm_chunk)."""

    def kernel():
        return _Kernel(n, plan, tool, params, out, shortcut, torch, max_depth)

    if threads > 1 and S.shape[1] >= 2 * threads * merge_below:
        parts = [_Block(n, per_target, np.ascontiguousarray(c)) for c in np.array_split(S, threads, axis=1)]
        left = [None] * threads
        errors = []

        def work(k):
            try:
                kern = kernel()
                kern.init_block(parts[k])
                left[k] = kern.run(parts[k], stop_below=merge_below)
            except BaseException as exc:  # re-raised in the calling thread
                errors.append(exc)

        workers = [threading.Thread(target=work, args=(k,)) for k in range(1, threads)]
        for w in workers:
            w.start()
        work(0)
        for w in workers:
            w.join()
        if errors:
            raise errors[0]
        blk = _Block.merge([b for b in left if b is not None])
        if blk is not None:
            kernel().run(blk)
    else:
        kern = kernel()
        blk = _Block(n, per_target, S)
        kern.init_block(blk)
        kern.run(blk)
