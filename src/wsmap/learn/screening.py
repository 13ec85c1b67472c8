"""Catalogue screening: rank many arms for a set of tool-down targets, the best decided by the
classical map, the others ruled out by upper bounds on their coverage.

A study asks which arm of a catalogue reaches most of its targets. The classical answer maps every
arm at every target (`wsmap.workspace.constant_orientation_map`: the closed form where the arm
has one, else the numerical search). `screen_arms` maps only the arms that could still enter the
ranking, best-first by an upper bound on each arm's coverage:

1. **A sound bound**: the share of the targets that the reach filter
   (`wsmap.kinematics.ik.reach_filter.reach_filter`: the wrist point beyond the links' reach, or
   outside the set the joints before it sweep it through) leaves possible. No configuration
   reaches a target it rules out, so the classical coverage never exceeds it. Cheap (about a
   millisecond per arm at 140 targets).
2. **The network's bound** (optional, `margin` finite): the share of the targets whose logit
   (`wsmap.learn.morph_model`, one batched pass over every arm and target) lies within `margin`
   of the threshold's or above. It is a bet on the network, not a proof: an arm the network
   underrates by more than `margin` logits at a target it reaches is bounded too low and can be
   missed.

An arm's bound is the smaller of the two. The arms are mapped in order of bound (high first), then
`cost` (low first), then index, and the screening stops as soon as `top` arms are mapped and the
`top`-th of them ranks at least as high as the next unmapped arm's bound would: no unmapped arm can
enter the ranking (the threshold algorithm of top-k retrieval). With the sound bound alone
(`margin=inf`, the default) the ranking returned is therefore the exhaustive classical ranking
itself, arm for arm; the network only makes the search shorter where it is trusted.

Targets are tool positions `(P, 3)` (m, the arms' base frame) at the model's orientation (tool down,
`T = transl(p)·Rx(π)`). Coverage is the share of the targets reached; ties are broken by `cost`
(lower first, e.g. the arm's total link length: the smallest arm that does the job) and then by
the arm's index. `benchmarks/learn/bench_screening.py` measures the recall and the time against the
exhaustive ranking.
"""

from __future__ import annotations

import math
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

__all__ = ["Screening", "screen_arms", "predicted_coverage", "coverage_bounds"]


@dataclass(frozen=True)
class Screening:
    """The outcome of `screen_arms`.

    Attributes
    ----------
    ranking : numpy.ndarray
        int `(k,)`: indices into the arms given, best first, among the arms mapped classically.
    coverage : numpy.ndarray
        `(k,)`: the classical coverage (share of the targets reached) of `ranking`'s arms.
    bound : numpy.ndarray
        `(B,)`: every arm's upper bound on its coverage (module notes), the order of the search.
    mapped : numpy.ndarray
        int `(C,)`: the arms mapped classically, in the order they were mapped.
    mapped_coverage : numpy.ndarray
        `(C,)`: their classical coverages.
    predicted : numpy.ndarray or None
        `(B,)`: the network's predicted coverage of every arm (`None` when the network was not
        consulted, `margin=inf`).
    complete : bool
        True when the search stopped because no unmapped arm could enter the ranking; False when
        `candidates` stopped it first (the ranking is then the best of the arms mapped).
    """

    ranking: np.ndarray
    coverage: np.ndarray
    bound: np.ndarray
    mapped: np.ndarray
    mapped_coverage: np.ndarray
    predicted: np.ndarray | None
    complete: bool


def _logits(model: MorphMapModel, arms: Sequence[Arm], targets: ArrayLike, allow_extrapolation: bool):
    """`(logits (B, P) float64, logit threshold)`: every arm checked against the model's range
    before any is evaluated (`predict_morph_map`'s errors), then one batched pass."""
    rows, points, logit_threshold = [], None, 0.0
    for arm in arms:
        x, points, logit_threshold = prepare_query(model, arm, targets, None, None, None, allow_extrapolation)
        rows.append(x)
    if not rows:
        raise ValueError("screen at least one arm, got none")
    with torch.no_grad():
        logits = model.logits_at(torch.as_tensor(np.stack(rows), dtype=torch.float32),
                                 torch.as_tensor(points, dtype=torch.float32)).numpy()
    return logits.astype(np.float64), logit_threshold


def predicted_coverage(model: MorphMapModel, arms: Sequence[Arm], targets: ArrayLike, *,
                       allow_extrapolation: bool = False) -> np.ndarray:
    """The network's coverage `(B,)` of `targets` `(P, 3)` (m, tool down) for each of `arms`: the
    share of targets whose probability exceeds the model's threshold. Every arm is checked against
    the model's range before any is evaluated (`predict_morph_map`'s errors)."""
    logits, logit_threshold = _logits(model, arms, targets, allow_extrapolation)
    return (logits > logit_threshold).mean(axis=1)


def coverage_bounds(arms: Sequence[Arm], targets: ArrayLike, rpy: ArrayLike, convention: str = "standard", *,
                    margin: float | None = None) -> np.ndarray:
    """Sound upper bounds `(B,)` on the coverage of `targets` `(P, 3)` (m, base frame) at the
    orientation `rpy` (rad, `constant_orientation_map`'s convention) for each of `arms`: the
    share of the targets the reach filter leaves possible (module notes). `margin` (m and rad,
    default the search's confirmation tolerance `FK_CONFIRM_TOL`): a pose this close to a
    reachable one is kept, so a solution confirmed within it is never ruled out."""
    from ..kinematics import as_chain
    from ..kinematics.ik.reach_filter import reach_filter
    from ..kinematics.ik.settings import FK_CONFIRM_TOL
    from ..workspace.maps import check_nodes, target_poses

    points = check_nodes("targets", targets)
    T = target_poses(points, rpy, convention)
    margin = FK_CONFIRM_TOL if margin is None else float(margin)
    out = np.empty(len(arms))
    for i, arm in enumerate(arms):
        out[i] = np.asarray(reach_filter(as_chain(arm), T, margin), dtype=bool).mean() if len(points) else 0.0
    return out


def _filter_margin(ik) -> float:
    """The reach filter's margin for the classical map's settings `ik` (checked here, before any
    work: a bad setting is the `ValueError` of `as_settings`): the confirmation tolerance, or the
    default one where the settings leave it unset (never smaller than the default)."""
    from ..kinematics.ik.settings import FK_CONFIRM_TOL, as_settings

    return max(FK_CONFIRM_TOL, float(as_settings(ik).confirm_tol or 0.0))


def _check(top, candidates, margin, cost, B):
    if isinstance(top, bool) or not isinstance(top, (int, np.integer)) or top < 1:
        raise ValueError(f"top must be a positive integer, got {top!r}")
    if candidates is not None:
        if isinstance(candidates, bool) or not isinstance(candidates, (int, np.integer)) or candidates < 1:
            raise ValueError(f"candidates must be a positive integer or None, got {candidates!r}")
        if candidates < top:
            raise ValueError(f"candidates ({candidates}) must be at least top ({top})")
    if isinstance(margin, bool) or not isinstance(margin, (int, float)) or not margin >= 0:
        raise ValueError(f"margin must be a non-negative number of logits (inf: the sound bound alone), got {margin!r}")
    cost = np.zeros(B) if cost is None else np.asarray(cost, dtype=np.float64)
    if cost.shape != (B,) or not np.all(np.isfinite(cost)):
        raise ValueError(f"cost must be {B} finite numbers (one per arm), got shape {cost.shape}")
    return cost


def screen_arms(model: MorphMapModel, arms: Sequence[Arm], targets: ArrayLike, *, top: int = 10,
                margin: float = math.inf, candidates: int | None = None, cost: ArrayLike | None = None,
                method: str = "auto", ik: SearchSettings | Mapping | None = None, collision: Callable | None = None,
                allow_extrapolation: bool = False) -> Screening:
    """Rank `arms` for `targets` (module notes): arms mapped classically best-first by an upper
    bound on their coverage until no unmapped arm can enter the best `top`.

    Parameters
    ----------
    model : MorphMapModel
        Its orientation and convention are the targets'; its network is consulted when `margin`
        is finite.
    arms : sequence of single arms (`DHRobot` or `SerialChain`), B of them
    targets : (P, 3) tool positions (m, base frame), tool down
    top : int
        Arms returned.
    margin : float
        Logits below the threshold's within which a target still counts towards an arm's bound;
        `inf` (default): the sound bound alone, and the ranking is the exhaustive one.
    candidates : int, optional
        Arms mapped classically at most (at least `top`); default: as many as the bounds need.
    cost : (B,) optional
        The tie-break between equal coverages, lower first (default: none, then the arm's index).
    method, ik, collision : the classical map's (`constant_orientation_map`)
    allow_extrapolation : the network's (`predict_morph_map`)

    Returns
    -------
    Screening

    Raises
    ------
    ValueError
        Bad `top`, `candidates`, `margin`, `cost`, `ik` or targets, before any work;
        `ExtrapolationError` for an arm outside the model's range (when the network is consulted).
    """
    from ..workspace.maps import check_nodes, constant_orientation_map

    arms = list(arms)
    B = len(arms)
    cost = _check(top, candidates, margin, cost, B)
    points = check_nodes("targets", targets)
    if not B:
        raise ValueError("screen at least one arm, got none")
    filter_margin = _filter_margin(ik)
    predicted = None
    bound = coverage_bounds(arms, points, model.rpy, model.convention, margin=filter_margin)
    if math.isfinite(margin):
        logits, logit_threshold = _logits(model, arms, points, allow_extrapolation)
        predicted = (logits > logit_threshold).mean(axis=1)
        bound = np.minimum(bound, (logits >= logit_threshold - margin).mean(axis=1))
    index = np.arange(B)
    order = np.lexsort((index, cost, -bound))
    limit = B if candidates is None else min(candidates, B)
    mapped, covered = [], []
    complete = True
    for i in order:
        if len(mapped) >= top:
            # the top-th mapped arm against the best any unmapped arm could be (they come in that order)
            kth = np.lexsort((mapped, cost[mapped], -np.asarray(covered)))[top - 1]
            j = mapped[kth]
            if (covered[kth], -cost[j], -j) >= (bound[i], -cost[i], -i):
                break
        if len(mapped) >= limit:
            complete = False
            break
        mapped.append(int(i))
        covered.append(float(constant_orientation_map(arms[i], points, model.rpy, method=method,
                                                      convention=model.convention, ik=ik,
                                                      collision=collision).mean()))
    mapped_a, covered_a = np.asarray(mapped, dtype=np.int64), np.asarray(covered)
    best = np.lexsort((mapped_a, cost[mapped_a], -covered_a))[:top]
    return Screening(ranking=mapped_a[best], coverage=covered_a[best], bound=bound, mapped=mapped_a,
                     mapped_coverage=covered_a, predicted=predicted, complete=complete)
