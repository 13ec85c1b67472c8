"""Reach at any orientation: whether the tool origin can be put at each position (bool per node).

Computed by `wsmap.workspace.position_map` (the numerical search on the position alone; there
is no closed form of its own, so `method="exact"` computes it numerically too). Its status: a node
not reached is certified where it lies beyond the links' reach from the first joint's axis
(`wsmap.workspace.status.position_status`), else not found.
"""

from __future__ import annotations

from ..reach import position_map
from ..status import position_status
from .registry import MapKind, grid_positions, register


def _compute(robot, grid, request):
    return position_map(robot, grid_positions(grid), ik=request.search, seed=request.seed, progress=request.progress)


def _status(robot, grid, request, values, bits, budget):
    return position_status(robot, grid_positions(grid), values), None


KIND = register(MapKind(
    name="reach", scope="R3", value_type=bool, compute=_compute, function=position_map,
    description="reachable at some orientation", priority=40, methods=("numerical",), convention="standard",
    status=_status,
))
