"""The compiled LM search on coupled chains: `wsmap.kinematics.lm_compiled`'s iteration on the
independent variables of a chain whose joints follow them (`wsmap.kinematics.chain.Coupling`).

A coupled chain has `nj` joints driven by `n <= nj` variables, `q_full[j] = mult[j] · q[var[j]] +
const[j]` (the constant folded into the joint offsets by `wsmap.kinematics.ik.kernel.arm_arrays`).
The iteration is `lm_compiled`'s (`MODE_SEARCH` and `MODE_POSITION`: the rotation-vector error,
the projection onto the variables' limits, the two passes, the stagnation and stationary tests, the
same random starts from the same keys, the confirmation by 4 x 4 forward kinematics inside the
limits) with two changes: the forward kinematics runs over the joints at `q_full`, and the
Jacobian of the variables is the joints' Jacobian times the coupling matrix, each variable's column
the sum of its joints' columns times their multipliers. `LM` on the reduced variables is then the
same LM as on any arm: the normal equations are `n x n`.

Why a module of its own rather than more fields of `lm_compiled`'s call: the arms' arrays cross the
kernel boundary by name (`lm_compiled.KernelCall`, whose fields the lane kernel's table must match,
`wsmap.kinematics.lm_lanes`), and the uncoupled kernel stays what it is, bit for bit and in speed.
The per-iteration pieces that do not read the joints (`pose_error`, `solve_damped`,
`project_joint`, the stagnation bound, `random_start`) are `lm_compiled`'s own, inlined.

Which variables wrap by whole turns: `Coupled.slide` is True for a variable that must not (a
prismatic one, or a revolute one driving a joint at a non-integer rate, which a whole turn of the
variable does not bring back); those are projected by clipping, like a prismatic joint, and never
moved by 2·pi at the end. One generic build (the joint counts are run-time values); compiled on
first use and cached beside `lm_compiled`'s builds (`lm_compiled.cache_dir`). The paper's mode
(`MODE_PAPER`) is for DH arms and is refused here.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np
from numba import njit

from . import lm_compiled
from .lm_compiled import (AT_START, EPS, ILIMIT, MODE_PAPER, MODE_POSITION, REJECTIONS, STAGNATED, STATIONARY, SUCCESS,
                          TARGETS_PER_TASK, TWO_PI, KernelCall, bind_callees, g2_trace, pose_error, project_joint,
                          random_start, sincos, solve_damped, spacing, spread, stationary)

__all__ = ["Coupled", "run_targets", "needs_compile"]

_NUMBA_CACHE_DIR_BEFORE = numba.config.CACHE_DIR
numba.config.CACHE_DIR = lm_compiled.cache_dir()


class Coupled(NamedTuple):
    """How the `nj` joints of the arms (`lm_compiled.ArmBatch` with per-joint `Rf`, `tf`, `rkind`,
    `off`, `axes`, `pris`, `zax` and per-variable limits and start box) follow the `n` variables:
    `var` (nj,) int64 and `mult` (nj,) float64 (`x_j = mult[j] · q[var[j]] + off[b, j]`); `slide`
    (n,) bool, the variables that are clipped and never moved by whole turns (module notes)."""

    var: np.ndarray
    mult: np.ndarray
    slide: np.ndarray


@njit(cache=True, inline="always", error_model="numpy", fastmath={"contract", "reassoc"})
def _fk_c(q, b, Rf, tf, rkind, off, axes, pris, zax, var, mult, R, p, w, o, T33, nj):  # noqa: C901 - one compiled loop, kept whole as lm_compiled's
    """`lm_compiled._fk` over the `nj` joints at `x_j = mult[j] · q[var[j]] + off[b, j]`."""
    for r in range(3):
        for c in range(3):
            R[r, c] = Rf[b, 0, r, c]
        p[r] = tf[b, 0, r]
    for i in range(nj):
        x = q[var[i]] * mult[i] + off[b, i]
        a0, a1, a2 = axes[i, 0], axes[i, 1], axes[i, 2]
        for r in range(3):
            o[i, r] = p[r]
            if zax[i]:
                w[i, r] = R[r, 2] * a2
            else:
                w[i, r] = R[r, 0] * a0 + R[r, 1] * a1 + R[r, 2] * a2
        if pris[i]:
            for r in range(3):
                p[r] = p[r] + w[i, r] * x
        elif zax[i]:
            si, ci = sincos(x)
            si = si * a2
            for r in range(3):
                r0 = R[r, 0] * ci + R[r, 1] * si
                r1 = R[r, 1] * ci - R[r, 0] * si
                R[r, 0] = r0
                R[r, 1] = r1
        else:
            s, c = sincos(x)
            K = ((0.0, -a2, a1), (a2, 0.0, -a0), (-a1, a0, 0.0))
            for r in range(3):
                for m in range(3):
                    k2 = K[r][0] * K[0][m] + K[r][1] * K[1][m] + K[r][2] * K[2][m]
                    T33[r, m] = (1.0 if r == m else 0.0) + K[r][m] * s + k2 * (1.0 - c)
            for r in range(3):
                v0 = R[r, 0] * T33[0, 0] + R[r, 1] * T33[1, 0] + R[r, 2] * T33[2, 0]
                v1 = R[r, 0] * T33[0, 1] + R[r, 1] * T33[1, 1] + R[r, 2] * T33[2, 1]
                v2 = R[r, 0] * T33[0, 2] + R[r, 1] * T33[1, 2] + R[r, 2] * T33[2, 2]
                R[r, 0] = v0
                R[r, 1] = v1
                R[r, 2] = v2
        t0, t1, t2 = tf[b, i + 1, 0], tf[b, i + 1, 1], tf[b, i + 1, 2]
        for r in range(3):
            p[r] = p[r] + (R[r, 0] * t0 + R[r, 1] * t1 + R[r, 2] * t2)
        kind = rkind[b, i + 1]
        if kind == 1:  # Rx(α), as lm_compiled._fk: the products with its zeros and ones dropped
            c1, s1, c2, s2 = Rf[b, i + 1, 1, 1], Rf[b, i + 1, 2, 1], Rf[b, i + 1, 1, 2], Rf[b, i + 1, 2, 2]
            for r in range(3):
                v1 = R[r, 1] * c1 + R[r, 2] * s1
                v2 = R[r, 1] * c2 + R[r, 2] * s2
                R[r, 1] = v1
                R[r, 2] = v2
        elif kind == 2:
            for r in range(3):
                v0 = R[r, 0] * Rf[b, i + 1, 0, 0] + R[r, 1] * Rf[b, i + 1, 1, 0] + R[r, 2] * Rf[b, i + 1, 2, 0]
                v1 = R[r, 0] * Rf[b, i + 1, 0, 1] + R[r, 1] * Rf[b, i + 1, 1, 1] + R[r, 2] * Rf[b, i + 1, 2, 1]
                v2 = R[r, 0] * Rf[b, i + 1, 0, 2] + R[r, 1] * Rf[b, i + 1, 1, 2] + R[r, 2] * Rf[b, i + 1, 2, 2]
                R[r, 0] = v0
                R[r, 1] = v1
                R[r, 2] = v2


@njit(cache=True, inline="always", error_model="numpy", fastmath={"contract", "reassoc"})
def _normal_equations_c(p, w, o, pris, var, mult, e, Jf, J, A, g, rows, n, nj):
    """The joints' geometric Jacobian `Jf` (6, nj), the variables' `J = Jf · coupling matrix`
    (6, n), then `A = JᵀJ` (n, n) and `g = Jᵀe` (n,) over the first `rows` rows."""
    for j in range(nj):
        if pris[j]:
            for r in range(3):
                Jf[r, j] = w[j, r]
                Jf[3 + r, j] = 0.0
        else:
            d0, d1, d2 = p[0] - o[j, 0], p[1] - o[j, 1], p[2] - o[j, 2]
            Jf[0, j] = w[j, 1] * d2 - w[j, 2] * d1
            Jf[1, j] = w[j, 2] * d0 - w[j, 0] * d2
            Jf[2, j] = w[j, 0] * d1 - w[j, 1] * d0
            for r in range(3):
                Jf[3 + r, j] = w[j, r]
    for v in range(n):
        for r in range(6):
            J[r, v] = 0.0
    for j in range(nj):
        v = var[j]
        m = mult[j]
        for r in range(6):
            J[r, v] = J[r, v] + m * Jf[r, j]
    for j in range(n):
        for m in range(j, n):
            s = J[0, j] * J[0, m]
            for r in range(1, rows):
                s = s + J[r, j] * J[r, m]
            A[j, m] = s
            A[m, j] = s
        s = J[0, j] * e[0]
        for r in range(1, rows):
            s = s + J[r, j] * e[r]
        g[j] = s


@njit(cache=True, error_model="numpy", fastmath={"contract", "reassoc"})
def _lm_c(q, b, Rt, pt, limited, rows, st, gtol, arms, cp, sc, n, nj):  # noqa: C901 - one compiled loop, kept whole as lm_compiled's
    """`lm_compiled._lm` (search modes: the rotation-vector error) on the variables `q` (n,) of
    a coupled arm: the same steps, tests and termination codes."""
    Rf, tf, rkind, off, axes, pris, zax = arms.Rf, arms.tf, arms.rkind, arms.off, arms.axes, arms.pris, arms.zax
    clo, chi, clipped = arms.clo, arms.chi, arms.clipped
    var, mult, slide = cp.var, cp.mult, cp.slide
    ilimit, rlimit, tol, lam0 = st.ilimit, st.rlimit, st.tol, st.lam0
    Rn, pn, wn, on, T33, e, en, Jf, J, A, g, H, dq, qt, held, out = sc
    touched = False
    for j in range(n):
        qt[j] = q[j]
    lam = lam0
    rej = 0
    it = 0
    code = 0
    na = np.inf
    start = True
    while True:
        if not start:
            any_held = False
            if limited:
                for j in range(n):
                    hj = clipped[b, j] and ((q[j] <= clo[b, j] and g[j] < 0.0) or (q[j] >= chi[b, j] and g[j] > 0.0))
                    held[j] = hj
                    any_held = any_held or hj
                if any_held:
                    touched = True
            solve_damped(A, g, lam * lam, held, any_held, H, dq, n)
            for j in range(n):
                qt[j] = q[j] + dq[j]
        if limited:
            for j in range(n):
                v = project_joint(qt[j], clo[b, j], chi[b, j], not slide[j])
                if v != qt[j]:
                    touched = True
                qt[j] = v
        _fk_c(qt, b, Rf, tf, rkind, off, axes, pris, zax, var, mult, Rn, pn, wn, on, T33, nj)
        nn = pose_error(Rn, pn, Rt, pt, en, True, rows)
        better = start or nn < na
        if better:
            for j in range(n):
                q[j] = qt[j]
            for r in range(6):
                e[r] = en[r]
            na = nn
            _normal_equations_c(pn, wn, on, pris, var, mult, e, Jf, J, A, g, rows, n, nj)
        if start:
            start = False
            if na <= tol:
                code = AT_START
                break
            if ilimit == 0:
                code = ILIMIT
                break
            continue
        it += 1
        if better:
            lam = lam * 0.5
            rej = 0
        else:
            lam = lam * 2.0
            rej += 1
        if better and na <= tol:
            code = SUCCESS
        elif better and gtol > 0.0 and stationary(A, g, na, gtol, n):
            code = STATIONARY
        elif rej > rlimit:
            code = REJECTIONS
        elif it >= ilimit:
            code = ILIMIT
        elif rej > 0:
            # lm_compiled._lm's exact stagnation bound, on the variables
            mu = lam * lam
            g2, trace = g2_trace(A, g, n)
            slack = (trace / mu + 64.0 * n * EPS) * math.sqrt(g2)
            stuck = True
            for j in range(n):
                if not ((abs(g[j]) + slack) / mu <= 0.125 * spacing(q[j])):
                    stuck = False
                    break
            if stuck:
                code = STAGNATED
        if code:
            break
    out[0] = it
    out[1] = rej
    out[2] = na
    return code, touched


@njit(cache=True, error_model="numpy", fastmath={"contract", "reassoc"})
def _confirm_c(q, b, Rt, pt, atol, rows, arms, cp, M4, N4, P4, n, nj):  # noqa: C901 - one compiled loop, kept whole as lm_compiled's
    """`lm_compiled._confirm` for a coupled arm: the variables `q` inside their limits, and 4 x 4
    forward kinematics over the joints at `x_j = mult[j] · q[var[j]] + off[b, j]` within `atol`."""
    Rf, tf, off, axes, pris, lo, hi = arms.Rf, arms.tf, arms.off, arms.axes, arms.pris, arms.lo, arms.hi
    var, mult = cp.var, cp.mult
    for j in range(n):
        if q[j] < lo[b, j] - 1e-9 or q[j] > hi[b, j] + 1e-9:
            return False
    for r in range(4):
        for c in range(4):
            M4[r, c] = 0.0
    for r in range(3):
        for c in range(3):
            M4[r, c] = Rf[b, 0, r, c]
        M4[r, 3] = tf[b, 0, r]
    M4[3, 3] = 1.0
    for i in range(nj):
        x = q[var[i]] * mult[i] + off[b, i]
        for r in range(4):
            for c in range(4):
                N4[r, c] = 1.0 if r == c else 0.0
        if pris[i]:
            for r in range(3):
                N4[r, 3] = axes[i, r] * x
        else:
            c0 = math.cos(x)
            s0 = math.sin(x)
            u = (axes[i, 0], axes[i, 1], axes[i, 2])
            for r in range(3):
                for c in range(3):
                    N4[r, c] = c0 * (1.0 if r == c else 0.0) + (1.0 - c0) * u[r] * u[c]
            N4[0, 1] -= s0 * u[2]
            N4[1, 0] += s0 * u[2]
            N4[0, 2] += s0 * u[1]
            N4[2, 0] -= s0 * u[1]
            N4[1, 2] -= s0 * u[0]
            N4[2, 1] += s0 * u[0]
        for r in range(4):
            for c in range(4):
                P4[r, c] = M4[r, 0] * N4[0, c] + M4[r, 1] * N4[1, c] + M4[r, 2] * N4[2, c] + M4[r, 3] * N4[3, c]
        for r in range(3):
            for c in range(3):
                N4[r, c] = Rf[b, i + 1, r, c]
            N4[r, 3] = tf[b, i + 1, r]
        for c in range(4):
            N4[3, c] = 1.0 if c == 3 else 0.0
        for r in range(4):
            for c in range(4):
                M4[r, c] = P4[r, 0] * N4[0, c] + P4[r, 1] * N4[1, c] + P4[r, 2] * N4[2, c] + P4[r, 3] * N4[3, c]
    dp = math.sqrt((M4[0, 3] - pt[0]) ** 2 + (M4[1, 3] - pt[1]) ** 2 + (M4[2, 3] - pt[2]) ** 2)
    if rows == 3:
        return dp <= atol
    v0 = v1 = v2 = 0.0
    cs = 0.0
    for k in range(3):
        v0 += M4[1, k] * Rt[2, k] - M4[2, k] * Rt[1, k]
        v1 += M4[2, k] * Rt[0, k] - M4[0, k] * Rt[2, k]
        v2 += M4[0, k] * Rt[1, k] - M4[1, k] * Rt[0, k]
        for r in range(3):
            cs += M4[r, k] * Rt[r, k]
    ang = math.atan2(0.5 * math.sqrt(v0 * v0 + v1 * v1 + v2 * v2), 0.5 * (cs - 1.0))
    return dp <= atol and ang <= atol


@njit(cache=True, error_model="numpy", fastmath={"contract", "reassoc"})
def _task_c(task, call, cp, n, nj):  # noqa: C901 - one compiled loop, kept whole as lm_compiled's
    """`lm_compiled._task` (search modes) for the targets of task `task` on coupled arms."""
    arm, Rt, pt, keys, qexp, nexp = call.targets
    arms, st = call.arms, call.settings
    lo, hi, limited_arm, unlimited, blo, bhi = arms.lo, arms.hi, arms.limited, arms.unlimited, arms.blo, arms.bhi
    slide = cp.slide
    mode, k_first, k_last = st.mode, st.k_first, st.k_last
    gtol, confirm_tol, free_pass = st.gtol, st.confirm_tol, st.free_pass
    q_out, ok_out, it_out, res_out, start_out = call.out
    M = Rt.shape[0]
    rows = 3 if mode == MODE_POSITION else 6
    Rn = np.empty((3, 3))
    pn = np.empty(3)
    wn = np.empty((nj, 3))
    on = np.empty((nj, 3))
    T33 = np.empty((3, 3))
    e = np.empty(6)
    en = np.empty(6)
    Jf = np.empty((6, nj))
    J = np.empty((6, n))
    A = np.empty((n, n))
    g = np.empty(n)
    H = np.empty((n, n + 1))
    dq = np.empty(n)
    qt = np.empty(n)
    held = np.zeros(n, dtype=np.bool_)
    out = np.empty(3)
    sc = (Rn, pn, wn, on, T33, e, en, Jf, J, A, g, H, dq, qt, held, out)
    q = np.empty(n)
    qs = np.empty(n)
    M4 = np.empty((4, 4))
    N4 = np.empty((4, 4))
    P4 = np.empty((4, 4))
    for i in range(task * TARGETS_PER_TASK, min(M, (task + 1) * TARGETS_PER_TASK)):
        b = arm[i]
        limited = limited_arm[b]
        total = 0
        best = np.inf
        found = False
        ntry = nexp[i] + max(0, k_last - k_first)
        for s in range(ntry):
            if s < nexp[i]:
                for j in range(n):
                    qs[j] = qexp[i, s, j]
            else:
                random_start(keys[i], k_first + s - nexp[i], b, blo, bhi, qs)
            passes = 2 if limited and free_pass else 1
            for pss in range(passes):
                for j in range(n):
                    q[j] = qs[j]
                code, touched = _lm_c(q, b, Rt[i], pt[i], limited and pss == 0, rows, st, gtol, arms, cp, sc, n, nj)
                total += int(out[0])
                for j in range(n):
                    v = project_joint(q[j], lo[b, j], hi[b, j], not slide[j])
                    if unlimited[b, j]:
                        v = np.mod(v + np.pi, TWO_PI) - np.pi
                    q[j] = v
                conv = code == SUCCESS or code == AT_START
                if pss == 0 and out[2] < best:
                    best = out[2]
                    for j in range(n):
                        q_out[i, j] = q[j]
                if conv and _confirm_c(q, b, Rt[i], pt[i], confirm_tol, rows, arms, cp, M4, N4, P4, n, nj):
                    found = True
                    for j in range(n):
                        q_out[i, j] = q[j]
                    res_out[i] = out[2]
                    start_out[i] = s
                    break
                if not touched:
                    break
            if found:
                break
        ok_out[i] = found
        it_out[i] = total
        if not found:
            res_out[i] = best
            start_out[i] = -1


@njit(cache=True, nogil=True, error_model="numpy", fastmath={"contract", "reassoc"})
def _run_targets_c(t0, t1, call, cp):
    """Tasks `t0 .. t1 - 1` of `call` on coupled arms `cp`; releases the GIL."""
    n = cp.slide.shape[0]
    nj = cp.var.shape[0]
    for task in range(t0, t1):
        _task_c(task, call, cp, n, nj)


def run_targets(call: KernelCall, coupled: Coupled) -> None:
    """`lm_compiled.run_targets` (`MODE_SEARCH`, `MODE_POSITION`) for arms whose joints follow
    the variables as `coupled` says: `call.arms` per joint (`Rf`, `tf`, `rkind`, `off`, `axes`,
    `pris`, `zax`) and per variable (limits, bounds, start box); `call.targets.qexp` and
    `call.out.q` hold variables `(.., n)`. A `MODE_PAPER` call is a `ValueError`."""
    if call.settings.mode == MODE_PAPER:
        raise ValueError("the paper's LM (MODE_PAPER) takes DH arms, not a chain with coupled joints")
    # a process loading this batch from numba's cache binds its calls as a fresh compile does
    # (lm_compiled's notes, "Cache"): lm_compiled's callees, then this module's, callees first
    bind_callees(_run_targets_c, (_confirm_c, _lm_c, _task_c))
    spread((len(call.targets.arm) + TARGETS_PER_TASK - 1) // TARGETS_PER_TASK,
           lambda a, b: _run_targets_c(a, b, call, coupled))


def needs_compile() -> bool:
    """Whether the first search on a coupled chain in this process will compile this kernel (about
    as long as one of `lm_compiled`'s builds: it, or a callee, is not cached for this CPU and this
    source; `lm_compiled.loadable`). `wsmap.kinematics.ik.warmup.ensure_compiled(coupled=True)`
    announces and does it."""
    return not all(lm_compiled.loadable(d) for d in (sincos, spacing, project_joint, stationary, random_start, _confirm_c,
                                                     _lm_c, _task_c, _run_targets_c))


numba.config.CACHE_DIR = _NUMBA_CACHE_DIR_BEFORE
