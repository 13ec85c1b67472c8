"""Catalogue screening: rank many arms for a set of tool-down targets by the morphology network's
predicted coverage, then decide the best candidates with the classical map.

A study asks which arm of a catalogue reaches most of its targets. The classical answer maps every
arm at every target; `screen_arms` asks the network for every arm at once (one encoder pass per
arm, one decoder pass per arm and target, batched), keeps the `candidates` arms it predicts best,
maps only those classically (`wsmap.workspace.constant_orientation_map`: the closed form where
the arm has one, else the numerical search) and ranks them by their classical coverage.

Which arms are candidates: the network's coverage is uncertain by a few per cent, and many arms of a
catalogue may cover every target, where the tie-break (`cost`) decides the ranking. So every arm
predicted within `slack` of the `top`-th best predicted coverage is a candidate first, cheapest
first; the rest follow by predicted coverage. The
returned ranking's coverages are classical, never predicted; what the network decides is only which
arms are not looked at, so an arm the network underrates can be missed
(`benchmarks/learn/bench_screening.py` measures the top-10 recall against the exhaustive ranking).

Targets are tool positions `(P, 3)` (m, the arms' base frame) at the model's orientation (tool down,
`T = transl(p)·Rx(π)`). Ties in coverage are broken by `cost` (lower first, e.g. the arm's total
link length: the smallest arm that does the job) and then by the arm's index.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import torch

from .morph_model import MorphMapModel, prepare_query

if TYPE_CHECKING:
    from collections.abc import Callable, Mapping, Sequence

    from wsmap._typing import ArrayLike

    from ..kinematics.chain import Arm
    from ..kinematics.ik.settings import SearchSettings

__all__ = ["Screening", "screen_arms", "predicted_coverage"]


@dataclass(frozen=True)
class Screening:
    """The outcome of `screen_arms`.

    Attributes
    ----------
    ranking : numpy.ndarray
        int `(k,)`: indices into the arms given, best first, among the candidates mapped classically.
    coverage : numpy.ndarray
        `(k,)`: the classical coverage (share of the targets reached) of `ranking`'s arms.
    predicted : numpy.ndarray
        `(B,)`: the network's predicted coverage of every arm.
    candidates : numpy.ndarray
        int `(C,)`: the arms mapped classically, in the order they were chosen (module notes).
    """

    ranking: np.ndarray
    coverage: np.ndarray
    predicted: np.ndarray
    candidates: np.ndarray


def predicted_coverage(model: MorphMapModel, arms: Sequence[Arm], targets: ArrayLike, *,
                       allow_extrapolation: bool = False) -> np.ndarray:
    """The network's coverage `(B,)` of `targets` `(P, 3)` (m, tool down) for each of `arms`: the
    share of targets whose probability exceeds the model's threshold. Every arm is checked against
    the model's range before any is evaluated (`predict_morph_map`'s errors)."""
    rows = []
    for arm in arms:
        x, points, logit_threshold = prepare_query(model, arm, targets, None, None, None, allow_extrapolation)
        rows.append(x)
    if not rows:
        raise ValueError("screen at least one arm, got none")
    with torch.no_grad():
        logits = model.logits_at(torch.as_tensor(np.stack(rows), dtype=torch.float32),
                                 torch.as_tensor(points, dtype=torch.float32)).numpy()
    return (logits > logit_threshold).mean(axis=1)


def _order(coverage: np.ndarray, cost: np.ndarray, index: np.ndarray) -> np.ndarray:
    """Positions sorting by coverage (high first), then cost (low first), then index."""
    return np.lexsort((index, cost, -coverage))


def screen_arms(model: MorphMapModel, arms: Sequence[Arm], targets: ArrayLike, *, top: int = 10,
                candidates: int = 50, cost: ArrayLike | None = None, slack: float = 0.1, method: str = "auto",
                ik: SearchSettings | Mapping | None = None, collision: Callable | None = None,
                allow_extrapolation: bool = False) -> Screening:
    """Rank `arms` for `targets` (module notes): the `candidates` arms of the highest predicted
    coverage are mapped classically and the best `top` of them returned.

    Parameters
    ----------
    model : MorphMapModel
    arms : sequence of single arms (`DHRobot` or `SerialChain`), B of them
    targets : (P, 3) tool positions (m, base frame), tool down
    top : int
        Arms returned.
    candidates : int
        Arms mapped classically (at least `top`; all of them when there are fewer arms).
    cost : (B,) optional
        The tie-break between equal coverages, lower first (default: none, then the arm's index).
    slack : float
        Arms predicted within this share of the targets of the `top`-th best predicted coverage are
        candidates first, by `cost` (module notes); 0 orders the candidates by predicted coverage
        alone.
    method, ik, collision : the classical map's (`constant_orientation_map`)
    allow_extrapolation : the network's (`predict_morph_map`)

    Returns
    -------
    Screening

    Raises
    ------
    ValueError
        Bad `top`, `candidates`, `cost` or targets, before any work; `ExtrapolationError` for an
        arm outside the model's range.
    """
    from ..workspace.maps import constant_orientation_map

    arms = list(arms)
    for name, v in (("top", top), ("candidates", candidates)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
            raise ValueError(f"{name} must be a positive integer, got {v!r}")
    if candidates < top:
        raise ValueError(f"candidates ({candidates}) must be at least top ({top})")
    if isinstance(slack, bool) or not isinstance(slack, (int, float)) or not 0 <= slack <= 1:
        raise ValueError(f"slack must be a share of the targets in [0, 1], got {slack!r}")
    B = len(arms)
    cost = np.zeros(B) if cost is None else np.asarray(cost, dtype=np.float64)
    if cost.shape != (B,) or not np.all(np.isfinite(cost)):
        raise ValueError(f"cost must be {B} finite numbers (one per arm), got shape {cost.shape}")
    predicted = predicted_coverage(model, arms, targets, allow_extrapolation=allow_extrapolation)
    points = np.asarray(targets, dtype=np.float64)
    index = np.arange(B)
    by_prediction = _order(predicted, cost, index)
    cutoff = predicted[by_prediction[min(top, B) - 1]] - slack
    near = index[predicted >= cutoff - 1e-12]
    # the arms near the top by cost, then the others by predicted coverage
    chosen = np.concatenate([near[_order(np.zeros(len(near)), cost[near], near)],
                             by_prediction[~np.isin(by_prediction, near)]])
    chosen = chosen[:min(candidates, B)]
    coverage = np.array([constant_orientation_map(arms[i], points, model.rpy, method=method, ik=ik,
                                                  collision=collision).mean() for i in chosen])
    best = _order(coverage, cost[chosen], chosen)[:top]
    return Screening(ranking=chosen[best], coverage=coverage[best], predicted=predicted, candidates=chosen)
