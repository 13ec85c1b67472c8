"""The constant-orientation map (the paper's "R3" map): which positions of a grid the tool reaches at
one fixed orientation `rpy` (bool per node).

Computed by `wsmap.workspace.grid_map` (`wsmap.workspace.constant_orientation_map` on the
grid's nodes; or a trained network, `method="model"`); for a batch of arms as well as one.
"""

from __future__ import annotations

from ..maps import constant_orientation_map
from .registry import paper_map_kind, register

KIND = register(paper_map_kind("constant", "R3", "rpy", constant_orientation_map,
                               "positions at a fixed orientation (--rpy; the paper's R3)", priority=10))
