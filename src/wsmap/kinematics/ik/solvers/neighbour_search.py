"""The maps' default numerical solver, `"search"`: every node started from its neighbours'
solutions (`wsmap.kinematics.ik.search.map_search`, on the compiled LM kernel the kernel choice
picks), any arm, joint limits inside the search, every success confirmed by forward kinematics."""

from __future__ import annotations

import numpy as np

from ..search import map_search
from ..settings import FK_CONFIRM_TOL, MAP_SETTINGS, SearchSettings
from ..solution import IKSolution
from ..solver import SOLVERS, frozen

__all__ = ["NeighbourSearch"]


class NeighbourSearch:
    """The `Solver` `"search"` (see the module notes); `neighbours` is required."""

    name = "search"
    priority = 20
    numerical = True
    neighbours = True
    defaults = frozen({"tol": 1e-10, "lam": 0.1, "q0": None, **MAP_SETTINGS, "seed": 0, "joint_limits": True,
                       "confirm_tol": FK_CONFIRM_TOL, "limit_bound": True, "accept_retry": 16,
                       "position_only": False, "kernel": ()})
    #: the maps' `ik` dicts always carried `chunk`, which splits no work here
    dropped = ("chunk",)

    def check_given(self, given) -> None:
        pass

    def check(self, arms, settings, accept) -> None:
        if accept is not None and not callable(accept):
            raise TypeError(f"accept must be a configuration predicate (callable), got {type(accept).__name__}")

    def solve(self, arms, T, settings=None, accept=None, *, neighbours=None, q_init=None, progress=None) -> IKSolution:
        if neighbours is None:
            raise ValueError("the solver 'search' starts nodes from their neighbours: give neighbours (N, K)")
        return map_search(arms, T, neighbours, settings if settings is not None else SearchSettings(),
                          q_init=q_init, progress=progress, accept=accept)

    def reachable(self, arms, T, settings=None, accept=None, *, neighbours=None, q_init=None,
                  progress=None) -> np.ndarray:
        return self.solve(arms, T, settings, accept, neighbours=neighbours, q_init=q_init, progress=progress).success


SOLVER = SOLVERS.register(NeighbourSearch())
