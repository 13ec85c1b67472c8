"""The numerical solver `"independent"`: every target solved on its own by the multi-start search
(`wsmap.kinematics.ik.search.ikine_search`: `starts` starts, joint limits inside the search, every
success confirmed by forward kinematics), what `wsmap.workspace.reachable` runs."""

from __future__ import annotations

import numpy as np

from ...chain import as_chain
from ..search import ikine_search
from ..settings import DEFAULT_ILIMIT, DEFAULT_RLIMIT, DEFAULT_STARTS, FK_CONFIRM_TOL, SearchSettings
from ..solution import IKReason, IKSolution
from ..solver import SOLVERS, frozen

__all__ = ["IndependentSearch", "search_accepted"]

#: Rounds of `search_accepted` for the maps: a pose whose solutions `accept` refused is searched
#: again this many times with other seeds.
ACCEPT_ROUNDS = 4


def search_accepted(robot, T, accept, starts, seed, rounds, settings) -> IKSolution:
    """`ikine_search` keeping only solutions `accept` takes (one arm): an `IKSolution` of
    `T.shape[:-2]` broadcast with the arm's; refused poses are searched again with other seeds
    (`seed + 7919·r`), `rounds` times, each round's first start a random configuration inside the
    limits instead of `q0`. `settings`: `ikine_search`'s other keyword arguments (`q0` and
    `progress` are used by the first round only). `q` is NaN where no accepted
    solution was found; `iterations` add up over the rounds; `residual` is the accepted solution's
    (the first round's elsewhere); `reason` is the first round's where it found no solution,
    `NO_CONVERGENCE` where `accept` refused every one; `start` None."""
    res = ikine_search(robot, T, starts=starts, seed=seed, **settings)
    chain = as_chain(robot)
    shape = res.success.shape
    ok = res.success.reshape(-1).copy()
    q = res.q.reshape(-1, res.q.shape[-1]).copy()
    its, resid = res.iterations.reshape(-1).copy(), res.residual.reshape(-1).copy()
    Tf = np.broadcast_to(T, shape + (4, 4)).reshape(-1, 4, 4)
    settings = {k: v for k, v in settings.items() if k not in ("q0", "progress")}
    left = np.zeros(ok.shape, dtype=bool)
    if ok.any():
        idx = np.flatnonzero(ok)
        ok[idx] = np.asarray(accept(q[idx]), dtype=bool)
        left[idx] = ~ok[idx]
    for r in range(1, int(rounds) + 1):
        idx = np.flatnonzero(left)
        if not idx.size:
            break
        round_seed = None if seed is None else int(seed) + 7919 * r
        # a round's first start is a random configuration, not q0: from q0 the search lands on the
        # refused solution again and stops there, so the rounds found nothing new
        q0 = chain.random_q(len(idx), np.random.default_rng(round_seed))
        again = ikine_search(robot, Tf[idx], starts=starts, seed=round_seed, q0=q0, **settings)
        its[idx] += again.iterations
        good = again.success.copy()
        if good.any():
            good[good] = np.asarray(accept(again.q[good]), dtype=bool)
        ok[idx[good]] = True
        q[idx[good]] = again.q[good]
        resid[idx[good]] = again.residual[good]
        left[idx[good]] = False
    q[~ok] = np.nan
    reason = np.where(ok, IKReason.SOLVED, np.where(res.success.reshape(-1), IKReason.NO_CONVERGENCE,
                                                    res.reason.reshape(-1))).astype(np.int8)
    return IKSolution(q.reshape(shape + (q.shape[-1],)), ok.reshape(shape), its.reshape(shape), resid.reshape(shape),
                      reason.reshape(shape), None)


class IndependentSearch:
    """The `Solver` `"independent"` (see the module notes); `chunk` targets per call (default
    16384, 2048 with `progress`); with `accept`, one arm (`search_accepted`, 4 rounds)."""

    name = "independent"
    priority = 30
    numerical = True
    neighbours = False
    defaults = frozen({"tol": 1e-10, "lam": 0.1, "q0": None, "starts": DEFAULT_STARTS, "seed": 0,
                       "ilimit": DEFAULT_ILIMIT, "rlimit": DEFAULT_RLIMIT, "joint_limits": True,
                       "confirm_tol": FK_CONFIRM_TOL, "position_only": False, "chunk": None, "kernel": ()})
    dropped = ()

    def check_given(self, given) -> None:
        pass

    def check(self, arms, settings, accept) -> None:
        if accept is not None and arms.batch_shape != ():
            raise ValueError(f"collision= checks one arm's configurations, got a batch of arms {arms.batch_shape}")

    @staticmethod
    def _keywords(s: SearchSettings, progress):
        kw = dict(q0=s.q0_array, tol=s.tol, ilimit=s.ilimit, rlimit=s.rlimit, lam=s.lam, joint_limits=s.joint_limits,
                  confirm_tol=s.confirm_tol, position_only=s.position_only, kernel=dict(s.kernel))
        if s.chunk is not None or progress is not None:
            kw["chunk"] = s.chunk if s.chunk is not None else 2048
        if progress is not None:
            kw["progress"] = progress
        return kw

    def solve(self, arms, T, settings=None, accept=None, *, neighbours=None, q_init=None, progress=None) -> IKSolution:
        self.check(arms, settings, accept)
        s = settings if settings is not None else SearchSettings(solver="independent")
        kw = self._keywords(s, progress)
        if accept is not None:
            return search_accepted(arms, T, accept, s.starts, s.seed, ACCEPT_ROUNDS, kw)
        if arms.batch_shape == ():
            return ikine_search(arms, T, starts=s.starts, seed=s.seed, **kw)  # (N,)
        sol = ikine_search(arms, T[:, None], starts=s.starts, seed=s.seed, **kw)  # (N, arms) -> (arms, N)
        return IKSolution(np.swapaxes(sol.q, 0, 1), sol.success.T, sol.iterations.T, sol.residual.T, sol.reason.T,
                          sol.start.T)

    def reachable(self, arms, T, settings=None, accept=None, *, neighbours=None, q_init=None,
                  progress=None) -> np.ndarray:
        return self.solve(arms, T, settings, accept, progress=progress).success


SOLVER = SOLVERS.register(IndependentSearch())
