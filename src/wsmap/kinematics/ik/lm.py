"""The paper's Levenberg–Marquardt inverse kinematics (Appendix), batched over targets.

One compiled loop per target (`wsmap.kinematics.lm_compiled`, `MODE_PAPER`), the targets
spread over threads; `wsmap.kinematics.ik.lm_reference.ikine_LM_reference` is the same
iteration in numpy, the reference the tests compare it with.
"""

from __future__ import annotations

import numpy as np

from ..chain import as_chain
from ..dh import DHRobot
from ..lm_compiled import MODE_PAPER
from ..transforms import check_rigid
from .kernel import arm_arrays, run_compiled
from .solution import MIN_TOL, IKSolution, failure_reasons
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap._typing import ArrayLike
    from wsmap.kinematics.chain import Arm

__all__ = ["ikine_LM"]


def _run_chunks(robot, shape, Tf, qf, ilimit, rlimit, tol, lam, chunk, progress):
    """The paper's LM on the flat targets `Tf` (count, 4, 4) from `qf` (count, n), `chunk` at a
    time, the arms of `robot` broadcast to `shape`: `(q, converged, iterations, residual)` flat."""
    count, n = len(Tf), robot.n
    q_out = np.empty((count, n))
    ok_out = np.zeros(count, dtype=bool)
    it_out = np.zeros(count, dtype=np.int64)
    res_out = np.empty(count)
    batch = robot.batch_shape
    aa = arm_arrays(as_chain(robot).replace(qlim=None))
    arm_of = np.broadcast_to(np.arange(int(np.prod(batch, dtype=np.int64))).reshape(batch), shape).reshape(-1)
    ones = np.ones(min(chunk, count), dtype=np.int64)
    no_keys = np.zeros(min(chunk, count), dtype=np.uint64)
    for s in range(0, count, chunk):
        sl = slice(s, min(s + chunk, count))
        m = sl.stop - sl.start
        q_out[sl], ok_out[sl], it_out[sl], res_out[sl], _ = run_compiled(
            MODE_PAPER, aa, arm_of[sl], Tf[sl], no_keys[:m], qf[sl][:, None, :], ones[:m], 0, 0, ilimit, rlimit,
            tol, lam, 1.0)
        if progress is not None:
            progress(m)
    return q_out, ok_out, it_out, res_out


def ikine_LM(
    robot: Arm,
    T: ArrayLike,
    q0: ArrayLike | None = None,
    *,
    ilimit: int = 500,
    rlimit: int = 100,
    tol: float = 1e-10,
    lam: float = 0.1,
    check_limits: bool = False,
    chunk: int = 65536,
    progress: bool | None = None,
) -> IKSolution:
    """Levenberg–Marquardt inverse kinematics (the paper's Appendix), vectorised over targets.

    For each target pose the iteration is::

        e  = pose_error(fkine(q), T)                    # 6-vector, base frame
        dq = (JᵀJ + λ² I)⁻¹ Jᵀ e                        # J = jacob0(q)
        accept if |e(q + dq)| < |e(q)|:  q += dq, λ /= 2, rejections = 0
        else                             λ *= 2, rejections += 1, fail when rejections > rlimit

    stopping with success once `|e| <= tol` and with failure after `ilimit` iterations.
    Every target carries its own `λ` and counters.

    Parameters
    ----------
    robot : DHRobot
        Its batch shape broadcasts with the targets' batch shape (the paper's arms; for a chain use
        `wsmap.kinematics.ik.search.ikine_search`).
    T : array_like, shape (..., 4, 4)
        Target tool poses in the base frame.
    q0 : array_like, shape (n,) or (..., n), optional
        Start configurations (default zeros, the paper's).
    ilimit, rlimit, tol, lam :
        Iteration limit, consecutive-rejection limit, tolerance on the error norm, initial λ.
    check_limits : bool
        If True and the robot has joint limits, a converged solution outside them is a failure.
    chunk : int
        Targets solved together; bounds memory.
    progress : callable, optional
        Called with the number of targets finished after each chunk (e.g. `tqdm.update`).

    Returns
    -------
    `IKSolution` of the broadcast batch shape: `q` the last
    accepted iterate (rad; meaningful where `success`), `success` the error norm reached
    `tol` (and, with `check_limits`, `q` is inside the limits), `iterations` as the
    Appendix's loop counts them (1 for a start already on the target), `residual` the final error
    norm, `reason` `OUTSIDE_LIMITS` (converged outside the limits) or `NO_CONVERGENCE`;
    `start` None.
    """
    if not isinstance(robot, DHRobot):
        raise TypeError(f"ikine_LM takes a DHRobot (the paper's arms), got {type(robot).__name__}; "
                        "use wsmap.kinematics.ikine_search for a SerialChain")
    T = check_rigid("target poses", T)
    for label, v in (("ilimit", ilimit), ("rlimit", rlimit)):
        if int(v) != v or v < 0:
            raise ValueError(f"{label} must be a non-negative integer, got {v!r}")
    if not (tol > 0 and np.isfinite(tol)):
        raise ValueError(f"tol must be positive and finite, got {tol!r}")
    if tol < MIN_TOL:
        raise ValueError(f"tol must be at least {MIN_TOL:g} (float64 forward kinematics is exact to about 1e-16 per "
                         f"metre, so no pose meets a smaller one), got {tol!r}")
    if not (lam > 0 and np.isfinite(lam)):
        raise ValueError(f"lam must be positive and finite, got {lam!r}")
    n = robot.n
    q0 = np.zeros(n) if q0 is None else robot._check_q(q0)
    shape = np.broadcast_shapes(T.shape[:-2], robot.batch_shape, q0.shape[:-1])
    Tf = np.broadcast_to(T, shape + (4, 4)).reshape(-1, 4, 4)
    qf = np.broadcast_to(q0, shape + (n,)).reshape(-1, n)
    q_out, ok_out, it_out, res_out = _run_chunks(robot, shape, Tf, qf, ilimit, rlimit, tol, lam, chunk, progress)
    q_out = q_out.reshape(shape + (n,))
    converged = ok_out.reshape(shape)
    ok = converged
    if check_limits and robot.qlim is not None:
        ok = converged & robot.within_limits(q_out)
    return IKSolution(q_out, ok, it_out.reshape(shape), res_out.reshape(shape),
                      failure_reasons(ok, outside_limits=converged))
