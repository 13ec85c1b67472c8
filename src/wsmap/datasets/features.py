"""The feature and label layout: what one row of a dataset is.

A dataset is `samples` random arms (one row each) with

* **features** `(samples, F)` float64 in the paper's layout (Appendix, "experience generation")::

      [d_1..d_6, a_1..a_6, alpha_1..alpha_6,  n_x (nx values), n_y (ny), n_z (nz),  n_i (3)]

  DH columns in metres / radians; `n_x, n_y, n_z` the node values along each grid axis (metres
  for an "R3" scope, the angles r1, r2, r3 in radians for an "SO3" scope) -- always the *whole*
  axes of the grid, also when only a slice of its nodes is labelled (so every 21³ R3 spec has
  18 + 63 + 3 = 84 columns); `n_i` the fixed orientation `(r1, r2, r3)` in radians (R3) or
  the fixed point in metres (SO3). Columns of a fixed quantity are constant; the model sees them
  because the paper's input has them.
  A chain family (`wsmap.datasets.spec.CHAIN_FAMILIES`, e.g. `panda7`) has its scale
  factors in place of the 18 DH columns::

      [scale_d1, scale_d3, scale_d5, scale_a4, scale_a5, scale_a7,  n_x, n_y, n_z,  n_i (3)]

  (dimensionless, the order of `wsmap.robots.family_arm`; 6 + 75 + 3 = 84 columns on the
  25³ grid).
* **labels** `(samples, nodes)` bool in node order (first coordinate fastest, see
  `wsmap.workspace`): `True` where inverse kinematics solves the node's target pose
  (`wsmap.datasets.labels`).

`features_for` builds the feature rows of any batch of 6-joint arms (or of a chain family's
arms or scales: what a trained model is asked about); `arms_from_features` and
`fixed_from_features` read them back.
"""

from __future__ import annotations

import numpy as np

from .. import robots
from .. import workspace as ws
from ..kinematics import DHRobot, SerialChain
from .spec import N_DH, N_JOINTS, DatasetSpec, check_spec, float64_array, require_finite
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap._typing import ArrayLike
    from wsmap.kinematics.chain import Arm

__all__ = [
    "grid_axes",
    "grid_nodes",
    "node_slice",
    "spec_nodes",
    "feature_slices",
    "feature_names",
    "features_for",
    "scales_for",
    "arms_from_features",
    "fixed_from_features",
    "fixed_rows",
    "check_arms",
]


# --------------------------------------------------------------------------- nodes
def grid_axes(spec: DatasetSpec) -> list[np.ndarray]:
    """The node values along each axis of the whole grid (m for R3, rad for SO3)."""
    check_spec(spec)
    return ws.grid_axes(spec.lo, spec.hi, spec.step)


def grid_nodes(spec: DatasetSpec) -> np.ndarray:
    """All nodes of the grid `(nx·ny·nz, 3)` in node order: positions (R3) or angles (SO3)."""
    check_spec(spec)
    make = ws.cartesian_grid if spec.scope == "R3" else ws.angle_grid
    return make(spec.lo, spec.hi, spec.step)


def node_slice(spec: DatasetSpec) -> slice:
    """The labelled nodes as a slice of the flat node order."""
    check_spec(spec)
    if spec.select is None:
        return slice(0, spec.grid_nodes)
    return slice(*spec.select)


def spec_nodes(spec: DatasetSpec) -> np.ndarray:
    """The labelled nodes `(n_nodes, 3)` in node order (label column `j` is row `j`)."""
    return grid_nodes(spec)[node_slice(spec)]


# --------------------------------------------------------------------------- features
def feature_slices(spec: DatasetSpec) -> dict[str, slice]:
    """Column ranges of the feature vector: `d`, `a`, `alpha` (a chain family: `scales`),
    `nx`, `ny`, `nz`, `fixed`."""
    check_spec(spec)
    nx, ny, nz = spec.grid_shape
    if spec.is_chain_family:
        edges = np.cumsum([0, spec.n_arm_features, nx, ny, nz, 3])
        keys = ("scales", "nx", "ny", "nz", "fixed")
    else:
        edges = np.cumsum([0, N_JOINTS, N_JOINTS, N_JOINTS, nx, ny, nz, 3])
        keys = ("d", "a", "alpha", "nx", "ny", "nz", "fixed")
    return {k: slice(int(edges[i]), int(edges[i + 1])) for i, k in enumerate(keys)}


def feature_names(spec: DatasetSpec) -> list[str]:
    """Column names: `d_1..d_6, a_1..a_6, alpha_1..alpha_6, n_x_1.., n_y_1.., n_z_1..` then
    `r_1..r_3` (R3: the orientation angles) or `p_1..p_3` (SO3: the point). 1-based, like the paper.
    A chain family starts with `scale_<param>` (`scale_d1 .. scale_a7` for `panda7`)."""
    check_spec(spec)
    nx, ny, nz = spec.grid_shape
    if spec.is_chain_family:
        family = robots.arm_family(spec.family)
        names = [f"{family.feature_prefix}{p}" for p in family.params]
    else:
        names = [f"{k}_{i}" for k in ("d", "a", "alpha") for i in range(1, N_JOINTS + 1)]
    for ax, n in (("x", nx), ("y", ny), ("z", nz)):
        names += [f"n_{ax}_{i}" for i in range(1, n + 1)]
    names += [f"{'r' if spec.scope == 'R3' else 'p'}_{i}" for i in (1, 2, 3)]
    return names


def fixed_rows(spec: DatasetSpec, count: int, fixed) -> np.ndarray:
    """The fixed orientation (R3, rad) or point (SO3, m) of each of `count` arms.

    Parameters
    ----------
    spec : DatasetSpec
        Its `fixed` is used when `fixed` is None (a `"random"` spec then raises `ValueError`).
    count : int
        Number of arms.
    fixed : array_like, shape (3,) or (count, 3), or None
        One triple for every arm, or one per arm; finite.

    Returns
    -------
    numpy.ndarray, shape (count, 3), float64
        A read-only broadcast view when one triple is shared.
    """
    if fixed is None:
        if spec.fixed == "random":
            raise ValueError(
                f"spec {spec.name!r} draws its {'orientation' if spec.scope == 'R3' else 'point'} per sample "
                "(fixed='random'); pass fixed=(count, 3) or (3,)"
            )
        fixed = spec.fixed
    fixed = float64_array(fixed, f"fixed must be numbers of shape (3,) or ({count}, 3), got {fixed!r}")
    if fixed.shape not in ((3,), (count, 3)):
        raise ValueError(f"fixed must have shape (3,) or ({count}, 3), got {fixed.shape}")
    require_finite(fixed, "fixed contains NaN or infinite values")
    return np.broadcast_to(fixed, (count, 3))


def check_arms(arms) -> DHRobot:
    """`arms` itself when it is a batch `(count,)` of 6-joint `DHRobot` arms (the paper's
    feature layout), else a one-line `TypeError` or `ValueError`.

    Parameters
    ----------
    arms : DHRobot
        The arms a function was given.

    Returns
    -------
    DHRobot
        `arms`, unchanged.
    """
    if not isinstance(arms, DHRobot):
        raise TypeError(f"arms must be a DHRobot, got {type(arms).__name__}")
    if arms.n != N_JOINTS:
        raise ValueError(f"the paper's feature layout is for 6-joint arms, got {arms.n} joints")
    if len(arms.batch_shape) != 1:
        raise ValueError(f"arms must be a batch of shape (count,), got batch shape {arms.batch_shape}")
    if arms.tool is not None:
        raise ValueError("arms with a tool transform have no place in the paper's feature layout")
    return arms


def scales_for(arms: Arm, spec: DatasetSpec) -> np.ndarray:
    """The scale factors `(count, n)` of a chain family's arms: `arms` is the scales themselves
    (`(count, n)`, checked as `wsmap.robots.family_arm` checks them) or a
    `SerialChain` batch `(count,)` of the family (scales read back with
    `wsmap.robots.family_params`)."""
    family = robots.arm_family(spec.family)
    if isinstance(arms, SerialChain):
        if len(arms.batch_shape) != 1:
            raise ValueError(f"arms must be a batch of shape (count,), got batch shape {arms.batch_shape}")
        return family.params_of(arms)
    if isinstance(arms, DHRobot):
        raise TypeError(f"spec {spec.name!r} is of family {spec.family!r}: give its arms (a SerialChain from "
                        "wsmap.robots.family_arm) or their scale factors, not a DHRobot")
    s = family.check_params(arms)
    if s.ndim != 2:
        raise ValueError(f"scales must have shape (count, {family.n_params}), got {s.shape}")
    return s


def features_for(arms: Arm, spec: DatasetSpec, fixed: ArrayLike | None = None) -> np.ndarray:
    """The feature matrix `(count, spec.n_features)` float64 of a batch of arms for `spec`.

    `arms` is a batch `(count,)` of 6-joint arms (any DH values: a model trained on `spec`
    predicts their maps); for a chain family (`panda7`) the family's arms or their scale factors
    `(count, 6)` (`scales_for`). `fixed` is the orientation (R3, rad) or point (SO3,
    m), `(3,)` or `(count, 3)`; by default the spec's (required when the spec's is
    `"random"`). A model trained on a fixed-orientation spec has only ever seen that orientation.
    """
    check_spec(spec)
    if spec.is_chain_family:
        scales = scales_for(arms, spec)
        count = scales.shape[0]
    else:
        arms = check_arms(arms)
        count = arms.batch_shape[0]
    fx = fixed_rows(spec, count, fixed)
    sl = feature_slices(spec)
    X = np.empty((count, spec.n_features), dtype=np.float64)
    if spec.is_chain_family:
        X[:, sl["scales"]] = scales
    else:
        X[:, sl["d"]] = arms.d
        X[:, sl["a"]] = arms.a
        X[:, sl["alpha"]] = arms.alpha
    for key, axis in zip(("nx", "ny", "nz"), grid_axes(spec)):
        X[:, sl[key]] = axis
    X[:, sl["fixed"]] = fx
    return X


def _feature_matrix(X) -> np.ndarray:
    X = float64_array(X, f"features must be a numeric matrix, got {type(X).__name__}")
    return require_finite(X, "features contain NaN or infinite values")


def arms_from_features(X: ArrayLike, spec: DatasetSpec | None = None) -> DHRobot | SerialChain:
    """The arms `(count,)` whose DH columns are the first 18 feature columns; for a `spec` of a
    chain family, the family's arms (`wsmap.robots.family_arm`) of the scale columns."""
    X = _feature_matrix(X)
    if spec is not None and check_spec(spec).is_chain_family:
        k = spec.n_arm_features
        if X.ndim != 2 or X.shape[1] < k:
            raise ValueError(f"features must have shape (count, >= {k}), got {X.shape}")
        return robots.family_arm(spec.family, X[:, :k])
    if X.ndim != 2 or X.shape[1] < N_DH:
        raise ValueError(f"features must have shape (count, >= {N_DH}), got {X.shape}")
    return DHRobot(X[:, 0:6], X[:, 6:12], X[:, 12:18])


def fixed_from_features(X: ArrayLike, spec: DatasetSpec) -> np.ndarray:
    """The orientation / point columns `(count, 3)` of a feature matrix."""
    check_spec(spec)
    X = _feature_matrix(X)
    if X.ndim != 2 or X.shape[1] != spec.n_features:
        raise ValueError(f"features for spec {spec.name!r} must have shape (count, {spec.n_features}), got {X.shape}")
    return X[:, feature_slices(spec)["fixed"]]
