"""The dexterous workspace for a set of orientations `(K, 3, 3)`: every orientation of the set is
reachable at the position (bool per node; `T = transl(p)·R_k`, the standard convention).

Computed by `wsmap.workspace.dexterous_map` (the reachability index `== 1`), with the
index's search defaults (`wsmap.workspace.reach.INDEX_SETTINGS`).
"""

from __future__ import annotations

from ..reach import dexterous_map
from ..status import node_status_every
from .registry import orientation_set_kind, register

KIND = register(orientation_set_kind("dexterous", bool, dexterous_map, "reachable at every one of --orientations",
                                     priority=50, from_bits=lambda bits: bits.all(axis=1), over=node_status_every, noun="dexterous"))
