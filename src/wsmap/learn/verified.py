"""Verified queries: the morphology network's map of an arm, with every node it is unsure of decided
by the classical search.

The network (`wsmap.learn.morph_model`) answers every node of a grid at once, but an answer
near its decision boundary is a guess. `verified_morph_grid` sends those nodes to the classical map
(`wsmap.workspace.constant_orientation_map`: the closed form where the arm has one, else the
numerical search) and keeps the network's answer only where it is sure:

1. **Unsure by margin**: nodes whose logit lies within `margin` of the threshold's logit.
2. **The predicted boundary shell**: nodes within `shell` grid steps (26-neighbourhood) of a node
   the network answers the other way. The network's errors sit on the map's boundary (docs/morphologies.md),
   so the shell holds most of them even where the network is confident.
3. **Growing from corrections**: where the classical answer differs from the network's, the
   error may continue beyond what was checked, so the unchecked 26-neighbours of every corrected
   node are checked in the next round, until a round corrects nothing (or `max_rounds`).

A node the classical search decided has the classical answer (`VerifiedMap.verified`); every other
node has the network's. The result equals the classical map wherever the network's errors are
connected to its unsure nodes or its boundary, which is a bet on the network, not a proof: a
confident error away from any boundary would stay (`verify="all"` checks every predicted-reachable
node as well, so that no unverified node is reported reachable). The orientation, convention, box
and extrapolation rules are the model's (`predict_morph_map`).
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
        bool `(N,)`: the answer, classical where `verified`, the network's elsewhere.
    network : numpy.ndarray
        bool `(N,)`: the network's own answer at every node.
    verified : numpy.ndarray
        bool `(N,)`: the nodes the classical search decided.
    rounds : int
        Classical calls made (the first set and each round grown from corrections).
    method : str
        The classical method used (`"exact"` or `"numerical"`).
    """

    values: np.ndarray
    network: np.ndarray
    verified: np.ndarray
    rounds: int
    method: str

    @property
    def fraction_verified(self) -> float:
        """The share of the grid's nodes the classical search decided."""
        return float(self.verified.mean()) if self.verified.size else 0.0

    @property
    def corrected(self) -> int:
        """Nodes where the classical answer overruled the network's."""
        return int((self.values != self.network).sum())


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
    method, ik, collision : the classical map's (`constant_orientation_map`)
    threshold, allow_extrapolation : the network's (`predict_morph_map`)

    Returns
    -------
    VerifiedMap

    Raises
    ------
    ValueError
        For a bad setting, orientation, convention or grid, before any work;
        `ExtrapolationError` as `predict_morph_map`.
    """
    from ..workspace.grids import cartesian_grid, grid_counts
    from ..workspace.maps import constant_orientation_map, resolve_method

    _check(margin, shell, max_rounds, verify)
    counts = [int(c) for c in grid_counts(lo, hi, step)]
    x, nodes, logit_threshold = prepare_query(model, robot, cartesian_grid(lo, hi, step), None, None, threshold,
                                         allow_extrapolation)
    method = resolve_method(robot, method)
    with torch.no_grad():
        X = torch.as_tensor(x[None], dtype=torch.float32)
        logits = model.logits_at(X, torch.as_tensor(nodes, dtype=torch.float32))[0].numpy().astype(np.float64)
    network = logits > logit_threshold
    shape = (counts[2], counts[1], counts[0])
    vol = network.reshape(shape)
    todo = np.abs(logits - logit_threshold) < margin
    if shell > 0:
        # a node near one predicted the other way: the dilated sets of both answers overlap there
        todo |= (_dilate(vol, shell) & _dilate(~vol, shell)).ravel()
    if verify == "all":
        todo |= network
    values = network.copy()
    verified = np.zeros(len(nodes), dtype=bool)
    rpy = tuple(float(a) for a in model.rpy)
    rounds = 0
    while todo.any() and rounds < max_rounds:
        idx = np.flatnonzero(todo)
        values[idx] = constant_orientation_map(robot, nodes[idx], rpy, method=method, ik=ik, collision=collision)
        verified[idx] = True
        rounds += 1
        wrong = np.zeros(len(nodes), dtype=bool)
        wrong[idx] = values[idx] != network[idx]
        todo = _dilate(wrong.reshape(shape), 1).ravel() & ~verified
    return VerifiedMap(values=values, network=network, verified=verified, rounds=rounds, method=method)

