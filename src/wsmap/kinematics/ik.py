"""Numerical inverse kinematics: the paper's Levenberg–Marquardt (Appendix), batched over targets.

Converged and failed targets leave the active set, so the cost of one iteration is proportional
to the number of targets still being solved (the kernel is :mod:`wsmap.kinematics.lm_kernel`).
"""

from __future__ import annotations

import numpy as np

from dataclasses import dataclass

from . import lm_kernel
from .transforms import check_rigid

__all__ = ["IKResult", "ikine_LM"]


@dataclass
class IKResult:
    """Result of a batched inverse-kinematics solve; every field has the targets' batch shape.

    q : (..., n) joint angles (rad), the last accepted iterate (meaningful where ``success``)
    success : (...,) bool, error norm reached the tolerance
    iterations : (...,) int, iterations used
    residual : (...,) float, final error norm
    """

    q: np.ndarray
    success: np.ndarray
    iterations: np.ndarray
    residual: np.ndarray


def ikine_LM(
    robot,
    T,
    q0=None,
    *,
    ilimit: int = 500,
    rlimit: int = 100,
    tol: float = 1e-10,
    lam: float = 0.1,
    check_limits: bool = False,
    chunk: int = 65536,
    progress=None,
    backend: str = "compiled",
) -> IKResult:
    """Levenberg–Marquardt inverse kinematics (the paper's Appendix), vectorised over targets.

    For each target pose the iteration is::

        e  = pose_error(fkine(q), T)                    # 6-vector, base frame
        dq = (JᵀJ + λ² I)⁻¹ Jᵀ e                        # J = jacob0(q)
        accept if |e(q + dq)| < |e(q)|:  q += dq, λ /= 2, rejections = 0
        else                             λ *= 2, rejections += 1, fail when rejections > rlimit

    stopping with success once ``|e| <= tol`` and with failure after ``ilimit`` iterations.
    Every target carries its own ``λ`` and counters; targets that stop leave the active set.

    Parameters
    ----------
    robot : DHRobot
        Its batch shape broadcasts with the targets' batch shape.
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
        Called with the number of targets finished after each chunk (e.g. ``tqdm.update``).
    backend : ``"compiled"`` (default; :mod:`.lm_compiled`, numba, one compiled loop per target on
        every thread) or ``"numpy"`` (:mod:`.lm_kernel`, the reference). The same iteration; answers
        agree up to the rounding of sin/cos.
    """
    from .search import _check_backend, arm_arrays, as_chain, run_compiled
    from .lm_compiled import MODE_PAPER

    _check_backend(backend)
    T = check_rigid("target poses", T)
    for label, v in (("ilimit", ilimit), ("rlimit", rlimit)):
        if int(v) != v or v < 0:
            raise ValueError(f"{label} must be a non-negative integer, got {v!r}")
    if not (tol > 0 and np.isfinite(tol)):
        raise ValueError(f"tol must be positive and finite, got {tol!r}")
    if not (lam > 0 and np.isfinite(lam)):
        raise ValueError(f"lam must be positive and finite, got {lam!r}")
    n = robot.n
    q0 = np.zeros(n) if q0 is None else robot._check_q(q0)

    shape = np.broadcast_shapes(T.shape[:-2], robot.batch_shape, q0.shape[:-1])
    count = int(np.prod(shape, dtype=np.int64))
    Tf = np.broadcast_to(T, shape + (4, 4)).reshape(-1, 4, 4)
    qf = np.broadcast_to(q0, shape + (n,)).reshape(-1, n)

    q_out = np.empty((count, n))
    ok_out = np.zeros(count, dtype=bool)
    it_out = np.zeros(count, dtype=np.int64)
    res_out = np.empty(count)
    if backend == "compiled":
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
    else:
        dh = np.broadcast_to(robot.dh, shape + (n, 3)).reshape(-1, n, 3)
    for s in range(0, count if backend == "numpy" else 0, chunk):
        sl = slice(s, min(s + chunk, count))
        q_out[sl], ok_out[sl], it_out[sl], res_out[sl] = lm_kernel.lm_chunk(
            dh[sl], Tf[sl], qf[sl], robot.tool, ilimit, rlimit, tol, lam
        )
        if progress is not None:
            progress(sl.stop - sl.start)

    q_out = q_out.reshape(shape + (n,))
    ok = ok_out.reshape(shape)
    if check_limits and robot.qlim is not None:
        ok = ok & robot.within_limits(q_out)
    return IKResult(q_out, ok, it_out.reshape(shape), res_out.reshape(shape))
