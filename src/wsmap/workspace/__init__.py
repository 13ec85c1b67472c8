"""Workspace maps: grids of nodes, maps of an arm (or a batch of arms) on them, and map files.

* `.grids` — grids and the layout of flat maps (node order: first coordinate fastest);
* `.maps` — reachability of poses (`reachable`), constant-orientation ("R3") and
  orientation ("SO3") maps, one-call grid maps;
* `.orientations` — orientation sets (super-Fibonacci over SO(3), approach directions x rolls);
* `.reach` — maps over orientations: reach at any orientation, reachability index, dexterous
  workspace, manipulability;
* `.placement` — base placement (inverse reachability);
* `.kinds` — the registry of map kinds (one module per kind: what a node holds, what the kind
  reads, the function above that computes it, how its values read), which `wsmap map --kind`,
  the map files and the views ask;
* `.files` — the `.npz` map file; `.reuleaux` — Reuleaux's HDF5 reachability maps (ROS).
"""

from . import kinds
from .files import MapFileError, load_map, load_status, save_map
from .grids import (
    BLOCK_NODES,
    CROP_3087,
    MAX_NODES,
    N_BLOCKS,
    angle_grid,
    available_memory,
    block_slice,
    cartesian_grid,
    grid_axes,
    grid_counts,
    map_to_volume,
    node_neighbours,
    volume_to_map,
)
from .maps import (
    CONVENTIONS,
    DEFAULT_STARTS,
    MAP_SETTINGS,
    METHODS,
    SCOPES,
    SOLVERS,
    constant_orientation_map,
    default_grid,
    grid_map,
    grid_spec,
    orientation_map,
    reachable,
    resolve_method,
    target_poses,
)

from .orientations import approach_orientations, check_rotations, continuation_order, orientation_samples
from .placement import Placement, base_placement, floor_poses
from .reuleaux import ReuleauxMap, load_reuleaux, save_reuleaux
from .sampled import fk_sampled_maps, orientation_share
from .reach import (
    dexterous_map,
    manipulability_map,
    manipulability_maps,
    position_map,
    reachability_index,
    yoshikawa,
)

__all__ = [
    "approach_orientations", "check_rotations", "continuation_order", "orientation_samples", "Placement",
    "base_placement", "floor_poses", "dexterous_map", "manipulability_map", "manipulability_maps", "position_map",
    "reachability_index", "yoshikawa",
    "BLOCK_NODES", "CONVENTIONS", "CROP_3087", "DEFAULT_STARTS", "MAX_NODES", "METHODS", "MapFileError", "N_BLOCKS",
    "MAP_SETTINGS", "SCOPES", "SOLVERS", "node_neighbours", "reachable", "resolve_method",
    "angle_grid", "available_memory", "block_slice", "cartesian_grid", "constant_orientation_map", "default_grid",
    "grid_axes", "grid_counts", "grid_map", "grid_spec", "load_map", "load_status", "map_to_volume", "orientation_map", "save_map",
    "target_poses", "volume_to_map", "kinds", "ReuleauxMap", "load_reuleaux", "save_reuleaux",
    "fk_sampled_maps", "orientation_share",
]
