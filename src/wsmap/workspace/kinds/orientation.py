"""The orientation map (the paper's "SO3" map): which orientations `(r1, r2, r3)` of a grid of
angles (rad) the tool reaches at one fixed point (m) (bool per node).

Computed by `wsmap.workspace.grid_map` (`wsmap.workspace.orientation_map` on the grid's
nodes; or a trained network, `method="model"`); for a batch of arms as well as one.
"""

from __future__ import annotations

from ..maps import orientation_map
from .registry import paper_map_kind, register

KIND = register(paper_map_kind("orientation", "SO3", "point", orientation_map,
                               "orientations at a fixed point (--point; the paper's SO3)", priority=20))
