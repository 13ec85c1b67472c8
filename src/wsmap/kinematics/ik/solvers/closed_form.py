"""The closed forms as a solver: every branch of the registered closed form that solves the arms
(`wsmap.kinematics.ik.registry.closed_form_for`), exact up to rounding; a target is reached when a
branch inside the joint limits, and accepted by the predicate, reaches it."""

from __future__ import annotations

import numpy as np

from ...dh import DHRobot
from ..registry import require_closed_form
from ..solution import IKReason, IKSolution, failure_reasons
from ..solver import SOLVERS, frozen, per_node

__all__ = ["ClosedFormSolver", "closed_form_reach"]


def _as_solved(arms):
    """The arms as the closed form takes them against `(N, 4, 4)` targets: a node axis for DH arms
    and batches (`per_node`), one `SerialChain` as it is."""
    return arms if arms.batch_shape == () and not isinstance(arms, DHRobot) else per_node(arms)


def _first_accepted(ok, q, accept):
    """Branch successes `ok` (..., 8) narrowed to the first branch `accept` takes: each branch asked
    only where no earlier branch was accepted (a pose needs one accepted branch)."""
    found = np.zeros(ok.shape[:-1], dtype=bool)
    for b in range(ok.shape[-1]):
        ask = ok[..., b] & ~found
        if ask.any():
            ok[..., b][ask] = np.asarray(accept(q[..., b, :][ask]), dtype=bool)
        found |= ok[..., b]
    return ok & (np.cumsum(ok, axis=-1) == 1)  # the first accepted branch (later ones were not asked)


def closed_form_reach(arms, T, accept=None, return_q=False):
    """Closed-form reachability of poses `T` (N, 4, 4) for arms (a batch `(B,)` or one): bool `(..., N)`.

    `accept` (a configuration predicate, one arm): a pose counts only with a branch it accepts;
    every branch is tried. `return_q` also returns an accepted branch's `q` `(..., N, n)` (the
    first accepted, NaN where none)."""
    reach, q, _ = _reach(arms, T, accept, return_q)
    return (reach, q) if return_q else reach


def _reach(arms, T, accept, return_q):
    """`(reach, q or None, branch reasons or None)` of `closed_form_reach`."""
    cf = require_closed_form(arms)
    robot = _as_solved(arms)
    if accept is None and not return_q:
        return cf.reachable(robot, T), None, None
    sol = cf.solve(robot, T)
    ok = np.array(sol.success, dtype=bool)
    q = sol.q
    if accept is not None and ok.any():
        ok = _first_accepted(ok, q, accept)
    reach = ok.any(axis=-1)
    if not return_q:
        return reach, None, sol.reason
    first = np.take_along_axis(q, ok.argmax(axis=-1)[..., None, None], axis=-2)[..., 0, :]
    return reach, np.where(reach[..., None], first, np.nan), sol.reason


class ClosedFormSolver:
    """The `Solver` of `method="exact"`: the registered closed forms (see the module notes)."""

    name = "closed_form"
    priority = 10
    numerical = False
    neighbours = False
    defaults = frozen({})
    dropped = ()

    def check_given(self, given) -> None:
        pass

    def check(self, arms, settings, accept) -> None:
        require_closed_form(arms)

    def solve(self, arms, T, settings=None, accept=None, *, neighbours=None, q_init=None, progress=None) -> IKSolution:
        """See `Solver.solve`: `iterations` 0, `residual` NaN (the closed forms do not evaluate it),
        `reason` `OUT_OF_REACH` where no branch reaches the pose, `OUTSIDE_LIMITS` where branches
        reach it only outside the limits, `NO_CONVERGENCE` where `accept` refused every branch
        inside them."""
        reach, q, branch = _reach(arms, T, accept, True)
        shape = reach.shape
        out_of_reach = np.all(branch == IKReason.OUT_OF_REACH, axis=-1)
        outside = np.any(branch == IKReason.OUTSIDE_LIMITS, axis=-1) & ~np.any(branch == IKReason.SOLVED, axis=-1)
        return IKSolution(q, reach, np.zeros(shape, dtype=np.int64), np.full(shape, np.nan),
                          failure_reasons(reach, out_of_reach=out_of_reach, outside_limits=outside), None)

    def reachable(self, arms, T, settings=None, accept=None, *, neighbours=None, q_init=None,
                  progress=None) -> np.ndarray:
        return closed_form_reach(arms, T, accept)


SOLVER = SOLVERS.register(ClosedFormSolver())
