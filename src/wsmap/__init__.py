"""wsmap: manipulator workspace maps, classical and learned.

The library (what a roboticist imports)::

    import wsmap
    arm = wsmap.robots.puma560()
    nodes = wsmap.cartesian_grid(-1, 1, 0.1)
    reach = wsmap.constant_orientation_map(arm, nodes, method="exact")

* :mod:`wsmap.kinematics` — transforms, robot models (:class:`DHRobot`), forward kinematics, IK;
* :mod:`wsmap.robots` — named arms and families of arms;
* :mod:`wsmap.workspace` — grids, maps, map files;
* :mod:`wsmap.datasets` — experience datasets (spec, features, labels, store);
* :mod:`wsmap.learn` — networks, initialisation, optimisers, training, the map predictor, model files;
* :mod:`wsmap.design` — the shortest arm of a family whose map covers task positions: gradient
  descent through a map model against CMA-ES and random search on the classical map;
* :mod:`wsmap.metrics` — precision, recall, F of maps;
* :mod:`wsmap.viz` — drawing; :mod:`wsmap.io` — atomic writes, tables, JSON; :mod:`wsmap.paths`.

The paper's reproduction lives apart, in :mod:`wsmap.paper` (its dataset specs, published numbers,
experiments, run-time comparison, report and notebook runner). A reproduction and extension of
P. Liao, "Deep Neural Network Based Subspace Learning of Robotic Manipulator Workspace Mapping".
"""

from . import kinematics, robots, workspace
from ._version import __version__
from .kinematics import (
    DHRobot,
    IKSolution,
    SerialChain,
    ikine_LM,
    ikine_search,
    ikine_spherical_wrist,
    rpy2r,
    transl,
)
from .workspace import (
    angle_grid,
    cartesian_grid,
    constant_orientation_map,
    grid_map,
    grid_spec,
    load_map,
    map_to_volume,
    orientation_map,
    reachable,
    save_map,
)

__all__ = [
    "__version__", "kinematics", "robots", "workspace",
    "DHRobot", "IKSolution", "SerialChain", "ikine_LM", "ikine_search", "ikine_spherical_wrist", "rpy2r", "transl",
    "angle_grid", "cartesian_grid", "constant_orientation_map", "grid_map", "grid_spec", "load_map",
    "map_to_volume", "orientation_map", "reachable", "save_map",
]
