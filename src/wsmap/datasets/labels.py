"""Labels: which nodes of the grid each arm reaches.

`method="exact"`: the closed-form test of `wsmap.workspace` (spherical-wrist family,
unlimited joints). `method="numerical"`: the paper's Levenberg–Marquardt (the IK solver
`"paper"` of `wsmap.kinematics.ik.solvers`, `ikine_LM`, called as the maps call a solver: one arm
and its targets at a time) with `tol`, `ilimit`, `rlimit`, from `starts` start configurations;
a node is reachable when ANY
start converges. Start 0 is `q0 = 0` (the paper's); starts 1.. are drawn per arm uniformly in
`[-pi, pi)^6` and shared by all nodes of that arm (`wsmap.datasets.start_configurations`).
Later starts are run only on the nodes the earlier ones did not solve (the union does not depend
on that). See `wsmap.datasets.starts_study` and `wsmap.datasets.starts_recall` for how
the default number of starts was chosen. Two things keep the numerical labels right and
affordable without changing any of them: pairs that `possibly_reachable` proves unreachable
(a sound bound on reach, height and tool tilt) are not handed to LM, and every LM success is
confirmed by forward kinematics (the LM pose error is also zero at a half turn of the
orientation, see `fk_confirmed`).

A chain family (`panda7`, `wsmap.datasets.spec.CHAIN_FAMILIES`) is labelled by the maps'
numerical path: `wsmap.workspace.constant_orientation_map` (R3) or
`wsmap.workspace.orientation_map` (SO3) with `method="numerical"` and the spec's
convention, i.e. `wsmap.kinematics.ik.search.map_search` with its defaults
(`MAP_SETTINGS`, seed 0) but for the border search
and the global seeding (`LABEL_SEARCH`: `border_starts=0`, `fk_seeds=0`): the search with the joint limits inside
it, each node started from its neighbours' solutions, every success confirmed by forward
kinematics inside the limits (so `True` is never wrong). An arm's labels do not depend on the
other arms of its batch, nor on the thread count. With the spec's `collision` settings
(`wsmap.datasets.collision`) each arm is mapped with `collision=` its own
`CollisionChecker`: `True` then also means a collision-free solution was
found (the search keeps looking when its first solutions collide).
"""

from __future__ import annotations

import numpy as np

from .. import robots
from .. import workspace as ws
from ..kinematics import DHRobot, SerialChain, require_closed_form
from ..kinematics.ik import SearchSettings, get_solver
from .features import check_arms, fixed_rows, scales_for, spec_nodes
from .sampling import start_configurations
from .spec import METHODS, N_JOINTS, DatasetSpec, check_choice, check_spec, float64_array, require_finite
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap._typing import ArrayLike

__all__ = ["possibly_reachable", "labels_for", "pair_poses", "lm_settings_for", "solve_confirmed", "fk_confirmed",
           "FK_CHECK_TOL"]

#: position and rotation-matrix tolerance of the forward-kinematics check of every LM success
FK_CHECK_TOL = 1e-6

#: What the chain families' labels change in the map search's defaults: no border search. It makes a
#: map about five times slower (measured on panda7_tooldown: 4 s an arm on a loaded core against
#: 0.8 s) for the last few border nodes: these labels had a measured recall of 0.9997 without it
#: (docs/recall.md), far below the models' error, and 20000 arms are a 5-hour job with it. Every
#: positive label is still a confirmed solution; the labels are those the committed models learned.
#: Nor the global seeding (issue 41): it adds 7 nodes to 5 of 12 panda7 arms' tool-down maps (25³),
#: which would change the committed datasets, and doubles a batch's labelling time (2.5 s -> 5.1 s
#: for 12 arms: a batch skips the joint-limit bound, so every node left takes its 8 seeded starts).
LABEL_SEARCH = {"border_starts": 0, "fk_seeds": 0}


def pair_poses(spec: DatasetSpec, nodes, fixed, b_idx, n_idx) -> np.ndarray:
    """The target flange poses of (arm, node) pairs, in the arms' base frame.

    Parameters
    ----------
    spec : DatasetSpec
        Its `scope` (R3: the nodes are positions, `fixed` orientations; SO3: the nodes are
        orientation angles, `fixed` points) and `convention` (`wsmap.workspace.target_poses`).
    nodes : numpy.ndarray, shape (N, 3)
        The grid nodes (m for R3, rad for SO3).
    fixed : numpy.ndarray, shape (B, 3)
        The fixed orientation (rad) or point (m) of each arm.
    b_idx, n_idx : numpy.ndarray of int, shape (K,)
        Pair `k` is arm `b_idx[k]` at node `n_idx[k]`.

    Returns
    -------
    numpy.ndarray, shape (K, 4, 4), float64
        Homogeneous poses (m).
    """
    if spec.scope == "R3":
        return ws.target_poses(nodes[n_idx], fixed[b_idx], spec.convention)
    return ws.target_poses(fixed[b_idx], nodes[n_idx], spec.convention)


def possibly_reachable(arms: DHRobot, T: ArrayLike, margin: float = 1e-8) -> np.ndarray:
    """A sound necessary condition for the flange pose `T` to be reachable (any 6R arm, no limits).

    `arms` and `T` `(..., 4, 4)` broadcast. `False` means provably unreachable: every
    pose the arm can reach is at least `margin` (m) away in position. With standard DH the flange
    origin is `o_6 = sum_i (d_i z_{i-1} + a_i x_i)` with `x_i ⊥ z_i` and `angle(z_i, z_{i-1}) =
    |alpha_i|`, hence, for the target orientation `R`:

    * the wrist point `o_5 = p - R·Rx(-alpha_6)·(a_6, 0, d_6)` is fixed by the target and
      `|o_5| <= sum_{i<=5} sqrt(a_i² + d_i²)`;
    * `angle(z_i, z_0) <= Θ_i = min(pi, sum_{j<=i} |alpha_j|)`, so `z_{i-1}·ẑ ∈ [cos Θ_{i-1}, 1]`
      and `|x_i·ẑ| <= sin(min(pi/2, Θ_i))`, which bounds the height of `o_5`;
    * the tool axis `R·ẑ` is at most `Θ_6` from the base `ẑ`.

    LM reports success only within `tol` of the target (the position error is part of the error
    norm), so with `margin >= tol` skipping the pairs this rejects never changes a numerical
    label; for arms with small twists (Table 3's arbitrary family) it skips most unreachable pairs.
    """
    _check_arms_6(arms)
    T = float64_array(T, f"T must be poses of shape (..., 4, 4), got {type(T).__name__}")
    if T.ndim < 2 or T.shape[-2:] != (4, 4):
        raise ValueError(f"T must have shape (..., 4, 4), got {T.shape}")
    margin = float(margin)
    if not margin >= 0:
        raise ValueError(f"margin must be a non-negative number, got {margin!r}")
    d, a, al = arms.d, arms.a, arms.alpha
    R, p = T[..., :3, :3], T[..., :3, 3]
    a6, d6, c6, s6 = a[..., 5], d[..., 5], np.cos(al[..., 5]), np.sin(al[..., 5])
    # Rx(-alpha_6)·(a_6, 0, d_6) = (a_6, d_6·sin(alpha_6), d_6·cos(alpha_6))
    off = np.stack(np.broadcast_arrays(a6, d6 * s6, d6 * c6), axis=-1)
    o5 = p - (R @ off[..., None])[..., 0]
    reach = np.sqrt(a[..., :5] ** 2 + d[..., :5] ** 2).sum(axis=-1)
    cum = np.minimum(np.pi, np.cumsum(np.abs(al), axis=-1))  # Θ_1..Θ_6
    prev = np.concatenate([np.zeros_like(cum[..., :1]), cum[..., :-1]], axis=-1)  # Θ_0..Θ_5
    cz = np.cos(prev[..., :5])
    sx = np.sin(np.minimum(np.pi / 2, cum[..., :5]))
    dz = np.stack([d[..., :5] * cz, d[..., :5]], axis=0)
    zlo = (dz.min(axis=0) - np.abs(a[..., :5]) * sx).sum(axis=-1)
    zhi = (dz.max(axis=0) + np.abs(a[..., :5]) * sx).sum(axis=-1)
    tilt = np.arccos(np.clip(R[..., 2, 2], -1.0, 1.0))
    return (
        (np.linalg.norm(o5, axis=-1) <= reach + margin)
        & (o5[..., 2] >= zlo - margin)
        & (o5[..., 2] <= zhi + margin)
        & (tilt <= cum[..., 5] + 1e-12)
    )


def _check_arms_6(arms) -> DHRobot:
    if not isinstance(arms, DHRobot):
        raise TypeError(f"arms must be a DHRobot, got {type(arms).__name__}")
    if arms.n != N_JOINTS:
        raise ValueError(f"possibly_reachable is for 6-joint arms, got {arms.n} joints")
    return arms


def lm_settings_for(spec: DatasetSpec, q0=None) -> SearchSettings:
    """The settings of the paper's LM solver (`"paper"`) for a spec's numerical labels.

    Parameters
    ----------
    spec : DatasetSpec
        Its `tol` (m and rad, at least `wsmap.kinematics.ik.solution.MIN_TOL`), `ilimit` and `rlimit`.
    q0 : array_like, shape (6,), optional
        The start (rad); None: zeros.

    Returns
    -------
    SearchSettings
        `solver="paper"`, the initial damping its default (0.1, `ikine_LM`'s).

    Raises
    ------
    ValueError
        A `tol` below `MIN_TOL` (no pose meets it in float64), as `SearchSettings` words it.
    """
    return SearchSettings(solver="paper", q0=None if q0 is None else tuple(q0), tol=spec.tol, ilimit=spec.ilimit,
                          rlimit=spec.rlimit)


def solve_confirmed(arms: DHRobot, b_idx, T, q0, spec: DatasetSpec) -> np.ndarray:
    """The paper's LM on (arm, target) pairs, each success confirmed by forward kinematics.

    The pairs are grouped by arm and each arm's targets solved by one call of the solver
    `"paper"` (`wsmap.kinematics.ik.solver.get_solver`, as the maps call it) with
    `lm_settings_for(spec, q0[b])`; a target's answer does not depend on the others of its call,
    so the grouping changes no label.

    Parameters
    ----------
    arms : DHRobot, batch (B,)
        The arms; their joint limits and tool, if any, are not used (the paper's labels).
    b_idx : array_like of int, shape (K,)
        The arm of each target.
    T : numpy.ndarray, shape (K, 4, 4)
        Target flange poses in the arms' base frame (m).
    q0 : numpy.ndarray, shape (B, 6)
        The start of each arm (rad), shared by its targets.
    spec : DatasetSpec
        Its `tol`, `ilimit` and `rlimit`.

    Returns
    -------
    numpy.ndarray, shape (K,), bool
        True where LM converged and `fk_confirmed` confirms the solution.
    """
    b_idx = np.asarray(b_idx, dtype=np.int64)
    ok = np.zeros(len(b_idx), dtype=bool)
    solver = get_solver("paper")
    order = np.argsort(b_idx, kind="stable")
    for group in np.split(order, np.flatnonzero(np.diff(b_idx[order])) + 1):
        if not group.size:
            continue
        b = int(b_idx[group[0]])
        # the DH numbers alone: the labels are those of the arms without limits or tool
        arm = DHRobot(arms.d[b], arms.a[b], arms.alpha[b])
        sol = solver.solve(arm, T[group], lm_settings_for(spec, q0[b]))
        ok[group] = fk_confirmed(arm, T[group], sol.q, sol.success)
    return ok


def fk_confirmed(robot: DHRobot, T, q, success) -> np.ndarray:
    """`success` where the solution `q` really reaches its target: position and rotation matrix
    within `FK_CHECK_TOL` of `T`.

    `pose_error`'s rotation part `0.5·sum(c_k x t_k)` is `sin(theta)·axis`: it vanishes at a
    half turn as well as at the target, so an LM "success" could in principle be the right
    position with the orientation off by pi. This check makes such a success a failure; in our
    runs it has never triggered.

    Parameters
    ----------
    robot : DHRobot
        One arm, or a batch `(K,)` (one arm per target).
    T : numpy.ndarray, shape (K, 4, 4)
        The targets (m).
    q : numpy.ndarray, shape (K, 6)
        The solutions (rad); read only where `success`.
    success : numpy.ndarray, shape (K,), bool
        The solver's successes.

    Returns
    -------
    numpy.ndarray, shape (K,), bool
    """
    ok = np.array(success, dtype=bool)
    if ok.any():
        idx = np.nonzero(ok)[0]
        Tc = (robot if robot.batch_shape == () else robot[idx]).fkine(q[idx])
        err = np.abs(Tc[:, :3, :] - T[idx][:, :3, :]).reshape(len(idx), -1).max(axis=1)
        ok[idx] = err <= FK_CHECK_TOL
    return ok


def _numerical_first_start(arms, spec, nodes, fixed, q0, prefilter=True) -> np.ndarray:
    """Index of the first start that solves each (arm, node) pair `(B, N)`, -1 where none does.

    int16: start indices up to `wsmap.datasets.spec.MAX_STARTS` fit (int8 would wrap at 128).
    """
    B, N = arms.batch_shape[0], len(nodes)
    first = np.full((B, N), -1, dtype=np.int16)
    b_idx, n_idx = (x.ravel() for x in np.indices((B, N)))
    if prefilter:
        # provably unreachable pairs stay -1 without running LM (labels unchanged, see possibly_reachable)
        ok = np.empty(b_idx.size, dtype=bool)
        for s in range(0, b_idx.size, 1 << 16):
            sl = slice(s, s + (1 << 16))
            sub = DHRobot(arms.d[b_idx[sl]], arms.a[b_idx[sl]], arms.alpha[b_idx[sl]])
            ok[sl] = possibly_reachable(sub, pair_poses(spec, nodes, fixed, b_idx[sl], n_idx[sl]), max(1e-8, spec.tol))
        b_idx, n_idx = b_idx[ok], n_idx[ok]
    for k in range(q0.shape[1]):
        if not b_idx.size:
            break
        T = pair_poses(spec, nodes, fixed, b_idx, n_idx)
        ok = solve_confirmed(arms, b_idx, T, q0[:, k], spec)
        first[b_idx[ok], n_idx[ok]] = k
        b_idx, n_idx = b_idx[~ok], n_idx[~ok]
    return first


def _nodes_array(nodes) -> np.ndarray:
    nodes = float64_array(nodes, f"nodes must be numbers of shape (N, 3), got {type(nodes).__name__}")
    if nodes.ndim != 2 or nodes.shape[1] != 3:
        raise ValueError(f"nodes must have shape (N, 3), got {nodes.shape}")
    require_finite(nodes, "nodes contain NaN or infinite values")
    return nodes


def _chain_family_labels(arms, spec: DatasetSpec, fx, nodes) -> np.ndarray:
    """Labels `(count, N)` of a chain family's arms (a checked SerialChain batch): the numerical
    map, one call per distinct orientation (point); arms sharing one are mapped as one batch (the
    same labels as one by one)."""
    count = arms.batch_shape[0]
    out = np.empty((count, len(nodes)), dtype=bool)
    if count == 0:
        return out
    if spec.collision is not None:
        # a checker belongs to one arm (its capsules follow the arm's links, its matrix is its own),
        # and the maps take one arm's predicate: arm by arm
        mapper = ws.constant_orientation_map if spec.scope == "R3" else ws.orientation_map
        for b in range(count):
            out[b] = mapper(arms[b], nodes, fx[b], method="numerical", convention=spec.convention, ik=LABEL_SEARCH,
                            collision=spec.collision.checker(arms[b]))
        return out
    rows, inverse = np.unique(fx, axis=0, return_inverse=True)
    for k, row in enumerate(rows):
        idx = np.flatnonzero(inverse.reshape(-1) == k)
        sub = arms if idx.size == count else arms[idx]
        if spec.scope == "R3":
            out[idx] = ws.constant_orientation_map(sub, nodes, row, method="numerical", convention=spec.convention,
                                                   ik=LABEL_SEARCH)
        else:
            out[idx] = ws.orientation_map(sub, nodes, row, method="numerical", convention=spec.convention,
                                          ik=LABEL_SEARCH)
    return out


def _chain_labels_for(arms, spec: DatasetSpec, fixed, method: str, q0, nodes: np.ndarray) -> np.ndarray:
    """`labels_for` of a chain family: the numerical map search (no other method, no `q0`) on the
    family's arms (a SerialChain batch, or their scale factors)."""
    if method != "numerical":
        raise ValueError(f"family {spec.family!r} has no closed form: method must be 'numerical', got {method!r}")
    if q0 is not None:
        raise ValueError(f"q0 sets the paper's LM starts; family {spec.family!r} is labelled by the map search, "
                         "which starts from neighbouring nodes' solutions")
    if isinstance(arms, SerialChain):
        scales_for(arms, spec)  # checks that they are a batch (count,) of the family's arms
    else:
        arms = robots.family_arm(spec.family, scales_for(arms, spec))
    return _chain_family_labels(arms, spec, fixed_rows(spec, arms.batch_shape[0], fixed), nodes)


def _checked_starts(spec: DatasetSpec, count: int, q0) -> np.ndarray:
    """The LM start configurations `(count, S, 6)` for `count` arms: `q0` (`(S, 6)` shared or
    `(count, S, 6)`, finite) or, when `None`, the spec's `start_configurations`."""
    if q0 is None:
        q0 = start_configurations(spec, count)
    q0 = float64_array(q0, f"q0 must be numbers of shape (S, 6) or ({count}, S, 6)")
    if q0.ndim == 2:
        q0 = np.broadcast_to(q0, (count,) + q0.shape)
    if q0.ndim != 3 or q0.shape[0] != count or q0.shape[2] != N_JOINTS or q0.shape[1] < 1:
        raise ValueError(f"q0 must have shape (S, 6) or ({count}, S, 6) with S >= 1, got {q0.shape}")
    return require_finite(q0, "q0 contains NaN or infinite values")


def _exact_labels(arms: DHRobot, spec: DatasetSpec, nodes: np.ndarray, fx: np.ndarray) -> np.ndarray:
    """Closed-form labels `(count, N)` of spherical-wrist `arms` at `nodes`, with the fixed
    orientation (R3) or point (SO3) `fx` `(count, 3)` of each arm."""
    count = arms.batch_shape[0]
    if count == 0:
        return np.zeros((0, len(nodes)), dtype=bool)
    # one orientation for all arms (a fixed spec, or rows that happen to agree): the map functions
    if not np.any(fx != fx[0]):
        if spec.scope == "R3":
            return ws.constant_orientation_map(arms, nodes, fx[0], method="exact", convention=spec.convention)
        return ws.orientation_map(arms, nodes, fx[0], method="exact", convention=spec.convention)
    # one orientation (point) per arm: the pose of node n for arm b, the closed form's reach test,
    # a few arms at a time (the (arms, nodes, 4, 4) poses are 128 bytes per pair)
    closed_form = require_closed_form(arms)
    out = np.empty((count, len(nodes)), dtype=bool)
    per = max(1, (1 << 18) // max(len(nodes), 1))
    for s in range(0, count, per):
        sl = slice(s, min(s + per, count))
        if spec.scope == "R3":
            T = ws.target_poses(nodes[None, :, :], fx[sl, None, :], spec.convention)
        else:
            T = ws.target_poses(fx[sl, None, :], nodes[None, :, :], spec.convention)
        sub = arms[sl]
        node_arms = DHRobot(sub.d[:, None, :], sub.a[:, None, :], sub.alpha[:, None, :])
        out[sl] = closed_form.reachable(node_arms, T)
    return out


def labels_for(
    arms: DHRobot,
    spec: DatasetSpec,
    fixed: ArrayLike | None = None,
    *,
    method: str | None = None,
    q0: ArrayLike | None = None,
    nodes: ArrayLike | None = None,
    prefilter: bool = True,
) -> np.ndarray:
    """Labels `(count, n_nodes)` bool of a batch of arms for `spec`, in node order.

    Parameters
    ----------
    arms : DHRobot, batch `(count,)`
        For a chain family (`panda7`): the family's arms (a SerialChain batch `(count,)`,
        `wsmap.robots.family_arm`) or their scale factors `(count, 6)`; labelled by the
        numerical map search (see the module notes; `method` `"numerical"` only, no `q0`,
        no `prefilter`).
    fixed : `(3,)` or `(count, 3)`, optional
        Orientation (R3, rad) or point (SO3, m); default the spec's (required if `"random"`).
    method : `"exact"` | `"numerical"`, optional
        Overrides the spec's (the label audit runs the numerical path on a spherical-wrist spec).
    q0 : `(count, S, 6)` or `(S, 6)`, optional
        Start configurations for the numerical path; default `start_configurations` of the spec
        for the first `count` arms (only right for the spec's own arms in order; pass them
        explicitly otherwise). `S = 1` with zeros is the paper's single start.
    nodes : `(N, 3)`, optional
        Nodes to label instead of `spec_nodes` (positions for R3, angles for SO3).
    prefilter : bool
        Numerical path: skip the pairs `possibly_reachable` proves unreachable (same labels,
        faster). `False` runs LM on every pair.
    """
    check_spec(spec)
    method = spec.method if method is None else check_choice("method", method, METHODS)
    nodes = spec_nodes(spec) if nodes is None else _nodes_array(nodes)
    if spec.is_chain_family:
        return _chain_labels_for(arms, spec, fixed, method, q0, nodes)
    arms = check_arms(arms)
    count = arms.batch_shape[0]
    fx = fixed_rows(spec, count, fixed)
    if method == "numerical":
        lm_settings_for(spec)  # a tol no pose meets is refused before any work
        q0 = _checked_starts(spec, count, q0)
        return _numerical_first_start(arms, spec, nodes, fx, q0, prefilter) >= 0
    return _exact_labels(arms, spec, nodes, fx)
