"""The reachability index: the fraction of a set of orientations ``(K, 3, 3)`` reachable at each
position (float in [0, 1] per node; ``T = transl(p)·R_k``, the standard convention).

Computed by :func:`wsmap.workspace.reachability_index`, with its own search defaults
(:data:`wsmap.workspace.reach.INDEX_SETTINGS`: fewer retries than the maps').
"""

from __future__ import annotations

from ..grids import cartesian_grid
from ..reach import INDEX_SETTINGS, reachability_index
from .registry import MapKind, register


def _compute(robot, grid, request):
    nodes = cartesian_grid(grid["lo"], grid["hi"], grid["step"])
    return reachability_index(robot, nodes, request.orientations, method=request.method, ik=request.search,
                              seed=request.seed)


KIND = register(MapKind(
    name="index", scope="R3", value_type=float, compute=_compute, function=reachability_index,
    description="the fraction of --orientations reachable at each position",
    label="reachability index", inputs=("orientations",), search_settings=INDEX_SETTINGS, convention="standard",
    levels=lambda values: (0.25, 0.5, 0.75), value_range=(0.0, 1.0),
))
