"""The IK solver interface: one protocol for every way a map decides which targets an arm reaches.

A solver answers, for arms (one, or a flat batch of `B`) and target poses `T` `(N, 4, 4)` shared
by them, which targets each arm reaches and with which joint solution, under `SearchSettings`
and an optional configuration predicate `accept` (collision-free, ...). The maps
(`wsmap.workspace.maps`), the orientation maps (`wsmap.workspace.reach`) and base placement
(`wsmap.workspace.placement`) ask `get_solver` (or `solver_for`) for one and call it; none of
them switches on a solver's name.

Each solver is one module of the plug-in folder `wsmap.kinematics.ik.solvers` that ends with
`SOLVERS.register(...)`; the folder discovers them (`wsmap._plugins.discover`) when
`wsmap.kinematics.ik` is imported, so a new solver is one new file there. The registry lives
here, beside the protocol, so that `SearchSettings` can ask a solver which fields it reads
without importing the solvers (which import the search, which imports the settings).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from types import MappingProxyType
from typing import TYPE_CHECKING, Protocol, runtime_checkable

import numpy as np

from ..._plugins import Registry
from ..dh import DHRobot
from .solution import IKSolution

if TYPE_CHECKING:  # names of the annotations only
    from ..chain import Arm

#: A configuration predicate, `accept(q)` with `q` `(M, n)` → bool `(M,)`.
Predicate = Callable[[np.ndarray], np.ndarray]

__all__ = ["Solver", "SOLVERS", "get_solver", "solver_for", "numerical_solvers", "per_node", "frozen"]


@runtime_checkable
class Solver(Protocol):
    """What every solver record is and does.

    Attributes
    ----------
    name : str
        The solver's name: `"closed_form"`, or a numerical one that `SearchSettings.solver` names.
    priority : int
        Its place in listings (lower first).
    numerical : bool
        Whether `SearchSettings` select it (the closed form is chosen by `method="exact"`).
    neighbours : bool
        Whether it reads the targets' neighbours (`solve(..., neighbours=)`, a grid's nodes).
    defaults : Mapping
        The `SearchSettings` fields it reads and their defaults (empty for the closed form).
    dropped : tuple of str
        Fields it accepts and ignores (a field outside `defaults` and `dropped` is refused).
    """

    name: str
    priority: int
    numerical: bool
    neighbours: bool
    defaults: Mapping
    dropped: tuple

    def __init__(self) -> None:
        """A solver takes no arguments: its record is its class's attributes."""

    def check_given(self, given: dict) -> None:
        """Raise a one-line `ValueError` for `SearchSettings` fields as given (None: not given)
        that the solver refuses beyond `defaults` and `dropped` (e.g. the paper's `starts`)."""

    def check(self, arms: Arm, settings: object, accept: Predicate | None) -> None:
        """Raise a one-line `ValueError` before any work if the solver cannot take `arms` or `accept`."""

    def solve(self, arms: Arm, T: np.ndarray, settings: object, accept: Predicate | None = None, *,
              neighbours: np.ndarray | None = None, q_init: np.ndarray | None = None,
              progress: Callable[[int], object] | None = None) -> IKSolution:
        """One answer per arm and target.

        Parameters
        ----------
        arms : DHRobot or SerialChain, one arm or a flat batch `(B,)`
        T : (N, 4, 4) target poses in the arms' base frame (m), shared by the arms
        settings : the `SearchSettings` of a numerical solver (None: its defaults; the closed form
            reads none; typed `object` here because the settings module imports this one)
        accept : optional predicate `accept(q)`, `q` `(M, n)` → bool `(M,)`: a solution it
            refuses does not count (one arm)
        neighbours : (N, K) node indices of each target's neighbours, -1 padding (solvers with
            `neighbours`)
        q_init : optional `(N, n)` starts tried first (the search), NaN rows where none
        progress : optional `progress(n)`, called with the number of targets settled

        Returns
        -------
        `IKSolution` of shape `(N,)` for one arm, `(B, N)` for a batch: `success` where a solution
        `accept` takes was found, `q` that solution (for the closed form, the first accepted branch,
        NaN elsewhere).
        """

    def reachable(self, arms: Arm, T: np.ndarray, settings: object, accept: Predicate | None = None, *,
                  neighbours: np.ndarray | None = None, q_init: np.ndarray | None = None,
                  progress: Callable[[int], object] | None = None) -> np.ndarray:
        """`solve(...).success`, through a faster path where the solver has one: bool `(N,)` or `(B, N)`."""


#: The registered solvers.
SOLVERS: Registry[Solver] = Registry("IK solver")


def get_solver(name: str) -> Solver:
    """The solver `name` (`ValueError` naming the known ones otherwise)."""
    return SOLVERS.get(name)


def numerical_solvers() -> tuple[str, ...]:
    """The names `SearchSettings.solver` takes, by priority (the first is the default)."""
    return tuple(s.name for s in SOLVERS.records() if s.numerical)


def solver_for(method: str, settings: object = None) -> Solver:
    """The solver of a map computed by `method` (`"exact"`: the closed form; `"numerical"`:
    `settings.solver`, default the search)."""
    if method == "exact":
        return get_solver("closed_form")
    if method != "numerical":
        raise ValueError(f"a solver is chosen for method 'exact' or 'numerical', got {method!r}")
    return get_solver("search" if settings is None else settings.solver)


def frozen(mapping: Mapping) -> Mapping:
    """A read-only copy of `mapping` (a solver's `defaults`)."""
    return MappingProxyType(dict(mapping))


def per_node(robot: DHRobot) -> DHRobot:
    """The same DH arms with a node axis inserted before the joints: batch `(..., 1)`, so that
    they broadcast against targets `(N, 4, 4)` into `(..., N)`."""
    qlim = robot.qlim
    if qlim is not None and qlim.ndim > 2:
        qlim = qlim[..., None, :, :]
    return DHRobot(robot.d[..., None, :], robot.a[..., None, :], robot.alpha[..., None, :], qlim=qlim, tool=robot.tool)
