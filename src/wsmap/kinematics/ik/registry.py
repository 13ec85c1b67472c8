"""The closed-form extension point: each closed form registers a recogniser and a solver here.

A closed form is one module of `wsmap.kinematics.ik.closed_forms` that ends with
`register(ClosedForm(...))`; that package discovers every module in it (`wsmap._plugins.discover`),
so adding a closed form is one new file there (and its tests). The registry asks them by their
`priority` (lower first), then their name. Whoever needs to decide "closed form or numerical", or which
closed form, asks `closed_form_for` (the maps, the reach maps, base placement, the dataset
labels, the command line).

Branch numbering, shared by every 6R closed form with 8 branches (`q` of shape `(..., 8, 6)`):
branch `k = 4·shoulder + 2·wrist + elbow` (bit 2 `SHOULDER`, bit 1 `WRIST`, bit 0
`ELBOW`), each bit defined on the closed form's canonical joint angles `θ`:

* shoulder 0: `θ1 = φ + asin(o/r)`, 1: `θ1 = φ + pi − asin(o/r)`, with `(r, φ)` the polar
  coordinates of the wrist point in the base plane and `o` the arm's lateral offset (`d3` of
  the spherical-wrist family, `d4` of the UR family);
* wrist 0: `sin θ5 >= 0`, 1: `sin θ5 <= 0`;
* elbow 0: `sin ψ >= 0`, 1: `sin ψ <= 0`, with `ψ` the elbow angle of the planar two-link
  arm of joints 2 and 3 (`θ3` for the UR family, `θ3 + atan2(d4, a3)` for the spherical-wrist
  family, whose forearm is pitched by that angle).
"""

from __future__ import annotations

import functools
import threading
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from ..._plugins import Registry
from ..arms import ArmBatch
from ..chain import PRISMATIC, SerialChain
from ..dh import DHRobot
from .memo import Memo, chain_key, content_key
from .solution import IKReason, IKSolution
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap._typing import ArrayLike
    from wsmap.kinematics.chain import Arm

__all__ = ["SHOULDER", "WRIST", "ELBOW", "ClosedForm", "CLOSED_FORMS", "register", "unregister", "closed_forms",
           "closed_form_for", "require_closed_form", "into_limits", "solution_within_limits", "within_limits"]

#: Bits of a closed-form branch index (see the module notes).
SHOULDER, WRIST, ELBOW = 4, 2, 1


@dataclass(frozen=True)
class ClosedForm:
    """A closed-form inverse kinematics for a family of arms.

    name : short identifier (`"spherical_wrist"`, `"ur"`), also the family's name in messages
        and map settings
    description : the family in words, for messages (`"the UR family"`)
    recognise : `robot -> bool array` of the robot's batch shape, True for each arm the closed form
        solves (False, not an error, for any other arm or robot type); a pure function of the
        arm's numbers (`closed_form_for` remembers its answers by the arm's content)
    require : `robot -> None`, raises `ValueError` naming the first arm and what differs
    solve : `(robot, T) -> IKSolution`, every branch (a branch axis before the joints), joint
        limits honoured (a branch outside them fails with `OUTSIDE_LIMITS`); `register` passes it
        through `within_limits`, so each succeeding branch's revolute angles come back inside the
        limits (moved by whole turns), whatever range the closed form computes them in
    reachable : `(robot, T) -> bool array`, some branch of `solve` succeeds (a faster path
        where the closed form has one); the shape of `T.shape[:-2]` broadcast with the batch
    priority : int, the order in which `closed_form_for` asks the closed forms (lower first): a
        family's own closed form before a more general one that also solves it
    """

    name: str
    description: str
    recognise: Callable
    require: Callable
    solve: Callable
    reachable: Callable
    priority: int


#: The registered closed forms, by `(priority, name)`.
CLOSED_FORMS: Registry[ClosedForm] = Registry("closed form")


#: The answers of `closed_form_for`, by the arm's content and the registered closed forms: a map
#: asks for the same arm several times (the method, the solver's check, the solve), and a family
#: test on the joint axes' geometry costs a few hundred microseconds.
_ANSWERS = Memo(size=32)
_ANSWERS_LOCK = threading.Lock()  # the memo's get is not atomic


def register(closed_form: ClosedForm) -> ClosedForm:
    """Add `closed_form` to the registry (asked by priority); returns the record stored, whose
    `solve` is `within_limits(closed_form.solve)`. A name that is already registered, or a
    priority that is not an int, is a `ValueError`."""
    if not isinstance(closed_form, ClosedForm):
        raise TypeError(f"register takes a ClosedForm, got {type(closed_form).__name__}")
    if not getattr(closed_form.solve, "within_limits", False):
        closed_form = replace(closed_form, solve=within_limits(closed_form.solve))
    return CLOSED_FORMS.register(closed_form)


def unregister(name: str) -> None:
    """Remove the closed form `name` (`KeyError` if none is registered under it)."""
    CLOSED_FORMS.unregister(name)


def closed_forms() -> tuple[ClosedForm, ...]:
    """The registered closed forms, by priority."""
    return CLOSED_FORMS.records()


def closed_form_for(robot: Arm) -> ClosedForm | None:
    """The registered closed form that recognises every arm of `robot` (the first by priority,
    should two), or None; None for anything that is not an arm (a `DHRobot` or a
    `SerialChain`), and for a chain with coupled joints (`SerialChain.coupling`: the closed forms
    solve one variable per joint, so such a chain maps by the numerical search)."""
    if not isinstance(robot, ArmBatch) or getattr(robot, "coupling", None) is not None:
        return None
    records = CLOSED_FORMS.records()
    key = _arm_key(robot)
    if key is None:
        return _first_recognising(records, robot)
    # the records themselves in the key: a closed form registered or removed is a new question
    with _ANSWERS_LOCK:
        return _ANSWERS.get((records, key), lambda: _first_recognising(records, robot))


def _first_recognising(records, robot):
    for cf in records:
        if bool(np.all(cf.recognise(robot))):
            return cf
    return None


def _arm_key(robot):
    """A content key of everything a recogniser may read of a `DHRobot` or `SerialChain` (None
    for another arm type, which is not remembered)."""
    if type(robot) is DHRobot:
        return content_key("dh", np.asarray(robot.d), np.asarray(robot.a), np.asarray(robot.alpha),
                           None if robot.qlim is None else np.asarray(robot.qlim),
                           None if robot.tool is None else np.asarray(robot.tool), robot.name)
    if type(robot) is SerialChain:
        return ("chain", robot.n, robot.name) + chain_key(robot)
    return None


def _names() -> str:
    words = [cf.description for cf in CLOSED_FORMS.records()]
    return " and ".join(words) if len(words) <= 2 else ", ".join(words[:-1]) + " and " + words[-1]


def require_closed_form(robot: Arm, what: str = "method 'exact'") -> ClosedForm:
    """`closed_form_for`, or a `ValueError` saying that `what` has no closed form for the
    arm, which closed forms there are, and to use method 'numerical'."""
    cf = closed_form_for(robot)
    if cf is None:
        raise ValueError(f"{what} has no closed form for {getattr(robot, 'name', None) or 'this arm'} "
                         f"(closed forms: {_names()}); use method 'numerical'")
    return cf


# --------------------------------------------------------------------------- joint limits
_TWO_PI = 2.0 * np.pi


def into_limits(q: ArrayLike, success: ArrayLike, lo: ArrayLike, hi: ArrayLike,
                revolute: ArrayLike | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Revolute joint angles moved by whole turns into their limits, where a solver succeeded.

    Parameters
    ----------
    q : ndarray, shape (..., n)
        Joint coordinates (rad for revolute joints).
    success : ndarray of bool, shape `q.shape[:-1]`
        Which rows of `q` are solutions; the others are returned as they are.
    lo, hi : array_like, broadcastable to `q`
        Lower and upper limits (rad), `lo <= hi`.
    revolute : array_like of bool, shape (n,), optional
        The joints that turn (default: all); a prismatic joint is never moved.

    Returns
    -------
    q, success : ndarray
        `q` with each angle of a succeeding row that lies outside `[lo, hi]` replaced by
        `lo + mod(q − lo, 2·pi)`, the smallest `q + 2·pi·k` at or above `lo` (capped at `hi`,
        which it may pass by the 1e-12 rad slack of `wsmap.kinematics.dh.angle_in_range`; `lo`
        itself where the angle lies within that slack below `lo`), or, where `lo` is `-inf`,
        by `hi − mod(hi − q, 2·pi)`, the largest at or below `hi`.
        A row with an angle that no whole turn brings inside is no solution: its `success` is
        False (the closed forms reject such branches themselves; this is the last guard). The
        inputs themselves are returned, not copied, when nothing moves.
    """
    q = np.asarray(q)
    success = np.asarray(success, dtype=bool)
    # the common case in two contiguous reductions (a tenth of the elementwise test): every angle
    # inside the narrowest of the limits (NaN angles fail it and take the full test)
    if q.size and q.min() >= np.max(lo) and q.max() <= np.min(hi):
        return q, success
    rows = np.nonzero(success)  # only the solutions are tested and moved
    qs = q[rows]  # (S, n)
    lo_s, hi_s = ((np.broadcast_to(x, q.shape)[rows] if np.ndim(x) > 1 else np.broadcast_to(x, q.shape[-1:]))
                  for x in (lo, hi))
    move = (qs < lo_s) | (qs > hi_s)
    if revolute is not None:
        move &= np.asarray(revolute, dtype=bool)
    if not move.any():
        return q, success
    r, j = np.nonzero(move)
    lo_m = lo_s[r, j] if lo_s.ndim > 1 else lo_s[j]
    hi_m = hi_s[r, j] if hi_s.ndim > 1 else hi_s[j]
    x = qs[r, j]
    # the same operations as angle_in_range, so that both agree on every angle; a limit of
    # -inf (half-open) moves the angle down below hi instead
    with np.errstate(invalid="ignore"):
        rem = np.mod(x - lo_m, _TWO_PI)
        shifted = np.where(np.isfinite(lo_m), lo_m + rem, hi_m - np.mod(hi_m - x, _TWO_PI))
    above = (shifted <= hi_m + 1e-12) | ((hi_m - lo_m) >= _TWO_PI)
    below = ~above & (rem >= _TWO_PI - 1e-12)  # within the slack below lo: lo itself
    fits = above | below
    qs[r, j] = np.where(above, np.minimum(shifted, hi_m), np.where(below, lo_m, x))
    if not fits.all():  # rows with an angle no turn brings inside: no solution, left as they were
        bad = np.unique(r[~fits])
        qs[bad] = q[tuple(i[bad] for i in rows)]
        success = success.copy()
        success[tuple(i[bad] for i in rows)] = False
    q = q.copy()
    q[rows] = qs
    return q, success


def solution_within_limits(robot: Arm, sol: IKSolution) -> IKSolution:
    """A closed form's solution `sol` (a branch axis before the joints) with every succeeding
    branch's revolute angles inside the limits of `robot` (its `qlim`, `(n, 2)` or
    `(..., n, 2)`, or None), by `into_limits`; a branch no whole turn brings inside fails with
    `OUTSIDE_LIMITS`. `sol` itself where nothing moves."""
    qlim = getattr(robot, "qlim", None)
    if qlim is None:
        return sol
    qlim = np.asarray(qlim, dtype=np.float64)
    if qlim.ndim > 2:
        qlim = qlim[..., None, :, :]  # the branch axis of sol.q, before the joints
    kinds = getattr(robot, "kinds", None)
    revolute = None if kinds is None else np.array([k != PRISMATIC for k in kinds])
    q, success = into_limits(sol.q, sol.success, qlim[..., 0], qlim[..., 1], revolute)
    if q is sol.q and success is sol.success:
        return sol
    reason = sol.reason
    if success is not sol.success:
        reason = np.where(success | ~np.asarray(sol.success, dtype=bool), reason,
                          np.int8(IKReason.OUTSIDE_LIMITS)).astype(np.asarray(reason).dtype)
    return replace(sol, q=q, success=success, reason=reason)


def within_limits(solve: Callable) -> Callable:
    """`solve(robot, T, ...)` of a closed form with its answer through `solution_within_limits`
    (a function already wrapped is returned as it is). `register` applies it to every closed form's
    `solve`; the closed forms' own public functions wear it too, so they answer alike."""
    if getattr(solve, "within_limits", False):
        return solve

    @functools.wraps(solve)
    def solve_within_limits(robot, T, *args, **kwargs):
        return solution_within_limits(robot, solve(robot, T, *args, **kwargs))

    solve_within_limits.within_limits = True
    return solve_within_limits
