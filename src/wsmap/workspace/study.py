"""The reach study's computation: which targets an arm placed at a base reaches, with which verified
joint solution and score, and where to place the base (ROS-Industrial REACH's question).

Frames and conventions
----------------------
Targets are tool poses `(M, 4, 4)` in the world frame (metres), the tool's z axis pointing into the
workpiece (`wsmap.workspace.workpiece`). The tool centre point (TCP) is `tcp` `(4, 4)` in the
arm's end frame (REACH's demo: `tool0` + 0.1 m along z). A base is the world pose `(4, 4)` of the
arm's base frame. The arm must put its TCP at `T_m · V_k` for some tool-frame rotation `V_k` of the
study's orientation freedom (`tool_variants`: turns about the tool axis, tilts within a cone), so
its end frame must reach `B⁻¹ · T_m · V_k · tcp⁻¹` in its base frame.

Each target gets one of three answers (`STATUS`):

* `REACHED` — a joint solution inside the joint limits (a revolute angle is moved by 2π where that
  brings it inside), confirmed by forward kinematics to `CONFIRM_TOL`, collision-free when a
  checker is given; among the variants, the one with the best combined score (ties: the lower
  variant index);
* `CERTIFIED` — no variant can be reached by any configuration: the certificates of
  `wsmap.kinematics.ik.certificate.certify` reject every variant — the sound filters (out of reach;
  outside what the joint limits allow), then the closed form's (an arm of a closed-form family) and
  the branch and bound over the joints (`joint_certificate`, arms of revolute joints; at most
  `CELL_BUDGET` boxes a variant), as for a map's nodes. Collisions only remove solutions, so the
  certificate holds with them too;
* `NOT_FOUND` — the search found no solution, and no certificate says none exists.

The orientation freedom is sampled: the answer is about the study's `K` variants (turns about the
tool axis every `2π / turns`, tilts on rings of the cone), not about every angle in between.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..kinematics import as_chain
from ..kinematics.ik.certificate import CERTIFY_MARGIN, certify
from ..kinematics.ik.settings import SearchSettings
from ..kinematics.ik.solver import get_solver
from ..kinematics.transforms import check_rigid
from .maps import resolve_method
from .scores import SCORES, combined, score_values, world_frame_scene
from .status import CERTIFIED, NOT_FOUND, REACHED, STATUS  # the codes of maps and studies alike
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from collections.abc import Callable, Sequence

    from ..kinematics.chain import Arm

__all__ = ["REACHED", "CERTIFIED", "NOT_FOUND", "STATUS", "CONFIRM_TOL", "tool_variants", "TargetResults",
           "evaluate_targets", "fit_to_limits", "BaseRegion", "BaseRanking", "rank_bases"]

#: Forward kinematics must put the end frame within this of its target (m, and rad of rotation).
CONFIRM_TOL = 1e-6


def _rz(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])


def _rx(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1.0]])


def tool_variants(turns: int = 1, cone: float = 0.0, rings: int = 0, per_ring: int = 6) -> np.ndarray:
    """The study's orientation freedom as tool-frame rotations `(K, 4, 4)`, right-multiplied onto a
    target: `Rz(φ_t) · Rz(α) Rx(θ) Rz(-α)` for turns `φ_t = 2π t / turns` about the tool axis and
    tilts `θ = cone · r / rings` (rad) at `per_ring` azimuths `α = 2π j / per_ring` on ring `r`.
    Variant 0 is the target itself; `turns = 1, cone = 0` gives only it."""
    for name, v in (("turns", turns), ("per_ring", per_ring)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
            raise ValueError(f"{name} must be an integer of at least 1, got {v!r}")
    if isinstance(rings, bool) or not isinstance(rings, (int, np.integer)) or rings < 0:
        raise ValueError(f"rings must be a non-negative integer, got {rings!r}")
    if not np.isfinite(cone) or not 0 <= cone < np.pi / 2:
        raise ValueError(f"the cone's half-angle must be in [0, pi/2) rad, got {cone!r}")
    if rings > 0 and cone == 0:
        raise ValueError("rings of tilts need a cone half-angle above 0")
    tilts = [np.eye(4)]
    for r in range(1, rings + 1):
        theta = cone * r / rings
        for j in range(per_ring):
            alpha = 2 * np.pi * j / per_ring
            tilts.append(_rz(alpha) @ _rx(theta) @ _rz(-alpha))
    return np.stack([_rz(2 * np.pi * t / turns) @ tilt for t in range(turns) for tilt in tilts])


def fit_to_limits(robot: Arm, q: np.ndarray) -> np.ndarray:
    """`q` `(..., n)` with each revolute angle moved by a multiple of 2π into its limits where one
    brings it inside (the same pose of the link); angles no shift brings inside are left as they are."""
    qlim = robot.qlim
    if qlim is None:
        return q
    lim = np.asarray(qlim, dtype=np.float64).reshape(robot.n, 2)
    revolute = as_chain(robot).periodic  # the revolute joints (a coupled chain: variables a whole turn leaves alone)
    lo, hi = lim[:, 0], lim[:, 1]
    finite = revolute & np.isfinite(lo) & np.isfinite(hi)
    shifted = q.copy()
    qf, turn = q[..., finite], 2 * np.pi
    k_lo = np.ceil((lo[finite] - qf) / turn - 1e-12)  # the turns that bring q above lo ...
    k_hi = np.floor((hi[finite] - qf) / turn + 1e-12)  # ... and below hi
    # the smallest shift: none where q is inside, else the nearest whole turn that brings it inside
    k = np.where((k_lo <= 0) & (k_hi >= 0), 0.0, np.where(k_lo > 0, k_lo, k_hi))
    shifted[..., finite] = np.where(k_lo <= k_hi, qf + turn * k, qf)
    return shifted


@dataclass
class TargetResults:
    """Per-target answers of `evaluate_targets` (M targets, n joints).

    status : (M,) int8, `REACHED`, `CERTIFIED` or `NOT_FOUND`
    q : (M, n) the chosen joint solution (rad; NaN unless reached)
    variant : (M,) int, the index of the chosen orientation variant (-1 unless reached)
    scores : name -> (M,) each score of the chosen solution (NaN unless reached)
    score : (M,) their product (NaN unless reached)
    base : (4, 4) the base pose the targets were evaluated from (world frame)
    unconfirmed : solutions a solver returned that failed the limits or the FK confirmation (dropped)
    """

    status: np.ndarray
    q: np.ndarray
    variant: np.ndarray
    scores: dict
    score: np.ndarray
    base: np.ndarray
    unconfirmed: int = 0

    @property
    def reached(self) -> np.ndarray:
        return self.status == REACHED

    @property
    def coverage(self) -> float:
        """The fraction of the targets reached."""
        return float(self.reached.mean()) if len(self.status) else 0.0

    @property
    def mean_score(self) -> float:
        """The combined score summed over the targets, over their number (unreached count 0)."""
        return float(np.where(self.reached, self.score, 0.0).sum() / max(len(self.status), 1))


def _accept(collision, base):
    """The configuration predicate of an arm at `base`: a checker whose scene is in the world frame
    (`world_frame_scene`: world-frame obstacles, or a floor, a height in the world frame as the
    targets are) checks it from that base (`at_bases`), any other predicate as it is."""
    if collision is None:
        return None
    if world_frame_scene(getattr(collision, "scene", None)):
        return lambda q: collision.at_bases(q, base)
    return collision


def _solve(robot, T, method, settings, accept):
    """Solutions `(N, n)` and success `(N,)` of the end-frame poses `T` `(N, 4, 4)`."""
    if method == "exact":
        sol = get_solver("closed_form").solve(robot, T, None, accept)
    else:
        sol = get_solver("independent").solve(as_chain(robot), T, settings, accept)
    return np.asarray(sol.q, dtype=np.float64), np.asarray(sol.success, dtype=bool)


def _confirm(robot, q, ok, T):
    """`ok` narrowed to solutions inside the limits whose forward kinematics reaches `T` within
    `CONFIRM_TOL`; returns `(q fitted to the limits, ok)`."""
    q = np.where(ok[:, None], q, 0.0)
    q = fit_to_limits(robot, q)
    F = robot.fkine(q)
    dp = np.linalg.norm(F[:, :3, 3] - T[:, :3, 3], axis=-1)
    cos = (np.einsum("nij,nij->n", F[:, :3, :3], T[:, :3, :3]) - 1) / 2
    angle = np.arccos(np.clip(cos, -1, 1))
    good = ok & robot.within_limits(q) & (dp <= CONFIRM_TOL) & (angle <= CONFIRM_TOL)
    return q, good


def _certified(robot, E, todo, method):
    """`(M,)` True where target `m` of `todo` `(M,)` has every variant `E[m]` `(M, K, 4, 4)` (end
    frame, base frame) certified unreachable (`certify`: the filters, then the closed form's
    certificate and the branch and bound for an exact arm, the branch and bound for another).
    Variant by variant, each only on the targets whose earlier variants were all certified."""
    left = np.flatnonzero(todo)
    for k in range(E.shape[1]):
        if not left.size:
            break
        left = left[certify(robot, E[left, k], CERTIFY_MARGIN, method="both" if method == "exact" else "numerical")]
    out = np.zeros(len(todo), dtype=bool)
    out[left] = True
    return out


def end_poses(targets: np.ndarray, base: np.ndarray, variants: np.ndarray, tcp: np.ndarray) -> np.ndarray:
    """The end-frame poses `(M, K, 4, 4)` in the base frame: `B⁻¹ · T_m · V_k · tcp⁻¹`."""
    return np.linalg.inv(base) @ targets[:, None] @ variants[None] @ np.linalg.inv(tcp)


def _check(robot, targets, base, variants, tcp):
    if robot.batch_shape != ():
        raise ValueError(f"a study evaluates one arm at a time, got a batch of shape {robot.batch_shape}")
    T = check_rigid("targets", targets)
    if T.ndim != 3 or len(T) == 0:
        raise ValueError(f"targets must have shape (M, 4, 4) with M >= 1, got {T.shape}")
    return T, check_rigid("base", base), check_rigid("variants", variants).reshape(-1, 4, 4), check_rigid("tcp", tcp)


def evaluate_targets(robot: Arm, targets, *, base=None, variants=None, tcp=None, collision: Callable | None = None,
                     method: str = "auto", starts: int = 8, seed: int = 0,
                     scores: Sequence[str] = ("manipulability", "joint_margin")) -> TargetResults:
    """Which `targets` `(M, 4, 4)` (world frame) the arm at `base` reaches; see the module notes.

    Parameters
    ----------
    robot : one `DHRobot` or `SerialChain`
    base : (4, 4) world pose of the arm's base (default identity)
    variants : (K, 4, 4) tool-frame rotations of the orientation freedom (default `tool_variants()`)
    tcp : (4, 4) the TCP in the arm's end frame (default identity)
    collision : a configuration predicate or `wsmap.collision.CollisionChecker` (world-frame
        obstacles are checked from `base`)
    method : "auto" (the closed form where the arm has one), "exact" or "numerical"
    starts, seed : the numerical search's starts per pose and their seed
    scores : names of `wsmap.workspace.scores.SCORES`, multiplied into `score`

    Returns
    -------
    TargetResults
    """
    base = np.eye(4) if base is None else base
    variants = tool_variants() if variants is None else variants
    tcp = np.eye(4) if tcp is None else tcp
    unknown = [s for s in scores if s not in SCORES]
    if unknown:
        raise ValueError(f"unknown score {unknown[0]!r}; known: {', '.join(SCORES)}")
    T, base, variants, tcp = _check(robot, targets, base, variants, tcp)
    method = resolve_method(robot, method)
    M, K = len(T), len(variants)
    E = end_poses(T, base, variants, tcp).reshape(-1, 4, 4)
    settings = SearchSettings(solver="independent", starts=starts, seed=seed)
    q, ok = _solve(robot, E, method, settings, _accept(collision, base))
    q, good = _confirm(robot, q, ok, E)
    values = {name: np.full(M * K, np.nan) for name in scores}
    if good.any():
        for name in scores:
            values[name][good] = score_values(name, robot, q[good], collision=collision, base=base)
    total = np.where(good, combined({k: v for k, v in values.items()}, M * K), -np.inf).reshape(M, K)
    best = np.argmax(total, axis=1)  # the first of equal scores: the lower variant index
    reached = good.reshape(M, K)[np.arange(M), best]
    pick = np.arange(M) * K + best
    status = np.where(reached, REACHED, NOT_FOUND).astype(np.int8)
    status[_certified(robot, E.reshape(M, K, 4, 4), ~reached, method)] = CERTIFIED
    qs = np.where(reached[:, None], q[pick], np.nan)
    chosen = {name: np.where(reached, v[pick], np.nan) for name, v in values.items()}
    score = np.where(reached, combined(chosen, M), np.nan)
    return TargetResults(status=status, q=qs, variant=np.where(reached, best, -1), scores=chosen, score=score,
                         base=base, unconfirmed=int((ok & ~good).sum()))


# ------------------------------------------------------------------------------ base placement
@dataclass(frozen=True)
class BaseRegion:
    """Where the base may stand: `x`, `y` ranges (m) sampled at `step` (both ends included), `yaws`
    headings `2π j / yaws` about the world z axis, the floor height `z0` (m), and `keep_out` boxes
    `(x_lo, x_hi, y_lo, y_hi)` (m) where it may not stand."""

    x: tuple = (-1.0, 1.0)
    y: tuple = (-1.0, 1.0)
    step: float = 0.1
    yaws: int = 8
    z0: float = 0.0
    keep_out: tuple = field(default_factory=tuple)

    def candidates(self) -> np.ndarray:
        """The candidate base poses `(C, 4, 4)`, x fastest, then y, then yaw; a region with no room
        left is a `ValueError`."""
        for name in ("x", "y"):
            lo, hi = getattr(self, name)
            if not (np.isfinite(lo) and np.isfinite(hi)) or lo > hi:
                raise ValueError(f"base region {name}: need finite lo <= hi, got ({lo}, {hi})")
        if not np.isfinite(self.step) or self.step <= 0:
            raise ValueError(f"base region step must be positive, got {self.step}")
        # positions as whole steps from lo, rounded (no 1e-16 where a step lands on 0), + 0.0 (no -0.0)
        xs = np.round(self.x[0] + self.step * np.arange(int(np.floor((self.x[1] - self.x[0]) / self.step + 1e-9)) + 1),
                      12) + 0.0
        ys = np.round(self.y[0] + self.step * np.arange(int(np.floor((self.y[1] - self.y[0]) / self.step + 1e-9)) + 1),
                      12) + 0.0
        yaw = 2 * np.pi * np.arange(self.yaws) / self.yaws
        Y, X = np.meshgrid(ys, xs, indexing="ij")
        px, py = X.reshape(-1), Y.reshape(-1)
        free = np.ones(len(px), dtype=bool)
        for box in self.keep_out:
            x0, x1, y0, y1 = box
            free &= ~((px >= x0) & (px <= x1) & (py >= y0) & (py <= y1))
        if not free.any():
            raise ValueError("the base region has no room: every position lies in a keep-out zone")
        px, py = px[free], py[free]
        C = len(px) * len(yaw)
        B = np.tile(np.eye(4), (C, 1, 1))
        a = np.repeat(yaw, len(px))
        B[:, 0, 0], B[:, 0, 1], B[:, 1, 0], B[:, 1, 1] = np.cos(a), -np.sin(a), np.sin(a), np.cos(a)
        B[:, 0, 3], B[:, 1, 3], B[:, 2, 3] = np.tile(px, len(yaw)), np.tile(py, len(yaw)), self.z0
        return B


@dataclass
class BaseRanking:
    """The best bases, best first: `bases` `(k, 4, 4)` with their `results` (per-target answers),
    and for every candidate `candidates` `(C, 4, 4)` its kinematic coverage bound `bound` `(C,)`
    (the fraction of targets some variant reaches, collisions ignored: at least the verified one)."""

    bases: np.ndarray
    results: list
    candidates: np.ndarray
    bound: np.ndarray
    verified: int

    @property
    def best(self) -> TargetResults:
        return self.results[0]


#: Poses solved per call of the coverage bound (memory: 128 bytes a pose, and the solutions).
BOUND_CHUNK = 200_000


def _coverage_bound(robot, T, cands, variants, tcp, method, starts, seed):
    """`(C,)` the fraction of targets each candidate reaches with some variant, collisions ignored:
    an upper bound of the verified coverage for the closed form (the same solutions, fewer checks);
    for the numerical search its own answer without the collision rounds."""
    M, K = len(T), len(variants)
    settings = SearchSettings(solver="independent", starts=starts, seed=seed)
    inner = T[:, None] @ variants[None] @ np.linalg.inv(tcp)  # (M, K, 4, 4)
    per = max(1, BOUND_CHUNK // (M * K))
    out = np.empty(len(cands))
    for c0 in range(0, len(cands), per):
        Binv = np.linalg.inv(cands[c0:c0 + per])
        E = (Binv[:, None, None] @ inner[None]).reshape(-1, 4, 4)
        q, ok = _solve(robot, E, method, settings, None)
        _, good = _confirm(robot, q, ok, E)
        out[c0:c0 + per] = good.reshape(-1, M, K).any(axis=2).mean(axis=1)
    return out


def _key(res: TargetResults, base: np.ndarray, centre: np.ndarray, index: int) -> tuple:
    """Sort key of a verified base: coverage, then the mean combined score, then nearer the region's
    centre, then the candidate order (deterministic)."""
    d = float(np.hypot(*(base[:2, 3] - centre)))
    return (-round(res.coverage, 12), -round(res.mean_score, 12), round(d, 9), index)


def rank_bases(robot: Arm, targets, region: BaseRegion, *, top: int = 5, variants=None, tcp=None,
               collision: Callable | None = None, method: str = "auto", starts: int = 8, seed: int = 0,
               scores: Sequence[str] = ("manipulability", "joint_margin")) -> BaseRanking:
    """The `top` best bases of `region` for `targets` (world frame), exactly: candidates are verified
    (`evaluate_targets`, collisions and scores included) in the order of their kinematic coverage
    bound, until the `top`-th verified coverage is above every unverified candidate's bound; ranked by
    coverage, then the mean combined score, then the distance to the region's centre, then the
    candidate order."""
    variants = tool_variants() if variants is None else variants
    tcp = np.eye(4) if tcp is None else tcp
    T, _, variants, tcp = _check(robot, targets, np.eye(4), variants, tcp)
    if isinstance(top, bool) or not isinstance(top, (int, np.integer)) or top < 1:
        raise ValueError(f"top must be an integer of at least 1, got {top!r}")
    method = resolve_method(robot, method)
    cands = region.candidates()
    bound = _coverage_bound(robot, T, cands, variants, tcp, method, starts, seed)
    order = np.lexsort((np.arange(len(cands)), -bound))
    centre = np.array([np.mean(region.x), np.mean(region.y)])
    verified = []
    for i in order:
        if len(verified) >= top and -verified[top - 1][0][0] > bound[i] + 1e-12:
            break  # no candidate left can reach the top-th verified coverage (ties are verified: scores break them)
        res = evaluate_targets(robot, T, base=cands[i], variants=variants, tcp=tcp, collision=collision,
                               method=method, starts=starts, seed=seed, scores=scores)
        verified.append((_key(res, cands[i], centre, int(i)), res, int(i)))
        verified.sort(key=lambda v: v[0])
    best = verified[:top]
    return BaseRanking(bases=np.stack([cands[i] for _, _, i in best]), results=[r for _, r, _ in best],
                       candidates=cands, bound=bound, verified=len(verified))
