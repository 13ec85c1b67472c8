"""wsmap: manipulator workspace maps, classical and learned.

The library (what a roboticist imports)::

    import wsmap
    arm = wsmap.load("ur5e")                                   # or wsmap.from_urdf(path), wsmap.from_dh(...)
    nodes = wsmap.cartesian_grid(-1, 1, 0.1)                   # (9261, 3) metres, x fastest
    reach = wsmap.constant_orientation_map(arm, nodes, rpy=(3.14159, 0, 0), convention="standard")
    index = wsmap.reachability_index(arm, nodes, wsmap.workspace.orientation_samples(50))  # (9261,) in [0, 1]

* `wsmap.jobs` — what the command line runs, as objects: `MapJob`, `PlacementJob` (`check`,
  `run`, `save`), their arm (`ArmSource`) and collision geometry (`CollisionSource`);
* `wsmap.kinematics` — transforms, robot models (`DHRobot`), forward kinematics, IK;
* `wsmap.robots` — named arms and families of arms;
* `wsmap.workspace` — grids, maps of every kind (one module each in `wsmap.workspace.kinds`),
  base placement, map files;
* `wsmap.datasets` — experience datasets (spec, features, labels, store);
* `wsmap.learn` — networks, initialisation, optimisers, training, the map predictor, model files;
* `wsmap.design` — the shortest arm of a family whose map covers task positions: gradient
  descent through a map model against CMA-ES and random search on the classical map;
  `wsmap.morph_design` the same across twist patterns, through the morphology model;
* `wsmap.metrics` — precision, recall, F of maps, threshold sweeps, per-node outcomes;
* `wsmap.viz` — drawing only; `wsmap.views` — 3-D views and exchange files; `wsmap.io` — atomic writes, tables, JSON; `wsmap.paths`.

The paper's reproduction lives apart, in `wsmap.paper` (its dataset specs, published numbers,
experiments, run-time comparison, report and notebook runner). A reproduction and extension of
P. Liao, "Deep Neural Network Based Subspace Learning of Robotic Manipulator Workspace Mapping".
"""

from . import jobs, kinematics, robots, workspace
from ._version import __version__
from .kinematics import (
    Coupling,
    DHRobot,
    IKSolution,
    SerialChain,
    closed_form_for,
    ikine_LM,
    ikine_search,
    ikine_spherical_wrist,
    ikine_ur,
    rpy2r,
    transl,
)
from .jobs import ArmSource, CollisionSource, MapJob, MapOutputs, PlacementJob
from .robots import from_dh, from_urdf, load
from .workspace import (
    Placement,
    angle_grid,
    base_placement,
    cartesian_grid,
    constant_orientation_map,
    dexterous_map,
    grid_map,
    grid_spec,
    load_map,
    load_status,
    manipulability_map,
    map_to_volume,
    orientation_map,
    position_map,
    reachability_index,
    reachable,
    save_map,
)
from .workspace.kinds import get_kind, kind_names
from .workspace.maps import grid_status
from .workspace.status import CERTIFIED, NOT_FOUND, REACHED, STATUS, node_status, node_status_over, status_counts

__all__ = [
    "__version__", "kinematics", "robots", "workspace",
    # arms: by name, from a URDF file, from a (modified) DH table
    "load", "from_urdf", "from_dh", "DHRobot", "SerialChain", "Coupling",
    # kinematics
    "IKSolution", "closed_form_for", "ikine_LM", "ikine_search", "ikine_spherical_wrist", "ikine_ur", "rpy2r",
    "transl",
    # maps: grids, every map kind, their files; base placement
    "angle_grid", "cartesian_grid", "grid_spec", "grid_map", "map_to_volume", "reachable",
    "constant_orientation_map", "orientation_map", "reachability_index", "position_map", "dexterous_map",
    "manipulability_map", "get_kind", "kind_names", "load_map", "save_map", "base_placement", "Placement",
    # the three answers of a map node: reached, certified unreachable, not found
    "REACHED", "CERTIFIED", "NOT_FOUND", "STATUS", "grid_status", "load_status", "node_status", "node_status_over", "status_counts",
    # jobs: what the command line runs, built in Python (check, run, save)
    "jobs", "MapJob", "MapOutputs", "PlacementJob", "ArmSource", "CollisionSource",
]
