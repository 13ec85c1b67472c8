"""Design across morphologies: the shortest arm of *any* twist pattern whose tool-down map covers
given task positions (issue 28, item 6).

`wsmap.design` searches the lengths of one family. Here the twist pattern is a design
variable too: every 6R (or 7R) arm whose consecutive joint axes are parallel or perpendicular
(`alpha` in `{0, +pi/2, -pi/2}`, 243 patterns for 6 joints), with its link lengths and offsets,
is one point of `MorphDesignSpace`. The surrogate is the morphology model
(`wsmap.learn.morph_model.MorphMapModel`, one network for every arm), so the search is one
batched gradient descent over every pattern at once (`design_across_morphologies`), each
answer verified by the classical map; `wsmap.design.design_by_cmaes` and
`design_by_random_search` search the same space on the classical map alone
(`compare_morph_designs` runs them side by side).

Conventions
-----------
* An arm is a modified-DH (Craig) table, joint `i` turning about `z_i`: row `i` is
  `(a_{i-1}, alpha_{i-1}, d_i, theta_i)` with `a_0 = alpha_0 = 0` (joint 1 about the base
  `z` axis) and every `theta_i = 0` at the controller's zero. The flange is frame `n` (no
  tool). Lengths in metres, angles in radians.
* The design parameters `(k, 3 (n - 1))` per arm, in order: `d_1 .. d_{n-1}` (offsets along
  the joint axes; `d_1` in `[0, 0.45]`, the others in `[-0.7, 0.7]`), `a_1 .. a_{n-1}`
  (common-normal lengths between axis `i` and `i + 1`, `[0, 0.7]`), then one *twist code*
  per row `2 .. n` in `[0, 1]`: `[0, 1/3)` is `alpha = 0` (axis `i + 1` parallel to axis
  `i`), `[1/3, 2/3)` is `+pi/2`, `[2/3, 1]` is `-pi/2` (`TWISTS`). `d_n = 0`:
  an offset along the last axis only moves the flange along it.
* Where axis `i + 1` is parallel to axis `i` the offset `d_i` is not a design variable (it is
  held at 0): along parallel axes only the sum of the offsets matters, and the canonical
  description (`wsmap.kinematics.morphology.describe`) keeps it in the last joint of the run.
  So every design is its own canonical description where all `a_i > 0`.
* The *total link length* is `sum_i a_i + sum_i |d_i|` over the design variables (m).
* The tasks: positions `(T, 3)` m in the base frame at the tool-down orientation
  (`R = Rx(pi)`, `T = transl(p)·R`: the morphology model's, `TOOL_DOWN`).
* Verification: each task solved on its own by `wsmap.workspace.constant_orientation_map`
  with `{"solver": "independent"}` (the per-pose search of `wsmap.reachable`, every
  success confirmed by forward kinematics inside the limits).
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import torch

from . import workspace as ws
from .design import DesignResult, check_tasks, compare_designs, design_by_gradient
from .kinematics import from_dh
from .kinematics.morphology import N_FEATURES, describe

__all__ = ["TWISTS", "MorphDesignSpace", "MorphSurrogate", "design_across_morphologies", "compare_morph_designs",
           "pattern_of"]

#: The twists a design may have between consecutive axes (rad), in twist-code order.
TWISTS = (0.0, math.pi / 2, -math.pi / 2)
_D1_MAX = 0.45  # the morph families' range (wsmap.robots.morph)
_LENGTH_MAX = 0.7
#: The verification's numerical settings: each task on its own, with reachable()'s starts.
VERIFY_IK = {"solver": "independent"}


def pattern_of(codes) -> np.ndarray:
    """Twist indices `(..., n - 1)` into `TWISTS` of twist codes `(..., n - 1)` in `[0, 1]`."""
    c = np.asarray(codes, dtype=np.float64)
    return np.clip(np.floor(c * len(TWISTS)), 0, len(TWISTS) - 1).astype(np.int64)


@dataclass(frozen=True, eq=False)
class MorphDesignSpace:
    """Arms of `n_joints` revolute joints of every twist pattern (module notes), as a design space
    for `wsmap.design` (`wsmap.design.DESIGN_SPACE_ATTRIBUTES`).

    Attributes
    ----------
    n_joints
        6 or 7.
    limits
        `(n, 2)` joint limits (rad) of every design; default a full turn each.
    rpy, convention
        the task orientation (tool down) and pose convention.
    """

    n_joints: int = 6
    limits: np.ndarray | None = None
    rpy: tuple[float, float, float] = (math.pi, 0.0, 0.0)
    convention: str = "standard"
    _cells: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def __post_init__(self):
        if self.n_joints not in (6, 7) or isinstance(self.n_joints, bool):
            raise ValueError(f"n_joints must be 6 or 7 (the morphology model's arms), got {self.n_joints!r}")
        lim = np.tile([-math.pi, math.pi], (self.n_joints, 1)) if self.limits is None else \
            np.array(self.limits, dtype=np.float64)
        if lim.shape != (self.n_joints, 2) or not np.all(np.isfinite(lim)) or np.any(lim[:, 0] >= lim[:, 1]):
            raise ValueError(f"limits must be finite (lower, upper) pairs with lower < upper, shape "
                             f"({self.n_joints}, 2), got {np.shape(self.limits)}")
        object.__setattr__(self, "limits", lim)

    # ------------------------------------------------------------------ the parameters
    @property
    def name(self) -> str:
        return f"morph{self.n_joints}_design"

    @property
    def n_free(self) -> int:
        """Rows with design variables: `n - 1`."""
        return self.n_joints - 1

    @property
    def params(self) -> tuple[str, ...]:
        m = self.n_free
        return (tuple(f"d_{i}" for i in range(1, m + 1)) + tuple(f"a_{i}" for i in range(1, m + 1))
                + tuple(f"twist_{i}" for i in range(2, m + 2)))

    @property
    def n_params(self) -> int:
        return 3 * self.n_free

    @property
    def low(self) -> np.ndarray:
        m = self.n_free
        return np.concatenate([[0.0], np.full(m - 1, -_LENGTH_MAX), np.zeros(m), np.zeros(m)])

    @property
    def high(self) -> np.ndarray:
        m = self.n_free
        return np.concatenate([[_D1_MAX], np.full(m - 1, _LENGTH_MAX), np.full(m, _LENGTH_MAX), np.ones(m)])

    def split(self, params):
        """`(d, a, pattern)` of `params` `(..., n_params)`: offsets `(..., n - 1)` with the
        held ones (parallel axes) set to 0, lengths `(..., n - 1)`, twist indices `(..., n - 1)`.
        Numpy or torch (torch: `d` and `a` differentiable, the pattern not)."""
        m = self.n_free
        if isinstance(params, torch.Tensor):
            pattern = torch.as_tensor(pattern_of(params[..., 2 * m:].detach().cpu().numpy()), device=params.device)
            free = (pattern != 0).to(params.dtype)
        else:
            params = np.asarray(params, dtype=np.float64)
            pattern = pattern_of(params[..., 2 * m:])
            free = (pattern != 0).astype(np.float64)
        return params[..., :m] * free, params[..., m:2 * m], pattern

    def total_length(self, params):
        """`sum a + sum |d|` (m) of `params` `(..., n_params)`: `(...)` (numpy or torch)."""
        d, a, _ = self.split(params)
        return a.sum(-1) + d.abs().sum(-1) if isinstance(d, torch.Tensor) else a.sum(-1) + np.abs(d).sum(-1)

    def tables(self, params) -> np.ndarray:
        """Modified-DH rows `(k, n, 4)` `(a_{i-1}, alpha_{i-1}, d_i, theta_i)` of `params` `(k, n_params)`."""
        d, a, pattern = self.split(np.atleast_2d(np.asarray(params, dtype=np.float64)))
        k, n = d.shape[0], self.n_joints
        rows = np.zeros((k, n, 4))
        rows[:, 1:, 0] = a
        rows[:, 1:, 1] = np.asarray(TWISTS)[pattern]
        rows[:, :-1, 2] = d
        return rows

    def arms(self, params):
        """The arms `(k,)` of `params` `(k, n_params)`: a `SerialChain`
        batch (modified DH, the space's limits)."""
        rows = self.tables(params)
        qlim = np.broadcast_to(self.limits, rows.shape[:2] + (2,))
        return from_dh(rows[..., 2], rows[..., 0], rows[..., 1], offset=rows[..., 3], qlim=qlim, modified=True,
                       name=self.name)

    def classical(self, params, tasks, rpy=None, convention=None) -> np.ndarray:
        """The classical map of the designs `(k, n_params)` at `tasks` `(T, 3)`: bool `(k, T)`
        (each task solved on its own, `VERIFY_IK`)."""
        rpy = self.rpy if rpy is None else rpy
        convention = self.convention if convention is None else convention
        p = np.atleast_2d(np.asarray(params, dtype=np.float64))
        return ws.constant_orientation_map(self.arms(p), check_tasks(tasks), rpy, method="numerical",
                                           convention=convention, ik=dict(VERIFY_IK))

    def patterns(self) -> np.ndarray:
        """Every twist pattern `(3^(n-1), n - 1)` as twist indices."""
        return np.array(list(itertools.product(range(len(TWISTS)), repeat=self.n_free)), dtype=np.int64)

    def codes(self, patterns) -> np.ndarray:
        """Twist codes `(..., n - 1)` at the middle of each index's interval."""
        return (np.asarray(patterns, dtype=np.float64) + 0.5) / len(TWISTS)

    # ------------------------------------------------------------------ the model's inputs
    def features(self, params) -> torch.Tensor:
        """The morphology features `(k, N_FEATURES)` (float64) of `params` `(k, n_params)`, equal to
        `describe(arm).features()` of each design, differentiable in the lengths.

        Within a *cell* (one twist pattern and one set of zero lengths `a_i = 0`) the canonical
        description is affine in the lengths (`_cell`; one
        `describe` per cell, kept). A length at 0 is on the
        border of the cell where it is positive, with the same gradient, so the descent can move
        it off 0."""
        x = params if isinstance(params, torch.Tensor) else torch.as_tensor(np.atleast_2d(params), dtype=torch.float64)
        x = x.to(torch.float64)
        m = self.n_free
        pnp = x.detach().cpu().numpy()
        pattern = pattern_of(pnp[:, 2 * m:])
        zero = pnp[:, m:2 * m] <= 1e-12
        cells = [self._cell(tuple(p), tuple(z)) for p, z in zip(pattern.tolist(), zero.tolist())]
        f0 = torch.as_tensor(np.stack([c[0] for c in cells]), dtype=torch.float64)
        J = torch.as_tensor(np.stack([c[1] for c in cells]), dtype=torch.float64)  # (k, N_FEATURES, 2 m)
        return f0 + torch.einsum("kfj,kj->kf", J, x[:, :2 * m])

    def _canonical(self, lengths: np.ndarray, pattern) -> np.ndarray:
        p = np.concatenate([lengths, self.codes(np.asarray(pattern))])
        return describe(self.arms(p[None])[0]).features()

    def _cell(self, pattern: tuple, zero: tuple):
        """`(f0 (N_FEATURES,), J (N_FEATURES, 2 (n - 1)))` of one cell: features = f0 + J @ lengths.

        `J` scatters each free length into its row's `a` or `d` feature: where every `a_i > 0`
        a design is its own canonical description, and a zero length changes only constant
        features (a twist's sign, an offset angle of pi), which `f0` holds; the tests check both
        against `describe`."""
        key = (pattern, zero)
        if key in self._cells:
            return self._cells[key]
        m = self.n_free
        free_d = np.asarray(pattern) != 0
        J = np.zeros((N_FEATURES, 2 * m))
        for i in range(m):  # d_{i+1} is feature 3 of row i + 1; a_{i+1} (row i + 2) feature 0
            J[9 * i + 3, i] = float(free_d[i])
            J[9 * (i + 1), m + i] = 1.0
        # a point inside the cell, away from every border, lengths of a real arm's size
        x0 = np.concatenate([np.full(m, 0.15), np.where(np.asarray(zero), 0.0, 0.2)])
        x0[0] = 0.2
        self._cells[key] = (self._canonical(x0, pattern) - J @ x0, J)
        return self._cells[key]


class MorphSurrogate:
    """Differentiable task coverage of a `MorphDesignSpace` design from a morphology model.

    The margin of task `p` is the model's logit there minus the logit of its threshold
    (positive where the model predicts the task reachable). `model` is a
    `wsmap.learn.morph_model.MorphMapModel` trained on the space's joint count, at its
    orientation and convention. Raises before any work: a model of another kind (`TypeError`),
    a model without the space's joint count or at another orientation, a task outside the model's
    box (`ValueError` naming the task).

    Attributes: `bounds` (the space's box), `default_margin` (1.0: `p >= 0.73` over the threshold
    in log-odds).
    """

    default_margin = 1.0

    def __init__(self, model, space: MorphDesignSpace, tasks):
        from .learn.morph_model import MorphMapModel, family_of

        if not isinstance(model, MorphMapModel):
            raise TypeError(f"model must be a wsmap.learn.morph_model.MorphMapModel, got {type(model).__name__}")
        if not isinstance(space, MorphDesignSpace):
            raise TypeError(f"space must be a MorphDesignSpace, got {type(space).__name__}")
        if family_of(space.n_joints, model.families) is None:
            raise ValueError(f"the model was trained on {', '.join(model.families)}, not on {space.n_joints}-joint arms")
        if not np.allclose(model.rpy, space.rpy, atol=1e-9) or model.convention != space.convention:
            raise ValueError(f"the model maps rpy = {list(model.rpy)} ({model.convention!r}), the space's tasks are at "
                             f"rpy = {list(space.rpy)} ({space.convention!r})")
        self.tasks = check_tasks(tasks)
        out = np.abs(self.tasks).max(axis=1) > model.box + 1e-9
        if out.any():
            i = int(np.argmax(out))
            raise ValueError(f"task {i} at {self.tasks[i].tolist()} m lies outside the model's box "
                             f"[-{model.box}, {model.box}]³ m")
        self.model, self.space = model, space
        t = float(model.threshold)
        self.raw_threshold = math.log(t / (1.0 - t))
        self.bounds = (space.low, space.high)
        self._points = torch.as_tensor(self.tasks, dtype=torch.float32)

    def __call__(self, params: torch.Tensor) -> torch.Tensor:
        """Margins `(k, T)` float64 of designs `(k, n_params)`: positive = covered."""
        X = self.space.features(params).to(torch.float32)
        return self.model.logits_at(X, self._points).to(torch.float64) - self.raw_threshold


def _screen(surrogate: MorphSurrogate, patterns: np.ndarray, draws: int, keep: int, per_pattern: int, margin: float,
            seed) -> np.ndarray:
    """Start designs `(keep * per_pattern, n_params)` from a surrogate screen of every pattern.

    Each pattern gets `draws` uniform length draws (one batch through the model, no gradient).
    A pattern ranks by the shortest draw the model says covers every task with `margin`, the
    patterns with none after those by their best worst-task margin; the `keep` best patterns
    start from their `per_pattern` best draws (the shortest covering ones first)."""
    space = surrogate.space
    rng = np.random.default_rng(seed)
    m = space.n_free
    lo, hi = space.low[:2 * m], space.high[:2 * m]
    P = len(patterns)
    lengths = rng.uniform(lo, hi, size=(P, draws, 2 * m))
    designs = np.concatenate([lengths, np.broadcast_to(space.codes(patterns)[:, None, :], (P, draws, m))], axis=-1)
    flat = designs.reshape(P * draws, -1)
    worst = np.empty(len(flat))
    with torch.no_grad():
        for s in range(0, len(flat), 4096):
            worst[s:s + 4096] = surrogate(torch.as_tensor(flat[s:s + 4096])).min(-1).values.numpy()
    worst = worst.reshape(P, draws)
    total = space.total_length(flat).reshape(P, draws)
    covers = worst >= margin
    key = np.where(covers, total, -worst)  # covering draws by length, the rest by margin
    order = np.lexsort((key, ~covers), axis=-1)  # per pattern, its draws best first
    best = order[:, 0]
    first = np.arange(P)
    kept = np.lexsort((key[first, best], ~covers[first, best]))[:keep]  # patterns by their best draw
    return np.concatenate([designs[kept, order[kept, j]] for j in range(min(per_pattern, draws))])


def design_across_morphologies(model, tasks, space: MorphDesignSpace | None = None, *, patterns=None,
                               screen: int = 64, keep: int = 64, starts_per_pattern: int = 2, steps: int = 300,
                               lr: float = 0.05, max_rounds: int = 4, verify_top: int = 16, seed=0,
                               **gradient) -> DesignResult:
    """The shortest arm of any twist pattern whose tool-down map covers `tasks`, by gradient descent
    through the morphology model, verified by the classical map.

    First a screen through the model (`_screen`): `screen` random length draws for every
    pattern of `patterns` (twist indices `(P, n - 1)`; default all of the space's, 243 for 6
    joints) in one batch; the `keep` most promising patterns go on with `starts_per_pattern`
    starts each. `wsmap.design.design_by_gradient` descends all of them in one batch (the
    twist codes get no gradient and stay put) and, each round, verifies the `verify_top`
    shortest designs the model says cover every task, until one is verified (at most
    `max_rounds` rounds, each asking more margin). `gradient`: more keyword arguments of
    `design_by_gradient`. Returns its `DesignResult`
    (`params`: the lengths, then the twist codes; `MorphDesignSpace.tables` gives the
    design's DH table; `surrogate_evals` counts the screen too, `wall_time` includes it)."""
    import time

    t0 = time.perf_counter()
    space = MorphDesignSpace() if space is None else space
    surrogate = MorphSurrogate(model, space, tasks)
    pats = space.patterns() if patterns is None else np.array(patterns, dtype=np.int64)
    if pats.ndim != 2 or pats.shape[1] != space.n_free or len(pats) < 1 or pats.min() < 0 or pats.max() >= len(TWISTS):
        raise ValueError(f"patterns must be twist indices (P, {space.n_free}) in 0..{len(TWISTS) - 1}, got "
                         f"shape {pats.shape}")
    for name, v in (("screen", screen), ("keep", keep), ("starts_per_pattern", starts_per_pattern)):
        if isinstance(v, bool) or int(v) != v or v < 1:
            raise ValueError(f"{name} must be a positive integer, got {v!r}")
    margin = float(gradient.get("margin") or surrogate.default_margin)
    starts = _screen(surrogate, pats, int(screen), int(keep), int(starts_per_pattern), margin, seed)
    screened = time.perf_counter() - t0
    r = design_by_gradient(space, surrogate.tasks, surrogate, starts=starts, steps=steps, lr=lr, max_rounds=max_rounds,
                           verify_top=verify_top, seed=seed, **gradient)
    r.surrogate_evals += len(pats) * int(screen)
    r.wall_time += screened
    if r.time_to_verified is not None:
        r.time_to_verified += screened
    return r


def compare_morph_designs(model, tasks, space: MorphDesignSpace | None = None, *,
                          methods: Sequence[str] = ("gradient", "cmaes", "random"), length_tol: float = 0.02,
                          max_calls: int = 3000, max_seconds: float | None = 300.0, gradient: dict | None = None,
                          seed=0, warm_up: bool = True) -> tuple[list[dict], dict[str, DesignResult]]:
    """`design_across_morphologies` against CMA-ES and random search on the classical map, in
    one run (as `wsmap.design.compare_designs`): the gradient design's verified length
    `L` sets the goal `L (1 + length_tol)` of the others, which stop there or after
    `max_calls` arms / `max_seconds`. CMA-ES searches the lengths and the twist codes together
    (a code is rounded to its twist). With `warm_up` one classical call is made first, untimed.
    Returns `(rows, results)` as `compare_designs`."""
    space = MorphDesignSpace() if space is None else space
    surrogate = MorphSurrogate(model, space, tasks)  # bad model or tasks: before any work
    return compare_designs(space, surrogate.tasks, surrogate, methods=methods, length_tol=length_tol,
                           max_calls=max_calls, max_seconds=max_seconds, gradient=gradient, seed=seed,
                           warm_up=warm_up,
                           gradient_search=functools.partial(design_across_morphologies, model, surrogate.tasks,
                                                             space))
