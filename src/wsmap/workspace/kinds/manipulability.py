"""The manipulability map: the largest Yoshikawa manipulability `√det(J Jᵀ)` over the IK solutions
found at each position for one orientation `rpy` (float >= 0 per node, 0 where unreachable; m³ for
a 6-joint arm with lengths in metres).

Computed by `wsmap.workspace.manipulability_map` (every closed-form branch, or the solution the
numerical search finds). Its status: a node is reached where its value is above 0, certified or not
found as the constant-orientation map's node at the same pose (`wsmap.workspace.grid_status`).
"""

from __future__ import annotations

import numpy as np

from ..maps import grid_status
from ..reach import manipulability_map
from .registry import MapKind, grid_positions, register


def _compute(robot, grid, request):
    return manipulability_map(robot, grid_positions(grid), request.rpy, convention=request.convention, method=request.method,
                              ik=request.search, seed=request.seed, progress=request.progress)


def _status(robot, grid, request, values, bits, budget):
    # 0 is the map's "unreachable" (a singular solution found would be a value ~1e-10, not 0)
    return grid_status(robot, grid, np.asarray(values) > 0, rpy=request.rpy, method=request.method,
                       convention=request.convention, budget=budget), None


def _levels(values):
    # the quartiles of the reachable nodes' values: the map's scale depends on the arm's size (m³).
    # Only distinct levels some node lies above (one reachable node, or many of one value, have
    # equal quartiles): half the largest value when none is left; none for a map with no reach.
    values = np.asarray(values, dtype=np.float64)
    reached = values[values > 0]
    if reached.size == 0:
        return ()
    top = float(reached.max())
    levels = tuple(float(v) for v in np.unique(np.quantile(reached, [0.25, 0.5, 0.75])) if v < top)
    return levels or (top / 2,)


KIND = register(MapKind(
    name="manipulability", scope="R3", value_type=float, compute=_compute, function=manipulability_map,
    description="the largest Yoshikawa manipulability of the IK solutions at --rpy", priority=60,
    label="manipulability √det(J Jᵀ)", inputs=("rpy", "convention"), levels=_levels, value_range=(0.0, None),
    status=_status,
))
