"""Scores of joint solutions, as ROS-Industrial REACH's evaluators score a reached target.

Each score maps joint solutions `q` `(M, n)` (rad, or m for a prismatic joint) of one arm to `(M,)`
float64, higher is better; `SCORES` names them for a study file. `combined` multiplies them, as
REACH's `MultiplicativeEvaluator` does.

* `manipulability` — Yoshikawa's `sqrt(det(J Jᵀ))` of the geometric Jacobian in the base frame
  (REACH's `ManipulabilityMoveIt`; m³ for a 6-joint arm's mixed linear/angular Jacobian);
* `joint_margin` — how far the joints are from their limits, in [0, 1]: the smallest over limited
  joints of `min(q - lo, hi - q) / ((hi - lo) / 2)`; 1 with every joint at the middle of its
  range (or no limited joint), 0 at a limit. REACH's `JointPenaltyMoveIt` penalises the same
  distance; this is its normalised form;
* `clearance` — REACH's `DistancePenaltyMoveIt`: `(d / threshold)^exponent` clipped to [0, 1], `d`
  (m) the smallest distance between the arm's links and the obstacles (the floor included) and
  between the link pairs the collision checker checks (non-adjacent links, by its allowed-collision
  matrix), by coal's distance query (`wsmap.collision.CollisionChecker.distance`; 0 in contact).
  The settings are REACH's demo's (`reach_ros` `demo/config/reach_study.yaml`): `threshold`
  `CLEARANCE_THRESHOLD` = 0.025 m, `exponent` `CLEARANCE_EXPONENT` = 2. REACH leaves the power
  unclipped (above 1 past the threshold); clipping keeps every score in [0, 1], so the product ranks
  a target by its worst factor rather than rewarding clearance beyond the threshold. It needs the
  collision checker and the base (`Score.needs_collision`; `score_values` passes them).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .reach import yoshikawa
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from collections.abc import Callable, Mapping

    from ..kinematics.chain import Arm

__all__ = ["Score", "SCORES", "manipulability", "joint_margin", "clearance", "world_frame_scene", "combined", "score_names",
           "score_values", "CLEARANCE_THRESHOLD", "CLEARANCE_EXPONENT"]

#: `clearance`'s distance threshold (m): at or beyond it the score is 1 (REACH's demo setting).
CLEARANCE_THRESHOLD = 0.025
#: `clearance`'s exponent (REACH's demo setting).
CLEARANCE_EXPONENT = 2.0


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


def world_frame_scene(scene) -> bool:
    """Whether a study checks `scene` from the arm's world pose (`CollisionChecker.at_bases`): it
    has world-frame obstacles, or a floor (a height in the world frame) and no base-frame
    obstacles (which move with the base, and which `at_bases` refuses)."""
    if scene is None:
        return False
    frames = {ob.frame for ob in scene.obstacles}
    return "world" in frames or (scene.floor is not None and "base" not in frames)


def clearance(robot: Arm, q, *, collision=None, base=None, threshold: float = CLEARANCE_THRESHOLD,
              exponent: float = CLEARANCE_EXPONENT) -> np.ndarray:
    """REACH's distance-to-collision penalty `(M,)` in [0, 1] of solutions `q` `(M, n)` (see the
    module notes): `min(1, (d / threshold)^exponent)`, `d` (m) the clearance of `collision`, a
    `wsmap.collision.CollisionChecker` of this arm. `base` `(4, 4)` is the arm's world pose: where
    the checker's scene has world-frame obstacles or a floor they are measured from it (as the study
    checks them, `world_frame_scene`, `CollisionChecker.at_bases`); otherwise `base` changes nothing.

    `ValueError` without a checker (or one with no `distance`), for a threshold or exponent that is
    not a positive finite number, or for `q` of the wrong shape.
    """
    q = _q(robot, q)
    if collision is None or not callable(getattr(collision, "distance", None)):
        raise ValueError("the clearance score needs the arm's collision checker (a study's collision: entry)")
    for name, v in (("threshold", threshold), ("exponent", exponent)):
        if isinstance(v, bool) or not isinstance(v, (int, float, np.number)) or not (np.isfinite(v) and v > 0):
            raise ValueError(f"clearance {name} must be a positive finite number, got {v!r}")
    world = world_frame_scene(getattr(collision, "scene", None))
    # the cap: past the threshold every distance scores 1, so coal need not measure it
    d = collision.distance(q, base if world and base is not None else None, cap=float(threshold))
    return np.clip((np.asarray(d, dtype=np.float64) / threshold) ** exponent, 0.0, 1.0)


@dataclass(frozen=True)
class Score:
    """A named score: `function(robot, q) -> (M,)`, what it measures, its unit; `needs_collision`:
    the function also takes the arm's collision checker and base (`collision=`, `base=`);
    `settings` its fixed parameters, for the study file's record."""

    name: str
    function: Callable
    description: str
    unit: str
    needs_collision: bool = False
    settings: dict = field(default_factory=dict)


SCORES: dict[str, Score] = {s.name: s for s in (
    Score("manipulability", manipulability, "Yoshikawa's sqrt(det(J J^T)), base-frame geometric Jacobian", "m^3"),
    Score("joint_margin", joint_margin, "smallest distance to a joint limit over half the joint's range", "1"),
    Score("clearance", clearance, "REACH's distance penalty: (d / threshold)^exponent clipped to [0, 1], d the "
          "smallest distance (m) between links and obstacles and between checked link pairs", "1",
          needs_collision=True, settings={"threshold_m": CLEARANCE_THRESHOLD, "exponent": CLEARANCE_EXPONENT}),
)}


def score_names() -> list[str]:
    """The names `SCORES` knows, in order."""
    return list(SCORES)


def score_values(name: str, robot: Arm, q, *, collision=None, base=None) -> np.ndarray:
    """Score `name` of `SCORES` `(M,)` for solutions `q` `(M, n)` of `robot` standing at `base`
    `(4, 4)` (world frame); `collision` (the arm's checker) goes to the scores that need it."""
    if name not in SCORES:
        raise ValueError(f"unknown score {name!r}; known: {', '.join(SCORES)}")
    score = SCORES[name]
    if score.needs_collision:
        return score.function(robot, q, collision=collision, base=base)
    return score.function(robot, q)


def combined(scores: Mapping[str, np.ndarray], size: int) -> np.ndarray:
    """The product `(size,)` of the scores (REACH's `MultiplicativeEvaluator`); 1 for no score."""
    out = np.ones(size)
    for values in scores.values():
        out = out * np.asarray(values, dtype=np.float64)
    return out
