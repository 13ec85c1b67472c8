"""The orientation map (the paper's "SO3" map): which orientations ``(r1, r2, r3)`` of a grid of
angles (rad) the tool reaches at one fixed point (m) (bool per node).

Computed by :func:`wsmap.workspace.grid_map` (:func:`wsmap.workspace.orientation_map` on the grid's
nodes; or a trained network, ``method="model"``); for a batch of arms as well as one.
"""

from __future__ import annotations

from ..maps import grid_map, orientation_map
from .registry import MapKind, register


def _compute(robot, grid, request):
    return grid_map(robot, grid, point=request.point, method=request.method, convention=request.convention,
                    model=request.model, allow_extrapolation=request.allow_extrapolation, ik=request.ik,
                    progress=request.progress)


KIND = register(MapKind(
    name="orientation", scope="SO3", value_type=bool, compute=_compute, function=orientation_map,
    description="orientations at a fixed point (--point; the paper's SO3)",
    inputs=("point", "convention"), methods=("exact", "numerical", "model"), paper_solver=True, batch=True,
))
