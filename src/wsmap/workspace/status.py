"""The three answers of a node or a target: reached, certified unreachable, not found.

A map node (`wsmap.workspace.constant_orientation_map`, `orientation_map`, `grid_map` with
`return_status=True`, the map file's `status`), a node and orientation of the reachability index
(`wsmap.workspace.reachability_index(..., return_status=True)`; a node over its orientations by
`node_status_over`; the dexterous map's node by `node_status_every`), a node of the reach map
(`position_status`) and a reach-study target (`wsmap.workspace.study`) each get one int8 code:

* `REACHED` (0) — a joint solution inside the limits, confirmed by forward kinematics (and
  collision-free where a checker is given);
* `CERTIFIED` (1) — a sound test proves that no configuration inside the joint limits puts the tool
  within `CERTIFY_MARGIN` of the pose (`wsmap.kinematics.ik.certificate`): out of reach, outside
  what the limits allow (the branch and bound over the joints), or, for an arm of a closed-form
  family, no branch of the closed form (complete there) inside the limits. Collisions only remove
  solutions, so the certificate also holds for collision-aware maps;
* `NOT_FOUND` (2) — no solution found, and no certificate that none exists.

The proof obligations are in `docs/maps.md` ("Certified unreachable").
"""

from __future__ import annotations

import numpy as np

from ..kinematics.ik import certificate
from ..kinematics.ik.certificate import CERTIFY_MARGIN, certify
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from wsmap._typing import ArrayLike, NDArray
    from wsmap.kinematics.chain import Arm

__all__ = ["REACHED", "CERTIFIED", "NOT_FOUND", "STATUS", "CERTIFY_MARGIN", "node_status", "node_status_over",
           "node_status_every", "orientation_status", "pose_grid", "position_status", "status_counts"]

REACHED, CERTIFIED, NOT_FOUND = 0, 1, 2
#: The names of the three answers, by code.
STATUS = ("reached", "certified unreachable", "not found")


def node_status(robot: Arm, T: ArrayLike, reached: ArrayLike, method: str = "numerical",
                margin: float = CERTIFY_MARGIN, budget: int | None = None) -> NDArray[np.int8]:
    """The int8 status `(..., N)` of target poses `T` `(N, 4, 4)` (world frame, shared by the arms)
    given which are `reached` `(..., N)` bool (the arms' batch shape first): `REACHED` where
    reached, else `CERTIFIED` where `wsmap.kinematics.ik.certificate.certify` proves the pose
    unreachable (`method` `"exact"`: the sound filters and the closed form's certificate;
    `"numerical"`: the filters and the branch and bound over the joints), else `NOT_FOUND`.
    Only the poses not reached are tested, arm by arm of a batch. `budget`: boxes per pose of the
    branch and bound (default `wsmap.kinematics.ik.certificate.CELL_BUDGET`; more certifies more
    of the nodes near the border, at about a microsecond a box)."""
    budget = certificate.CELL_BUDGET if budget is None else int(budget)
    T = np.asarray(T, dtype=np.float64)
    reached = np.asarray(reached, dtype=bool)
    status = np.where(reached, REACHED, NOT_FOUND).astype(np.int8)
    batch = robot.batch_shape
    if batch == ():
        left = np.flatnonzero(~reached)
        if left.size:
            status[left[certify(robot, T[left], margin, method=method, budget=budget)]] = CERTIFIED
        return status
    from ..kinematics.chain import flatten_arms

    flat = flatten_arms(robot)
    rows = status.reshape(-1, T.shape[0])
    for b in range(rows.shape[0]):
        left = np.flatnonzero(rows[b] != REACHED)
        if left.size:
            rows[b, left[certify(flat[b], T[left], margin, method=method, budget=budget)]] = CERTIFIED
    return rows.reshape(status.shape)


def node_status_over(status: ArrayLike) -> NDArray[np.int8]:
    """The status `(...,)` of a node over its orientations, from the status `(..., K)` of each
    (`wsmap.workspace.reachability_index(..., return_status=True)`): `REACHED` where one
    orientation is reached, `CERTIFIED` where every one is certified unreachable, else `NOT_FOUND`."""
    status = np.asarray(status)
    out = np.full(status.shape[:-1], NOT_FOUND, dtype=np.int8)
    out[(status == CERTIFIED).all(axis=-1)] = CERTIFIED
    out[(status == REACHED).any(axis=-1)] = REACHED
    return out


def node_status_every(status: ArrayLike) -> NDArray[np.int8]:
    """The status `(...,)` of a node of a map that asks for *every* orientation of a set (the
    dexterous map), from the status `(..., K)` of each: `REACHED` where every orientation is
    reached, `CERTIFIED` where one is certified unreachable (so the node is certainly not
    dexterous), else `NOT_FOUND`."""
    status = np.asarray(status)
    out = np.full(status.shape[:-1], NOT_FOUND, dtype=np.int8)
    out[(status == CERTIFIED).any(axis=-1)] = CERTIFIED
    out[(status == REACHED).all(axis=-1)] = REACHED
    return out


def pose_grid(nodes: ArrayLike, orientations: ArrayLike) -> NDArray[np.float64]:
    """The poses `(N, K, 4, 4)` `T = transl(p)·R_k` of positions `nodes` `(N, 3)` (m) at each of
    `orientations` `(K, 3, 3)`: the targets of the maps over a set of orientations."""
    nodes = np.asarray(nodes, dtype=np.float64)
    R = np.asarray(orientations, dtype=np.float64)
    T = np.zeros((len(nodes), len(R), 4, 4))
    T[..., :3, :3], T[..., :3, 3], T[..., 3, 3] = R[None], nodes[:, None], 1.0
    return T


#: Poses `orientation_status` builds and certifies at a time (about 34 MB of poses).
POSE_BLOCK = 1 << 18


def orientation_status(robot: Arm, nodes: ArrayLike, orientations: ArrayLike, reached: ArrayLike,
                       method: str = "numerical", margin: float = CERTIFY_MARGIN, budget: int | None = None
                       ) -> NDArray[np.int8]:
    """The int8 status `(N, K)` of one arm's poses `T = transl(p)·R_k` (`pose_grid` of `nodes`
    `(N, 3)` m and `orientations` `(K, 3, 3)`) given which are `reached` `(N, K)` bool, as
    `node_status` gives it (`method`, `margin`, `budget` the same), without building the
    `N x K` poses at once: only those not reached, `POSE_BLOCK` at a time."""
    budget = certificate.CELL_BUDGET if budget is None else int(budget)
    nodes = np.asarray(nodes, dtype=np.float64)
    R = np.asarray(orientations, dtype=np.float64)
    reached = np.asarray(reached, dtype=bool)
    if reached.shape != (len(nodes), len(R)):
        raise ValueError(f"reached must have shape ({len(nodes)}, {len(R)}) (nodes x orientations), got {reached.shape}")
    status = np.where(reached, REACHED, NOT_FOUND).astype(np.int8)
    flat = status.reshape(-1)
    left = np.flatnonzero(~reached.reshape(-1))
    for start in range(0, left.size, POSE_BLOCK):
        idx = left[start:start + POSE_BLOCK]
        node, k = np.divmod(idx, len(R))
        T = np.zeros((idx.size, 4, 4))
        T[:, :3, :3], T[:, :3, 3], T[:, 3, 3] = R[k], nodes[node], 1.0
        flat[idx[certify(robot, T, margin, method=method, budget=budget)]] = CERTIFIED
    return status


def position_status(robot: Arm, nodes: ArrayLike, reached: ArrayLike, margin: float = CERTIFY_MARGIN
                    ) -> NDArray[np.int8]:
    """The int8 status `(N,)` of the reach map (the tool origin at positions `nodes` `(N, 3)`, m,
    at any orientation) given which are `reached` `(N,)` bool: `REACHED` where reached, else
    `CERTIFIED` where the position is farther from the first joint's axis than the links, the
    tool and the prismatic strokes reach together, plus `margin`
    (`wsmap.kinematics.ik.reach_filter.position_filter`, a sound test), else `NOT_FOUND`."""
    from ..kinematics.chain import as_chain
    from ..kinematics.ik.reach_filter import position_filter

    reached = np.asarray(reached, dtype=bool)
    status = np.where(reached, REACHED, NOT_FOUND).astype(np.int8)
    left = np.flatnonzero(~reached)
    if left.size:
        far = ~np.asarray(position_filter(as_chain(robot), np.asarray(nodes, dtype=np.float64)[left], margin))
        status[left[far]] = CERTIFIED
    return status


def status_counts(status: ArrayLike) -> dict[str, int]:
    """`{name: count}` of the three answers (`STATUS` order)."""
    status = np.asarray(status)
    return {name: int((status == code).sum()) for code, name in enumerate(STATUS)}
