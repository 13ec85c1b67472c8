"""Scores of joint solutions, as ROS-Industrial REACH's evaluators score a reached target.

Each score maps joint solutions `q` `(M, n)` (rad, or m for a prismatic joint) of one arm to `(M,)`
float64, higher is better; `SCORES` names them for a study file. `combined` multiplies them, as
REACH's `MultiplicativeEvaluator` does.

* `manipulability` — Yoshikawa's `sqrt(det(J Jᵀ))` of the geometric Jacobian in the base frame
  (REACH's `ManipulabilityMoveIt`; m³ for a 6-joint arm's mixed linear/angular Jacobian);
* `joint_margin` — how far the joints are from their limits, in [0, 1]: the smallest over limited
  joints of `min(q - lo, hi - q) / ((hi - lo) / 2)`; 1 with every joint at the middle of its
  range (or no limited joint), 0 at a limit. REACH's `JointPenaltyMoveIt` penalises the same
  distance; this is its normalised form.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .reach import yoshikawa
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from collections.abc import Callable, Mapping

    from ..kinematics.chain import Arm

__all__ = ["Score", "SCORES", "manipulability", "joint_margin", "combined", "score_names"]


def _q(robot: Arm, q) -> np.ndarray:
    q = np.asarray(q, dtype=np.float64)
    if q.ndim != 2 or q.shape[1] != robot.n:
        raise ValueError(f"joint solutions must have shape (M, {robot.n}), got {q.shape}")
    if not np.all(np.isfinite(q)):
        raise ValueError("joint solutions must be finite (a NaN row is an unreached target: score reached ones)")
    return q


def manipulability(robot: Arm, q) -> np.ndarray:
    """Yoshikawa's manipulability `sqrt(det(J Jᵀ))` `(M,)` of solutions `q` `(M, n)`, `J` the
    geometric Jacobian `(6, n)` in the base frame (linear rows in m/rad, angular rows unitless)."""
    q = _q(robot, q)
    return np.asarray(yoshikawa(robot.jacob0(q)), dtype=np.float64).reshape(len(q))


def joint_margin(robot: Arm, q) -> np.ndarray:
    """The joints' distance from their limits `(M,)` in [0, 1] (see the module notes)."""
    q = _q(robot, q)
    if robot.qlim is None:
        return np.ones(len(q))
    lim = np.asarray(robot.qlim, dtype=np.float64).reshape(robot.n, 2)
    limited = np.isfinite(lim).all(axis=1) & (lim[:, 1] > lim[:, 0])
    if not limited.any():
        return np.ones(len(q))
    lo, hi = lim[limited, 0], lim[limited, 1]
    ql = q[:, limited]
    margin = np.minimum(ql - lo, hi - ql) / ((hi - lo) / 2)
    return np.clip(margin.min(axis=1), 0.0, 1.0)


@dataclass(frozen=True)
class Score:
    """A named score: `function(robot, q) -> (M,)`, what it measures, its unit."""

    name: str
    function: Callable
    description: str
    unit: str


SCORES: dict[str, Score] = {s.name: s for s in (
    Score("manipulability", manipulability, "Yoshikawa's sqrt(det(J J^T)), base-frame geometric Jacobian", "m^3"),
    Score("joint_margin", joint_margin, "smallest distance to a joint limit over half the joint's range", "1"),
)}


def score_names() -> list[str]:
    """The names `SCORES` knows, in order."""
    return list(SCORES)


def combined(scores: Mapping[str, np.ndarray], size: int) -> np.ndarray:
    """The product `(size,)` of the scores (REACH's `MultiplicativeEvaluator`); 1 for no score."""
    out = np.ones(size)
    for values in scores.values():
        out = out * np.asarray(values, dtype=np.float64)
    return out
