"""Reach at any orientation: whether the tool origin can be put at each position (bool per node).

Computed by `wsmap.workspace.position_map` (the numerical search on the position alone; there
is no closed form of its own, so `method="exact"` computes it numerically too).
"""

from __future__ import annotations

from ..reach import position_map
from .registry import MapKind, grid_positions, register


def _compute(robot, grid, request):
    return position_map(robot, grid_positions(grid), ik=request.search, seed=request.seed, progress=request.progress)


KIND = register(MapKind(
    name="reach", scope="R3", value_type=bool, compute=_compute, function=position_map,
    description="reachable at some orientation", priority=40, methods=("numerical",), convention="standard",
))
