"""The classical algorithm: binary workspace maps by discretisation.

A *scope* is a grid of nodes, either positions at a fixed orientation (the constant-orientation
workspace, "R3") or orientations at a fixed point (the orientation workspace, "SO3"). A node is
`True` when inverse kinematics has a solution for the node's target pose.

Pose conventions:

* `"standard"` (the default everywhere, the robotics convention): `T = transl(p) · R`, the tool
  at position `p` with orientation `R`;
* `"paper"`: `T = Rx(r1)·Ry(r2)·Rz(r3) · transl(p)` (the authors' code): the position tested is
  `R·p`, not `p`; the paper's pipeline (`wsmap.paper`, its dataset specs) passes it explicitly.

They agree when `R = I`.
"""

from __future__ import annotations

import math

import numpy as np

from ..kinematics import DHRobot, SerialChain, closed_form_for, require_closed_form, rpy2r
from ..kinematics.chain import as_chain, flatten_arms
from ..kinematics.ik.search import ikine_search
from ..kinematics.ik.settings import DEFAULT_STARTS, MAP_SETTINGS, SearchSettings, as_settings
from ..kinematics.ik.solvers import numerical_solvers, per_node, solver_for
from ..kinematics.ik.solvers.independent import search_accepted
from ..kinematics.transforms import as_real_array
from .._progress import check_progress, progress_bar
from .grids import cartesian_grid, check_fits, grid_axes, node_neighbours, triple
from .status import node_status
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap._typing import Any, ArrayLike, Callable, Mapping, NDArray, PathLike
    from wsmap.kinematics.chain import Arm

__all__ = ["METHODS", "CONVENTIONS", "SCOPES", "SOLVERS", "DEFAULT_STARTS", "MAP_SETTINGS", "SearchSettings",
           "target_poses", "reachable", "resolve_method", "constant_orientation_map", "orientation_map",
           "grid_map", "MAP_PREDICTORS", "register_map_predictor", "check_choice", "check_nodes",
           "configuration_predicate", "search_settings", "grid_status"]

#: `"auto"` is `"exact"` for an arm of a closed-form family, else `"numerical"`.
METHODS = ("auto", "exact", "numerical")
#: Numerical solvers (`ik={"solver": ...}`, `SearchSettings.solver`), registered in
#: `wsmap.kinematics.ik.solvers`: `"search"` (default) is the search with joint limits
#: inside it, started at each node from its neighbours' solutions as well
#: (`wsmap.kinematics.ik.search.map_search`, settings `MAP_SETTINGS`); `"independent"`
#: solves every node on its own with `wsmap.kinematics.ik.search.ikine_search` (`starts`
#: default `DEFAULT_STARTS`); `"paper"` is the paper's one-start LM from q0 = 0
#: (`wsmap.kinematics.ik.lm.ikine_LM`, DH arms, a converged solution outside the limits rejected
#: afterwards), which the paper's pipeline uses.
SOLVERS = numerical_solvers()
CONVENTIONS = ("paper", "standard")
SCOPES = ("R3", "SO3")
#: Map methods of `grid_map` that other packages supply, by name: `predict(model, robot,
#: fixed, *, grid, convention, allow_extrapolation) -> bool (N,)` in the grid's node order.
#: `wsmap.learn.predictor` registers `"model"` (a trained network, torch) when it is
#: imported, so the classical library never imports the learned one.
MAP_PREDICTORS: dict = {}


def register_map_predictor(name: str, predict) -> None:
    """Make `method=name` of `grid_map` call `predict` (see `MAP_PREDICTORS`)."""
    if not callable(predict):
        raise TypeError(f"map predictor {name!r} must be callable, got {type(predict).__name__}")
    MAP_PREDICTORS[name] = predict


def check_choice(name: str, value: object, choices: tuple) -> None:
    """A one-line `ValueError` unless `value` is one of `choices` (`name` says what it is)."""
    if value not in choices:
        raise ValueError(f"unknown {name} {value!r}; choose one of {', '.join(choices)}")


def target_poses(positions: ArrayLike, rpy: ArrayLike, convention: str = "standard") -> np.ndarray:
    """Target poses `(..., 4, 4)` from positions `(..., 3)` (m) and angles `(..., 3)` (rad).

    `"standard"` (default): `transl(p) · R`; `"paper"`: `Rx Ry Rz · transl(p)` (position `R·p`).
    """
    check_choice("convention", convention, CONVENTIONS)
    positions = np.asarray(positions, dtype=np.float64)
    if positions.shape[-1:] != (3,):
        raise ValueError(f"positions must have a last dimension of 3, got shape {positions.shape}")
    if not np.all(np.isfinite(positions)):
        raise ValueError("positions contain NaN or infinite values")
    rpy = np.asarray(rpy, dtype=np.float64)
    if not np.all(np.isfinite(rpy)):
        raise ValueError("orientation angles contain NaN or infinite values")
    R = rpy2r(rpy)
    shape = np.broadcast_shapes(positions.shape[:-1], R.shape[:-2])
    T = np.zeros(shape + (4, 4))
    T[..., :3, :3] = R
    if convention == "paper":
        T[..., :3, 3] = (R @ positions[..., None])[..., 0]
    else:
        T[..., :3, 3] = positions
    T[..., 3, 3] = 1.0
    return T


# --------------------------------------------------------------------------- reachability of poses
def reachable(robot: Arm, T: ArrayLike, *, starts: int = DEFAULT_STARTS, seed: int = 0,
              collision: Callable | None = None, collision_rounds: int = 4, return_q: bool = False,
              **settings) -> NDArray[np.bool_] | tuple[NDArray[np.bool_], NDArray[np.float64]]:
    """Whether the arm reaches each pose: bool with the broadcast batch shape of `T` and the arms.

    Parameters
    ----------
    robot : SerialChain or DHRobot, one arm or a batch (its batch shape broadcasts with `T`'s)
    T : array_like, shape (..., 4, 4)
        Tool poses in the base (world) frame; a pose that is not a rigid transform is a `ValueError`.
    starts, seed :
        IK start configurations per pose (start 0: `q0`, default zeros; then random ones inside
        the limits) and the seed of the random ones.
    **settings :
        `q0`, `tol`, `ilimit`, `rlimit`, `lam`, `joint_limits`, `confirm_tol`, `chunk`,
        `progress` of `wsmap.kinematics.ik.search.ikine_search`, which also returns the solutions.
    collision : callable, optional
        One arm: a configuration predicate, `collision(q)` with `q` `(M, n)` → bool
        `(M,)` True where acceptable, e.g. a `wsmap.collision.CollisionChecker`; a pose then
        counts only with an accepted solution, and a pose whose solutions were refused is searched
        again `collision_rounds` times with other random starts (`seed` moved on per round).
    collision_rounds : int
        How many more searches, with other random starts, a pose whose solutions `collision` refused gets.
    return_q : bool
        Also return the solutions `(..., n)` (NaN where unreachable).

    Notes
    -----
    A pose is reachable when some start converges to it inside the joint limits and forward
    kinematics confirms the solution (within 1e-6 m and rad), so `True` comes with a solution;
    `False` means no start found one (recall measured against exact references in
    `benchmarks/maps/bench_recall.py`: >= 0.999 with the default starts, no false positive).
    """
    valid = configuration_predicate(robot, collision)
    if valid is None:
        res = ikine_search(robot, T, starts=starts, seed=seed, **settings)
        return (res.success, np.where(res.success[..., None], res.q, np.nan)) if return_q else res.success
    res = search_accepted(robot, np.asarray(T, dtype=np.float64), valid, starts, seed, collision_rounds, settings)
    return (res.success, res.q) if return_q else res.success


def configuration_predicate(arms: Arm, collision: Callable | None) -> Callable | None:
    """`collision` checked as a configuration predicate of `arms` (one arm), or None. A
    `wsmap.collision.CollisionChecker` of another arm (other joint frames) is refused."""
    if collision is None:
        return None
    if not callable(collision):
        raise TypeError(f"collision must be a configuration predicate (e.g. a wsmap.collision.CollisionChecker), "
                        f"got {type(collision).__name__}")
    if arms.batch_shape != ():
        raise ValueError(f"collision= checks one arm's configurations, got a batch of arms {arms.batch_shape}")
    chain = getattr(getattr(collision, "model", None), "chain", None)
    if chain is not None:
        mine = as_chain(arms)
        if chain.n != mine.n:
            raise ValueError(f"the collision model has {chain.n} joints, the arm {mine.n}")
        q = mine.random_q(3, np.random.default_rng(0))
        if not np.allclose(chain.joint_frames(q)[0], mine.joint_frames(q)[0], atol=1e-9):
            raise ValueError("the collision model belongs to another arm: its joint frames differ from the arm's")
    return collision


# --------------------------------------------------------------------------- maps
#: The DH arms with a node axis before the joints (`wsmap.kinematics.ik.solvers.per_node`; the
#: name the kernel tests read).
_per_node = per_node


def search_settings(ik: SearchSettings | Mapping | None, base: Mapping = MAP_SETTINGS, *,
                    seed: int | None = None) -> SearchSettings:
    """The settings of the neighbour search (solver `"search"`) of a map, a reach map, an index or a
    placement: `ik` itself when it is a `SearchSettings`, else the dict `ik` over `base`
    (without its `solver`, `chunk` and `progress` keys, which those maps never read); `seed`
    (the function's own argument) replaces the settings' seed when given."""
    if isinstance(ik, SearchSettings):
        if ik.solver != "search":
            raise ValueError(f"this map runs the solver 'search' (neighbours' solutions), got solver {ik.solver!r}")
        settings = ik
    else:
        drop = ("solver", "chunk", "progress")
        settings = as_settings({k: v for k, v in (ik or {}).items() if k not in drop}, base)
    return settings if seed is None else settings.replace(seed=seed)


def resolve_method(robot: Arm, method: str = "auto") -> str:
    """`"exact"` or `"numerical"`: `auto` picks the closed form where a registered closed form
    solves the arm (`wsmap.kinematics.closed_form_for`), else numerical IK. `exact` for an
    arm without a closed form is a `ValueError` that says so."""
    check_choice("method", method, METHODS)
    if method == "auto":
        return "exact" if closed_form_for(robot) is not None else "numerical"
    if method == "exact":
        require_closed_form(robot)
    return method


def _map(arms, positions, rpy, convention, method, ik, chunk_elements, progress, space, return_method,
         collision=None, return_q=False, return_status=False):
    """Shared driver: positions (N, 3) or (1, 3), rpy (3,) or (N, 3); `space` (N, 3) the nodes whose
    neighbours start the numerical search; returns (arms..., N) bool (then the solutions
    (arms..., N, n) with `return_q`, the int8 status (arms..., N) with `return_status`, and the
    method used, with `return_method`)."""
    if not isinstance(arms, (DHRobot, SerialChain)):
        raise TypeError(f"arms must be a DHRobot or a SerialChain, got {type(arms).__name__}")
    valid = configuration_predicate(arms, collision)
    method = resolve_method(arms, method)
    check_choice("convention", convention, CONVENTIONS)
    T = target_poses(positions, rpy, convention)  # (N, 4, 4)
    N = T.shape[0]
    batch = arms.batch_shape
    B = int(np.prod(batch, dtype=np.int64))
    check_fits(B * N, f"a map of {B} arms x {N} nodes")
    settings = None if method == "exact" else as_settings(ik)
    solver = solver_for(method, settings)
    solver.check(arms, settings, valid)
    nb = node_neighbours(space) if solver.neighbours else None
    flat = arms if batch == () else flatten_arms(arms)
    out = np.empty((max(B, 1), N), dtype=bool)
    q_out = np.full((max(B, 1), N, arms.n), np.nan) if return_q else None
    per_chunk = max(1, chunk_elements // max(N, 1))
    with progress_bar(progress, max(B, 1) * N, desc=f"{method} map") as update:
        # a numerical solver reports as it goes (per chunk of targets, the search per pass and wave);
        # the closed form after each chunk of arms
        _map_chunks(flat, batch, B, N, T, nb, solver, settings, per_chunk, out, q_out, valid, update)
    out = out.reshape(batch + (N,))
    result = (out,) if not return_q else (out, q_out.reshape(batch + (N, arms.n)))
    if return_status:
        # the certificates are kinematic: collisions only remove solutions, so they hold with them too
        result += (node_status(arms, T, out, method),)
    if return_method:
        result += (method,)
    return result if len(result) > 1 else out


def _map_chunks(flat, batch, B, N, T, nb, solver, settings, per_chunk, out, q_out, valid, update):
    """Fill `out` (max(B, 1), N) and, unless `None`, `q_out` (max(B, 1), N, n) chunk of arms by
    chunk of arms with `solver` (a `wsmap.kinematics.ik.solvers.Solver`); `valid` the
    configuration predicate or `None`; `update(n)` the progress."""
    inner = update if solver.numerical else None
    for s in range(0, max(B, 1), per_chunk):
        sub = flat if batch == () else flat[s : s + per_chunk]
        if q_out is None:
            res = solver.reachable(sub, T, settings, valid, neighbours=nb, progress=inner)
        else:
            sol = solver.solve(sub, T, settings, valid, neighbours=nb, progress=inner)
            res, qq = sol.success, sol.q
        rows = out[s : s + per_chunk].shape[0]
        out[s : s + per_chunk] = np.broadcast_to(res, (rows, N))
        if q_out is not None:
            q_out[s : s + per_chunk] = np.where(out[s : s + per_chunk, :, None],
                                                np.broadcast_to(qq, (rows, N, q_out.shape[-1])), np.nan)
        if update is not None and not solver.numerical:
            update(out[s : s + per_chunk].size)


def check_nodes(name: str, nodes: ArrayLike) -> np.ndarray:
    """`nodes` as a finite real float64 array `(N, 3)`, or a one-line `ValueError` naming `name`."""
    nodes = as_real_array(name, nodes)  # complex nodes are refused, not cast (numpy drops the imaginary part)
    if nodes.ndim != 2 or nodes.shape[1] != 3:
        raise ValueError(f"{name} must have shape (N, 3), got {nodes.shape}")
    if not np.all(np.isfinite(nodes)):
        raise ValueError(f"{name} contain NaN or infinite values")
    return nodes


def constant_orientation_map(arms: Arm, nodes: ArrayLike, rpy: ArrayLike = (0.0, 0.0, 0.0), method: str = "auto",
                             convention: str = "standard", *, ik: dict | None = None, chunk_elements: int = 1 << 21,
                             progress: bool | None = None, return_method: bool = False,
                             collision: Callable | None = None, return_q: bool = False,
                             return_status: bool = False) -> NDArray[np.bool_] | tuple:
    """Constant-orientation workspace ("R3"): which positions are reachable at orientation `rpy`.

    Parameters
    ----------
    arms : DHRobot or SerialChain, one arm or a batch (batch shape `(...)`)
    nodes : (N, 3) positions in metres, e.g. from `cartesian_grid`
    rpy : (3,) angles (r1, r2, r3) in radians, `R = Rx(r1)·Ry(r2)·Rz(r3)`
    method : `"auto"` (default: the closed form where the arms belong to a closed-form family,
        `wsmap.kinematics.closed_form_for`, else numerical), `"exact"` (closed form only) or
        `"numerical"` (any arm). `ik` passes the numerical settings: by default the search
        started from neighbouring nodes' solutions (`wsmap.kinematics.ik.search.map_search`;
        `starts`, `retry`, `seeds`, `seed`, `q0`, `tol`, `ilimit`, `rlimit`, `gtol`,
        `joint_limits`; defaults `MAP_SETTINGS`); `{"solver": "independent"}` solves each
        node alone with `reachable`'s search (`starts` default `DEFAULT_STARTS`);
        `{"solver": "paper"}` is the paper's one-start LM from q0 = 0 (`ikine_LM`; DH arms;
        `q0`, `tol`, `ilimit`, `rlimit`, `lam`, `chunk`), as the paper's pipeline runs it
    convention : `"standard"` (default, `T = transl(p)·R`) or `"paper"` (see the module docstring)
    progress : `True` for a bar on stderr of the nodes settled (arms x nodes), or a callable
        `progress(n)` (`wsmap._progress`); numerically it moves as the search solves nodes
    return_method : also return the method used (`"exact"` or `"numerical"`)
    collision : optional configuration predicate for one arm (`collision(q)`, `q` `(M, n)` →
        bool `(M,)`, True where acceptable), e.g. a `wsmap.collision.CollisionChecker`: a
        node counts only with a collision-free solution. The closed forms try every branch; the
        search keeps looking where its solutions are refused (neighbours' free solutions, retries,
        `accept_retry` more starts: `wsmap.kinematics.ik.search.map_search`)
    return_q : also return each node's solution `(..., N, n)` (NaN where unreachable), so
        anyone can check it (forward kinematics, limits, collisions)
    return_status : also return each node's answer, int8 `(..., N)`: `REACHED` (0),
        `CERTIFIED` unreachable (1) or `NOT_FOUND` (2) (`wsmap.workspace.status`; the
        certificates of `wsmap.kinematics.ik.certificate`: the closed form's for `"exact"`, the
        sound filters and the branch and bound over the joints for `"numerical"`)

    Returns
    -------
    bool array `(..., N)` in node order (then the solutions, with `return_q`, the status, with
    `return_status`, and the method, with `return_method`). Joint limits are honoured when the
    arms carry them.
    """
    nodes = check_nodes("nodes", nodes)
    rpy = triple("rpy", rpy)
    return _map(arms, nodes, rpy, convention, method, ik, chunk_elements, progress, nodes, return_method,
                collision, return_q, return_status)


def orientation_map(arms: Arm, angle_nodes: ArrayLike, point: ArrayLike = (0.5, 0.5, 0.5), method: str = "auto",
                    convention: str = "standard", *, ik: dict | None = None, chunk_elements: int = 1 << 21,
                    progress: bool | None = None, return_method: bool = False,
                    collision: Callable | None = None, return_q: bool = False,
                    return_status: bool = False) -> NDArray[np.bool_] | tuple:
    """Orientation workspace ("SO3"): which orientations are reachable at the point `point` (m).

    `angle_nodes` (N, 3) are angles (r1, r2, r3) in radians, e.g. from `angle_grid`.
    Under the paper convention the position tested is `R·point`, so the map is really a test of
    positions on the sphere of radius `|point|`. Other arguments as
    `constant_orientation_map` (`collision`, `return_q`, `return_status` too); returns bool `(..., N)`.
    """
    angle_nodes = check_nodes("angle nodes", angle_nodes)
    point = triple("point", point)
    return _map(arms, point[None, :], angle_nodes, convention, method, ik, chunk_elements, progress, angle_nodes,
                return_method, collision, return_q, return_status)


def default_grid(scope: str) -> tuple[float, float, float]:
    """The paper's grid of a scope: R3 `[-1, 1]` m at 0.1 m, SO3 `[0, 2·pi]` rad at `pi/10`."""
    check_choice("scope", scope, SCOPES)
    return (-1.0, 1.0, 0.1) if scope == "R3" else (0.0, 2 * math.pi, math.pi / 10)


def grid_spec(scope: str = "R3", lo: float | ArrayLike | None = None, hi: float | ArrayLike | None = None,
              step: float | ArrayLike | None = None) -> dict:
    """A grid description `{"scope", "lo", "hi", "step", "shape"}` (3-lists; `shape` is nx, ny, nz).

    Missing bounds take the paper's defaults (`default_grid`). Checked (finite, `lo <= hi`,
    `step > 0`, not too many nodes) without building the nodes.
    """
    dlo, dhi, dstep = default_grid(scope)
    lo, hi, step = (dlo if lo is None else lo), (dhi if hi is None else hi), (dstep if step is None else step)
    axes = grid_axes(lo, hi, step)
    return {"scope": scope, "lo": triple("lo", lo).tolist(), "hi": triple("hi", hi).tolist(),
            "step": triple("step", step).tolist(), "shape": [len(a) for a in axes]}


def grid_map(robot: Arm, grid: dict, *, rpy: ArrayLike = (0.0, 0.0, 0.0), point: ArrayLike = (0.5, 0.5, 0.5),
             method: str = "auto", convention: str = "standard", model: PathLike | None = None,
             allow_extrapolation: bool = False, ik: Mapping[str, Any] | None = None, progress: bool = False,
             return_method: bool = False, collision: Callable | None = None, return_status: bool = False
             ) -> NDArray[np.bool_] | tuple:
    """One call from an arm to its map on a whole grid (from `grid_spec`): bool `(N,)` in node order.

    `grid["scope"]` is `"R3"` (positions at orientation `rpy`) or `"SO3"` (orientations at
    `point`). `method` is `"auto"` (see `resolve_method`), `"exact"`, `"numerical"`
    (`ik` passes the solver's settings) or
    `"model"`: `model` is then a path to a model file saved with a `map_spec`
    (`wsmap.learn.predict_maps_from_file`; `wsmap.learn` must be imported, it registers
    the method in `MAP_PREDICTORS`) whose grid, pose convention and fixed orientation
    (R3) or point (SO3) are the ones asked for and which covers every node of the grid; otherwise
    `ValueError` says what differs, and arms outside the model's training range are refused unless
    `allow_extrapolation`. `collision` as `constant_orientation_map` (not with `"model"`).

    `progress`: `True` shows a bar on stderr of the nodes settled (numerically: as the search
    solves them, wave after wave), or a callable `progress(n)` (`wsmap._progress`).
    `return_status`: also the int8 status `(N,)` of each node (`constant_orientation_map`), before
    the method; not with `"model"`.
    """
    check_progress(progress)
    nodes = cartesian_grid(grid["lo"], grid["hi"], grid["step"])
    scope = grid["scope"]
    check_choice("scope", scope, SCOPES)
    if method == "model":
        if return_status:
            raise ValueError("method 'model' predicts a map; return_status needs method exact or numerical")
        if collision is not None:
            raise ValueError("method 'model' predicts the chain's map; collision= needs method exact or numerical")
        if model is None:
            raise ValueError("method 'model' needs a model file (--model PATH)")
        if "model" not in MAP_PREDICTORS:
            raise ValueError("method 'model' is supplied by wsmap.learn (trained networks, needs torch): "
                             "import wsmap.learn first")
        fixed = rpy if scope == "R3" else point
        flat = MAP_PREDICTORS["model"](model, robot, fixed, grid=grid, convention=convention,
                                       allow_extrapolation=allow_extrapolation)
        if flat.shape != (len(nodes),):  # a model file disagreeing with its own spec
            raise ValueError(f"model {model} gave a map of shape {flat.shape}, the grid has {len(nodes)} nodes")
        return (flat, "model") if return_method else flat
    method = resolve_method(robot, method)
    ik = ik if isinstance(ik, SearchSettings) else dict(ik or {})
    if scope == "R3":
        return constant_orientation_map(robot, nodes, rpy, method=method, convention=convention, ik=ik,
                                        progress=progress, return_method=return_method, collision=collision,
                                        return_status=return_status)
    return orientation_map(robot, nodes, point, method=method, convention=convention, ik=ik, progress=progress,
                           return_method=return_method, collision=collision, return_status=return_status)


def grid_status(robot: Arm, grid: dict, reached: ArrayLike, *, rpy: ArrayLike = (0.0, 0.0, 0.0),
                point: ArrayLike = (0.5, 0.5, 0.5), method: str = "auto", convention: str = "standard",
                budget: int | None = None) -> NDArray[np.int8]:
    """The int8 status `(N,)` of a `grid_map` already computed (`reached` `(N,)` bool, node order),
    with the same `grid`, `rpy` / `point`, `method` and `convention`: `REACHED`,
    `CERTIFIED` or `NOT_FOUND` (`wsmap.workspace.status.node_status`, its `budget` too); the map
    itself is not computed again."""
    nodes = cartesian_grid(grid["lo"], grid["hi"], grid["step"])
    reached = np.asarray(reached, dtype=bool)
    if reached.shape != (len(nodes),):
        raise ValueError(f"reached must have shape ({len(nodes)},) (the grid's nodes), got {reached.shape}")
    method = resolve_method(robot, method)
    check_choice("scope", grid["scope"], SCOPES)
    if grid["scope"] == "R3":
        T = target_poses(nodes, triple("rpy", rpy), convention)
    else:
        T = target_poses(triple("point", point)[None, :], nodes, convention)
    return node_status(robot, T, reached, method, budget=budget)
