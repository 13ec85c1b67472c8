"""The registry of map kinds: what a kind of workspace map is, and where the library finds one.

A *map kind* says what each node of a grid holds (reachable at a fixed orientation, the fraction of a
set of orientations reachable, Yoshikawa's manipulability, ...). Its `MapKind` record carries
everything the command line (`wsmap map --kind NAME`), the map files (`wsmap.workspace.files`)
and the views need to know about it: its scope (a grid of positions, `"R3"`, or of orientations,
`"SO3"`), its value type (`bool` or `float`), the inputs and methods it takes, the function that
computes it on the nodes of a grid, and how its values read (a label with units, iso-surface levels,
a colour range). Each kind is one module of `wsmap.workspace.kinds` that ends with
`register`; nothing outside the registry names a kind. The registry lists kinds by their
`MapKind.priority` (lower first), then their name (`wsmap._plugins.Registry`).
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

from ..._plugins import Registry
from ...kinematics.ik.settings import SearchSettings, as_settings
from ..grids import cartesian_grid
from ..maps import CONVENTIONS, MAP_SETTINGS, SCOPES, grid_map, grid_status
from ...kinematics import rpy2r
from ..reach import INDEX_SETTINGS, reachability_index
from ..status import orientation_status
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap._typing import ArrayLike

__all__ = ["INPUTS", "METHODS", "KINDS", "MapKind", "MapRequest", "register", "unregister", "get_kind", "kinds",
           "kind_names", "default_kind", "kinds_taking", "grid_positions", "paper_map_kind",
           "orientation_set_kind"]

#: What a kind may read besides the arm and the grid: `"rpy"` the fixed orientation (rad,
#: `R = Rx·Ry·Rz`), `"point"` the fixed point (m), `"orientations"` a set of orientations
#: `(K, 3, 3)`, `"convention"` the caller's pose convention (`wsmap.workspace.target_poses`).
INPUTS = ("rpy", "point", "orientations", "convention")
#: How a kind can be computed: `"exact"` (a closed form), `"numerical"` (the IK search),
#: `"model"` (a trained network that predicts the map, `wsmap.workspace.grid_map`).
METHODS = ("exact", "numerical", "model")

_NAME = re.compile(r"^[a-z][a-z0-9_]*$")


@dataclass(frozen=True)
class MapRequest:
    """What a kind's `compute` is asked for, besides the arm and the grid.

    Attributes
    ----------
    method
        `"exact"`, `"numerical"` or `"model"` (`"auto"` lets the kind's function
        choose, `wsmap.workspace.resolve_method`).
    convention
        the pose convention, `"standard"` (default) or `"paper"` (a kind with a fixed
        `MapKind.convention` is always given that one).
    rpy
        the fixed orientation `(r1, r2, r3)` in radians, `R = Rx(r1)·Ry(r2)·Rz(r3)`.
    point
        the fixed point `(x, y, z)` in metres.
    orientations
        `(K, 3, 3)` rotation matrices, or `None` (kinds without `"orientations"`).
    ik
        the numerical settings: a `SearchSettings` (its `solver` the paper's one-start LM
        or the search), or, during the transition from the `ik` dicts, a dict as a map file
        records them (`wsmap.workspace.MAP_SETTINGS` keys, `tol`, `ilimit`, `rlimit`,
        `seed`, `solver`), kept as given (the record) and converted into `settings`.
    settings
        the `SearchSettings` of `ik` (set on construction, not an argument), or None
        where `ik` is empty: the kind's own defaults (`MapKind.search_settings`).
    seed
        the seed of random IK starts and of the orientation set.
    model
        a trained model file (`method="model"`); `allow_extrapolation` as
        `wsmap.workspace.grid_map`.
    progress
        `True` for a progress bar on stderr, or a callable `progress(n)`
        (`wsmap._progress`); every kind's function takes it.
    collision
        a configuration predicate (e.g. `wsmap.collision.CollisionChecker`) for
        kinds that take one (`MapKind.collision`): a node counts only with a
        collision-free solution; `None`: the chain's map.
    """

    method: str = "auto"
    convention: str = "standard"
    rpy: tuple = (0.0, 0.0, 0.0)
    point: tuple = (0.5, 0.5, 0.5)
    orientations: np.ndarray | None = None
    ik: SearchSettings | Mapping | None = field(default_factory=dict)
    seed: int = 0
    model: str | None = None
    allow_extrapolation: bool = False
    progress: object = False
    collision: object = None
    settings: SearchSettings | None = field(default=None, init=False)

    def __post_init__(self):
        # checked before any work; a dict stays the record a map file writes, byte for byte
        ik = self.ik
        settings = ik if isinstance(ik, SearchSettings) else (as_settings(ik) if ik else None)
        object.__setattr__(self, "settings", settings)

    @property
    def search(self) -> SearchSettings | None:
        """The settings the kinds over orientations pass their functions (`settings`; the functions
        take `seed` apart, from `MapRequest.seed`)."""
        return self.settings


def _boolean_levels(values: ArrayLike) -> tuple[float, ...]:
    return (0.5,)


@dataclass(frozen=True)
class MapKind:
    """One kind of workspace map.

    Attributes
    ----------
    name
        the kind's name (`wsmap map --kind NAME`; the `"kind"` of a map file's settings):
        lower case letters, digits and `_`.
    scope
        `"R3"` (nodes are positions, m) or `"SO3"` (nodes are angles `(r1, r2, r3)`, rad).
    value_type
        `bool` (one bit per node) or `float` (float64 per node, finite).
    compute
        `compute(robot, grid, request) -> (N,) array` of `value_type`: the map of one arm
        (or of a batch, where `batch`) on the nodes of `grid`
        (`wsmap.workspace.grid_spec`; node order x fastest) for a `MapRequest`.
    function
        the library function `compute` calls (its docstring gives units and conventions).
    description
        one line for `wsmap map --help`: what a node holds, which options it reads.
    label
        what a value is, with units (colour bars, point-cloud comments, HTML views).
    noun
        what a `True` node is, in a summary (`"reachable"`, `"dexterous"`); bool kinds.
    inputs
        the subset of `INPUTS` the kind reads.
    methods
        the subset of `METHODS` the kind has; a kind without `"exact"` is computed
        numerically when the closed form is asked for (an arm with a closed form).
    paper_solver
        takes the paper's one-start LM (`ik={"solver": "paper"}`, `--paper-lm`).
    batch
        maps a batch of arms at once (otherwise one arm).
    search_settings
        the numerical search's defaults for this kind (what the command line's
        `--starts`/`--retry`/... override).
    convention
        the pose convention the kind always uses, or `None` when it takes the caller's
        (`"convention"` in `inputs`).
    levels
        `levels(values) -> tuple` of iso-surface levels of a map (`.glb` views).
    value_range
        `(lo, hi)` colour range of float maps; `None` for an end means the map's own.
    priority
        the kind's place in the registry's order (lower first: `--kind`'s choices,
        `kinds`; the first of a scope is its `default_kind`).
    poses
        `poses(robot, grid, request) -> (values (N,), bits (N, K) bool, R (K, 3, 3))`: the
        map together with the reachability of every node at each of the `K` orientations it
        tested (`T = transl(p)·R_k`), one computation; what a Reuleaux HDF5 file stores
        (`wsmap.workspace.save_reuleaux`, `wsmap map --h5`). `None`: the kind's values
        are not reachability at a set of orientations, so it does not export.
    collision
        the kind's `compute` honours `MapRequest.collision` (self-collision and
        obstacles, `wsmap map --collision/--scene`).
    status
        `status(robot, grid, request, values, bits, budget) -> (status (N,), per_pose)`:
        each node's answer (`wsmap.workspace.status`: reached, certified unreachable, not
        found; int8, `REACHED` exactly where the map reaches: True, or a value above 0) of
        a map `values` the kind computed by the closed form or the search, and for a kind
        over a set of orientations the answer of every node and orientation `(N, K)` int8
        (`bits` its `(N, K)` reachability, from `poses`; None for the other kinds, and
        `per_pose` None). `budget`: boxes per pose of the branch and bound (None: the
        kind's `status_budget`). `None`: the kind has no status.
    status_budget
        the kind's default `budget` of `status` (None: the certificate's own,
        `wsmap.kinematics.ik.certificate.CELL_BUDGET`; 0: the sound filters and the
        closed form's certificate only, for kinds whose `N x K` poses would take minutes).
    over
        kinds over a set of orientations: `over(per_pose (N, K)) -> (N,)`, a node's answer
        from its orientations' (`wsmap.workspace.node_status_over` for the index); what a map
        file's stored statuses must agree with.
    from_bits
        kinds over a set of orientations: `from_bits(bits (N, K)) -> (N,)`, the map's values
        from the reachability of each node and orientation (what `poses` returns, and what a
        map file's per-orientation status must give back).
    """

    name: str
    scope: str
    value_type: type
    compute: Callable
    function: Callable
    description: str
    priority: int
    label: str = "reachable"
    noun: str = "reachable"
    inputs: tuple = ()
    methods: tuple = ("exact", "numerical")
    paper_solver: bool = False
    batch: bool = False
    search_settings: Mapping = field(default_factory=lambda: MAP_SETTINGS)
    convention: str | None = None
    levels: Callable = _boolean_levels
    value_range: tuple = (None, None)
    poses: Callable | None = None
    collision: bool = False
    status: Callable | None = None
    status_budget: int | None = None
    over: Callable | None = None
    from_bits: Callable | None = None

    def __post_init__(self):
        where = f"map kind {self.name!r}"
        if not isinstance(self.name, str) or not _NAME.match(self.name):
            raise ValueError(f"a map kind's name is lower case letters, digits and '_', got {self.name!r}")
        if not isinstance(self.priority, int) or isinstance(self.priority, bool):
            raise ValueError(f"{where}: priority must be an int (its place in the registry), got {self.priority!r}")
        if self.scope not in SCOPES:
            raise ValueError(f"{where}: scope must be one of {', '.join(SCOPES)}, got {self.scope!r}")
        if self.value_type not in (bool, float):
            raise ValueError(f"{where}: value_type must be bool or float, got {self.value_type!r}")
        for attr, allowed in (("inputs", INPUTS), ("methods", METHODS)):
            values = getattr(self, attr)
            if isinstance(values, str) or not all(v in allowed for v in values):
                raise ValueError(f"{where}: {attr} must be a tuple of {', '.join(allowed)}, got {values!r}")
            object.__setattr__(self, attr, tuple(values))
        if "numerical" not in self.methods:
            raise ValueError(f"{where}: every kind has the numerical method (any arm), got {self.methods!r}")
        if self.convention is not None and self.convention not in CONVENTIONS:
            raise ValueError(f"{where}: convention must be None or one of {', '.join(CONVENTIONS)}, "
                             f"got {self.convention!r}")
        if (self.convention is None) != ("convention" in self.inputs):
            raise ValueError(f"{where}: a kind either takes the caller's convention ('convention' in inputs, "
                             "convention None) or fixes its own")
        for attr in ("compute", "function", "levels"):
            if not callable(getattr(self, attr)):
                raise ValueError(f"{where}: {attr} must be callable")
        if self.poses is not None and (not callable(self.poses) or self.scope != "R3"):
            raise ValueError(f"{where}: poses must be None or a callable of an R3 kind")
        self._check_status_fields(where)
        object.__setattr__(self, "search_settings", MappingProxyType(dict(self.search_settings)))

    def _check_status_fields(self, where: str) -> None:
        for attr in ("status", "over", "from_bits"):
            if getattr(self, attr) is not None and not callable(getattr(self, attr)):
                raise ValueError(f"{where}: {attr} must be None or callable")
        if (self.over is None) != (self.from_bits is None) or (self.over is not None and "orientations" not in self.inputs):
            raise ValueError(f"{where}: over and from_bits go together, for a kind over a set of orientations")
        budget = self.status_budget
        if budget is not None and (isinstance(budget, bool) or not isinstance(budget, int) or budget < 0):
            raise ValueError(f"{where}: status_budget must be None or a non-negative int, got {budget!r}")

    @property
    def settings(self) -> SearchSettings:
        """The kind's numerical search defaults (`search_settings`) as `SearchSettings`."""
        return SearchSettings.from_dict(self.search_settings)

    @property
    def dtype(self) -> np.dtype:
        """The map file's dtype of this kind: bool or float64."""
        return np.dtype(bool) if self.value_type is bool else np.dtype(np.float64)

    def summary(self, values: ArrayLike) -> str:
        """One line on a computed map `values` (N,): how many nodes are reachable (and, for a float
        map, the mean value over the reachable nodes, those above 0: the box's unreachable nodes
        would only dilute it by the box's size)."""
        values = np.asarray(values)
        if self.value_type is float:
            reached = values > 0
            line = f"{int(reached.sum())} of {values.size} nodes reachable"
            if reached.any():
                line += f", mean {self.label} over reachable nodes {values[reached].mean():.3f}"
            return line
        return f"{int(values.sum())} of {values.size} nodes {self.noun}"


def grid_positions(grid: Mapping) -> np.ndarray:
    """The nodes `(N, 3)` (m, x fastest) of an R3 grid spec (`wsmap.workspace.grid_spec`)."""
    return cartesian_grid(grid["lo"], grid["hi"], grid["step"])


def paper_map_kind(name: str, scope: str, fixed: str, function: Callable, description: str,
                   priority: int) -> MapKind:
    """The record of one of the paper's maps (bool per node, computed by `wsmap.workspace.grid_map`
    for a batch of arms; every method, the paper's one-start LM, the caller's convention) of `scope`
    at the request's `fixed` input (`"rpy"` for R3, `"point"` for SO3); `function` the map
    function `grid_map` calls on the grid's nodes; `priority` its place in the registry."""

    def compute(robot, grid, request):
        return grid_map(robot, grid, method=request.method, convention=request.convention, model=request.model,
                        allow_extrapolation=request.allow_extrapolation, ik=request.settings, progress=request.progress,
                        collision=request.collision, **{fixed: getattr(request, fixed)})

    def poses(robot, grid, request):
        # one orientation: the map is its own column of bits; a pose is T = transl(p)·R only in the
        # standard convention (the paper's tests R·p, which is not the node)
        if request.convention != "standard":
            raise ValueError(f"the {name} map's poses are T = transl(p)·R only in the standard convention, "
                             f"not {request.convention!r}")
        if robot.batch_shape != ():
            raise ValueError(f"poses of the {name} map are for one arm, got a batch of shape {robot.batch_shape}")
        values = compute(robot, grid, request)
        return values, np.asarray(values, dtype=bool)[:, None], rpy2r(np.asarray(request.rpy, dtype=float))[None]

    def status(robot, grid, request, values, bits, budget):
        # the certificates are kinematic: collisions only remove solutions, so they hold with them too
        return grid_status(robot, grid, values, rpy=request.rpy, point=request.point, method=request.method,
                           convention=request.convention, budget=budget), None

    return MapKind(name=name, scope=scope, value_type=bool, compute=compute, function=function,
                   description=description, priority=priority, inputs=(fixed, "convention"), methods=METHODS,
                   paper_solver=True,
                   batch=True, poses=poses if scope == "R3" else None, collision=True, status=status)


def orientation_set_kind(name: str, value_type: type, function: Callable, description: str, priority: int,
                         from_bits: Callable, over: Callable | None = None, **fields) -> MapKind:
    """The record of a kind over the request's set of orientations at each position of an R3 grid
    (`T = transl(p)·R_k`, the standard convention; the index's search defaults
    `wsmap.workspace.reach.INDEX_SETTINGS`), computed by `function(robot, nodes, orientations,
    method=, ik=, seed=, progress=)`; `from_bits(bits (N, K)) -> (N,)` the same values from
    `wsmap.workspace.reachability_index`'s bits (its `MapKind.poses`); `over(status (N, K))
    -> (N,)` a node's answer from its orientations' (`MapKind.over`; None: the kind has no
    status); `fields` the rest of its `MapKind` (label, levels, ...). Its status certifies with the sound filters and the closed
    form's certificate only (`status_budget` 0): on the Panda, 10 cm x 50 orientations, the
    branch and bound at its default budget certified 2 % more of the poses not reached for 113 s
    against 0.5 s (docs/maps.md)."""

    def compute(robot, grid, request):
        return function(robot, grid_positions(grid), request.orientations, method=request.method,
                        ik=request.search, seed=request.seed, progress=request.progress, collision=request.collision)

    def poses(robot, grid, request):
        _, bits = reachability_index(robot, grid_positions(grid), request.orientations, method=request.method,
                                     ik=request.search, seed=request.seed, progress=request.progress,
                                     collision=request.collision, return_bits=True)
        return from_bits(bits), bits, np.asarray(request.orientations, dtype=np.float64)

    def status(robot, grid, request, values, bits, budget):
        per_pose = orientation_status(robot, grid_positions(grid), request.orientations, bits, request.method,
                                      budget=budget)
        return over(per_pose), per_pose

    return MapKind(name=name, scope="R3", value_type=value_type, compute=compute, function=function,
                   description=description, priority=priority, inputs=("orientations",),
                   search_settings=INDEX_SETTINGS,
                   convention="standard", poses=poses, collision=True, status=None if over is None else status,
                   status_budget=fields.pop("status_budget", 0), over=over,
                   from_bits=None if over is None else from_bits, **fields)


#: The registered kinds, by `(priority, name)`.
KINDS: Registry[MapKind] = Registry("map kind")


def register(kind: MapKind, *, replace: bool = False) -> MapKind:
    """Add `kind` to the registry (the end of every kind module) and return it. A second kind of
    the same name is a `ValueError` unless `replace`; kinds are listed by their priority
    (`--kind`'s choices, `kinds`)."""
    if not isinstance(kind, MapKind):
        raise TypeError(f"register takes a MapKind, got {type(kind).__name__}")
    if kind.name in KINDS:
        if not replace:
            raise ValueError(f"a map kind named {kind.name!r} is already registered (register(..., replace=True) "
                             "replaces it)")
        KINDS.unregister(kind.name)
    return KINDS.register(kind)


def unregister(name: str) -> MapKind:
    """Remove the kind `name` from the registry and return it (`ValueError` when unknown)."""
    kind = get_kind(name)
    KINDS.unregister(name)
    return kind


def get_kind(name: str) -> MapKind:
    """The registered kind `name`; `ValueError` naming the known kinds otherwise."""
    if not isinstance(name, str) or name not in KINDS:
        raise ValueError(f"unknown map kind {name!r}; known kinds: {', '.join(KINDS.names())}")
    return KINDS.get(name)


def kinds() -> tuple[MapKind, ...]:
    """Every registered kind, by priority."""
    return KINDS.records()


def kind_names() -> tuple[str, ...]:
    """The names of the registered kinds, by priority."""
    return tuple(KINDS.names())


def default_kind(scope: str) -> MapKind:
    """The first kind of `scope` by priority: the paper's map of that scope (`constant` for R3,
    `orientation` for SO3)."""
    for kind in KINDS.records():
        if kind.scope == scope:
            return kind
    raise ValueError(f"no map kind of scope {scope!r} is registered")


def kinds_taking(input_name: str) -> tuple[MapKind, ...]:
    """The kinds that read `input_name` (one of `INPUTS`), by priority."""
    if input_name not in INPUTS:
        raise ValueError(f"unknown input {input_name!r}; inputs: {', '.join(INPUTS)}")
    return tuple(k for k in KINDS.records() if input_name in k.inputs)
