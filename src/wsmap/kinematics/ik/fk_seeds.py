"""Global seeding of the map search: sampled configurations, through forward kinematics, as IK starts.

The map search (`wsmap.kinematics.ik.search.map_search`) spreads from solved nodes to their
neighbours, so a reachable region that no solved node borders (an island: another branch of the
arm, a pocket behind a joint limit, or every node when start 0 solves none) is never searched.
Global seeding gives every such region a start from the arm's own configurations:

* **samples**: `count` configurations per arm, a low-discrepancy sequence (Halton's, shifted by
  `seed`: the same seed gives the same samples) mapped into the box the random starts are
  drawn in (`wsmap.kinematics.ik.kernel.start_box`: the limits, `[-pi, pi)` where a
  revolute joint has none), and their tool poses by one vectorised float64 forward kinematics;
* **nearest samples**: a pose is embedded as the 12-vector `(p / L, vec(R) / sqrt(2))`, `p` the
  tool position (m), `R` its rotation, `L` the root-mean-square distance of the samples' tool
  positions from their centroid (m, per arm), so that the Euclidean distance of two embeddings is
  `sqrt(|Δp|² / L² + 4·sin²(θ/2))` ≈ `sqrt(|Δp|² / L² + θ²)`, `θ` the rotation angle between
  them (rad): a position error of `L` weighs as much as a rotation of one radian, both about one
  radian of joint motion. Each target node takes the configurations of its `per_node` nearest
  samples as starts (a k-d tree per arm, `scipy.spatial.cKDTree`, queried with `eps = 0.5`: each
  within 1.5 times the true nearest distance): the samples whose tool lies nearest the node with
  the orientation closest to the node's.

Every island that some sample lands near gets starts, whatever the neighbour spreading reached;
the search then grows each solved island from its solutions. Deterministic (the sequence, its shift and the tree are), and no loop runs per node (one loop per arm of a batch).
"""

from __future__ import annotations

import math

import numpy as np

from .kernel import mix, start_box
from .memo import Memo, chain_key

__all__ = ["sample_count", "sample_configurations", "halton", "pose_features", "nearest_starts", "MIN_SAMPLES"]

#: The fewest configurations sampled per arm (a small grid still covers the arm's joint space).
MIN_SAMPLES = 1024

_SAMPLES = Memo(8)


def sample_count(per_node: int, nodes: int) -> int:
    """The configurations sampled per arm for `per_node` samples per node of a map of `nodes`
    nodes: `per_node · nodes`, at least `MIN_SAMPLES`, rounded up to a power of two (so that
    maps of similar size share their samples); 0 where `per_node` is 0 (seeding off)."""
    if per_node <= 0 or nodes <= 0:
        return 0
    return 1 << int(math.ceil(math.log2(max(per_node * nodes, MIN_SAMPLES))))


def _primes(count: int) -> list[int]:
    """The first `count` primes."""
    out: list[int] = []
    k = 2
    while len(out) < count:
        if all(k % p for p in out if p * p <= k):
            out.append(k)
        k += 1
    return out


def halton(count: int, dim: int) -> np.ndarray:
    """The points `1 .. count` of the Halton sequence in `[0, 1)^dim` `(count, dim)`: coordinate
    `j` the radical inverse of the point's index in the `j`-th prime base (exact in float64 for
    `count < 2**53`)."""
    k = np.arange(1, count + 1, dtype=np.int64)
    out = np.zeros((count, dim))
    for j, base in enumerate(_primes(dim)):  # a loop over joints and digits, not over samples
        rest, scale = k.copy(), 1.0 / base
        while rest.any():
            out[:, j] += (rest % base) * scale
            rest //= base
            scale /= base
    return out


def sample_configurations(chain, count: int, seed: int) -> np.ndarray:
    """`count` joint configurations `(count, n)` of one arm (rad; m for prismatic joints) inside
    its start box (`start_box`): the Halton sequence (`halton`), every coordinate shifted modulo 1
    by a number of `seed` (splitmix64 of the seed and the joint: a Cranley–Patterson rotation, so
    the same seed gives the same samples and each joint's projection stays evenly spread), scaled
    into the box."""
    n = chain.n
    words = mix(np.uint64(int(seed) % 2**64) ^ mix(np.arange(1, n + 1, dtype=np.uint64)))
    shift = (words >> np.uint64(11)).astype(np.float64) * 2.0**-53
    u = np.mod(halton(count, n) + shift, 1.0)
    lo, hi = start_box(np.asarray(chain.limits, dtype=np.float64))
    with np.errstate(over="ignore", invalid="ignore"):
        q = lo + u * (hi - lo)
    # limits of ±1e308 overflow hi - lo: the same point as a convex combination there
    return np.where(np.isfinite(q), q, lo * (1.0 - u) + hi * u)


def pose_features(T: np.ndarray, scale: float, position_only: bool = False) -> np.ndarray:
    """The embeddings `(..., 12)` of poses `T` `(..., 4, 4)`: `(p / scale, vec(R) / sqrt(2))`
    (see the module notes; `scale` in m); `(..., 3)` positions `p / scale` with `position_only`."""
    T = np.asarray(T, dtype=np.float64)
    p = T[..., :3, 3] / scale
    if position_only:
        return p
    return np.concatenate([p, T[..., :3, :3].reshape(T.shape[:-2] + (9,)) / math.sqrt(2.0)], axis=-1)


def _make_samples(chain, count, seed, position_only):
    """(q (S, n), scale L (m), k-d tree of the samples' embeddings) of one arm."""
    from scipy.spatial import cKDTree

    q = sample_configurations(chain, count, seed)
    F = chain.fkine(q)
    p = F[:, :3, 3]
    scale = float(np.sqrt(np.mean(np.sum((p - p.mean(axis=0)) ** 2, axis=-1))))
    if not scale > 0:  # a tool that no joint moves (every axis through the tool point)
        scale = 1.0
    return q, scale, cKDTree(pose_features(F, scale, position_only))


def nearest_starts(flat, T: np.ndarray, arm: np.ndarray, node: np.ndarray, count: int, per_node: int,
                   seed: int, position_only: bool = False) -> np.ndarray:
    """Starts `(C, per_node, n)` for the targets `(arm[c], node[c])`: the configurations of the
    `per_node` samples (of `count` per arm) nearest each target pose `T[node[c]]` (see the
    module notes).

    Parameters
    ----------
    flat : SerialChain, one arm or a flat batch `(B,)`
    T : (N, 4, 4) the nodes' target poses in the arms' base frame (m)
    arm, node : (C,) int, each target's arm index (0 for one arm) and node index
    count, per_node : samples per arm and starts per target (`1 <= per_node <= count`)
    seed : the samples' seed (`sample_configurations`)
    position_only : nearest by the tool position alone (the targets' orientations do not count)
    """
    n = flat.n
    out = np.empty((arm.size, per_node, n))
    batch = flat.batch_shape != ()
    for b in np.unique(arm):  # one loop per arm of a batch, never per node
        chain = flat[int(b)] if batch else flat
        q, scale, tree = _SAMPLES.get((chain_key(chain), count, seed, position_only),
                                      lambda: _make_samples(chain, count, seed, position_only))  # noqa: B023
        rows = np.flatnonzero(arm == b)
        # eps: a sample within 1.5 times the nearest one's distance will do as a start, and the
        # query of a node far from every sample (an orientation few samples have) is then 3x faster
        _, j = tree.query(pose_features(T[node[rows]], scale, position_only), k=per_node, eps=0.5)
        out[rows] = q[np.asarray(j).reshape(rows.size, per_node)]
    return out
