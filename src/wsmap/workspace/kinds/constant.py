"""The constant-orientation map (the paper's "R3" map): which positions of a grid the tool reaches at
one fixed orientation ``rpy`` (bool per node).

Computed by :func:`wsmap.workspace.grid_map` (:func:`wsmap.workspace.constant_orientation_map` on the
grid's nodes; or a trained network, ``method="model"``); for a batch of arms as well as one.
"""

from __future__ import annotations

from ..maps import constant_orientation_map, grid_map
from .registry import MapKind, register


def _compute(robot, grid, request):
    return grid_map(robot, grid, rpy=request.rpy, method=request.method, convention=request.convention,
                    model=request.model, allow_extrapolation=request.allow_extrapolation, ik=request.ik,
                    progress=request.progress)


KIND = register(MapKind(
    name="constant", scope="R3", value_type=bool, compute=_compute, function=constant_orientation_map,
    description="positions at a fixed orientation (--rpy; the paper's R3)",
    inputs=("rpy", "convention"), methods=("exact", "numerical", "model"), paper_solver=True, batch=True,
))
