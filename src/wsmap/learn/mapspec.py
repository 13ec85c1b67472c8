"""What a model maps: the `map_spec` (grid, nodes, threshold), and how arms become the model's inputs.

A model that knows what it maps carries a *map description*, `model.map_spec` (`None` when
absent; set it with `wsmap.learn.network.SubspaceMLP.set_map_spec`; saved and loaded with
the model), a plain dict::

    {"dataset": DatasetSpec.to_dict() of the spec it was trained on (grid, scope, fixed
                orientation or point, pose convention),
     "nodes": [start, stop],   # flat node indices of the spec's grid its outputs cover, in order
     "assemble": bool,         # True: the S subspaces are consecutive node blocks, concatenated
     "subspace": int | None,   # which subspace predicts when S > 1 and not assembled
     "threshold": float}       # score threshold in (0, 1) (0.5, the paper's)

This module validates such a dict against a model's config (`map_plan`), checks the arms,
fixed orientation / point and grid a caller asks for (`check_map_arms`,
`grid_mismatch`, `check_threshold`), and builds the feature rows of arms for the spec
(`map_features`, the layout of `wsmap.datasets.features_for`). It does not run networks:
`predict_maps` and `wsmap.learn.predictor` do.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..datasets.features import feature_names, features_for, node_slice
from ..datasets.spec import DatasetSpec, float64_array, require_finite
from ..io import check_record
from ..kinematics import DHRobot
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap._typing import ArrayLike
    from wsmap.datasets.store import Dataset

__all__ = [
    "make_map_spec",
    "map_plan",
    "MapPlan",
    "check_map_arms",
    "check_threshold",
    "check_batch_size",
    "grid_mismatch",
    "map_features",
    "map_batch_shape",
    "family_scales",
    "spec_feature_names",
]


def check_threshold(threshold, where: str = "threshold") -> float:
    """`threshold` as a float in the open interval (0, 1), else `ValueError`.

    Scores are probabilities (`output_kind "logit"`) or regressions of 0/1 labels (`"linear"`):
    a threshold at or outside 0 and 1 makes every node reachable or none, and NaN none.
    """
    if isinstance(threshold, bool) or not isinstance(threshold, (int, float, np.integer, np.floating)):
        raise ValueError(f"{where} must be a number in (0, 1); got {threshold!r}")
    t = float(threshold)
    if not (math.isfinite(t) and 0.0 < t < 1.0):
        raise ValueError(f"{where} must be a finite number in (0, 1) (a node is reachable where score > "
                         f"threshold); got {threshold!r}")
    return t


def check_batch_size(batch_size) -> int | None:
    """`None` or a positive integer, else `ValueError`."""
    if batch_size is None:
        return None
    if isinstance(batch_size, bool) or not isinstance(batch_size, (int, np.integer)) or batch_size < 1:
        raise ValueError(f"batch_size must be a positive integer or None (all at once); got {batch_size!r}")
    return int(batch_size)


@dataclass(frozen=True)
class MapPlan:
    """A validated `map_spec`: the parsed dataset spec and how to run the model."""

    spec: DatasetSpec
    nodes: slice  # flat indices of the spec's grid covered by the outputs
    assemble: bool
    key: int | None
    threshold: float
    # One feature row of the spec with zero DH columns (fixed specs only): predict_maps fills in
    # the 18 DH columns instead of calling features_for, whose grid construction dominates the
    # time of a one-arm map (~0.1 ms of it).
    template: np.ndarray | None = None


def make_map_spec(dataset: Dataset, *, nodes: ArrayLike | None = None, assemble: bool = False,
                  subspace: int | None = None, threshold: float = 0.5) -> dict[str, Any]:
    """A `map_spec` dict (module docstring), before checking it against a model.

    Parameters
    ----------
    dataset
        the `wsmap.datasets.DatasetSpec` the model was trained on, or its `to_dict()`.
    nodes
        `(start, stop)` or a slice of the spec grid's flat node order covered by the
        model's outputs (0-based, stop exclusive; within the spec's labelled nodes). `None`:
        the spec's labelled nodes (`wsmap.datasets.node_slice`); with `assemble` and a
        node count different from the model's, `start` is kept and `stop` follows from
        the model (see `set_map_spec`).
    assemble
        the S subspaces are consecutive node blocks of `m` nodes each, concatenated
        in node order (section 6.2: 7 blocks of 1323 → the 9261-node map).
    subspace
        for a stacked model used without `assemble`, the subspace that predicts.
    threshold
        score threshold (`score > threshold` is reachable; the paper's 0.5).
    """
    spec = dataset if isinstance(dataset, DatasetSpec) else DatasetSpec.from_dict(dataset)
    if isinstance(nodes, slice):
        nodes = (nodes.start, nodes.stop)
    return {"dataset": spec.to_dict(), "nodes": None if nodes is None else [nodes[0], nodes[1]],
            "assemble": bool(assemble), "subspace": subspace, "threshold": threshold}


def _plan_dataset(config, map_spec) -> DatasetSpec:
    """The `DatasetSpec` of `map_spec["dataset"]`, checked against the model's input count."""
    if "dataset" not in map_spec:
        raise ValueError("map_spec needs 'dataset' (the DatasetSpec dict the model was trained on)")
    try:
        spec = DatasetSpec.from_dict(dict(map_spec["dataset"]))
    except (TypeError, ValueError) as e:
        raise ValueError(f"map_spec dataset is not a valid dataset spec: {e}") from None
    n_inputs = getattr(config, "n_inputs", None)
    if n_inputs is not None and spec.n_features != n_inputs:
        raise ValueError(f"map_spec dataset {spec.name!r} has {spec.n_features} features per arm but the model "
                         f"expects {n_inputs}: the model was trained on another grid or feature layout")
    return spec


def _plan_subspace(map_spec, assemble: bool, S: int) -> int | None:
    """The subspace that predicts (`None` for an assembled model, which uses every one of its `S`)."""
    key = map_spec.get("subspace")
    if assemble:
        if key is not None:
            raise ValueError("map_spec: an assembled model uses every subspace; give no subspace")
        return None
    if key is None:
        if S > 1:
            raise ValueError(f"map_spec: the model has {S} subspaces: set assemble=True (consecutive node "
                             "blocks) or pick one with subspace=k")
        return 0
    if isinstance(key, bool) or not isinstance(key, (int, np.integer)) or not 0 <= key < S:
        raise ValueError(f"map_spec subspace must be an integer in 0..{S - 1}; got {key!r}")
    return int(key)


def _plan_nodes(map_spec, spec: DatasetSpec, assemble: bool, S: int, m: int) -> tuple[int, int]:
    """The node range `[start, stop)` the outputs map: within the dataset's labelled nodes and
    as wide as the model's outputs (`S·m` assembled, else `m`)."""
    width = S * m if assemble else m
    labelled = node_slice(spec)
    nodes = map_spec.get("nodes")
    if nodes is None:
        start = labelled.start
        stop = start + width if assemble else labelled.stop
    else:
        if isinstance(nodes, slice):
            nodes = (nodes.start, nodes.stop)
        if (not isinstance(nodes, (list, tuple)) or len(nodes) != 2
                or any(isinstance(v, bool) or not isinstance(v, (int, np.integer)) for v in nodes)):
            raise ValueError(f"map_spec nodes must be [start, stop] (integers) or None; got {nodes!r}")
        start, stop = int(nodes[0]), int(nodes[1])
    if not labelled.start <= start < stop <= labelled.stop:
        raise ValueError(f"map_spec nodes [{start}, {stop}) are not within the nodes [{labelled.start}, "
                         f"{labelled.stop}) that dataset {spec.name!r} labels")
    if stop - start != width:
        what = f"{S} subspaces x {m} outputs" if assemble else f"{m} outputs"
        raise ValueError(f"map_spec covers {stop - start} nodes [{start}, {stop}) but the model gives {width} "
                         f"({what})")
    return start, stop


def _template_features(spec: DatasetSpec) -> np.ndarray | None:
    """The read-only feature row of the nominal arm whose columns `map_features` overwrites
    (`None` for datasets with random fixed values: every column comes from the arm)."""
    if spec.fixed == "random":
        return None
    if spec.is_chain_family:
        # the nominal arm (scales 1): map_features overwrites the scale columns
        template = features_for(np.ones((1, spec.n_arm_features)), spec)[0]
    else:
        zero = np.zeros((1, 6))
        template = features_for(DHRobot(zero, zero, zero), spec)[0]
    template.setflags(write=False)
    return template


def map_plan(config, map_spec) -> tuple[dict[str, Any], MapPlan]:
    """Validate `map_spec` against a model's config -> (normalised dict, plan)."""
    check_record(map_spec, {"dataset", "nodes", "assemble", "subspace", "threshold"}, "map_spec", "map_spec")
    spec = _plan_dataset(config, map_spec)
    assemble = map_spec.get("assemble", False)
    if not isinstance(assemble, (bool, np.bool_)):
        raise ValueError(f"map_spec assemble must be true or false; got {assemble!r}")
    assemble = bool(assemble)
    key = _plan_subspace(map_spec, assemble, config.n_subspaces)
    start, stop = _plan_nodes(map_spec, spec, assemble, config.n_subspaces, config.n_outputs)
    threshold = map_spec.get("threshold", 0.5)
    threshold = check_threshold(0.5 if threshold is None else threshold, "map_spec threshold")
    normalised = {"dataset": spec.to_dict(), "nodes": [start, stop], "assemble": assemble,
                  "subspace": key, "threshold": float(threshold)}
    return normalised, MapPlan(spec, slice(start, stop), assemble, key, float(threshold), _template_features(spec))


def family_scales(arms, spec) -> tuple[np.ndarray, tuple[int, ...]]:
    """The scale factors `(B, k)` and batch shape of the arms of a chain-family spec (`panda7`):
    `arms` is a `SerialChain` built by `wsmap.robots.family_arm`
    (one arm or a batch of any shape) or the scales themselves `(..., k)`. Arms of another kind
    (a `DHRobot`, a chain whose fixed transforms are not the family's) are refused with the
    family's `ValueError` / `TypeError`; scales outside the family's range as
    `wsmap.robots.family_arm` refuses them."""
    from ..kinematics import SerialChain

    family = spec.arm_family
    if isinstance(arms, DHRobot):
        raise TypeError(f"the model maps arms of the family {spec.family!r} (dataset {spec.name!r}): give a "
                        "SerialChain from wsmap.robots.family_arm or the scale factors, not a DHRobot")
    if isinstance(arms, SerialChain):
        scales = family.params_of(arms)
    else:
        scales = family.check_params(arms)
    batch = tuple(scales.shape[:-1])
    return scales.reshape(-1, family.n_params), batch


def map_batch_shape(arms, spec) -> tuple[int, ...]:
    """The batch shape of `arms` as `predict_maps` returns it."""
    if spec.is_chain_family:
        return family_scales(arms, spec)[1]
    return tuple(arms.batch_shape)


def check_map_arms(arms, spec) -> DHRobot:
    """`arms` as a 1-D batch `(B,)` of 6-joint arms with finite DH values, no limits, no tool."""
    if not isinstance(arms, DHRobot):
        raise TypeError(f"arms must be a wsmap.kinematics.DHRobot (one arm or a batch); got {type(arms).__name__}")
    if arms.n != 6:
        raise ValueError(f"the model maps 6-joint arms (the feature layout of dataset {spec.name!r}); "
                         f"got arms with {arms.n} joints")
    # DHRobot refuses non-finite values when built, but its arrays are plain attributes.
    for label in ("d", "a", "alpha"):
        values = np.asarray(getattr(arms, label))
        if not np.all(np.isfinite(values)):
            bad = np.flatnonzero(~np.isfinite(values.reshape(-1, arms.n)).all(axis=1))
            raise ValueError(f"DH column {label} contains NaN or infinite values (arms {bad[:5].tolist()})")
    if arms.qlim is not None:
        raise ValueError("the model was trained on arms without joint limits and cannot honour qlim; "
                         "drop the limits or use the classical map (method exact/numerical)")
    if arms.tool is not None:
        raise ValueError("arms with a tool transform have no place in the model's feature layout")
    if arms.d.ndim == 2:
        return arms
    n = arms.n
    return DHRobot(arms.d.reshape(-1, n), arms.a.reshape(-1, n), arms.alpha.reshape(-1, n))


def map_features(plan: MapPlan, arms, fixed=None) -> np.ndarray:
    """Features `(B, n_features)` float64 of `arms` (a `DHRobot`, one
    arm or a batch of any shape, flattened to `B` arms) for the plan's dataset spec.

    `fixed`: the orientation (R3 specs; rad) or point (SO3 specs; m), `(3,)` or `(B, 3)`;
    `None`: the spec's. Required for a spec with `fixed="random"`; for a fixed spec it must
    equal the spec's (1e-9). Raises `ValueError` / `TypeError` as `check_map_arms`.
    """
    spec = plan.spec
    if spec.is_chain_family:
        flat, _ = family_scales(arms, spec)
        n = flat.shape[0]
    else:
        flat = check_map_arms(arms, spec)
        n = flat.batch_shape[0]
    if fixed is not None:
        f = float64_array(fixed, f"fixed must be 3 numbers (or ({n}, 3)); got {fixed!r}")
        if f.shape not in ((3,), (n, 3)):
            raise ValueError(f"fixed must have shape (3,) or ({n}, 3), got {f.shape}")
        require_finite(f, "fixed contains NaN or infinite values")
        if spec.fixed != "random" and not np.allclose(f, spec.fixed, rtol=0, atol=1e-9):
            what = "orientation (rad)" if spec.scope == "R3" else "point (m)"
            raise ValueError(f"the model was trained at the fixed {what} {list(spec.fixed)} only "
                             f"(dataset {spec.name!r}); got {np.round(f, 6).tolist()}")
    if fixed is None and plan.template is not None:
        # features_for's layout, from the cached row: [d(6), a(6), alpha(6), grid axes, fixed(3)]
        X = np.empty((n, plan.template.size))
        X[:] = plan.template
        if spec.is_chain_family:
            X[:, :flat.shape[1]] = flat
        else:
            X[:, 0:6], X[:, 6:12], X[:, 12:18] = flat.d, flat.a, flat.alpha
        return X
    return features_for(flat, spec, fixed)


_GRID_KEYS = ("scope", "lo", "hi", "step", "shape")


def grid_mismatch(spec, grid: dict) -> list[str]:
    """How a caller's grid (`scope`, `lo`, `hi`, `step`, optionally `shape`, as
    `wsmap.workspace.grid_spec` describes one) differs from the dataset spec's; empty when they
    agree (1e-9 tolerance). A grid that is not such a dict raises `ValueError`."""
    if not isinstance(grid, dict):
        raise ValueError(f"grid must be a dict with scope, lo, hi, step; got {type(grid).__name__}")
    unknown = sorted(set(grid) - set(_GRID_KEYS))
    if unknown:
        raise ValueError(f"unknown grid keys {unknown}; known: {list(_GRID_KEYS)}")
    problems = []
    scope = grid.get("scope", spec.scope)
    if scope not in ("R3", "SO3"):
        raise ValueError(f"grid scope must be 'R3' or 'SO3'; got {scope!r}")
    if scope != spec.scope:
        problems.append(f"scope {scope} (model: {spec.scope})")
    for k in ("lo", "hi", "step"):
        if k in grid and grid[k] is not None:
            want = np.broadcast_to(np.asarray(getattr(spec, k), dtype=np.float64), 3)
            try:
                got = np.broadcast_to(np.asarray(grid[k], dtype=np.float64), 3)
            except (TypeError, ValueError):
                raise ValueError(f"grid {k} must be one number or three; got {grid[k]!r}") from None
            if not np.allclose(got, want, rtol=0, atol=1e-9):
                problems.append(f"{k} {np.round(got, 6).tolist()} (model: {np.round(want, 6).tolist()})")
    if grid.get("shape") is not None and not problems:
        try:
            shape = [int(v) for v in grid["shape"]]
        except (TypeError, ValueError):
            raise ValueError(f"grid shape must be 3 integers; got {grid['shape']!r}") from None
        if shape != list(spec.grid_shape):
            problems.append(f"shape {shape} (model: {list(spec.grid_shape)})")
    return problems


def spec_feature_names(dataset_spec, n_features: int) -> list[str] | None:
    """The feature names of a dataset spec (a `DatasetSpec` or its dict) when it has
    `n_features` features; `None` when it is not a valid spec or has another layout."""
    if dataset_spec is None:
        return None
    try:
        spec = dataset_spec if isinstance(dataset_spec, DatasetSpec) else DatasetSpec.from_dict(
            dict(dataset_spec.to_dict() if hasattr(dataset_spec, "to_dict") else dataset_spec))
        names = list(feature_names(spec))
    except (TypeError, ValueError, KeyError, AttributeError):
        return None
    return names if len(names) == n_features else None
