"""The paper's numerical solver, `"paper"`: one Levenberg–Marquardt start from `q0` per target
(`wsmap.kinematics.ik.lm.ikine_LM`, DH arms, a converged solution outside the joint limits rejected
afterwards), as the paper's pipeline runs its maps."""

from __future__ import annotations

import numpy as np

from ...dh import DHRobot
from ..lm import ikine_LM
from ..settings import SearchSettings
from ..solution import IKSolution
from ..solver import SOLVERS, frozen, per_node

__all__ = ["PaperLM"]


class PaperLM:
    """The `Solver` `"paper"` (see the module notes): no predicate (one start cannot look for
    another solution); `chunk` targets per call (default 65536, 2048 with `progress`)."""

    name = "paper"
    priority = 40
    numerical = True
    neighbours = False
    defaults = frozen({"tol": 1e-10, "lam": 0.1, "q0": None, "ilimit": 500, "rlimit": 100, "chunk": None})
    #: the maps' `ik` dicts may carry a seed and `starts=1` (`SearchSettings` checks it is 1)
    dropped = ("seed", "starts")

    def check_given(self, given) -> None:
        if given.get("starts") not in (None, 1):
            raise ValueError(f"the paper's solver has one start (q0), got starts={given['starts']!r}; "
                             "use solver 'search'")

    def check(self, arms, settings, accept) -> None:
        if not isinstance(arms, DHRobot):
            raise ValueError("the paper's solver (ikine_LM) is for DHRobot arms; use solver 'search'")
        if accept is not None:
            raise ValueError("the paper's solver has one start and cannot look for another solution; collision= "
                             "needs solver 'search' or 'independent'")

    def solve(self, arms, T, settings=None, accept=None, *, neighbours=None, q_init=None, progress=None) -> IKSolution:
        self.check(arms, settings, accept)
        s = settings if settings is not None else SearchSettings(solver="paper")
        chunk = s.chunk if s.chunk is not None else (2048 if progress is not None else 65536)
        return ikine_LM(per_node(arms), T, s.q0_array, ilimit=s.ilimit, rlimit=s.rlimit, tol=s.tol, lam=s.lam,
                        check_limits=arms.qlim is not None, chunk=chunk, progress=progress)

    def reachable(self, arms, T, settings=None, accept=None, *, neighbours=None, q_init=None,
                  progress=None) -> np.ndarray:
        return self.solve(arms, T, settings, accept, progress=progress).success


SOLVER = SOLVERS.register(PaperLM())
