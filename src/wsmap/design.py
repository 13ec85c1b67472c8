"""Design by gradient: the shortest arm of a family whose workspace covers given task positions.

Issue 14, part 5. A map model (`wsmap.learn.SubspaceMLP`) is differentiable in the arm's
parameters, so the question "which arm of the family, with the smallest total link length, reaches
every task position at the task orientation?" can be answered by gradient descent through the
network, and the answer checked with the classical map at the tasks. The same question asked of
the classical map directly needs a gradient-free search (CMA-ES, random search). `compare_designs`
runs both in one process and reports the time each needs to reach a design *verified by the
classical map*.

Conventions
-----------
* Positions are metres in the arm's base frame (`panda7`: the mounting flange, `panda_link0`;
  spherical-wrist family: the frame of joint 1, shoulder at the origin since d1 = 0).
* A *family* (`DesignFamily`, `design_family`) has `n` design parameters `params`
  with box bounds: `panda7`'s six dimensionless scale factors (d1, d3, d5, a4, a5, a7; range
  `[0.7, 1.3]`), or the spherical-wrist family's lengths (a2, a3, d3, d4) in metres (range
  `[0, 0.5]`, the paper's `beta`). The *total link length* is the sum of the absolute scaled
  lengths in metres, linear in the parameters (`DesignFamily.total_length`); lengths that are
  not design variables (the Panda's flange row, 0.107 m) are left out.
* The task orientation is a fixed `rpy` (rad, `R = Rx·Ry·Rz`) with a pose convention of
  `wsmap.workspace.maps`. Defaults: `panda7` tool-down, `rpy = (pi, 0, 0)`, `"standard"`
  (`T = transl(p)·R`, the `panda7_tooldown` dataset); spherical wrist `(0, 0, 0)` (the paper's
  models; with unlimited joints and the tool point at the wrist centre its map does not depend
  on the orientation, so tool-down tasks have the same answer).
* A *surrogate* is any callable `params (k, n) torch.float64 -> (k, T)` margins, positive where
  the surrogate says the task is covered, differentiable in `params`. `MapSurrogate` makes
  one from a map model by trilinear interpolation of the model's node outputs (logits for an
  `output_kind "logit"` model, raw scores for `"linear"`) minus the model's threshold.
* *Verification* is the classical map at the task positions
  (`wsmap.workspace.constant_orientation_map`: closed form for the spherical-wrist family,
  the compiled numerical search for `panda7`). `classical_calls` counts arms whose map at all
  tasks was computed (one arm x T tasks = 1 call), batched into as few library calls as possible.
"""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import torch

from . import robots
from . import workspace as ws

__all__ = [
    "DesignFamily",
    "DESIGN_FAMILIES",
    "design_family",
    "box_tasks",
    "check_tasks",
    "MapSurrogate",
    "DesignResult",
    "design_by_gradient",
    "design_by_cmaes",
    "design_by_random_search",
    "compare_designs",
    "format_design_table",
]


# ------------------------------------------------------------------------------------------ families
@dataclass(frozen=True)
class DesignFamily:
    """A family of arms (`wsmap.robots.ArmFamily`) seen as a design space.

    Attributes
    ----------
    family
        the arm family of `wsmap.robots.FAMILIES`: its arms, parameters and range.
    params
        the `n` design parameters, in order: the family's parameters by name (`panda7`:
        its own order; the spherical wrist: `(a2, a3, d3, d4)`).
    length_coeffs
        `(n,)` metres per unit of each parameter: the total link length is
        `sum(length_coeffs * params)` (the absolute nominal lengths for `panda7`, ones for
        the spherical-wrist family whose parameters are lengths).
    rpy, convention
        the default task orientation (rad) and pose convention.
    """

    family: robots.ArmFamily
    params: tuple[str, ...]
    length_coeffs: np.ndarray
    rpy: tuple[float, float, float]
    convention: str

    def __post_init__(self):
        if sorted(self.params) != sorted(self.family.params):
            raise ValueError(f"design parameters {self.params} must be the parameters of family "
                             f"{self.family.name!r} ({', '.join(self.family.params)}) in some order")

    @property
    def name(self) -> str:
        """`"panda7"` or `"spherical_wrist"` (`DESIGN_FAMILIES`)."""
        return self.family.name

    @property
    def n_params(self) -> int:
        return len(self.params)

    @property
    def low(self) -> np.ndarray:
        """Lower bounds `(n,)` of the parameters: the family's range (units: see the module docstring)."""
        return np.full(self.n_params, self.family.low)

    @property
    def high(self) -> np.ndarray:
        """Upper bounds `(n,)` of the parameters."""
        return np.full(self.n_params, self.family.high)

    @property
    def method(self) -> str:
        """The classical map's method for this family: `"exact"` where the family has a closed form."""
        return "exact" if self.family.exact else "numerical"

    def total_length(self, params):
        """Total link length in metres of `params` `(..., n)` (numpy or torch): `(...)`."""
        if isinstance(params, torch.Tensor):
            return params @ torch.as_tensor(self.length_coeffs, dtype=params.dtype, device=params.device)
        return np.asarray(params, dtype=np.float64) @ self.length_coeffs

    def arms(self, params):
        """The arms of `params` `(k, n)`: a batch `(k,)` for the classical map."""
        p = np.asarray(params, dtype=np.float64)
        order = [self.params.index(name) for name in self.family.params]
        return self.family.arms(p[..., order])

    def classical(self, params, tasks, rpy=None, convention=None) -> np.ndarray:
        """The classical map of the arms `params` `(k, n)` at `tasks` `(T, 3)` (m): bool `(k, T)`."""
        rpy = self.rpy if rpy is None else rpy
        convention = self.convention if convention is None else convention
        p = np.atleast_2d(np.asarray(params, dtype=np.float64))
        return ws.constant_orientation_map(self.arms(p), tasks, rpy, method=self.method, convention=convention)

    def model_columns(self, spec) -> list[int]:
        """The feature columns (of `wsmap.datasets.features_for`'s layout for `spec`) that
        hold each design parameter, in parameter order: a scaled family's scale columns, else the
        DH table entries the parameters set."""
        from .datasets.features import feature_slices

        columns = feature_slices(spec)
        if self.family.scaled:
            return [columns["scales"].start + self.family.params.index(name) for name in self.params]
        entries = dict(zip(self.family.params, self.family.entries()))
        return [columns[column].start + row for column, row in (entries[name] for name in self.params)]

    def feature_template(self, spec) -> np.ndarray:
        """One feature row `(n_features,)` for `spec` (any arm of the family: the design columns
        are overwritten by `MapSurrogate`)."""
        from .datasets.features import features_for

        mid = (self.low + self.high) / 2
        arms = mid[None] if self.family.scaled else self.arms(mid[None])
        return features_for(arms, spec)[0]


#: The design families by name. The spherical-wrist range `[0, 0.5]` m is the paper's (`beta`).
DESIGN_FAMILIES: dict[str, DesignFamily] = {
    "panda7": DesignFamily(robots.PANDA7, robots.PANDA7.params, np.abs(robots.PANDA7.nominal), (math.pi, 0.0, 0.0),
                           "standard"),
    "spherical_wrist": DesignFamily(robots.SPHERICAL_WRIST, ("a2", "a3", "d3", "d4"), np.ones(4), (0.0, 0.0, 0.0),
                                    "standard"),
}


#: What a design space must have besides `DesignFamily` itself (e.g.
#: `wsmap.morph_design.MorphDesignSpace`, arms of any twist pattern): `name`, `params`,
#: `n_params`, `low`, `high`, `total_length(params)` (numpy and torch) and
#: `classical(params, tasks, rpy, convention)`.
DESIGN_SPACE_ATTRIBUTES = ("name", "params", "n_params", "low", "high", "total_length", "classical")


def design_family(family) -> DesignFamily:
    """`family` (a name, a `DesignFamily` or another design space with
    `DESIGN_SPACE_ATTRIBUTES`) as a design space; an unknown name is a `ValueError`
    listing the known ones."""
    if isinstance(family, DesignFamily) or (not isinstance(family, str)
                                            and all(hasattr(family, a) for a in DESIGN_SPACE_ATTRIBUTES)):
        return family
    if not isinstance(family, str) or family not in DESIGN_FAMILIES:
        raise ValueError(f"unknown design family {family!r}; known families: {', '.join(DESIGN_FAMILIES)}")
    return DESIGN_FAMILIES[family]


def _bounds(fam: DesignFamily, bounds) -> tuple[np.ndarray, np.ndarray]:
    if bounds is None:
        return fam.low.copy(), fam.high.copy()
    lo, hi = (np.broadcast_to(np.asarray(b, dtype=np.float64), (fam.n_params,)).copy() for b in bounds)
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)) and np.all(lo < hi)):
        raise ValueError(f"bounds must be finite with low < high for each of {fam.params}, got {lo}, {hi}")
    if np.any(lo < fam.low - 1e-12) or np.any(hi > fam.high + 1e-12):
        raise ValueError(f"bounds {lo.tolist()}..{hi.tolist()} leave the range of family {fam.name!r} "
                         f"({fam.low.tolist()}..{fam.high.tolist()})")
    return lo, hi


# ------------------------------------------------------------------------------------------ tasks
def box_tasks(centre, size: float = 0.4) -> np.ndarray:
    """The 20 task positions of an axis-aligned cube: 8 corners then 12 edge midpoints, `(20, 3)` m.

    `centre` (3,) m in the base frame, `size` the edge length in m. Corners are in
    `itertools.product([-1, 1], repeat=3)` order of their offsets `±size/2`; an edge midpoint has
    one offset 0 (x-parallel edges first, then y, then z).
    """
    c = np.asarray(centre, dtype=np.float64)
    if c.shape != (3,) or not np.all(np.isfinite(c)):
        raise ValueError(f"centre must be 3 finite numbers (m), got {centre!r}")
    if not (isinstance(size, (int, float, np.floating, np.integer)) and math.isfinite(size) and size > 0):
        raise ValueError(f"size must be a positive finite number of metres, got {size!r}")
    h = size / 2
    corners = [np.array(s, dtype=np.float64) * h for s in itertools.product((-1, 1), repeat=3)]
    edges = []
    for axis in range(3):  # the edge parallel to `axis`: that coordinate 0, the other two ±h
        for s in itertools.product((-1, 1), repeat=2):
            e = np.insert(np.array(s, dtype=np.float64) * h, axis, 0.0)
            edges.append(e)
    return c + np.array(corners + edges)


def check_tasks(tasks) -> np.ndarray:
    """`tasks` as a float64 array `(T, 3)` of finite positions (m), `T >= 1`."""
    try:
        t = np.array(tasks, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"tasks must be positions (T, 3) in metres, got {type(tasks).__name__}") from None
    if t.ndim != 2 or t.shape[1] != 3 or t.shape[0] < 1:
        raise ValueError(f"tasks must have shape (T, 3) with T >= 1, got {t.shape}")
    bad = ~np.all(np.isfinite(t), axis=1)
    if bad.any():
        i = int(np.argmax(bad))
        raise ValueError(f"task {i} is not a finite position: {t[i].tolist()}")
    return t


# ------------------------------------------------------------------------------------------ surrogate
def _surrogate_spec(model, fam: DesignFamily, tasks: np.ndarray, rpy, convention):
    """The `DatasetSpec` of a map model's `map_spec`, checked for a design of `fam` at the
    tasks' orientation `rpy` (rad) and `convention` (`TypeError` / `ValueError`)."""
    from .datasets.spec import DatasetSpec
    from .learn.network import SubspaceMLP

    if not isinstance(model, SubspaceMLP):
        raise TypeError(f"model must be a wsmap.learn.SubspaceMLP, got {type(model).__name__}")
    ms = model.map_spec
    if ms is None:
        raise ValueError("the model has no map_spec (which grid its outputs are): set one with "
                         "model.set_map_spec(dataset_spec)")
    spec = DatasetSpec.from_dict(dict(ms["dataset"]))
    if spec.family != fam.name:
        raise ValueError(f"the model maps family {spec.family!r} (dataset {spec.name!r}), not {fam.name!r}")
    if spec.scope != "R3" or spec.fixed == "random":
        raise ValueError(f"the model maps {spec.scope} with fixed={spec.fixed!r}: a design needs a "
                         "constant-orientation (R3) model at one fixed orientation")
    # the model's and the tasks' target poses must be the same (the paper and standard
    # conventions agree at R = I, so the paper's identity-orientation models serve both)
    want = ws.target_poses(tasks, rpy, convention)
    have = ws.target_poses(tasks, spec.fixed, spec.convention)
    if not np.allclose(want, have, rtol=0, atol=1e-9):
        raise ValueError(f"the model was trained at orientation {list(spec.fixed)} rad ({spec.convention} "
                         f"convention); the tasks are at {list(np.round(rpy, 6))} ({convention})")
    return spec


def _task_cells(spec, tasks: np.ndarray, nodes: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Trilinear interpolation of the tasks `(T, 3)` m on the grid of `spec`: the flat node
    index `(T, 8)` of each cell corner and its weight `(T, 8)`. `ValueError` for a task outside
    the grid, or whose cell has a weighted node outside the model's `nodes` `[start, stop)`."""
    lo, hi = np.array(spec.lo, dtype=np.float64), np.array(spec.hi, dtype=np.float64)
    lo, hi = np.broadcast_to(lo, (3,)), np.broadcast_to(hi, (3,))
    step = np.broadcast_to(np.array(spec.step, dtype=np.float64), (3,))
    shape = np.array(spec.grid_shape)
    top = lo + (shape - 1) * step  # the last node on each axis
    out = np.any((tasks < lo - 1e-9) | (tasks > top + 1e-9), axis=1)
    if out.any():
        i = int(np.argmax(out))
        raise ValueError(f"task {i} at {np.round(tasks[i], 6).tolist()} m is outside the model's grid "
                         f"[{lo[0]:g}, {top[0]:g}] x [{lo[1]:g}, {top[1]:g}] x [{lo[2]:g}, {top[2]:g}] m "
                         f"(dataset {spec.name!r})")
    # cell of each task: index of its lower node, clipped so a task on the last node uses the
    # last cell (weight 1 on its upper node)
    f = (tasks - lo) / step
    i0 = np.clip(np.floor(f + 1e-9).astype(np.int64), 0, np.maximum(shape - 2, 0))
    t = np.clip(f - i0, 0.0, 1.0)
    corners = np.array(list(itertools.product((0, 1), repeat=3)))  # (8, 3): offsets (dx, dy, dz)
    idx = i0[:, None, :] + corners[None]  # (T, 8, 3)
    idx = np.minimum(idx, shape - 1)  # a one-node axis: both corners the same node
    flat = idx[..., 0] + shape[0] * (idx[..., 1] + shape[1] * idx[..., 2])  # node order: x fastest
    w = np.prod(np.where(corners[None] == 1, t[:, None, :], 1.0 - t[:, None, :]), axis=-1)  # (T, 8)
    start, stop = nodes
    # a corner of weight 0 (a task on a cell face or node) may be off a node-slice model: it is
    # not needed, so it reads the task's heaviest corner instead
    flat = np.where(w > 0, flat, flat[np.arange(len(flat)), np.argmax(w, axis=1)][:, None])
    uncovered = np.any((flat < start) | (flat >= stop), axis=1)
    if uncovered.any():
        i = int(np.argmax(uncovered))
        covered_nodes = ws.cartesian_grid(spec.lo, spec.hi, spec.step)[start:stop]
        blo, bhi = covered_nodes.min(axis=0), covered_nodes.max(axis=0)
        raise ValueError(f"task {i} at {np.round(tasks[i], 6).tolist()} m lies in a grid cell the model "
                         f"does not cover: it maps nodes [{start}, {stop}) of dataset {spec.name!r}, the box "
                         f"[{blo[0]:g}, {bhi[0]:g}] x [{blo[1]:g}, {bhi[1]:g}] x [{blo[2]:g}, {bhi[2]:g}] m")
    return flat, w


def _surrogate_bounds(fam: DesignFamily, spec, model) -> tuple[np.ndarray, np.ndarray]:
    """The family's range intersected with the model's training range of the design features."""
    blo, bhi = fam.low.copy(), fam.high.copy()
    rng = model.training_range
    if rng is not None:
        cols = fam.model_columns(spec)
        blo = np.maximum(blo, np.asarray(rng.low, dtype=np.float64)[cols])
        bhi = np.minimum(bhi, np.asarray(rng.high, dtype=np.float64)[cols])
        if np.any(blo >= bhi):
            raise ValueError(f"the model's training range does not overlap the range of family {fam.name!r}")
    return blo, bhi


class MapSurrogate:
    """Differentiable task coverage from a map model: trilinear interpolation of node outputs.

    `model` is a `wsmap.learn.SubspaceMLP` with a `map_spec` of an R3 dataset of the
    family (fixed orientation), e.g. `panda7_tooldown` or the paper's `sec62`. For each task
    `p` (m) in the grid, the margin is `sum_c w_c (raw_c - raw_threshold)` over the 8 nodes
    `c` of the grid cell holding `p` (trilinear weights `w_c`); `raw` is the model's raw
    output (a logit for `output_kind "logit"`, whose threshold is `logit(t)`; the score for
    `"linear"`, threshold `t`), so at a node the margin is positive exactly where the model
    predicts the node reachable, and between nodes it is linear along each axis.

    Raises `ValueError` before any work: a task outside the grid (naming the task index, its
    position and the grid's bounds) or on a cell whose nodes the model does not cover (a node-slice
    model such as the paper's block 5), a model of another family or scope, or a model trained at
    another orientation than the tasks'.

    Attributes
    ----------
    bounds
        `(low, high)` of the design parameters: the family's range intersected with the
        model's training range of those features (so the descent never leaves where the model
        was trained).
    default_margin
        the margin asked of every task before verification (1.0 for logits, i.e.
        `p >= 0.73`; 0.1 for linear scores).
    """

    def __init__(self, model, family, tasks, *, rpy=None, convention=None):
        from .learn.network import ACTIVATIONS

        fam = design_family(family)
        tasks = check_tasks(tasks)
        rpy = fam.rpy if rpy is None else rpy
        convention = fam.convention if convention is None else convention
        spec = _surrogate_spec(model, fam, tasks, rpy, convention)
        ms = model.map_spec
        self.family, self.tasks, self.spec = fam, tasks, spec
        self.rpy, self.convention = tuple(float(v) for v in rpy), convention
        self.model = model
        flat, w = _task_cells(spec, tasks, ms["nodes"])
        self.weights = torch.as_tensor(w, dtype=torch.float64)  # (T, 8)
        # the outputs the margins need: each distinct node once (shared corners of neighbouring tasks)
        need, inverse = np.unique(flat.reshape(-1), return_inverse=True)
        self._inverse = torch.as_tensor(inverse.reshape(flat.shape), dtype=torch.long)  # (T, 8) into need
        m = model.config.n_outputs
        local = need - ms["nodes"][0]
        if ms["assemble"]:
            sub, col = local // m, local % m
        else:
            sub, col = np.full(len(local), ms["subspace"]), local
        # per subspace: the output columns it gives, and where they go in `need` order
        self._groups = [(int(s), torch.as_tensor(col[sub == s]), torch.as_tensor(np.flatnonzero(sub == s)))
                        for s in np.unique(sub)]
        self._n_need = len(need)
        self._act = ACTIVATIONS[model.config.activation][0]
        thr = float(ms["threshold"])
        self.logit = model.config.output_kind == "logit"
        self.raw_threshold = math.log(thr / (1 - thr)) if self.logit else thr
        self.default_margin = 1.0 if self.logit else 0.1
        self._template = torch.as_tensor(fam.feature_template(spec), dtype=torch.float64)
        self._columns = torch.as_tensor(fam.model_columns(spec), dtype=torch.long)
        self.bounds = _surrogate_bounds(fam, spec, model)

    def features(self, params: torch.Tensor) -> torch.Tensor:
        """Feature rows `(k, n_features)` (float64, differentiable) of design parameters `(k, n)`."""
        x = self._template.expand(params.shape[0], -1).clone()
        x[:, self._columns] = params.to(torch.float64)
        return x

    def node_outputs(self, params: torch.Tensor) -> torch.Tensor:
        """The model's raw outputs at the nodes the tasks need, `(k, n_nodes)`.

        Only the needed columns of the output layer are computed: that layer is most of the
        network's cost (e.g. 256 x 9261 for a whole 21³ grid) and the tasks need ~160 nodes.
        Equal to the columns of `model.forward` (`assemble` for an assembled model).
        """
        model = self.model
        x = self.features(params)
        out = x.new_zeros((x.shape[0], self._n_need), dtype=model.weights[0].dtype)
        last = model.n_layers - 1
        for s, cols, where in self._groups:
            h = model.network_inputs(x, key=s)
            for j, (W, b) in enumerate(zip(model.weights, model.biases)):
                if j < last:
                    h = self._act(torch.addmm(b[s], h, W[s]))
                else:
                    h = torch.addmm(b[s][cols], h, W[s][:, cols])
            out = out.index_copy(1, where, h)
        return out

    def __call__(self, params: torch.Tensor) -> torch.Tensor:
        """Margins `(k, T)` float64 of design parameters `(k, n)`: positive = covered."""
        raw = self.node_outputs(params).to(torch.float64) - self.raw_threshold  # (k, n_nodes)
        return (raw[:, self._inverse] * self.weights).sum(-1)


# ------------------------------------------------------------------------------------------ results
@dataclass
class DesignResult:
    """One design search.

    Attributes
    ----------
    method
        `"gradient"`, `"cmaes"` or `"random"`.
    family
        the family's name; `param_names` its parameters.
    params
        the design `(n,)`: `panda7` scale factors (dimensionless), spherical-wrist
        lengths a2, a3, d3, d4 (m). The shortest verified design found, or (none verified) the
        candidate covering the most tasks.
    total_length
        its total link length, m.
    verified
        the classical map covers every task with `params`.
    covered
        `(T,)` bool, the classical map of `params` at the tasks.
    classical_calls
        arms whose classical map at the tasks was computed.
    surrogate_evals
        arms passed through the surrogate (forward + backward), 0 without one.
    wall_time
        seconds of the whole search.
    time_to_verified
        seconds until the first verified design (`None`: none).
    time_to_target
        seconds until a verified design of total length `<= target_length`
        (`None`: not reached or no target).
    target_length
        the length goal of a gradient-free search (m), or `None`.
    path
        `(steps, 2)`: total length (m) and surrogate coverage (fraction of tasks with a
        positive margin) per descent step of the start that gave `params` (gradient only;
        `(evaluations, 2)`, best-so-far length of a verified design and its classical
        coverage, for the gradient-free searches).
    margins
        the margin asked of each start at its last round (gradient only).
    rounds
        verification rounds (gradient) or generations / batches (gradient-free).
    classical_time
        seconds of `wall_time` spent in the classical map.
    """

    method: str
    family: str
    param_names: tuple[str, ...]
    params: np.ndarray
    total_length: float
    verified: bool
    covered: np.ndarray
    classical_calls: int
    surrogate_evals: int
    wall_time: float
    time_to_verified: float | None
    time_to_target: float | None = None
    target_length: float | None = None
    path: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    margins: np.ndarray | None = None
    rounds: int = 0
    classical_time: float = 0.0

    def row(self) -> dict:
        """One row of `compare_designs`'s table (plain Python values)."""
        return {"method": self.method, "family": self.family,
                "time_to_verified_s": self.time_to_verified, "time_to_target_s": self.time_to_target,
                "wall_s": self.wall_time, "classical_s": self.classical_time,
                "classical_calls": self.classical_calls,
                "surrogate_evals": self.surrogate_evals, "total_length_m": self.total_length,
                "covered": f"{int(self.covered.sum())}/{self.covered.size}", "verified": self.verified,
                "params": [round(float(v), 4) for v in self.params]}


class _Verifier:
    """Counts and times classical calls; `fn(params (k, n)) -> bool (k, T)`."""

    def __init__(self, fn):
        self.fn, self.calls, self.seconds = fn, 0, 0.0

    def __call__(self, params: np.ndarray) -> np.ndarray:
        t = time.perf_counter()
        out = np.asarray(self.fn(np.atleast_2d(params)), dtype=bool)
        self.seconds += time.perf_counter() - t
        self.calls += out.shape[0]
        return out


def _verifier(fam, tasks, verify, rpy, convention) -> _Verifier:
    if verify is None:
        return _Verifier(lambda p: fam.classical(p, tasks, rpy, convention))
    if not callable(verify):
        raise TypeError(f"verify must be callable (params (k, n) -> bool (k, T)), got {type(verify).__name__}")
    return _Verifier(verify)


def _rng(seed):
    return seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)


# ------------------------------------------------------------------------------------------ gradient
def _start_designs(fam: DesignFamily, starts, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray | None, int]:
    """`design_by_gradient`'s `starts`: `(None, count)` for a count, `(rows, len(rows))` for
    start designs `(k, n)` (checked: finite, inside `[lo, hi]`)."""
    if not isinstance(starts, (np.ndarray, list, tuple)):
        return None, starts
    start_rows = np.array(starts, dtype=np.float64)
    if start_rows.ndim != 2 or start_rows.shape[1] != fam.n_params or len(start_rows) < 1:
        raise ValueError(f"starts must be a positive integer or designs (k, {fam.n_params}), "
                         f"got shape {start_rows.shape}")
    if not np.all(np.isfinite(start_rows)) or np.any(start_rows < lo - 1e-12) or np.any(start_rows > hi + 1e-12):
        raise ValueError("every start design must be finite and inside the bounds")
    return start_rows, len(start_rows)


def _check_descent_counts(starts, steps, max_rounds, dual_every, verify_top) -> None:
    """`ValueError` for a count of `design_by_gradient` that is not a positive integer."""
    for name, v in (("starts", starts), ("steps", steps), ("max_rounds", max_rounds), ("dual_every", dual_every)):
        if isinstance(v, bool) or int(v) != v or v < 1:
            raise ValueError(f"{name} must be a positive integer, got {v!r}")
    if verify_top is not None and (isinstance(verify_top, bool) or int(verify_top) != verify_top or verify_top < 1):
        raise ValueError(f"verify_top must be None or a positive integer, got {verify_top!r}")


def _unit_starts(fam: DesignFamily, start_rows: np.ndarray | None, starts: int, lo: np.ndarray, hi: np.ndarray,
                 rng: np.random.Generator) -> np.ndarray:
    """The starting points `(starts, n)` in unit coordinates `u = (params − lo)/(hi − lo)`:
    the given designs, or the upper corner, the centre, then `starts − 2` uniform draws of `rng`."""
    if start_rows is not None:
        u0 = list((start_rows - lo) / (hi - lo))
    else:
        u0 = [np.ones(fam.n_params), np.full(fam.n_params, 0.5)] + [rng.uniform(size=fam.n_params)
                                                                     for _ in range(max(starts - 2, 0))]
    return np.clip(np.array(u0[:starts]), 0.0, 1.0)


class _Descent:
    """The augmented-Lagrangian descent of `design_by_gradient`, all starts at once.

    Holds the unit coordinates `u` `(k, n)` with their Adam state, the multipliers `lam`
    `(k, T)`, the penalty weights `rho` `(k, 1)`, the worst violation at the last dual update,
    the per-step path (total length, surrogate coverage) of every start and the count of
    surrogate evaluations.
    """

    def __init__(self, surrogate, fam: DesignFamily, lo: np.ndarray, hi: np.ndarray, u0: np.ndarray, n_tasks: int,
                 lr: float, rho: float):
        self.surrogate, self.fam, self.lr = surrogate, fam, lr
        self.u = torch.tensor(u0, dtype=torch.float64, requires_grad=True)
        self.k = self.u.shape[0]
        self.lo_t, self.span_t = torch.as_tensor(lo), torch.as_tensor(hi - lo)
        self.l_max = float(fam.total_length(hi))
        self.lam = torch.zeros((self.k, n_tasks), dtype=torch.float64)
        self.rho = torch.full((self.k, 1), float(rho), dtype=torch.float64)
        self.opt = torch.optim.Adam([self.u], lr=lr)
        self.paths: list[np.ndarray] = []
        self.evals = 0
        self.new_round()

    def new_round(self) -> None:
        """Forget the last worst violation (a round's margins differ from the last round's)."""
        self.worst_prev = torch.full((self.k,), math.inf, dtype=torch.float64)

    def run_round(self, margins: np.ndarray, steps: int, dual_every: int) -> np.ndarray:
        """`steps` descent steps asking margins `(k,)`; returns the final designs `(k, n)`."""
        m_t = torch.as_tensor(margins)[:, None]
        for it in range(steps):
            for g in self.opt.param_groups:  # geometric decay to 1 % over the round
                g["lr"] = self.lr * 0.01 ** (it / max(steps - 1, 1))
            c = self._step(m_t)
            if (it + 1) % dual_every == 0:
                self._dual_update(c)
        with torch.no_grad():
            return (self.lo_t + self.span_t * self.u).numpy().copy()

    def _step(self, m_t: torch.Tensor) -> torch.Tensor:
        """One Adam step on `L/L_max + sum psi(m − margin)`, then `u` clamped to `[0, 1]`;
        returns the constraint values `c = m − margin` `(k, T)` (detached)."""
        params = self.lo_t + self.span_t * self.u
        g_i = self.surrogate(params)  # (k, T)
        self.evals += self.k
        length = self.fam.total_length(params)
        c = m_t - g_i
        psi = (torch.clamp(self.lam + self.rho * c, min=0) ** 2 - self.lam ** 2) / (2 * self.rho)
        loss = (length / self.l_max + psi.sum(-1)).sum()  # starts are independent: sum their losses
        self.opt.zero_grad()
        loss.backward()
        self.opt.step()
        with torch.no_grad():
            self.u.clamp_(0.0, 1.0)
            self.paths.append(np.stack([length.detach().numpy(), (g_i.detach() > 0).double().mean(-1).numpy()], -1))
        return c.detach()

    def _dual_update(self, c: torch.Tensor) -> None:
        """`lam ← max(0, lam + rho c)`; `rho` doubles (to at most 1e3) where the worst violation
        has not halved since the last update."""
        self.lam = torch.clamp(self.lam + self.rho * c, min=0)
        worst = c.clamp(min=0).max(-1).values
        grow = (worst > 0.5 * self.worst_prev) & (worst > 0)
        self.rho = torch.where(grow[:, None], torch.clamp(self.rho * 2, max=1e3), self.rho)
        self.worst_prev = worst


def _verify_finals(fam: DesignFamily, surrogate, check: _Verifier, final: np.ndarray, n_tasks: int,
                   verify_top: int | None) -> tuple[tuple[int, np.ndarray, np.ndarray, bool], int]:
    """Check a round's final designs `(k, n)` with the classical map (with `verify_top`: only
    the shortest ones the surrogate says cover every task).

    Returns `((start, params, covered, verified), surrogate_evals)`: the shortest verified
    design, or (none verified) the most covered then shortest checked one (nothing checked: the
    one the surrogate covers most, checked alone).
    """
    k = len(final)
    lengths = fam.total_length(final)
    evals = 0
    if verify_top is None:
        rows = np.arange(k)
    else:  # the shortest finals the surrogate says cover every task
        with torch.no_grad():
            predicted = (surrogate(torch.as_tensor(final)) > 0).numpy()
        evals = k
        cand = np.flatnonzero(predicted.all(-1))
        rows = cand[np.argsort(lengths[cand], kind="stable")][: int(verify_top)]
    covered = check(final[rows]) if len(rows) else np.zeros((0, n_tasks), dtype=bool)
    ok = covered.all(-1)
    if ok.any():
        j = int(np.flatnonzero(ok)[np.argmin(lengths[rows][ok])])
        return (int(rows[j]), final[rows[j]], covered[j], True), evals
    if len(rows):
        j = int(np.lexsort((lengths[rows], -covered.sum(-1)))[0])  # most covered, then shortest
        return (int(rows[j]), final[rows[j]], covered[j], False), evals
    # nothing predicted covering: the most covered by the surrogate, checked
    i = int(np.lexsort((lengths, -predicted.sum(-1)))[0])
    return (i, final[i], check(final[i:i + 1])[0], False), evals


def design_by_gradient(family, tasks, model, *, rpy=None, convention=None, verify=None, bounds=None,
                       starts: int | np.ndarray = 8, steps: int = 500, lr: float = 0.1, margin: float | None = None,
                       margin_step: float | None = None, max_rounds: int = 6, rho: float = 0.1,
                       dual_every: int = 10, verify_top: int | None = None, seed=0) -> DesignResult:
    """Shortest design covering `tasks`, by augmented-Lagrangian gradient descent through `model`.

    Problem: minimise `total_length(params)` over the box `bounds` subject to
    `margin_i(params) >= m` for every task `i` (the surrogate's margins, `m` the asked margin).

    Method: the parameters are mapped to `u in [0, 1]^n` (so one learning rate suits every
    parameter); from `starts` starting points at once (the upper corner, where the arm is
    largest, the centre, then uniform draws from `seed`; or the rows of an array `(k, n)` of
    starting designs inside `bounds`), Adam minimises
    `L/L_max + sum_i psi(m - margin_i)` with the augmented-Lagrangian term
    `psi(c) = (max(0, lam + rho c)^2 - lam^2) / (2 rho)`; every `dual_every` steps
    `lam <- max(0, lam + rho c)` and `rho` doubles (to at most 1e3) when the worst violation
    has not halved. After each step `u` is clamped to `[0, 1]`. The learning rate decays
    geometrically to 1 % over a round of `steps` steps. (Defaults tuned on the paper's
    spherical-wrist model: a small `rho` keeps the penalty soft where the logits are steep;
    several starts because the feasible set is not convex -- e.g. a3 and d4 add up in the length
    but in quadrature in the reach, so the shortest designs lie on corners of the box.) At the
    end of a round the final design of every start is checked with the classical map (with
    `verify_top`: only the `verify_top` shortest finals whose surrogate margins are all
    positive, the rest costing no classical call); if some are verified the shortest is returned;
    otherwise each start's margin rises by
    `margin_step` and its descent continues (multipliers kept), for at most `max_rounds`
    rounds.

    Parameters
    ----------
    family
        a name of `DESIGN_FAMILIES` or a `DesignFamily`.
    tasks
        positions `(T, 3)` m in the base frame.
    model
        a `wsmap.learn.SubspaceMLP` with a `map_spec` (made a
        `MapSurrogate`: tasks outside its grid are a `ValueError` before any work), or
        any surrogate callable `params (k, n) float64 tensor -> margins (k, T)`,
        differentiable, positive = covered (it may have `bounds` and `default_margin`).
    rpy, convention
        task orientation (rad) and pose convention; default the family's.
    verify
        `params (k, n) -> bool (k, T)`; default the classical map at the tasks.
    bounds
        `(low, high)` of the parameters; default the surrogate's `bounds` if it has
        them, else the family's range.
    margin
        margin asked in the first round; default the surrogate's `default_margin` (0 if
        it has none). `margin_step`: the raise after a failed verification (default
        `max(margin, 0.05)`, in the surrogate's units).

    Returns
    -------
    DesignResult
        `DesignResult` with `method="gradient"`.
    """
    t0 = time.perf_counter()
    fam = design_family(family)
    tasks = check_tasks(tasks)
    surrogate = model
    if not callable(model) or _is_subspace_mlp(model):
        surrogate = MapSurrogate(model, fam, tasks, rpy=rpy, convention=convention)
    check = _verifier(fam, tasks, verify, rpy, convention)
    if bounds is None and getattr(surrogate, "bounds", None) is not None:
        bounds = surrogate.bounds
    lo, hi = _bounds(fam, bounds)
    start_rows, starts = _start_designs(fam, starts, lo, hi)
    _check_descent_counts(starts, steps, max_rounds, dual_every, verify_top)
    m0 = float(getattr(surrogate, "default_margin", 0.0) if margin is None else margin)
    step_m = float(max(m0, 0.05) if margin_step is None else margin_step)
    u0 = _unit_starts(fam, start_rows, starts, lo, hi, _rng(seed))
    descent = _Descent(surrogate, fam, lo, hi, u0, len(tasks), lr, rho)
    margins = np.full(descent.k, m0)
    for rnd in range(1, max_rounds + 1):
        final = descent.run_round(margins, steps, dual_every)
        best, evals = _verify_finals(fam, surrogate, check, final, len(tasks), verify_top)
        descent.evals += evals
        if best[3]:
            break
        # none verified: ask every start for more margin and go on from where it is
        margins = margins + step_m
        descent.new_round()
    i, p, cov, verified = best
    wall = time.perf_counter() - t0
    return DesignResult("gradient", fam.name, fam.params, p, float(fam.total_length(p)), bool(verified), cov,
                        check.calls, descent.evals, wall, wall if verified else None,
                        path=np.array(descent.paths)[:, i, :], margins=margins, rounds=rnd,
                        classical_time=check.seconds)

def _is_subspace_mlp(obj) -> bool:
    from .learn.network import SubspaceMLP

    return isinstance(obj, SubspaceMLP)


# ------------------------------------------------------------------------------------------ gradient-free
class _Search:
    """Book-keeping shared by the gradient-free searches: penalised objective on classical maps,
    the best verified design, the stopping rule."""

    def __init__(self, method, fam, tasks, check, lo, hi, penalty, target_length, max_calls, max_seconds):
        self.method, self.fam, self.tasks, self.check = method, fam, tasks, check
        self.lo, self.hi = lo, hi
        # default: any uncovered task costs more than the longest arm of the box, so every verified
        # design ranks before every unverified one
        self.penalty = float(fam.total_length(hi)) if penalty is None else float(penalty)
        self.target, self.max_calls, self.max_seconds = target_length, max_calls, max_seconds
        self.t0 = time.perf_counter()
        self.best = None  # (length, params, covered)
        self.fallback = None  # (n uncovered, length, params, covered): best unverified
        self.t_verified = self.t_target = None
        self.path: list[tuple[float, float]] = []
        self.rounds = 0

    def evaluate(self, params: np.ndarray) -> np.ndarray:
        """Penalised objective `(k,)` of designs `(k, n)` (m)."""
        params = np.clip(params, self.lo, self.hi)
        covered = self.check(params)
        lengths = self.fam.total_length(params)
        missing = (~covered).sum(-1)
        now = time.perf_counter() - self.t0
        for j in range(len(params)):
            if missing[j] == 0:
                if self.best is None or lengths[j] < self.best[0]:
                    self.best = (float(lengths[j]), params[j].copy(), covered[j].copy())
                if self.t_verified is None:
                    self.t_verified = now
                if self.target is not None and self.t_target is None and lengths[j] <= self.target:
                    self.t_target = now
            elif self.best is None and (self.fallback is None or (missing[j], lengths[j]) < self.fallback[:2]):
                self.fallback = (int(missing[j]), float(lengths[j]), params[j].copy(), covered[j].copy())
            self.path.append((math.nan if self.best is None else self.best[0], float(covered[j].mean())))
        self.rounds += 1
        return lengths + self.penalty * missing

    def done(self) -> bool:
        if self.t_target is not None:
            return True
        if self.max_calls is not None and self.check.calls >= self.max_calls:
            return True
        return self.max_seconds is not None and time.perf_counter() - self.t0 >= self.max_seconds

    def result(self) -> DesignResult:
        wall = time.perf_counter() - self.t0
        if self.best is not None:
            length, p, cov = self.best
        else:
            _, length, p, cov = self.fallback
        return DesignResult(self.method, self.fam.name, self.fam.params, p, float(length), self.best is not None, cov,
                            self.check.calls, 0, wall, self.t_verified, self.t_target, self.target,
                            path=np.array(self.path, dtype=np.float64).reshape(-1, 2), rounds=self.rounds,
                            classical_time=self.check.seconds)


def _search_setup(family, tasks, verify, rpy, convention, bounds, max_calls, max_seconds):
    fam = design_family(family)
    tasks = check_tasks(tasks)
    lo, hi = _bounds(fam, bounds)
    if max_calls is None and max_seconds is None:
        raise ValueError("give a budget: max_calls or max_seconds")
    return fam, tasks, _verifier(fam, tasks, verify, rpy, convention), lo, hi


def design_by_cmaes(family, tasks, *, rpy=None, convention=None, verify=None, bounds=None,
                    target_length: float | None = None, penalty: float | None = None, sigma0: float = 0.3,
                    popsize: int | None = None, max_calls: int | None = 2000, max_seconds: float | None = None,
                    seed=0) -> DesignResult:
    """Shortest design covering `tasks` by CMA-ES (the `cma` package) on the classical map.

    The objective of a design is `total_length + penalty * (uncovered tasks)` (m) from the
    classical map at the tasks (`verify`, default the family's classical map), so every design
    it evaluates is verified or not by construction. CMA-ES runs on `u in [0, 1]^n` (the box
    `bounds`, default the family's range, mapped affinely; `cma`'s bound handling), from the
    centre with step size `sigma0`; a generation is one batched classical call. It stops when a
    verified design of total length `<= target_length` (m) is found, when `max_calls` arms or
    `max_seconds` are spent, or when CMA-ES itself stops.

    `penalty` default: the total length at the upper bounds. Returns a `DesignResult`
    (`method="cmaes"`).
    """
    fam, tasks, check, lo, hi = _search_setup(family, tasks, verify, rpy, convention, bounds, max_calls, max_seconds)
    from ._optional import require

    cma = require("cma", why="design_by_cmaes")  # after the checks: bad input fails without the import

    s = _Search("cmaes", fam, tasks, check, lo, hi, penalty, target_length, max_calls, max_seconds)
    opts = {"bounds": [0.0, 1.0], "verbose": -9, "verb_log": 0, "verb_disp": 0,
            "seed": int(_rng(seed).integers(1, 2**31 - 1))}
    if popsize is not None:
        opts["popsize"] = int(popsize)
    es = cma.CMAEvolutionStrategy(np.full(fam.n_params, 0.5), sigma0, opts)
    while not s.done() and not es.stop():
        U = np.clip(np.array(es.ask()), 0.0, 1.0)
        f = s.evaluate(lo + (hi - lo) * U)
        es.tell(list(U), f.tolist())
    return s.result()


def design_by_random_search(family, tasks, *, rpy=None, convention=None, verify=None, bounds=None,
                            target_length: float | None = None, penalty: float | None = None, batch: int = 16,
                            max_calls: int | None = 2000, max_seconds: float | None = None,
                            seed=0) -> DesignResult:
    """Shortest design covering `tasks` by uniform random search on the classical map.

    Batches of `batch` designs drawn uniformly in the box (one batched classical call each);
    stops as `design_by_cmaes`. Returns a `DesignResult` (`method="random"`).
    """
    fam, tasks, check, lo, hi = _search_setup(family, tasks, verify, rpy, convention, bounds, max_calls, max_seconds)
    s = _Search("random", fam, tasks, check, lo, hi, penalty, target_length, max_calls, max_seconds)
    rng = _rng(seed)
    while not s.done():
        s.evaluate(rng.uniform(lo, hi, size=(batch, fam.n_params)))
    return s.result()


# ------------------------------------------------------------------------------------------ study
def compare_designs(family, tasks, model, *, methods: Sequence[str] = ("gradient", "cmaes", "random"),
                    rpy=None, convention=None, length_tol: float = 0.02, max_calls: int = 3000,
                    max_seconds: float | None = 120.0, gradient: dict | None = None, seed=0,
                    warm_up: bool = True, gradient_search=None) -> tuple[list[dict], dict[str, DesignResult]]:
    """Gradient descent through `model` against gradient-free searches on the classical map, in one run.

    The surrogate is built first (tasks outside the model's grid: `ValueError` before any work);
    with `warm_up` one classical map of the centre design is computed and not timed, so no
    method pays the compiled kernels' first-call compilation. The gradient design comes first;
    its verified total length `L` sets the goal `L * (1 + length_tol)` of the others, which
    stop when they reach it or after `max_calls` arms / `max_seconds`. Every search uses the
    same box (the surrogate's bounds: the family's range within the model's training range).

    Parameters
    ----------
    family, tasks, model, rpy, convention
        as `design_by_gradient`.
    methods
        any of `"gradient"`, `"cmaes"`, `"random"`, in run order (the gradient first
        when given: the others' goal).
    gradient
        more keyword arguments of `design_by_gradient` (or of `gradient_search`).
    gradient_search
        the gradient method to run instead of `design_by_gradient`,
        `gradient_search(seed=..., **gradient) -> DesignResult` (e.g. the screened search of
        `wsmap.morph_design.design_across_morphologies`).

    Returns
    -------
    tuple[list[dict], dict[str, DesignResult]]
        `(rows, results)`: one row per method (`DesignResult.row`: method, family, time to
        a verified design and to the length goal in s, classical calls, total length in m, covered
        tasks, ...) and the `DesignResult` of each method by name.
    """
    fam = design_family(family)
    tasks = check_tasks(tasks)
    known = ("gradient", "cmaes", "random")
    for m in methods:
        if m not in known:
            raise ValueError(f"unknown design method {m!r}; choose from {', '.join(known)}")
    surrogate = MapSurrogate(model, fam, tasks, rpy=rpy, convention=convention) if _is_subspace_mlp(model) else model
    bounds = getattr(surrogate, "bounds", None)
    if warm_up:
        lo, hi = _bounds(fam, bounds)
        fam.classical(((lo + hi) / 2)[None], tasks, rpy, convention)
    results: dict[str, DesignResult] = {}
    target = None
    order = sorted(methods, key=lambda m: m != "gradient")
    for m in order:
        if m == "gradient":
            if gradient_search is not None:
                r = gradient_search(seed=seed, **(gradient or {}))
            else:
                r = design_by_gradient(fam, tasks, surrogate, rpy=rpy, convention=convention, bounds=bounds,
                                       seed=seed, **(gradient or {}))
            target = r.total_length * (1 + length_tol) if r.verified else None
            r.target_length = target
            r.time_to_target = r.time_to_verified
        elif m == "cmaes":
            r = design_by_cmaes(fam, tasks, rpy=rpy, convention=convention, bounds=bounds, target_length=target,
                                max_calls=max_calls, max_seconds=max_seconds, seed=seed)
        else:
            r = design_by_random_search(fam, tasks, rpy=rpy, convention=convention, bounds=bounds,
                                        target_length=target, max_calls=max_calls, max_seconds=max_seconds, seed=seed)
        results[m] = r
    return [results[m].row() for m in order], results


def format_design_table(rows: Sequence[dict]) -> str:
    """The rows of `compare_designs` as a Markdown table (times in s, lengths in m)."""
    from .io import markdown_table

    cols = ["method", "family", "time_to_verified_s", "time_to_target_s", "wall_s", "classical_s", "classical_calls",
            "surrogate_evals", "total_length_m", "covered"]
    return markdown_table(list(rows), cols, digits=3, missing="-")
