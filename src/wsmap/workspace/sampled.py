"""Maps from forward kinematics alone: sample joint configurations, keep the poses near the map's
orientation, mark the grid cell each one lands in.

This is how sampling-based reachability maps are made (RM4D's construction; the experience RAM,
"Reachability Across Morphologies", trains its one network on): no inverse kinematics, one
forward-kinematics pass per sample. It costs little per arm and needs no solver, but it is an
approximation both ways against the exact map of `wsmap.workspace.constant_orientation_map`:

* a cell counts as reachable when some sample's flange lands in it (within half a step of the node
  on every axis) with its rotation within `angle_tol` of the map's: positions near the border
  that are reached only at another orientation come in (false positives, fewer as `angle_tol`
  shrinks);
* a cell no sample landed in counts as unreachable: the share of configurations that keep the tool
  within `angle_tol` of one orientation is about `(angle_tol - sin angle_tol) / pi` (0.34 % at
  0.4 rad), so thin parts of the map are missed unless `samples` is large (false negatives).

The project's own labels come from the map search (exact up to the solver's tolerance); this module
is the baseline those labels are measured against (`wsmap.learn.morph_model`).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..kinematics.chain import as_chain
from ..kinematics.transforms import rpy2r
from .grids import grid_counts
from .maps import CONVENTIONS

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap.kinematics.chain import Arm

__all__ = ["fk_sampled_maps", "orientation_share"]


def orientation_share(angle_tol: float) -> float:
    """The share of uniformly random rotations within `angle_tol` (rad) of a given one:
    `(angle_tol - sin angle_tol) / pi` (the Haar measure of a ball in SO(3))."""
    t = float(angle_tol)
    return (t - math.sin(t)) / math.pi


def _positive_int(name: str, value) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise ValueError(f"{name} must be a positive integer, got {value!r}")
    return int(value)


def fk_sampled_maps(robot: Arm, lo: float | ArrayLike, hi: float | ArrayLike, step: float | ArrayLike, rpy: ArrayLike, *,
                    convention: str = "standard", samples: int = 1_000_000, angle_tol: float = 0.4, seed: int = 0,
                    chunk: int = 4096) -> NDArray[np.bool_]:
    """The constant-orientation map of `robot` (one arm or a batch of arms sharing joint types:
    a `SerialChain` with a batch shape) on the grid `lo..hi` at
    `step` (m, scalars or 3-tuples; nodes in `cartesian_grid` order) from
    `samples` forward-kinematics samples per arm, uniform inside the joint limits.

    A node is `True` where some sample's tool pose has its rotation within `angle_tol` (rad)
    of `R = rpy2r(rpy)` and its position in the node's cell: the flange point `t` itself
    (`"standard"`: `T = transl(p)·R`) or `R^T t` (`"paper"`: `T = R·transl(p)`), within
    half a step of the node on every axis. Returns bool `(*batch, N)`. Deterministic in `seed`.
    """
    if convention not in CONVENTIONS:
        raise ValueError(f"unknown convention {convention!r}; choose one of {', '.join(CONVENTIONS)}")
    samples = _positive_int("samples", samples)
    chunk = _positive_int("chunk", chunk)
    angle_tol = float(angle_tol)
    if not (0.0 < angle_tol <= math.pi):
        raise ValueError(f"angle_tol must be in (0, pi] rad, got {angle_tol!r}")
    counts = np.array(grid_counts(lo, hi, step))
    lo3 = np.broadcast_to(np.asarray(lo, dtype=np.float64), (3,))
    step3 = np.broadcast_to(np.asarray(step, dtype=np.float64), (3,))
    if np.shape(rpy) != (3,):
        raise ValueError(f"rpy must be 3 angles (rad), got shape {np.shape(rpy)}")
    R = rpy2r(np.asarray(rpy, dtype=np.float64))
    chain = as_chain(robot)
    batch = chain.batch_shape
    n_arms = int(np.prod(batch)) if batch else 1
    n_nodes = int(np.prod(counts))
    hit = np.zeros((n_arms, n_nodes), dtype=bool)
    arm_index = np.broadcast_to(np.arange(n_arms).reshape(batch or ()), (1,) + tuple(batch))
    min_trace = 1.0 + 2.0 * math.cos(angle_tol)  # trace(R^T Rs) = 1 + 2 cos(angle)
    rng = np.random.default_rng(seed)
    done = 0
    while done < samples:
        c = min(chunk, samples - done)
        T = chain.fkine(chain.random_q(c, rng))  # (c, *batch, 4, 4)
        Rs, t = T[..., :3, :3], T[..., :3, 3]
        close = np.einsum("ij,...ij->...", R, Rs) >= min_trace
        if convention == "paper":
            t = t @ R  # R^T t, row vectors
        k = np.rint((t - lo3) / step3)
        inside = close & np.all((k >= 0) & (k < counts), axis=-1)
        k = k[inside].astype(np.int64)
        flat = k[:, 0] + counts[0] * (k[:, 1] + counts[1] * k[:, 2])
        arms = np.broadcast_to(arm_index, inside.shape)[inside]
        hit[arms, flat] = True
        done += c
    return hit.reshape(tuple(batch) + (n_nodes,))
