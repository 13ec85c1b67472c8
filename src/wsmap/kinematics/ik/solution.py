"""The one answer type of every inverse-kinematics solver: `IKSolution`, with `IKReason`.

Every solver of `wsmap.kinematics.ik` (the closed forms, the paper's LM, the reachability
search) returns an `IKSolution` of batched arrays, as Robotics Toolbox's `IKSolution`
does for one target. The closed forms return every branch: their arrays carry a branch axis of
length 8 before the joints (see `wsmap.kinematics.ik.registry` for the branch numbering).
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

import numpy as np

__all__ = ["IKReason", "IKSolution", "MIN_TOL"]

#: The smallest tolerance on the pose error norm (m and rad) a numerical solver accepts. Float64
#: forward kinematics is exact to about 1e-16 per metre of reach, so a smaller tolerance is never
#: met: with `tol=1e-16` the Panda's 0.25 m constant map finds 106 of its 122 reachable nodes, with
#: `3e-17` none, silently. 1e-14 leaves a hundredfold margin for arms of a few metres.
MIN_TOL = 1e-14


class IKReason(IntEnum):
    """Why a target (or a closed-form branch) is not solved; the values of `IKSolution.reason`.

    `SOLVED` (0): solved (`success` is True exactly there).
    `OUT_OF_REACH` (1): proven out of reach: the closed form has no solution on this branch (the
    shoulder or the elbow cannot reach the point), or the search's sound pre-filter
    (`wsmap.kinematics.ik.reach_filter`) ruled the pose out without running LM.
    `OUTSIDE_LIMITS` (2): a configuration reaches the pose but lies outside the joint limits
    (a closed-form branch; `ikine_LM` with `check_limits`).
    `NO_CONVERGENCE` (3): the numerical iteration did not reach the tolerance (rejection or
    iteration limit, stagnation, a stationary point) from any start, or, in the search, no start's
    solution was confirmed by forward kinematics inside the limits.
    """

    SOLVED = 0
    OUT_OF_REACH = 1
    OUTSIDE_LIMITS = 2
    NO_CONVERGENCE = 3


@dataclass
class IKSolution:
    """Result of a batched inverse-kinematics solve; every field has the solve's batch shape `S`
    (the broadcast of the targets' and the arms' batch shapes, and for a closed form a last branch
    axis of 8).

    q : S + (n,) float64, joint coordinates (rad; m for prismatic joints): the solution where
        `success`; elsewhere the solver's best attempt (documented per solver; NaN where no
        attempt was made)
    success : S bool, the pose is reached (inside the limits where the solver honours them)
    iterations : S int64, LM iterations spent (over every start tried; 0 for a closed form)
    residual : S float64, the error norm `|e|` at `q` (m and rad) of the numerical solvers
        (`inf` where LM was not run); NaN for the closed forms, which do not evaluate it (exact up
        to rounding and their reach tolerance `atol`)
    reason : S int8, an `IKReason` value: 0 where `success`, else why not
    start : S int64 or None, the search's start that succeeded (0 = `q0`, `k` = random start
        `k`, `-2` a neighbour's solution in `map_search`,
        `-1` none); None for solvers without starts
    """

    q: np.ndarray
    success: np.ndarray
    iterations: np.ndarray
    residual: np.ndarray
    reason: np.ndarray
    start: np.ndarray | None = None


def failure_reasons(success, *, out_of_reach=None, outside_limits=None) -> np.ndarray:
    """`reason` (int8, the shape of `success`): `SOLVED` where `success`; elsewhere
    `OUT_OF_REACH` where `out_of_reach`, else `OUTSIDE_LIMITS` where `outside_limits`, else
    `NO_CONVERGENCE`. The masks broadcast with `success`; None means nowhere."""
    success = np.asarray(success, dtype=bool)
    reason = np.full(success.shape, IKReason.NO_CONVERGENCE, dtype=np.int8)
    if outside_limits is not None:
        reason[np.broadcast_to(outside_limits, success.shape)] = IKReason.OUTSIDE_LIMITS
    if out_of_reach is not None:
        reason[np.broadcast_to(out_of_reach, success.shape)] = IKReason.OUT_OF_REACH
    reason[success] = IKReason.SOLVED
    return reason
