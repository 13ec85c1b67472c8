"""Map kinds: one module per kind of workspace map, each ending by registering its `MapKind`.

The command line (`wsmap map --kind NAME`), the map files (`wsmap.workspace.files`) and the
views ask this registry what a kind is (`get_kind`, `kinds`); none of them names a kind.

Kinds, by their `MapKind.priority` (the registry's order, the order of `--kind`'s choices):

* `.constant` (10) — the paper's R3 map: positions reachable at a fixed orientation (bool);
* `.orientation` (20) — the paper's SO3 map: orientations reachable at a fixed point (bool);
* `.index` (30) — the reachability index over a set of orientations (float in [0, 1]);
* `.reach` (40) — reachable at some orientation (bool);
* `.dexterous` (50) — reachable at every orientation of a set (bool);
* `.manipulability` (60) — the best Yoshikawa manipulability at a fixed orientation (float, m³).

A new kind is one new module here (its glue: a `compute(robot, grid, request)` that calls the
library function, and `register(MapKind(..., priority=...))` at its end; a kind like the paper's
maps or one over a set of orientations builds its record with `paper_map_kind` or
`orientation_set_kind`) and its tests: the package discovers it (`wsmap._plugins.discover`).
The computing function itself lives with the maps (`wsmap.workspace.maps`,
`wsmap.workspace.reach`).

What a kind reads (`MapKind.inputs`) is what `wsmap map` accepts with it: an option feeding an
input the kind does not read is refused. A kind with `MapKind.poses` (reachability at each of a
set of orientations) can be written as a Reuleaux HDF5 map (`--h5`, `wsmap.workspace.reuleaux`).
"""

from ..._plugins import discover
from .registry import (
    INPUTS,
    KINDS,
    METHODS,
    MapKind,
    MapRequest,
    default_kind,
    get_kind,
    kind_names,
    kinds,
    kinds_taking,
    register,
    unregister,
)

# Importing a kind module registers it; the registry orders the kinds by priority: the paper's map
# of each scope first (the default kind of its scope, default_kind), then the maps over orientations.
discover(__name__, __path__)

__all__ = ["INPUTS", "KINDS", "METHODS", "MapKind", "MapRequest", "default_kind", "get_kind", "kind_names",
           "kinds", "kinds_taking", "register", "unregister"]
