"""Compiled (numba) Levenberg–Marquardt kernel: the paper's LM and the multi-start reachability search.

One compiled loop per target, the targets spread over threads; the one implementation of the LM
iteration behind `ikine_search`,
`map_search` and `ikine_LM` (called
through `wsmap.kinematics.ik.kernel`). `wsmap.kinematics.ik.lm_reference` is the same
iteration in numpy, the reference that the tests compare it with: the same arithmetic per target,
so answers agree up to rounding (of `sin`/`cos`, `_sincos` here and SIMD there, and of
the sums, see below), which can, rarely, send an iteration down another path near a branch point.

Why a compiled loop: a numpy kernel pays a Python-level dispatch for every small operation on a row
of targets, and the rows thin out as targets finish; per target, a compiled loop does an iteration
of a 6-joint arm (forward kinematics, pose error, Jacobian, 6 x 6 normal equations) in well under
a microsecond, with no active-set bookkeeping and early exits that cost nothing.

Layout: a call is one object, a `KernelCall` (its targets, the arms they name, the settings and
the arrays the answers go to), read by both kernels by field name. Every arm of a batch is
described by arrays with a leading arm axis `B` (`ArmBatch`: fixed rotations `Rf` (B, n+1, 3, 3)
and translations `tf` (B, n+1, 3) with the base folded into the first and the tool into the
last, joint offsets and limits (B, n)); each target `i` names its arm `arm[i]`. Shared by the
batch: joint axes (n, 3) in the joint frames, which joints are prismatic, which axes are `z`.

Speed (`benchmarks/maps/bench_fast_maps.py`, kernel rate): the forward kinematics takes its sines and
cosines from `_sincos` (no libm call: a third of the forward kinematics' time went to libm),
and the joint count is a compile-time constant for six-joint arms (`_run_targets6` passes
the literal 6 to `_task`, numba compiles that build apart and LLVM unrolls the loops over
joints: the 6 x 6 solve a third faster); other arms take the generic build, `_run_targets`.
Each build is its own compiled function, compiled on first use: a session of seven-joint arms
never compiles the six-joint build. The per-iteration functions are inlined into `_lm` by
numba (`inline="always"`), not called with their dozen array arguments: a fifth faster again
(and most of the compile time: without it a build compiles in 17 s of CPU instead of 23 s, but
the Panda's single-start IK runs about 1.5x slower). `_lm` evaluates the start and every
trial step at one call site, so each is inlined once. A build compiles once (docs/speed.md,
"Compile time"): the builds are cached on disk.

Floating point: compiled with `fastmath={"contract", "reassoc"}` (fused multiply-adds, and sums
the compiler may reorder and vectorise; no assumption about NaN or infinity, which the limits use):
about 15 % faster here than strict IEEE order, and the comparison with the numpy reference in
`tests/kinematics/test_lm_compiled.py` holds (same successes and starts on the test grids).

Cache: a process that loads the kernel from numba's disk cache runs the bits of the process that
compiled it (`tests/kinematics/test_lm_compiled_cache.py`). That needs `run_targets` to be a
Python function around the compiled batches (`_run_targets`, `_run_targets6`). Why: numba links a copy of every separately
compiled callee (`_task`, `_confirm`, ...) into its caller's code and optimises that copy
again with the caller (with `reassoc` a second pass may reorder sums), and the loader binds a call
to the first definition of its symbol that it loaded. A fresh compile loads each callee before its
caller, so the calls bind to the callees as compiled alone; a cache load of `_run_targets` alone
bound them to its own re-optimised copies, and a 7-joint arm's search (the generic build; the
six-joint build came out the same) then differed by ~1e-9 in `q`, in iteration counts and, for
unreachable targets, in the best end point. So `_bind_callees` first loads the cached callees,
callees before callers, as a fresh compile would: the fresh compile's results, in every process
(~0.1 s more on the first call; the same speed after).

Where the cache lives: `NUMBA_CACHE_DIR` if set, else `$XDG_CACHE_HOME/wsmap/numba` (default
`~/.cache/wsmap/numba`), `cache_dir`; numba's own choice (beside the sources) where that
cannot be written. A user directory, so that an install into a read-only site-packages still
caches: numba's locator is chosen when a function is decorated, so this module points
`numba.config.CACHE_DIR` there while its own functions are decorated and puts it back after
(other numba code in the process keeps numba's default). `needs_compile` tells whether the
first call will compile (the cache index says); `wsmap.kinematics.ik.warmup.ensure_compiled`
announces and does it (it runs searches: the IK layer, which this module does not import).

Threads: `set_threads` (default: `WSMAP_THREADS` or every core numba sees). A batch is a
plain compiled loop over tasks that releases the GIL (`nogil`); `_spread` runs it on this
thread and on pool threads, each taking `TASKS_PER_GRAB` tasks of `TARGETS_PER_TASK`
targets at a time from a shared counter, so the slow unreachable ones do not pile up on one thread.
Not numba's `prange`: a parallel loop compiled `_task` twice more (the outlined loop body),
a third of a build's compile time. Calls too small for a second thread run on this one
(`threads_for`). Results never depend on the thread count (each target is independent).
"""

from __future__ import annotations

import itertools
import math
import os
import threading
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from typing import NamedTuple, get_type_hints

import numba
import numpy as np
from numba import njit

__all__ = ["MODE_SEARCH", "MODE_PAPER", "MODE_POSITION", "TARGETS_PER_TASK", "ArmBatch", "Targets", "LMSettings",
           "Answers", "KernelCall", "call_fields", "lm_settings", "set_threads", "threads", "threads_for", "run_targets", "pose_keys",
           "orbit_test", "cache_dir", "needs_compile", "loadable", "estimate", "builds_for", "record_compile_seconds"]


def cache_dir() -> str:
    """Where numba caches the compiled kernels: `NUMBA_CACHE_DIR` if set, else
    `$XDG_CACHE_HOME/wsmap/numba` (`~/.cache/wsmap/numba` where `XDG_CACHE_HOME` is unset)."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return os.environ["NUMBA_CACHE_DIR"]
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "wsmap", "numba")


# this module's functions cache in cache_dir(); put back at the end of the module (see the notes)
_NUMBA_CACHE_DIR_BEFORE = numba.config.CACHE_DIR
numba.config.CACHE_DIR = cache_dir()

MODE_SEARCH = 0  # rotation-vector error, limits inside the iteration, FK confirmation, multi-start
MODE_PAPER = 1  # Corke's tr2delta error, no limits in the iteration, one start (the paper's)
MODE_POSITION = 2  # as MODE_SEARCH on the tool position alone (any orientation)

#: Targets per task handed to a thread (small: unreachable targets cost 100x reachable ones).
TARGETS_PER_TASK = 8

_TWO_PI = 2.0 * np.pi
_EPS = float(np.finfo(np.float64).eps)
_TINY = 5e-324  # np.spacing(0.0)

# termination codes of one LM run
_SUCCESS, _REJECTIONS, _ILIMIT, _STAGNATED, _AT_START, _STATIONARY = 1, 2, 3, 4, 5, 6


# --------------------------------------------------------------------------- what a call reads and writes
# One object crosses the kernel boundary, `KernelCall`; the numba kernels read its fields by name and the
# lane kernel (`wsmap.kinematics.lm_lanes`) reads the same fields by name through its one table
# (`WSMAP_LANES_ARRAYS` and `WSMAP_LANES_SCALARS` in `_lanes/lanes.hpp`; `call_fields` lists them and
# `wsmap.kinematics.lm_lanes` checks the two agree). A new LM setting: a last field of `LMSettings` with
# its default and its use in the numba kernel (this file), a line of the lane table and its use in the lane
# kernel (`_lanes/lanes.hpp`); `wsmap.kinematics.ik.kernel.run_compiled` passes any field by name
# (`lm_settings`), so a caller that wants another value names it there. Named tuples, not dataclasses:
# numba takes them as they are.


class ArmBatch(NamedTuple):
    """A batch of `B` arms of `n` joints as the kernels read them (built by
    `wsmap.kinematics.ik.kernel.arm_arrays`); every array C-contiguous.

    Per arm: `Rf` (B, n+1, 3, 3) float64 and `tf` (B, n+1, 3) float64, the fixed rotations and
    translations with the base folded into the first and the tool into the last; `rkind` (B, n+1)
    int8, each fixed rotation 0 the identity, 1 a rotation about `x`, 2 any; `off`, `lo`, `hi`
    (B, n) float64, joint offsets and limits (±inf where unlimited); `clo`, `chi` (B, n) float64
    and `clipped` (B, n) bool, the bounds the LM projects onto and which joints have them;
    `limited` (B,) bool, any joint clipped; `unlimited` (B, n) bool, revolute without limits;
    `blo`, `bhi` (B, n) float64, the box random starts are drawn in. Shared by the batch: `axes`
    (n, 3) float64, the joint axes in the joint frames; `pris`, `zax` (n,) bool, prismatic joints
    and axes along `z`.
    """

    Rf: np.ndarray
    tf: np.ndarray
    rkind: np.ndarray
    off: np.ndarray
    axes: np.ndarray
    pris: np.ndarray
    zax: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    clo: np.ndarray
    chi: np.ndarray
    clipped: np.ndarray
    limited: np.ndarray
    unlimited: np.ndarray
    blo: np.ndarray
    bhi: np.ndarray


class Targets(NamedTuple):
    """The `M` targets of a call: `arm` (M,) int64, the index into the `ArmBatch` of each;
    `Rt` (M, 3, 3) and `pt` (M, 3) float64, the target rotations and positions (m); `keys`
    (M,) uint64, the hash of each target's random starts (`wsmap.kinematics.ik.kernel.pose_keys`);
    `qexp` (M, S, n) float64 and `nexp` (M,) int64, the explicit starts, the first `nexp[i]`
    of `qexp[i]` tried in order."""

    arm: np.ndarray
    Rt: np.ndarray
    pt: np.ndarray
    keys: np.ndarray
    qexp: np.ndarray
    nexp: np.ndarray


class LMSettings(NamedTuple):
    """How a call searches (build one with `lm_settings`, which casts each field to its type).

    Attributes
    ----------
    mode : int
        `MODE_SEARCH`, `MODE_PAPER` or `MODE_POSITION`.
    k_first, k_last : int
        The random starts `k_first .. k_last - 1`, after the explicit ones.
    ilimit, rlimit : int
        Per LM run: at most `ilimit` iterations and `rlimit` consecutive rejected steps.
    tol : float
        Success at `|e| <= tol` (m and rad).
    lam0 : float
        The damping at the start of each run.
    gtol : float
        The stationary-point test (0: off; ignored by `MODE_PAPER`).
    confirm_tol : float
        A success is confirmed by forward kinematics within `confirm_tol` (m and rad).
    free_pass : bool
        A failed constrained run whose steps the limits changed is run again free of them.

    Notes
    -----
    A new field goes last, with a default (the kernels' behaviour before it), so that every caller
    that does not name it runs as before.
    """

    mode: int
    k_first: int
    k_last: int
    ilimit: int
    rlimit: int
    tol: float
    lam0: float
    gtol: float
    confirm_tol: float
    free_pass: bool


class Answers(NamedTuple):
    """What a call writes, per target (M of them): `q` (M, n) float64, `ok` (M,) bool,
    `iterations` (M,) int64, `residual` (M,) float64 and `start` (M,) int64 (see `run_targets`)."""

    q: np.ndarray
    ok: np.ndarray
    iterations: np.ndarray
    residual: np.ndarray
    start: np.ndarray


class KernelCall(NamedTuple):
    """Everything one call of a kernel reads and writes: the `targets`, the `arms` they name, the
    `settings` and the `out` arrays it fills (`run_targets`, `wsmap.kinematics.lm_lanes.run_targets`)."""

    targets: Targets
    arms: ArmBatch
    settings: LMSettings
    out: Answers


_GROUPS = {"targets": Targets, "arms": ArmBatch, "settings": LMSettings, "out": Answers}


#: The type of each `LMSettings` field (int, float or bool), what `lm_settings` casts a value to.
SETTING_TYPES = get_type_hints(LMSettings)


def lm_settings(**values) -> LMSettings:
    """An `LMSettings` from its fields by name: each value cast to its field's type (`int`,
    `float`, `bool`, as both kernels read them), a field not given taking its default.

    Parameters
    ----------
    **values
        Fields of `LMSettings` (`mode=0, k_first=1, ..., tol=1e-10`).

    Returns
    -------
    LMSettings

    Raises
    ------
    TypeError
        A name that is not a field of `LMSettings`, or a field without a default not given.
    """
    unknown = sorted(set(values) - set(LMSettings._fields))
    if unknown:
        raise TypeError(f"unknown LM setting(s) {', '.join(unknown)}; LMSettings has {', '.join(LMSettings._fields)}")
    missing = [f for f in LMSettings._fields if f not in values and f not in LMSettings._field_defaults]
    if missing:
        raise TypeError(f"LM setting(s) {', '.join(missing)} not given (they have no default)")
    return LMSettings(**{name: SETTING_TYPES[name](value) for name, value in values.items()})


def call_fields() -> tuple:
    """Every field of a `KernelCall` as `"group.name"` (`"settings.tol"`), in order: the names
    the lane kernel's table must hold (`wsmap.kinematics.lm_lanes`)."""
    return tuple(f"{group}.{name}" for group in KernelCall._fields for name in _GROUPS[group]._fields)


def set_threads(count: int | None = None) -> int:
    """Threads the kernel uses from now on: `count`, else `WSMAP_THREADS`, else every core numba
    sees (`NUMBA_NUM_THREADS`). Returns the number set."""
    if count is None:
        env = os.environ.get("WSMAP_THREADS")
        count = int(env) if env else numba.config.NUMBA_NUM_THREADS
    count = max(1, min(int(count), numba.config.NUMBA_NUM_THREADS))
    numba.set_num_threads(count)
    return count


def threads() -> int:
    """Threads the kernel currently uses."""
    return numba.get_num_threads()


@contextmanager
def threads_for(items: int, per_thread: int):
    """Within the block, at most one thread per `per_thread` work items (at least one, at most
    `threads`). A parallel region costs a wake-up of every thread, and when another process
    holds a core, a scheduler tick (milliseconds) waiting for it: small calls (a wave of a few
    dozen targets, a 9261-pose closed-form map) run faster on one thread."""
    n = numba.get_num_threads()
    want = max(1, min(n, int(items) // max(1, int(per_thread))))
    if want != n:
        numba.set_num_threads(want)
    # tasks handed out a few at a time, not in one static block per thread: targets differ in cost
    before = numba.get_parallel_chunksize()
    numba.set_parallel_chunksize(4)
    try:
        yield want
    finally:
        numba.set_parallel_chunksize(before)
        if want != n:
            numba.set_num_threads(n)



_PIO2_1, _PIO2_2, _PIO2_3 = 1.57079632673412561417e+00, 6.07710050630396597660e-11, 2.02226624871116645580e-21
_INV_PIO2 = 6.36619772367581382433e-01


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def _sincos(x):
    """`(sin x, cos x)` within 2 ulp of libm (`tests/kinematics/test_lm_compiled.py`), inlined where it is
    called: `x` reduced by the nearest multiple of pi/2 in three parts (Cody–Waite; the products
    exact for `|x| < 2**20`), then the minimax polynomials of fdlibm's `k_sin.c` and `k_cos.c`
    on [-pi/4, pi/4] and the quadrant's swap and signs; libm itself beyond `|x| = 1e5` and for
    NaN and infinity. Only `contract`: reassociation would undo the reduction's ordered sums."""
    if not abs(x) < 1e5:
        return math.sin(x), math.cos(x)
    k = (x * _INV_PIO2 + 6755399441055744.0) - 6755399441055744.0  # round to nearest, no libm call
    r = ((x - k * _PIO2_1) - k * _PIO2_2) - k * _PIO2_3
    z = r * r
    s = r + r * z * (-1.66666666666666324348e-01 + z * (8.33333333332248946124e-03 + z * (
        -1.98412698298579493134e-04 + z * (2.75573137070700676789e-06 + z * (
            -2.50507602534068634195e-08 + z * 1.58969099521155010221e-10)))))
    c = 1.0 - 0.5 * z + z * z * (4.16666666666666019037e-02 + z * (-1.38888888888741095749e-03 + z * (
        2.48015872894767294178e-05 + z * (-2.75573143513906633035e-07 + z * (
            2.08757232129817482790e-09 + z * -1.13596475577881948265e-11)))))
    q = np.int64(k)
    sv = c if q & 1 else s
    cv = s if q & 1 else c
    if q & 2:
        sv = -sv
    if (q + 1) & 2:
        cv = -cv
    return sv, cv


# --------------------------------------------------------------------------- kinematics of one target
@njit(cache=True, inline="always", error_model="numpy", fastmath={"contract", "reassoc"})
def _fk(q, b, Rf, tf, rkind, off, axes, pris, zax, R, p, w, o, T33, n):
    """Tool rotation `R` (3, 3), position `p` (3,), world joint axes `w` (n, 3) and joint
    origins `o` (n, 3) of arm `b` at `q` (n,); sums in the numpy reference's order.
    `rkind` (B, n+1): each fixed rotation is 0 the identity, 1 an `Rx(α)`, 2 any."""
    for r in range(3):
        for c in range(3):
            R[r, c] = Rf[b, 0, r, c]
        p[r] = tf[b, 0, r]
    for i in range(n):
        x = q[i] + off[b, i]
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
            si, ci = _sincos(x)
            si = si * a2
            for r in range(3):
                r0 = R[r, 0] * ci + R[r, 1] * si
                r1 = R[r, 1] * ci - R[r, 0] * si
                R[r, 0] = r0
                R[r, 1] = r1
        else:
            # Rodrigues: Rot = I + s K + (1 - c) K², K the cross-product matrix of the axis
            s, c = _sincos(x)
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
        if kind == 1:
            # Rx(α) (every DH link): the products with its zeros and ones dropped, same values
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
def _pose_error(R, p, Rt, pt, e, rotvec, rows):
    """`e` (6,) ← `[pt − p; v]` and returns |e|. `v` is `½ Σ_k R_k × Rt_k = sin θ·a`
    (Corke's `tr2delta`, the paper's) or, with `rotvec`, the rotation vector `θ·a` of
    `Rt·Rᵀ` (see `wsmap.kinematics.ik.lm_reference._pose_error` for why); `rows` = 3: position
    only (`v` = 0)."""
    for r in range(3):
        e[r] = pt[r] - p[r]
    if rows == 3:
        e[3] = 0.0
        e[4] = 0.0
        e[5] = 0.0
        return math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
    for r in range(3):
        a = (r + 1) % 3
        bb = (r + 2) % 3
        acc = R[a, 0] * Rt[bb, 0] - R[bb, 0] * Rt[a, 0]
        acc = acc + (R[a, 1] * Rt[bb, 1] - R[bb, 1] * Rt[a, 1])
        acc = acc + (R[a, 2] * Rt[bb, 2] - R[bb, 2] * Rt[a, 2])
        e[3 + r] = 0.5 * acc
    if rotvec:
        tr = R[0, 0] * Rt[0, 0]
        for a in range(3):
            for bb in range(3):
                if a or bb:
                    tr = tr + R[a, bb] * Rt[a, bb]
        sn = math.sqrt(e[3] * e[3] + e[4] * e[4] + e[5] * e[5])
        cs = 0.5 * (tr - 1.0)
        theta = math.atan2(sn, cs)
        if sn > 1e-9:
            scale = theta / sn
            for r in range(3):
                e[3 + r] *= scale
        elif cs < 0.0:
            # a half turn: a·aᵀ = (Rt·Rᵀ + I) / 2; the axis from its largest diagonal entry's column
            jmax = 0
            best = -np.inf
            for j in range(3):
                d = 0.5 * (Rt[j, 0] * R[j, 0] + Rt[j, 1] * R[j, 1] + Rt[j, 2] * R[j, 2] + 1.0)
                if d > best:
                    best = d
                    jmax = j
            den = math.sqrt(max(best, 1e-300))
            for i in range(3):
                s_ij = 0.5 * (Rt[i, 0] * R[jmax, 0] + Rt[i, 1] * R[jmax, 1] + Rt[i, 2] * R[jmax, 2]
                              + (1.0 if i == jmax else 0.0))
                e[3 + i] = s_ij / den * theta
    sq = e[0] * e[0]
    for r in range(1, 6):
        sq = sq + e[r] * e[r]
    return math.sqrt(sq)


@njit(cache=True, inline="always", error_model="numpy", fastmath={"contract", "reassoc"})
def _normal_equations(p, w, o, pris, e, J, A, g, rows, n):
    """Geometric Jacobian `J` (6, n), then `A = JᵀJ` (n, n) and `g = Jᵀe` (n,) over its
    first `rows` rows (6, or 3: position only)."""
    for j in range(n):
        if pris[j]:
            for r in range(3):
                J[r, j] = w[j, r]
                J[3 + r, j] = 0.0
        else:
            d0, d1, d2 = p[0] - o[j, 0], p[1] - o[j, 1], p[2] - o[j, 2]
            J[0, j] = w[j, 1] * d2 - w[j, 2] * d1
            J[1, j] = w[j, 2] * d0 - w[j, 0] * d2
            J[2, j] = w[j, 0] * d1 - w[j, 1] * d0
            for r in range(3):
                J[3 + r, j] = w[j, r]
    for j in range(n):
        for m in range(j, n):  # symmetric: the upper triangle, mirrored
            s = J[0, j] * J[0, m]
            for r in range(1, rows):
                s = s + J[r, j] * J[r, m]
            A[j, m] = s
            A[m, j] = s
        s = J[0, j] * e[0]
        for r in range(1, rows):
            s = s + J[r, j] * e[r]
        g[j] = s


@njit(cache=True, inline="always", error_model="numpy", fastmath={"contract", "reassoc"})
def _solve(A, g, l2, held, any_held, H, x, n):
    """`x` ← `(A + λ² I)⁻¹ g` by Gaussian elimination without pivoting (symmetric positive
    definite); held joints get the identity's row and column and a zero step."""
    for i in range(n):
        for k in range(n):
            H[i, k] = A[i, k]
        H[i, n] = g[i]
        H[i, i] = H[i, i] + l2
    if any_held:
        for i in range(n):
            for k in range(n):
                if held[i] or held[k]:
                    H[i, k] = 0.0
            if held[i]:
                H[i, i] = 1.0
                H[i, n] = 0.0
    for j in range(n):
        piv = H[j, j]
        for k in range(j + 1, n + 1):
            H[j, k] = H[j, k] / piv
        for i in range(j + 1, n):
            hij = H[i, j]
            for k in range(j + 1, n + 1):
                H[i, k] = H[i, k] - hij * H[j, k]
    for i in range(n):
        x[i] = H[i, n]
    for j in range(n - 1, 0, -1):
        xj = x[j]
        for i in range(j):
            x[i] = x[i] - H[i, j] * xj


@njit(cache=True, error_model="numpy", fastmath={"contract", "reassoc"})
def _project1(qj, lo, hi, revolute):
    """One joint projected onto `[lo, hi]`: a revolute joint outside moved by a multiple of 2·pi
    to the equivalent closest to the range, then clipped; a prismatic joint clipped."""
    if qj >= lo and qj <= hi:
        return qj
    if not revolute:
        return min(max(qj, lo), hi)
    if math.isfinite(lo):
        s = lo + np.mod(qj - lo, _TWO_PI)
    else:
        s = hi - np.mod(hi - qj, _TWO_PI)
    if s > hi:
        s = hi if s - hi <= lo + _TWO_PI - s else lo
    return s


@njit(cache=True, error_model="numpy", fastmath={"contract", "reassoc"})
def _spacing(x):
    """`np.spacing(|x|)`: the gap to the next float above `|x|`."""
    ax = abs(x)
    if ax == 0.0:
        return _TINY
    m, ex = math.frexp(ax)
    return max(math.ldexp(1.0, ex - 53), _TINY)


@njit(cache=True, inline="always", error_model="numpy", fastmath={"contract", "reassoc"})
def _g2_trace(A, g, n):
    """`(gᵀg, tr A)`, summed over the joints in order (the stagnation bound and the stationary test)."""
    g2 = g[0] * g[0]
    tr = A[0, 0]
    for j in range(1, n):
        g2 = g2 + g[j] * g[j]
        tr = tr + A[j, j]
    return g2, tr


@njit(cache=True, error_model="numpy", fastmath={"contract", "reassoc"})
def _stationary(A, g, na, gtol, n):
    """`|g| <= gtol·sqrt(tr A)·|e|`: the gradient `g = Jᵀe` vanishes relative to `|J|_F·|e|`."""
    g2, tr = _g2_trace(A, g, n)
    return math.sqrt(g2) <= gtol * math.sqrt(tr) * na


# --------------------------------------------------------------------------- one LM run
@njit(cache=True, error_model="numpy", fastmath={"contract", "reassoc"})
def _lm(q, b, Rt, pt, limited, rotvec, rows, st, gtol, arms, sc, n):
    """LM from `q` (n,), updated in place, towards `(Rt, pt)`; inside the LM bounds if `limited`.

    `st`: the `LMSettings` (`ilimit`, `rlimit`, `tol`, `lam0` read here); `gtol` > 0 (the
    mode's, not `st.gtol`: the paper's LM has none): fail at a stationary point, an accepted step
    after which `|Jᵀe| <= gtol·|J|_F·|e|` with `|e| > tol` (a local minimum of the error that is
    not a solution; 0 turns the test off, as the paper's iteration has it).
    `arms`: the `ArmBatch`; `sc`: scratch (a tuple: a call with over 30 arguments compiles to a
    bytecode numba does not take).

    `out` (3,) float ← iterations, consecutive rejections at the end, final |e|. Returns
    `(code, touched)`: the termination code and whether the limits changed a trial step.
    """
    Rf, tf, rkind, off, axes, pris, zax = arms.Rf, arms.tf, arms.rkind, arms.off, arms.axes, arms.pris, arms.zax
    clo, chi, clipped = arms.clo, arms.chi, arms.clipped
    ilimit, rlimit, tol, lam0 = st.ilimit, st.rlimit, st.tol, st.lam0
    Rn, pn, wn, on, T33, e, en, J, A, g, H, dq, qt, held, out = sc
    touched = False
    for j in range(n):
        qt[j] = q[j]
    lam = lam0
    rej = 0
    it = 0
    code = 0
    na = np.inf
    start = True
    # one evaluation site for the start and every trial step: the inlined forward kinematics,
    # error and normal equations are compiled once, not twice
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
            _solve(A, g, lam * lam, held, any_held, H, dq, n)
            for j in range(n):
                qt[j] = q[j] + dq[j]
        if limited:  # the start and every trial step into the LM bounds
            for j in range(n):
                v = _project1(qt[j], clo[b, j], chi[b, j], not pris[j])
                if v != qt[j]:
                    touched = True
                qt[j] = v
        _fk(qt, b, Rf, tf, rkind, off, axes, pris, zax, Rn, pn, wn, on, T33, n)
        nn = _pose_error(Rn, pn, Rt, pt, en, rotvec, rows)
        better = start or nn < na
        if better:
            for j in range(n):
                q[j] = qt[j]
            for r in range(6):
                e[r] = en[r]
            na = nn
            _normal_equations(pn, wn, on, pris, e, J, A, g, rows, n)
        if start:
            start = False
            if na <= tol:
                code = _AT_START
                break
            if ilimit == 0:
                code = _ILIMIT
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
            code = _SUCCESS
        elif better and gtol > 0.0 and _stationary(A, g, na, gtol, n):
            code = _STATIONARY
        elif rej > rlimit:
            code = _REJECTIONS
        elif it >= ilimit:
            code = _ILIMIT
        elif rej > 0:
            # exact stagnation: with μ = λ², A = JᵀJ and g = Jᵀe, every component of the step obeys
            # |dq_j| <= (|g_j| + (tr A / μ)·|g|) / μ (plus a bound of the solve's rounding), which only
            # shrinks as λ doubles; below an eighth of the spacing at q_j for every joint, q + dq
            # rounds back to q now and at every later trial, so every later trial is rejected
            mu = lam * lam
            g2, trace = _g2_trace(A, g, n)
            slack = (trace / mu + 64.0 * n * _EPS) * math.sqrt(g2)
            stuck = True
            for j in range(n):
                if not ((abs(g[j]) + slack) / mu <= 0.125 * _spacing(q[j])):
                    stuck = False
                    break
            if stuck:
                code = _STAGNATED
        if code:
            break
    out[0] = it
    out[1] = rej
    out[2] = na
    return code, touched


# --------------------------------------------------------------------------- confirmation
@njit(cache=True, error_model="numpy", fastmath={"contract", "reassoc"})
def _confirm(q, b, Rt, pt, atol, rows, arms, M4, N4, P4, n):
    """Forward kinematics by 4 x 4 homogeneous products (another code path than `_fk`) puts
    the tool within `atol` of the target (m; rotation angle, rad, unless `rows` = 3: position
    only), and `q` is inside the limits of arm `b` of `arms` (an `ArmBatch`)."""
    Rf, tf, off, axes, pris, lo, hi = arms.Rf, arms.tf, arms.off, arms.axes, arms.pris, arms.lo, arms.hi
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
    for i in range(n):
        # the joint's motion as a 4 x 4
        x = q[i] + off[b, i]
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
        # then the fixed transform after the joint
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


# --------------------------------------------------------------------------- random starts
@njit(cache=True, error_model="numpy", fastmath={"contract", "reassoc"})
def _mix(z):
    """splitmix64's finaliser (uint64, wrapping), as `wsmap.kinematics.ik.kernel.mix`."""
    z = z + np.uint64(0x9E3779B97F4A7C15)
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))


@njit(cache=True, error_model="numpy", fastmath={"contract", "reassoc"})
def _random_start(key, k, b, blo, bhi, q):
    """Start `k` of the target with hash `key`: uniform in the start box (as `lm_reference._uniform`)."""
    n = q.shape[0]
    for j in range(n):
        ctr = _mix(np.uint64(k) * np.uint64(1 << 16) + np.uint64(j + 1))
        bits = _mix(key + ctr)
        u = np.float64(bits >> np.uint64(11)) * (1.0 / 9007199254740992.0)
        q[j] = blo[b, j] + u * (bhi[b, j] - blo[b, j])


# --------------------------------------------------------------------------- the batch
@njit(cache=True, error_model="numpy", fastmath={"contract", "reassoc"})
def _task(task, call, n):
    """The targets of task `task` of `call` (a `KernelCall`; see `run_targets`); `n` the joint
    count, a compile-time constant where `run_targets` passes a literal (the loops over joints
    then unroll)."""
    arm, Rt, pt, keys, qexp, nexp = call.targets
    arms, st = call.arms, call.settings
    lo, hi, pris, limited_arm, unlimited, blo, bhi = arms.lo, arms.hi, arms.pris, arms.limited, arms.unlimited, \
        arms.blo, arms.bhi
    mode, k_first, k_last, ilimit, rlimit = st.mode, st.k_first, st.k_last, st.ilimit, st.rlimit
    gtol, confirm_tol, free_pass = st.gtol, st.confirm_tol, st.free_pass
    q_out, ok_out, it_out, res_out, start_out = call.out
    M = Rt.shape[0]
    # both modes call _lm with run-time flags, not literals: numba compiles one _lm per build
    # instead of one per literal combination (the inlined loop is most of the compile time)
    paper = mode == MODE_PAPER
    rows = 3 if mode == MODE_POSITION else 6
    gtol_run = 0.0 if paper else gtol
    Rn = np.empty((3, 3))
    pn = np.empty(3)
    wn = np.empty((n, 3))
    on = np.empty((n, 3))
    T33 = np.empty((3, 3))
    e = np.empty(6)
    en = np.empty(6)
    J = np.empty((6, n))
    A = np.empty((n, n))
    g = np.empty(n)
    H = np.empty((n, n + 1))
    dq = np.empty(n)
    qt = np.empty(n)
    held = np.zeros(n, dtype=np.bool_)
    out = np.empty(3)
    sc = (Rn, pn, wn, on, T33, e, en, J, A, g, H, dq, qt, held, out)
    q = np.empty(n)
    qs = np.empty(n)
    M4 = np.empty((4, 4))
    N4 = np.empty((4, 4))
    P4 = np.empty((4, 4))
    for i in range(task * TARGETS_PER_TASK, min(M, (task + 1) * TARGETS_PER_TASK)):
        b = arm[i]
        if mode == MODE_PAPER:
            for j in range(n):
                q[j] = qexp[i, 0, j]
            code, _ = _lm(q, b, Rt[i], pt[i], not paper, not paper, rows, st, gtol_run, arms, sc, n)
            it = int(out[0])
            if code == _AT_START:
                its = min(1, ilimit)  # the Appendix's count: 1, or 0 when ilimit = 0
            elif code == _SUCCESS:
                its = min(it + 1, ilimit)
            elif code == _REJECTIONS:
                its = it
            elif code == _STAGNATED:
                its = min(it + 1 + (rlimit - int(out[1])), ilimit)
            else:
                its = ilimit
            for j in range(n):
                q_out[i, j] = q[j]
            ok_out[i] = code == _SUCCESS or code == _AT_START
            it_out[i] = its
            res_out[i] = out[2]
            start_out[i] = 0 if ok_out[i] else -1
            continue
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
                _random_start(keys[i], k_first + s - nexp[i], b, blo, bhi, qs)
            passes = 2 if limited and free_pass else 1
            res_c = np.inf
            for pss in range(passes):
                for j in range(n):
                    q[j] = qs[j]
                code, touched = _lm(q, b, Rt[i], pt[i], limited and pss == 0, not paper, rows, st, gtol_run, arms, sc,
                                    n)
                total += int(out[0])
                # into the limits by multiples of 2·pi; unlimited revolute joints into [-pi, pi)
                for j in range(n):
                    v = _project1(q[j], lo[b, j], hi[b, j], not pris[j])
                    if unlimited[b, j]:
                        v = np.mod(v + np.pi, _TWO_PI) - np.pi
                    q[j] = v
                conv = code == _SUCCESS or code == _AT_START
                if pss == 0:
                    res_c = out[2]
                    if res_c < best:
                        best = res_c
                        for j in range(n):
                            q_out[i, j] = q[j]
                if conv and _confirm(q, b, Rt[i], pt[i], confirm_tol, rows, arms, M4, N4, P4, n):
                    found = True
                    for j in range(n):
                        q_out[i, j] = q[j]
                    res_out[i] = out[2]
                    start_out[i] = s
                    break
                if not touched:
                    break  # the free run would repeat the constrained one
            if found:
                break
        ok_out[i] = found
        it_out[i] = total
        if not found:
            res_out[i] = best
            start_out[i] = -1


@njit(cache=True, nogil=True, error_model="numpy", fastmath={"contract", "reassoc"})
def _run_targets(t0, t1, call):
    """Tasks `t0 .. t1 - 1` of `call` (a `KernelCall`, see `run_targets`), any joint count (the
    generic build); releases the GIL (see "Threads" and "Cache" in the module notes)."""
    n = call.arms.axes.shape[0]
    for task in range(t0, t1):
        _task(task, call, n)


@njit(cache=True, nogil=True, error_model="numpy", fastmath={"contract", "reassoc"})
def _run_targets6(t0, t1, call):
    """`_run_targets` for six-joint arms: the joint count the literal 6 (the loops over joints
    unroll), a build of its own, compiled on first use."""
    for task in range(t0, t1):
        _task(task, call, 6)


def _build(n: int):
    """The compiled batch for `n`-joint arms: `_run_targets6` for six, else `_run_targets`."""
    return _run_targets6 if n == 6 else _run_targets


#: Tasks a thread takes at a time from the shared counter of `_spread`.
TASKS_PER_GRAB = 4
_pool = None
_pool_lock = threading.Lock()


def _spread(ntask: int, run) -> None:
    """`run(a, b)` (a compiled batch that releases the GIL) over tasks `0 .. ntask - 1` on
    `threads` threads, this one and pool threads, each taking `TASKS_PER_GRAB` tasks at a
    time from a shared counter, so the slow unreachable targets do not pile up on one thread."""
    want = min(numba.get_num_threads(), (ntask + TASKS_PER_GRAB - 1) // TASKS_PER_GRAB)
    if want <= 1:
        run(0, ntask)
        return
    grabs = itertools.count()  # next() on it is atomic under the GIL

    def work():
        while True:
            a = next(grabs) * TASKS_PER_GRAB
            if a >= ntask:
                return
            run(a, min(ntask, a + TASKS_PER_GRAB))

    on_threads(want, work)


def on_threads(want: int, work) -> None:
    """`work()` (a function that releases the GIL and shares its work out itself) on this thread
    and `want - 1` pool threads; returns when every call has."""
    global _pool
    if want <= 1:
        work()
        return
    with _pool_lock:
        if _pool is None:
            _pool = ThreadPoolExecutor(max(1, numba.config.NUMBA_NUM_THREADS - 1), thread_name_prefix="wsmap-ik")
    futures = [_pool.submit(work) for _ in range(want - 1)]
    work()
    for f in futures:
        f.result()


# every separately compiled function that a batch reaches, callees before callers (the order of a
# fresh compile); a new one must join the list, or a cached process may again run other bits
_CALLEES = ("_sincos", "_mix", "_spacing", "_project1", "_stationary", "_random_start", "_confirm", "_lm", "_task")
_bound: set = set()


def _bind_callees(batch=None, more=()) -> None:
    """Load the cached builds of `_CALLEES`, callees first, before `batch` (a compiled batch:
    `_run_targets`, `_run_targets6`) is loaded (see "Cache" in the module notes);
    signatures from each cache index, for this CPU only. `more`: the dispatchers of another
    module's batch that calls these (`wsmap.kinematics.lm_coupled`), loaded after them, callees
    first. Reads the index through numba's private
    cache classes (`_cache`, `_load_index`, `_index_key`: numba 0.68); where numba renames them
    this fails loudly, in the cache test too."""
    batch = _run_targets if batch is None else batch
    name = batch.py_func.__name__
    if name in _bound:
        return
    _bound.add(name)
    if batch.overloads:
        return  # compiled (or loaded) already in this process: its calls are bound
    codegen = batch.targetctx.codegen()
    for dispatcher in [globals()[callee] for callee in _CALLEES] + list(more):
        cache = dispatcher._cache
        index = cache._cache_file._load_index()  # {} where the cache is empty or stale
        for key in index:
            # only entries this process would load itself (this CPU, this bytecode): a cache hit, no compile
            if cache._index_key(key[0], codegen) == key and key[0] not in dispatcher.overloads:
                dispatcher.compile(key[0])


def run_targets(call: KernelCall) -> None:
    """Solve every target `i` of `call` (a `KernelCall`; M targets) for arm `call.targets.arm[i]`;
    the answers written into `call.out`. With `t = call.targets` and `s = call.settings`:

    `MODE_SEARCH`: the explicit starts `t.qexp[i, :t.nexp[i]]` in order, then the random starts
    `s.k_first .. s.k_last - 1` (hashed from `t.keys[i]`), until one succeeds; per start a
    constrained run and, where it failed and the limits changed it, a free run whose solution
    counts if it is inside the limits (unless `s.free_pass` is False); a success is confirmed by
    forward kinematics. `out.start`: the position of the succeeding start in that order (explicit
    first), -1 where none did. Where none did, `out.q` is the constrained end point of the start
    with the smallest residual.

    `MODE_POSITION`: as `MODE_SEARCH` with the position error alone (the tool's orientation free).

    `MODE_PAPER`: one run from `t.qexp[i, 0]` with the paper's error, no limits, no confirmation;
    `out.iterations` counts iterations as the Appendix's loop does (success is tested at the top
    of the next iteration; see `wsmap.kinematics.ik.lm_reference.ikine_LM_reference`).
    """
    batch = _build(call.arms.axes.shape[0])
    _bind_callees(batch)
    _spread((len(call.targets.arm) + TARGETS_PER_TASK - 1) // TARGETS_PER_TASK, lambda a, b: batch(a, b, call))


# --------------------------------------------------------------------------- helpers of the search
@njit(cache=True, error_model="numpy")
def pose_keys(h0, words):
    """Per target `i`: `h0` mixed in turn with each of `words[i]` (K, W) uint64 by `_mix`
    (the loop of `wsmap.kinematics.ik.kernel.pose_keys`, one pass instead of a numpy pass per
    word). Returns (K,) uint64."""
    K, W = words.shape
    out = np.empty(K, dtype=np.uint64)
    for i in range(K):
        h = h0
        for c in range(W):
            h = _mix(h ^ words[i, c])
        out[i] = h
    return out


@njit(cache=True, error_model="numpy")
def orbit_test(a, e0, c, r, u, w, p):
    """The loop of `wsmap.kinematics.ik.reach_filter._orbit_test` (its notes give the geometry), one
    point per row: `a`, `e0` (3,) the axis and a unit vector normal to it; `c`, `u`, `p`
    (K, 3); `r`, `w` (K,), the slack already added. Returns (K,) bool."""
    K = p.shape[0]
    out = np.empty(K, dtype=np.bool_)
    for k in range(K):
        hp = p[k, 0] * a[0] + p[k, 1] * a[1] + p[k, 2] * a[2]
        hc = c[k, 0] * a[0] + c[k, 1] * a[1] + c[k, 2] * a[2]
        rp2 = 0.0
        rc2 = 0.0
        for j in range(3):
            pj = p[k, j] - hp * a[j]
            cj = c[k, j] - hc * a[j]
            rp2 += pj * pj
            rc2 += cj * cj
        rp = math.sqrt(rp2)
        rc = math.sqrt(rc2)
        # (e1, e2): an orthonormal basis of the plane normal to a, e1 towards c where c is off the axis
        e1 = (e0[0], e0[1], e0[2])
        if rc > 0.0:
            e1 = ((c[k, 0] - hc * a[0]) / rc, (c[k, 1] - hc * a[1]) / rc, (c[k, 2] - hc * a[2]) / rc)
        e2 = (a[1] * e1[2] - a[2] * e1[1], a[2] * e1[0] - a[0] * e1[2], a[0] * e1[1] - a[1] * e1[0])
        u1 = u[k, 0] * e1[0] + u[k, 1] * e1[1] + u[k, 2] * e1[2]
        u2 = u[k, 0] * e2[0] + u[k, 1] * e2[1] + u[k, 2] * e2[2]
        ua = u[k, 0] * a[0] + u[k, 1] * a[1] + u[k, 2] * a[2]
        cu = c[k, 0] * u[k, 0] + c[k, 1] * u[k, 1] + c[k, 2] * u[k, 2]
        # x(phi) = hp·a + rp·(cos phi·e1 + sin phi·e2); |x - c|² = D - 2·rp·rc·cos phi
        D = (hp - hc) ** 2 + rp * rp + rc * rc
        # g(phi) = (x - c)·u = G0 + rp·(u1 cos phi + u2 sin phi) = G0 + Gm cos(phi - psi)
        G0 = hp * ua - cu
        Gm = rp * math.hypot(u1, u2)
        psi = math.atan2(u2, u1)
        best = 1.0 if abs(G0 + rp * u1) <= w[k] else -np.inf  # phi = 0, the nearest point, in the slab
        if Gm > 0.0:  # else the arcs' ends where g = ±w
            for bound in (w[k], -w[k]):
                cosv = (bound - G0) / Gm
                if abs(cosv) <= 1.0:
                    th = math.acos(cosv)
                    best = max(best, math.cos(th + psi), math.cos(-th + psi))
        out[k] = math.isfinite(best) and D - 2.0 * rp * rc * best <= r[k] * r[k]
    return out


# --------------------------------------------------------------------------- the first call
#: Seconds a cold compile of one build of the kernels took on the development machine (2 shared
#: cores; see docs/speed.md, "Compile time"); the notice's estimate until this machine has
#: measured its own.
COLD_COMPILE_SECONDS = 25
_ESTIMATE_FILE = "wsmap_compile_seconds.txt"

# what a numerical map calls besides a batch (the batch's own callees: _CALLEES)
_HELPERS = ("pose_keys", "orbit_test")


def loadable(dispatcher) -> bool:
    """Whether `dispatcher` (a `numba.njit` function with `cache=True`) is compiled in this process
    or has a cache entry this process can load (this CPU, this source), read from numba's cache
    index as `_bind_callees` does; False: its next call compiles it."""
    if dispatcher.overloads:
        return True
    cache = dispatcher._cache
    codegen = dispatcher.targetctx.codegen()
    return any(cache._index_key(key[0], codegen) == key for key in cache._cache_file._load_index())


def needs_compile(joints=(6, 7)) -> bool:
    """Whether the first numerical map of this process on arms of each joint count in `joints`
    (an int or a sequence: 6 takes the six-joint build, any other count the generic one) will
    compile a kernel: one of them, or of their callees, or the search's helpers, is not cached for
    this CPU and this source. `joints` empty: the helpers alone (about a second), all that a
    search on the lane kernel (`wsmap.kinematics.lm_lanes`) compiles."""
    builds = builds_for(joints)
    names = _HELPERS + ((_CALLEES + tuple(b.py_func.__name__ for b in builds)) if builds else ())
    return not all(loadable(globals()[name]) for name in names)


def estimate() -> int:
    """The notice's estimate (s): the last cold compile measured here, else `COLD_COMPILE_SECONDS`
    (also for a file that does not hold a number of seconds from 0 to a day: `inf` in it ended the
    map in an `OverflowError`)."""
    try:
        with open(os.path.join(cache_dir(), _ESTIMATE_FILE)) as f:
            seconds = float(f.read(64))
    except (OSError, ValueError, UnicodeDecodeError):
        return COLD_COMPILE_SECONDS
    return max(1, round(seconds)) if 0 <= seconds <= 86400 else COLD_COMPILE_SECONDS


def record_compile_seconds(seconds: float) -> None:
    """Keep `seconds` (one build's cold compile, measured here) as the next notice's estimate."""
    try:
        from ..io import atomic_path

        with atomic_path(os.path.join(cache_dir(), _ESTIMATE_FILE)) as tmp:
            with open(tmp, "w") as f:
                f.write(f"{seconds:.1f}\n")
    except OSError:
        pass  # a read-only cache: the estimate stays the default


def builds_for(joints) -> set:
    """The compiled batches that arms of the joint counts `joints` (an int or a sequence; may be
    empty) run on."""
    joints = (joints,) if isinstance(joints, (int, np.integer)) else tuple(joints)
    return {_build(int(n)) for n in joints}


# --------------------------------------------------------------------------- shared with lm_coupled
# The pieces of the iteration that do not read the joints, by public name, for the kernel of chains with
# coupled joints (`wsmap.kinematics.lm_coupled`), which repeats `_lm` and `_task` on the reduced
# variables; the same compiled functions, so neither kernel changes the other.
sincos, pose_error, solve_damped, project_joint = _sincos, _pose_error, _solve, _project1
spacing, g2_trace, stationary, random_start, spread = _spacing, _g2_trace, _stationary, _random_start, _spread
SUCCESS, REJECTIONS, ILIMIT, STAGNATED, AT_START, STATIONARY = _SUCCESS, _REJECTIONS, _ILIMIT, _STAGNATED, _AT_START, \
    _STATIONARY
EPS, TWO_PI = _EPS, _TWO_PI
bind_callees = _bind_callees

numba.config.CACHE_DIR = _NUMBA_CACHE_DIR_BEFORE
