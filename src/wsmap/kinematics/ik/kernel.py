"""The bridge from arms and targets to the compiled LM kernel (`wsmap.kinematics.lm_compiled`).

* `arm_arrays` — a chain's numbers laid out as the kernel reads them (an `ArmBatch`);
* `run_compiled` — one call of the kernel on a set of targets (one `KernelCall`);
* `pose_keys` — the per-target keys of the random starts (counter-based hashing, so a pose
  gets the same starts wherever it sits in a batch), and `start_box`, where they are drawn.

Used by the paper's LM (`.lm`) and the search (`.search`); the numpy reference
(`.lm_reference`) draws the same starts from `mix` and `start_box`.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .. import lm_compiled, lm_coupled, lm_lanes
from ..chain import PRISMATIC, SerialChain
from ..lm_compiled import Answers, ArmBatch, KernelCall, Targets, lm_settings

__all__ = ["arm_arrays", "CoupledArms", "run_compiled", "pose_keys", "start_box", "mix"]

_TWO_PI = 2.0 * np.pi


def start_box(limits: np.ndarray):
    """Bounds `(lo, hi)` (..., n) that random starts are drawn in: the limits, `[-pi, pi)` where unlimited."""
    lo = np.where(np.isfinite(limits[..., 0]), limits[..., 0], -np.pi)
    hi = np.where(np.isfinite(limits[..., 1]), limits[..., 1], np.pi)
    # a half-open revolute range: one turn from its finite end
    lo = np.where(np.isfinite(limits[..., 1]) & ~np.isfinite(limits[..., 0]), hi - _TWO_PI, lo)
    hi = np.where(np.isfinite(limits[..., 0]) & ~np.isfinite(limits[..., 1]), lo + _TWO_PI, hi)
    return lo, hi


def mix(z):
    """splitmix64's finaliser on uint64 arrays (wrapping arithmetic)."""
    z = z + np.uint64(0x9E3779B97F4A7C15)
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))


def pose_keys(seed: int, T) -> np.ndarray:
    """A 64-bit key per target pose `(K, 4, 4)`: the seed mixed with the bits of `T[:3, :]`,
    so a pose gets the same random starts wherever it sits in a batch."""
    # + 0.0 turns -0.0 into 0.0, so that equal poses have equal keys
    words = np.ascontiguousarray(T[:, :3, :] + 0.0, dtype=np.float64).reshape(len(T), 12).view(np.uint64)
    return lm_compiled.pose_keys(mix(np.array([seed], dtype=np.uint64))[0], words)


class CoupledArms(NamedTuple):
    """The kernel's arrays of a coupled chain (`arm_arrays`): `arms` the `ArmBatch` (per joint:
    fixed transforms, offsets with the coupling's constants added, axes, kinds; per variable: the
    limits, bounds and start box) and `coupled` the `wsmap.kinematics.lm_coupled.Coupled`."""

    arms: ArmBatch
    coupled: lm_coupled.Coupled


def arm_arrays(chain: SerialChain) -> ArmBatch | CoupledArms:
    """The numbers of a chain (or a batch, flattened to `B` arms) as the compiled kernels read them:
    a `wsmap.kinematics.lm_compiled.ArmBatch` (its fields by name).

    `Rf` (B, n+1, 3, 3) and `tf` (B, n+1, 3): the fixed transforms with the base folded into the
    first and the tool into the last; `off`, `lo`, `hi` (B, n): offsets and limits (±inf where
    unlimited); `clo`, `chi`, `clipped` (B, n): the bounds the LM projects onto (the clipped
    joints: prismatic, or revolute with a range narrower than a turn; the others move freely and are
    brought into their range by a multiple of 2·pi at the end); `limited` (B,): any joint clipped;
    `unlimited` (B, n): revolute without limits; `blo`, `bhi` (B, n): the box random starts are
    drawn in; shared `axes` (n, 3), `pris` and `zax` (n,) bool.

    A coupled chain (`chain.coupling`) gives a `CoupledArms`: the fixed transforms, offsets
    (plus the coupling's constants), axes, `pris` and `zax` per joint, the rest per variable, the
    variables that must not wrap by whole turns clipped like prismatic joints
    (`wsmap.kinematics.lm_coupled`).
    """
    if chain.coupling is not None:
        return _coupled_arrays(chain)
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
    with np.errstate(invalid="ignore", over="ignore"):  # limits of ±1e308 overflow hi - lo to inf: unclipped
        clipped = np.where(~pris, (hi - lo) < _TWO_PI, True) & (np.isfinite(lo) | np.isfinite(hi))
    blo, bhi = start_box(lim)
    Rf = np.ascontiguousarray(F[:, :, :3, :3])
    # 0: identity, 1: a rotation about x (R[0] = e0, R[:, 0] = e0), 2: any; exact comparisons, so
    # the kernel's shortcuts drop only products with exact zeros and ones
    e0 = np.array([1.0, 0.0, 0.0])
    about_x = np.all(Rf[..., 0, :] == e0, axis=-1) & np.all(Rf[..., :, 0] == e0, axis=-1)
    rkind = np.where(np.all(Rf == np.eye(3), axis=(-2, -1)), 0, np.where(about_x, 1, 2)).astype(np.int8)
    return ArmBatch(
        Rf=Rf, tf=np.ascontiguousarray(F[:, :, :3, 3]), rkind=rkind,
        off=np.ascontiguousarray(np.broadcast_to(chain.offset, batch + (n,)).reshape(B, n), dtype=np.float64),
        axes=np.ascontiguousarray(chain.axes, dtype=np.float64), pris=pris,
        zax=np.array([a[0] == 0.0 and a[1] == 0.0 for a in chain.axes]),
        lo=lo, hi=hi, clo=np.where(clipped, lo, -np.inf), chi=np.where(clipped, hi, np.inf), clipped=clipped,
        limited=clipped.any(axis=1), unlimited=~pris & np.isinf(lo) & np.isinf(hi),
        blo=np.ascontiguousarray(blo), bhi=np.ascontiguousarray(bhi),
    )


def _coupled_arrays(chain: SerialChain) -> CoupledArms:
    """`arm_arrays` of a coupled chain: the joints' arrays from its relaxation (`uncoupled`), the
    variables' limits, bounds and start box over them."""
    cp = chain.coupling
    n, nj, batch = chain.n, chain.n_joints, chain.batch_shape
    B = int(np.prod(batch, dtype=np.int64))
    joints = arm_arrays(chain.uncoupled().replace(offset=np.asarray(chain.offset) + cp.const))
    if joints.Rf.shape[0] != B:  # the relaxation's own batch is the fixed transforms' and offsets'
        joints = joints._replace(Rf=np.ascontiguousarray(np.broadcast_to(joints.Rf, (B,) + joints.Rf.shape[1:])),
                                 tf=np.ascontiguousarray(np.broadcast_to(joints.tf, (B,) + joints.tf.shape[1:])),
                                 rkind=np.ascontiguousarray(np.broadcast_to(joints.rkind, (B, nj + 1))),
                                 off=np.ascontiguousarray(np.broadcast_to(joints.off, (B, nj))))
    lim = np.broadcast_to(chain.limits, batch + (n, 2)).reshape(B, n, 2)
    lo, hi = np.ascontiguousarray(lim[..., 0]), np.ascontiguousarray(lim[..., 1])
    slide = ~chain.periodic
    with np.errstate(invalid="ignore", over="ignore"):
        clipped = np.where(~slide, (hi - lo) < _TWO_PI, True) & (np.isfinite(lo) | np.isfinite(hi))
    blo, bhi = start_box(lim)
    arms = joints._replace(lo=lo, hi=hi, clo=np.where(clipped, lo, -np.inf), chi=np.where(clipped, hi, np.inf),
                           clipped=clipped, limited=clipped.any(axis=1), unlimited=~slide & np.isinf(lo) & np.isinf(hi),
                           blo=np.ascontiguousarray(blo), bhi=np.ascontiguousarray(bhi))
    return CoupledArms(arms, lm_coupled.Coupled(np.ascontiguousarray(cp.var, dtype=np.int64),
                                                np.ascontiguousarray(cp.mult, dtype=np.float64), slide))


def unsolved(count: int, n: int):
    """The answers of `count` targets before any start has run (the arrays every solver fills):
    `q` (count, n) NaN, `ok` False, `iterations` 0, `residual` inf, `start` -1."""
    return (np.full((count, n), np.nan), np.zeros(count, dtype=bool), np.zeros(count, dtype=np.int64),
            np.full(count, np.inf), np.full(count, -1, dtype=np.int64))


def run_compiled(mode, aa: ArmBatch, arm, T, keys, qexp, nexp, k_first, k_last, ilimit, rlimit, tol, lam, confirm_tol,
                 gtol=0.0, free_pass=True, **more):
    """Run the kernel in use (`wsmap.kinematics.lm_lanes.run_targets`, else
    `wsmap.kinematics.lm_compiled.run_targets`) on targets of arms from a batch.

    Parameters
    ----------
    mode : int
        `wsmap.kinematics.lm_compiled.MODE_SEARCH`, `MODE_PAPER` or `MODE_POSITION`.
    aa : ArmBatch
        The arms (`arm_arrays`).
    arm : array_like of int, shape (M,)
        The index into `aa` of each target's arm.
    T : numpy.ndarray, shape (M, 4, 4)
        Target poses in the arms' base frame (m).
    keys : array_like of uint64, shape (M,)
        The keys of each target's random starts (`pose_keys`).
    qexp : array_like, shape (M, S, n)
        Explicit starts (rad or m per joint), the first `nexp[i]` of row `i` tried in order.
    nexp : array_like of int, shape (M,)
    k_first, k_last, ilimit, rlimit, tol, confirm_tol, gtol, free_pass :
        The fields of `wsmap.kinematics.lm_compiled.LMSettings` of the same names.
    lam : float
        Its field `lam0`, the initial damping.
    **more
        Any other field of `LMSettings`, by name; a field not named takes its default. So a new
        LM setting (a field with its default) reaches both kernels with no edit here.

    Returns
    -------
    q : numpy.ndarray, shape (M, n)
    ok : numpy.ndarray of bool, shape (M,)
    iterations : numpy.ndarray of int64, shape (M,)
    residual : numpy.ndarray, shape (M,)
    start : numpy.ndarray of int64, shape (M,)
        See `wsmap.kinematics.lm_compiled.run_targets`.

    Raises
    ------
    TypeError
        A name in `more` that is not a field of `LMSettings` (before the kernel runs).
    """
    settings = lm_settings(mode=mode, k_first=k_first, k_last=k_last, ilimit=ilimit, rlimit=rlimit, tol=tol, lam0=lam,
                           gtol=gtol, confirm_tol=confirm_tol, free_pass=free_pass, **more)
    coupled = isinstance(aa, CoupledArms)
    M, n = len(T), (aa.coupled.slide.shape[0] if coupled else aa.axes.shape[0])
    out = Answers(*unsolved(M, n))
    if M:
        targets = Targets(
            arm=np.ascontiguousarray(arm, dtype=np.int64), Rt=np.ascontiguousarray(T[:, :3, :3], dtype=np.float64),
            pt=np.ascontiguousarray(T[:, :3, 3], dtype=np.float64), keys=np.ascontiguousarray(keys, dtype=np.uint64),
            qexp=np.ascontiguousarray(qexp, dtype=np.float64), nexp=np.ascontiguousarray(nexp, dtype=np.int64))
        if not coupled and lm_lanes.runs_on_lanes(n):
            # the lane kernel picks its threads itself (a thread per two blocks of lanes at least,
            # lm_lanes.threads_for) and starts them in C++: numba's count is left alone
            lm_lanes.run_targets(KernelCall(targets, aa, settings, out))
            return tuple(out)
        with lm_compiled.threads_for(M, 64):
            if coupled:  # the lane kernel and lm_compiled take one variable per joint: coupled arms run here
                lm_coupled.run_targets(KernelCall(targets, aa.arms, settings, out), aa.coupled)
            else:
                lm_compiled.run_targets(KernelCall(targets, aa, settings, out))
    return tuple(out)
