"""Verified queries: the morphology network's map of an arm, with every node it is unsure of decided
by the classical search.

The network (`wsmap.learn.morph_model`) answers every node of a grid at once, but an answer
near its decision boundary is a guess. `verified_morph_grid` decides those nodes classically and
keeps the network's answer only where it is sure, doing as little classical work as it can:

0. **A closed-form arm** (`method` resolves to `"exact"`) is mapped by its closed form at every
   node: that costs less than the network's own pass (2-7 ms against 50-130 ms for 29,791 nodes,
   docs/morphologies.md), so the network is not consulted (`VerifiedMap.network` is None).
1. **The sound filters first**: nodes the reach and joint-limit filters rule out
   (`wsmap.kinematics.ik.certificate.filter_certificate`, the pre-filters of the numerical search)
   are unreachable by proof; neither the network nor the search looks at them
   (`VerifiedMap.possible`). They are most of a box around the arm (the Panda: 27,600 of 29,791).
2. **Unsure by margin**: of the other nodes, those whose logit lies within `margin` of the
   threshold's (one batched network call over them).
3. **The predicted boundary shell**: nodes within `shell` grid steps (26-neighbourhood) of a node
   the network answers the other way (a node the filters rule out counts as answered unreachable).
   The network's errors sit on the map's boundary (docs/morphologies.md), so the shell holds most of
   them even where the network is confident.
4. **Growing from corrections**: where the classical answer differs from the network's, the
   error may continue beyond what was checked, so the unchecked 26-neighbours of every corrected
   node are checked in the next round, until a round corrects nothing (or `max_rounds`).

The checked nodes of a round are one call of the classical solver on those nodes alone (the
neighbour search, `wsmap.kinematics.ik.search.map_search`, with their grid neighbours among them),
each node of a later round started first from a solution of a neighbour an earlier round solved
(`q_init`), as the whole map's search would start it from its neighbours.

A node the classical search decided has the classical answer (`VerifiedMap.verified`); a node the
filters rule out is unreachable; every other node has the network's. The result equals the
classical map wherever the network's errors are connected to its unsure nodes or its boundary,
which is a bet on the network, not a proof: a confident error away from any boundary would stay
(`verify="all"` checks every predicted-reachable node as well, so that no unverified node is
reported reachable). The orientation, convention, box and extrapolation rules are the model's
(`predict_morph_map`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import torch

from .morph_model import MorphMapModel, prepare_query

if TYPE_CHECKING:
    from collections.abc import Callable, Mapping

    from wsmap._typing import ArrayLike

    from ..kinematics.chain import Arm
    from ..kinematics.ik.settings import SearchSettings

__all__ = ["VerifiedMap", "verified_morph_grid", "VERIFY_MARGIN", "VERIFY_SHELL"]

#: The default logit margin: a node whose logit is within this of the threshold's is checked
#: (`benchmarks/learn/bench_verified_queries.py` measures what it costs and what it catches).
VERIFY_MARGIN = 4.0
#: The default shell: nodes within this many grid steps of a node predicted the other way are checked.
VERIFY_SHELL = 1
_MODES = ("unsure", "all")


@dataclass(frozen=True)
class VerifiedMap:
    """A verified map of one arm on a grid (nodes x fastest, `wsmap.workspace.cartesian_grid`).

    Attributes
    ----------
    values : numpy.ndarray
        bool `(N,)`: the answer, classical where `verified`, False where not `possible`, the
        network's elsewhere.
    network : numpy.ndarray or None
        bool `(N,)`: the network's own answer at the `possible` nodes (False at the others, which
        it was not asked about); None for a closed-form arm, mapped without it (module notes).
    verified : numpy.ndarray
        bool `(N,)`: the nodes the classical search decided.
    possible : numpy.ndarray
        bool `(N,)`: the nodes the sound filters leave (the others are unreachable by proof).
    rounds : int
        Classical calls made (the first set and each round grown from corrections).
    method : str
        The classical method used (`"exact"` or `"numerical"`).
    """

    values: np.ndarray
    network: np.ndarray | None
    verified: np.ndarray
    possible: np.ndarray
    rounds: int
    method: str

    @property
    def fraction_verified(self) -> float:
        """The share of the grid's nodes the classical search decided."""
        return float(self.verified.mean()) if self.verified.size else 0.0

    @property
    def corrected(self) -> int:
        """Nodes where the classical answer overruled the network's (0 without the network)."""
        return 0 if self.network is None else int((self.values != self.network).sum())


def _dilate(volume: np.ndarray, steps: int) -> np.ndarray:
    """`volume` (bool, z y x) grown by `steps` grid steps in the 26-neighbourhood."""
    from scipy.ndimage import binary_dilation

    return binary_dilation(volume, structure=np.ones((3, 3, 3), dtype=bool), iterations=steps)


def _check(margin, shell, max_rounds, verify):
    if not (isinstance(margin, (int, float)) and not isinstance(margin, bool) and margin >= 0):
        raise ValueError(f"margin must be a non-negative number of logits, got {margin!r}")
    for name, v in (("shell", shell), ("max_rounds", max_rounds)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < (0 if name == "shell" else 1):
            raise ValueError(f"{name} must be an integer >= {0 if name == 'shell' else 1}, got {v!r}")
    if verify not in _MODES:
        raise ValueError(f"verify must be one of {', '.join(map(repr, _MODES))}, got {verify!r}")


def _possible(robot, T: np.ndarray, settings) -> np.ndarray:
    """bool `(N,)`: the poses `T` `(N, 4, 4)` the numerical search's own sound pre-filters leave
    (the reach filter, then the limit filter where the search runs it), within the confirmation
    tolerance: a pose they rule out is unreachable in the classical map too."""
    from ..kinematics import as_chain
    from ..kinematics.ik.reach_filter import limit_filter, reach_filter
    from ..kinematics.ik.settings import FK_CONFIRM_TOL

    chain = as_chain(robot)
    tol = max(FK_CONFIRM_TOL, float(getattr(settings, "confirm_tol", None) or 0.0))
    possible = np.asarray(reach_filter(chain, T, tol), dtype=bool).copy()
    if chain.qlim is not None and getattr(settings, "joint_limits", True) is not False:
        idx = np.flatnonzero(possible)
        possible[idx] = limit_filter(chain, T[idx], tol)
    return possible


#: The 6 face and the 12 edge neighbours' offsets (dx, dy, dz); `_grid_neighbours_of` puts them in
#: the column order of the whole grid's table (`wsmap.workspace.grids.node_neighbours`), which
#: decides which neighbour's solution starts a node first.
_OFFSETS = [(dx, dy, dz) for dz in (-1, 0, 1) for dy in (-1, 0, 1) for dx in (-1, 0, 1)
            if abs(dx) + abs(dy) + abs(dz) in (1, 2)]


def _grid_neighbours_of(idx: np.ndarray, counts) -> np.ndarray:
    """int `(len(idx), 18)`: the grid indices of the face and edge neighbours of nodes `idx` of a
    grid of `counts` `(nx, ny, nz)` nodes (x fastest), -1 off the grid; index arithmetic on the
    subset alone."""
    nx, ny, nz = counts
    i, j, k = idx % nx, (idx // nx) % ny, idx // (nx * ny)
    order = sorted(_OFFSETS, key=lambda o: (abs(o[0]) + abs(o[1]) + abs(o[2]), o[0] + nx * o[1] + nx * ny * o[2]))
    out = np.empty((idx.size, len(order)), dtype=np.int64)
    for c, (dx, dy, dz) in enumerate(order):
        inside = (i + dx >= 0) & (i + dx < nx) & (j + dy >= 0) & (j + dy < ny) & (k + dz >= 0) & (k + dz < nz)
        out[:, c] = np.where(inside, idx + (dx + nx * dy + nx * ny * dz), -1)
    return out


class _Classical:
    """The classical solver on node subsets of one grid: each call solves the nodes `idx` alone, with
    their grid neighbours among them, started first from the solution of a neighbour an earlier call
    solved, and with the global seeding of the whole grid's map (the same sampled configurations)."""

    def __init__(self, robot, T, counts, method, ik, collision):
        from ..kinematics.ik.settings import as_settings
        from ..kinematics.ik.solvers import solver_for
        from ..workspace.maps import configuration_predicate

        self.robot, self.T, self.counts = robot, T, counts
        self.settings = None if method == "exact" else as_settings(ik)
        self.solver = solver_for(method, self.settings)
        self.valid = configuration_predicate(robot, collision)
        self.solver.check(robot, self.settings, self.valid)
        self.n = robot.n
        self.q = np.full((len(T), self.n), np.nan)  # solutions found so far
        self.neighbours = getattr(self.solver, "neighbours", False)

    def _settings_for(self, size: int):
        """The settings for a call on `size` nodes: global seeding samples as many configurations
        as the whole grid's map does (`fk_seeds.sample_count` of the whole grid), so that a node
        gets the starts it would get there."""
        from ..kinematics.ik.fk_seeds import sample_count

        s = self.settings
        if s is None or not getattr(s, "fk_seeds", 0) or s.solver != "search":
            return s
        whole = sample_count(s.fk_seeds, len(self.T))
        # per_node·size rounds up to the same power of two: in (whole/2, whole]
        return s.replace(fk_seeds=max(1, whole // max(size, 1)))

    def solve(self, idx: np.ndarray) -> np.ndarray:
        """bool `(len(idx),)`: the classical answer at grid nodes `idx`."""
        nb = q_init = None
        if self.neighbours:
            full = _grid_neighbours_of(idx, self.counts)
            pos = np.full(len(self.T), -1, dtype=np.int64)
            pos[idx] = np.arange(idx.size)
            nb = np.where(full >= 0, pos[np.maximum(full, 0)], -1)
            # the first neighbour (face neighbours first) that an earlier call solved starts the node
            seeded = (full >= 0) & np.isfinite(self.q[np.maximum(full, 0), 0])
            if seeded.any():
                first = np.argmax(seeded, axis=1)
                q_init = np.where(seeded.any(axis=1)[:, None], self.q[full[np.arange(idx.size), first]], np.nan)
        sol = self.solver.solve(self.robot, self.T[idx], self._settings_for(idx.size), self.valid, neighbours=nb,
                                q_init=q_init)
        ok = np.asarray(sol.success, dtype=bool).reshape(-1)
        self.q[idx[ok]] = np.asarray(sol.q).reshape(-1, self.n)[ok]
        return ok


def _shell(network: np.ndarray, possible: np.ndarray, shape, steps: int) -> np.ndarray:
    """bool `(N,)`: the `possible` nodes within `steps` grid steps (26-neighbourhood) of a node
    answered the other way. Computed in the box of the possible nodes grown by `steps` (clipped to
    the grid), which holds every node within `steps` of them: the same as on the whole grid."""
    out = np.zeros(network.size, dtype=bool)
    where = np.argwhere(possible.reshape(shape))
    if not where.size:
        return out
    box = tuple(slice(max(a - steps, 0), min(b + steps + 1, n))
                for a, b, n in zip(where.min(axis=0), where.max(axis=0), shape))
    vol = network.reshape(shape)[box]
    # the dilated sets of both answers overlap where a node is near one answered the other way
    out.reshape(shape)[box] = _dilate(vol, steps) & _dilate(~vol, steps)
    return out & possible


def verified_morph_grid(model: MorphMapModel, robot: Arm, lo: float | ArrayLike, hi: float | ArrayLike,
                        step: float | ArrayLike, *, margin: float = VERIFY_MARGIN, shell: int = VERIFY_SHELL,
                        max_rounds: int = 8, verify: str = "unsure", method: str = "auto",
                        ik: SearchSettings | Mapping | None = None, collision: Callable | None = None,
                        threshold: float | None = None, allow_extrapolation: bool = False) -> VerifiedMap:
    """The morphology model's map of `robot` on the grid `cartesian_grid(lo, hi, step)` (m, base
    frame, x fastest) at the model's orientation, its unsure nodes decided by the classical search
    (module notes).

    Parameters
    ----------
    model : MorphMapModel
        The network (`wsmap.learn.morph_model.load_morph_model`).
    robot : one `DHRobot` or `SerialChain` in the model's range
    lo, hi, step : the grid (m; scalars or 3-tuples)
    margin : float
        Logits around the threshold's within which a node is checked.
    shell : int
        Grid steps around the predicted boundary within which a node is checked (0: none).
    max_rounds : int
        Classical calls at most (the first, then the rounds grown from corrections).
    verify : str
        `"unsure"` (the above) or `"all"` (also every node the network calls reachable).
    method, ik, collision : the classical map's (`constant_orientation_map`); a closed-form arm
        (`method` `"auto"` or `"exact"`) is mapped by its closed form alone, without the network
    threshold, allow_extrapolation : the network's (`predict_morph_map`; not read for a
        closed-form arm)

    Returns
    -------
    VerifiedMap

    Raises
    ------
    ValueError
        For a bad setting or grid, before any work; `ExtrapolationError` as `predict_morph_map`
        where the network is consulted (not for a closed-form arm).
    """
    from ..workspace.grids import cartesian_grid, grid_counts
    from ..workspace.maps import constant_orientation_map, resolve_method, target_poses

    _check(margin, shell, max_rounds, verify)
    counts = [int(c) for c in grid_counts(lo, hi, step)]
    grid = cartesian_grid(lo, hi, step)
    method = resolve_method(robot, method)
    rpy = tuple(float(a) for a in model.rpy)
    if method == "exact":
        # the closed form at every node: its answer is the classical map's, and it costs less than
        # the network's pass (the model's range and box do not matter then)
        values = constant_orientation_map(robot, grid, rpy, method=method, convention=model.convention,
                                          collision=collision)
        everywhere = np.ones(len(grid), dtype=bool)
        return VerifiedMap(values=values, network=None, verified=everywhere, possible=everywhere, rounds=1,
                           method=method)
    x, nodes, logit_threshold = prepare_query(model, robot, grid, None, None, threshold, allow_extrapolation)
    N = len(nodes)
    T = target_poses(nodes, rpy, model.convention)
    classical = _Classical(robot, T, counts, method, ik, collision)
    possible = _possible(robot, T, classical.settings)
    where = np.flatnonzero(possible)
    logits = np.full(N, -np.inf)
    if where.size:
        with torch.no_grad():
            X = torch.as_tensor(x[None], dtype=torch.float32)
            logits[where] = model.logits_at(X, torch.as_tensor(nodes[where], dtype=torch.float32))[0].numpy()
    network = logits > logit_threshold
    shape = (counts[2], counts[1], counts[0])
    todo = np.abs(logits - logit_threshold) < margin
    if shell > 0:
        # a node near one predicted the other way: the dilated sets of both answers overlap there
        todo |= _shell(network, possible, shape, shell)
    if verify == "all":
        todo |= network
    todo &= possible
    values = network.copy()
    verified = np.zeros(N, dtype=bool)
    rounds = 0
    while todo.any() and rounds < max_rounds:
        idx = np.flatnonzero(todo)
        values[idx] = classical.solve(idx)
        verified[idx] = True
        rounds += 1
        wrong = np.zeros(N, dtype=bool)
        wrong[idx] = values[idx] != network[idx]
        todo = _dilate(wrong.reshape(shape), 1).ravel() & ~verified & possible
    return VerifiedMap(values=values, network=network, verified=verified, possible=possible, rounds=rounds,
                       method=method)
