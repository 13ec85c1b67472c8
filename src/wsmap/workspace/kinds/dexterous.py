"""The dexterous workspace for a set of orientations ``(K, 3, 3)``: every orientation of the set is
reachable at the position (bool per node; ``T = transl(p)·R_k``, the standard convention).

Computed by :func:`wsmap.workspace.dexterous_map` (the reachability index ``== 1``), with the
index's search defaults (:data:`wsmap.workspace.reach.INDEX_SETTINGS`).
"""

from __future__ import annotations

from ..grids import cartesian_grid
from ..reach import INDEX_SETTINGS, dexterous_map
from .registry import MapKind, register


def _compute(robot, grid, request):
    nodes = cartesian_grid(grid["lo"], grid["hi"], grid["step"])
    return dexterous_map(robot, nodes, request.orientations, method=request.method, ik=request.search,
                         seed=request.seed)


KIND = register(MapKind(
    name="dexterous", scope="R3", value_type=bool, compute=_compute, function=dexterous_map,
    description="reachable at every one of --orientations", noun="dexterous", inputs=("orientations",),
    search_settings=INDEX_SETTINGS, convention="standard",
))
