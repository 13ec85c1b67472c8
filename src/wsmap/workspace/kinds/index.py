"""The reachability index: the fraction of a set of orientations `(K, 3, 3)` reachable at each
position (float in [0, 1] per node; `T = transl(p)·R_k`, the standard convention).

Computed by `wsmap.workspace.reachability_index`, with its own search defaults
(`wsmap.workspace.reach.INDEX_SETTINGS`: fewer retries than the maps').
"""

from __future__ import annotations

from ..reach import reachability_index
from ..status import node_status_over
from .registry import orientation_set_kind, register

KIND = register(orientation_set_kind(
    "index", float, reachability_index, "the fraction of --orientations reachable at each position", priority=30,
    from_bits=lambda bits: bits.mean(axis=1), over=node_status_over,
    label="reachability index", levels=lambda values: (0.25, 0.5, 0.75), value_range=(0.0, 1.0),
))
