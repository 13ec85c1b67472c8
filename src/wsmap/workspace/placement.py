"""Base placement (inverse reachability): where on the floor to put an arm so that it reaches a set
of target poses.

Candidate bases stand on the plane `z = z0` of the world frame: `B(x, y, yaw) = transl(x, y, z0)·
Rz(yaw)`. A target pose `T_m` (world frame) is reached from `B` when the arm reaches
`B⁻¹·T_m` in its own base frame. The candidates form a grid over `(x, y, yaw)`, on which the
reachability of one target varies smoothly, so each target is solved over the whole grid by the
neighbour-started search (`wsmap.kinematics.map_search`), or by the closed form for the
closed-form families; every "reached" comes with a confirmed joint solution.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..kinematics import DHRobot, SerialChain, as_chain, check_rigid
from ..kinematics.ik.solvers import get_solver
from .grids import check_fits, node_neighbours, triple
from .maps import configuration_predicate, resolve_method, search_settings
from .scores import joint_margin, manipulability
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap._typing import ArrayLike, Callable
    from wsmap.kinematics.chain import Arm

__all__ = ["Placement", "base_placement", "floor_poses", "MAX_TARGETS", "MAX_YAWS", "MAX_CANDIDATES", "RANKING",
           "TIEBREAKS"]

#: How `base_placement` ranks its candidates, in words (the command line prints it).
#: The ways `base_placement` breaks ties (`tiebreak=`): the default first.
TIEBREAKS = ("manipulability", "centre")
RANKING = ("best first: the larger fraction of targets reached; ties: the higher mean manipulability of the "
           "solutions first, then the higher mean joint-limit margin, then nearer the middle of the region, then "
           "the lower heading, y and x")

#: The most target poses one placement takes: each target is one map over every candidate base
#: (3528 candidates by default: about 1 to 10 s per target on one core), so 100000 are already days.
MAX_TARGETS = 100_000
#: The most base headings: 3600 are 0.1° apart, finer than any base is put down.
MAX_YAWS = 3600
#: The most candidate bases (positions x headings): each holds a 4x4 pose, its inverse and a joint
#: solution per target; 10**7 are 400 times the default region (21 x 21 positions x 8 headings).
MAX_CANDIDATES = 10**7


@dataclass
class Placement:
    """Candidate bases ranked best first (every field in that order; the rule: `RANKING`).

    poses : (C, 4, 4) base poses in the world frame (`transl(x, y, z0)·Rz(yaw)`)
    x, y, yaw : (C,) metres, metres, radians; exact multiples of the step from the range's start
        (rounded to 1e-12, so the middle of a symmetric range is +0.0, not -2e-17)
    score : (C,) fraction of the targets reached from the base
    manipulability : (C,) the tie-break: the mean Yoshikawa manipulability `sqrt(det(J Jᵀ))` (m³
        for a six-joint arm; `wsmap.workspace.scores.manipulability`) of the base's solutions of
        the targets it reaches (the closed form's first branch inside the limits, or the search's
        solution); 0 where it reaches none
    joint_margin : (C,) the second tie-break: the mean over the same solutions of their distance
        from the joint limits in [0, 1] (`wsmap.workspace.scores.joint_margin`); 0 where none
    reached : (C, M) bool, which targets each base reaches
    q : (M, n) joint solutions of the best base for the targets it reaches (NaN elsewhere), each
        confirmed by forward kinematics (numerical) or from the closed form
    method : "exact" or "numerical"
    """

    poses: np.ndarray
    x: np.ndarray
    y: np.ndarray
    yaw: np.ndarray
    score: np.ndarray
    manipulability: np.ndarray
    joint_margin: np.ndarray
    reached: np.ndarray
    q: np.ndarray
    method: str

    def best(self) -> dict:
        """The best base as a dict: `x`, `y`, `yaw` (rad), `score`, `pose` (4x4 list)."""
        return {"x": float(self.x[0]), "y": float(self.y[0]), "yaw": float(self.yaw[0]),
                "score": float(self.score[0]), "pose": self.poses[0].tolist()}


def _range(name, r):
    r = np.asarray(r, dtype=np.float64)
    if r.shape != (2,) or not np.all(np.isfinite(r)):
        raise ValueError(f"{name} must be a finite (lo, hi) pair, got {r.tolist() if r.size < 10 else r.shape}")
    if r[0] > r[1]:
        raise ValueError(f"{name}: lo ({r[0]}) is above hi ({r[1]})")
    return r


def floor_poses(x: ArrayLike, y: ArrayLike, yaw: ArrayLike, z0: float = 0.0) -> np.ndarray:
    """Base poses `transl(x, y, z0)·Rz(yaw)` (broadcast) as `(..., 4, 4)`."""
    x, y, yaw = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float), np.asarray(yaw, float))
    B = np.zeros(x.shape + (4, 4))
    c, s = np.cos(yaw), np.sin(yaw)
    B[..., 0, 0], B[..., 0, 1], B[..., 1, 0], B[..., 1, 1] = c, -s, s, c
    B[..., 2, 2] = B[..., 3, 3] = 1.0
    B[..., 0, 3], B[..., 1, 3], B[..., 2, 3] = x, y, z0
    return B


def _from_its_base(robot, checker, target):
    """The predicate of solutions `q` `(C, n)` of one world `target` (4, 4) from candidate
    bases: each checked at the base it reaches the target from, `target·fkine(q)⁻¹` (the
    candidate's pose to the solver's tolerance, about 1e-9 m), with the scene's world obstacles."""
    def valid(q):
        q = np.asarray(q, dtype=np.float64)
        return checker.at_bases(q, target @ np.linalg.inv(robot.fkine(q)))
    return valid


def _check_placement(robot, targets, x, y, step, yaws, z0, method):
    """`base_placement`'s checks of everything but `collision`, before any work:
    `(T (M, 4, 4), x range, y range, z0, method)`."""
    if not isinstance(robot, (DHRobot, SerialChain)):
        raise TypeError(f"robot must be a DHRobot or a SerialChain, got {type(robot).__name__}")
    if robot.batch_shape != ():
        raise ValueError(f"base placement takes one arm, got a batch of shape {robot.batch_shape}")
    T = check_rigid("targets", targets)
    if T.ndim == 2:
        T = T[None]
    if T.ndim != 3 or len(T) == 0:
        raise ValueError(f"targets must have shape (M, 4, 4) with M >= 1, got {T.shape}")
    xr, yr = _range("x", x), _range("y", y)
    if isinstance(step, bool) or not (np.isscalar(step) and np.isfinite(step) and step > 0):
        raise ValueError(f"step must be positive and finite, got {step!r}")
    if isinstance(yaws, bool) or not isinstance(yaws, (int, np.integer)) or yaws < 1:
        raise ValueError(f"yaws must be a positive integer (the number of base headings), got {yaws!r}")
    if yaws > MAX_YAWS:
        raise ValueError(f"yaws must be at most {MAX_YAWS} (headings 0.1° apart; finer ones only multiply the work), "
                         f"got {yaws}")
    if len(T) > MAX_TARGETS:
        raise ValueError(f"at most {MAX_TARGETS} targets (each is one map over every candidate base, 1 to 10 s on "
                         f"one core), got {len(T)}")
    z0 = float(triple("z0", z0)[0])
    method = resolve_method(robot, method)
    with np.errstate(over="ignore"):  # counted in floating point: a 1e-300 step must not wrap an integer
        counts = [np.floor((r[1] - r[0]) / step + 0.5) + 1.0 for r in (xr, yr)]
        total = float(counts[0] * counts[1] * yaws)
    if not total <= MAX_CANDIDATES:
        raise ValueError(f"a region of {counts[0]:.3g} x {counts[1]:.3g} positions x {yaws} headings is {total:.3g} "
                         f"candidate bases, more than {MAX_CANDIDATES:.0e} (each holds a pose and a solution per "
                         "target); use a larger step or a smaller region")
    check_fits(int(total) * (len(T) * (8 * robot.n + 1) + 512),
                f"{int(total)} candidate bases x {len(T)} targets")
    return T, xr, yr, z0, method


def _check_collision(robot, collision):
    """`base_placement`'s `collision` checked: `(the predicate or None, whether the scene has
    world-frame obstacles)`."""
    valid = configuration_predicate(robot, collision)
    scene = getattr(collision, "scene", None)
    world = scene is not None and any(ob.frame == "world" for ob in scene.obstacles)
    if world and not callable(getattr(collision, "at_bases", None)):
        raise ValueError("base placement moves the base under world-frame obstacles: give a "
                         "wsmap.collision.CollisionChecker (it checks each candidate base) or base-frame obstacles")
    if world and any(ob.frame == "base" for ob in scene.obstacles):
        raise ValueError("base placement takes world-frame or base-frame obstacles, not both in one scene")

    return valid, world


def _solve_targets(robot, T, Binv, nb, method, settings, valid, world_checker, progress, reached, qsol):
    """Fill `reached` (C, M) and `qsol` (C, M, n) target by target over the candidate bases
    `Binv` (C, 4, 4) (inverted), by the closed form or the neighbour search (`settings`);
    `world_checker` the `CollisionChecker` of a world-frame scene, else None (`valid` as is)."""
    from tqdm.auto import tqdm

    chain = as_chain(robot)
    solver = get_solver("closed_form" if method == "exact" else "search")
    for m in tqdm(range(len(T)), unit="target", desc="base placement", disable=not progress, leave=False):
        Tm = Binv @ T[m]  # (C, 4, 4): the target in each candidate's base frame
        if world_checker is not None:
            valid = _from_its_base(robot, world_checker, T[m])
        # solved, not only decided: the solutions' manipulability breaks the ties of the ranking
        if method == "exact":
            res = solver.solve(robot, Tm, None, valid)
        else:
            res = solver.solve(chain, Tm, settings, valid, neighbours=nb)
        reached[:, m] = res.success
        qsol[:, m] = np.where(res.success[:, None], res.q, np.nan)


def base_placement(robot: Arm, targets: ArrayLike, x: tuple[float, float] = (-1.0, 1.0),
                   y: tuple[float, float] = (-1.0, 1.0), *, step: float = 0.1, yaws: int = 8, z0: float = 0.0,
                   method: str = "auto", ik: dict | None = None, seed: int = 0,
                   progress: bool = False, collision: Callable | None = None,
                   tiebreak: str = "manipulability") -> Placement:
    """Rank candidate base poses on the floor by the fraction of `targets` they reach.

    Parameters
    ----------
    robot : DHRobot or SerialChain (one arm)
    targets : (M, 4, 4) target tool poses in the world frame (rigid transforms, metres)
    x, y : (lo, hi) ranges of the base position (m), sampled at `step` (both ends included)
    yaws : number of base headings, `2π j / yaws`
    z0 : height of the floor plane the base stands on (m)
    method, ik, seed : as `wsmap.workspace.constant_orientation_map` (`ik` for the numerical search)
    progress : a progress bar over the targets (on stderr)
    collision : a configuration predicate, as `wsmap.workspace.constant_orientation_map`: a
        target counts only with a collision-free solution. A plain predicate must not depend on the
        candidate base (self-collision, the floor the base stands on, obstacles in the base frame,
        carried with the base). A `wsmap.collision.CollisionChecker` whose scene has
        obstacles in the world frame (a table the targets lie on) checks each solution against
        them from its own candidate base (`at_bases`; the
        base is `T_m·fkine(q)⁻¹`, the pose the solution was found for); such a scene must then
        have no base-frame obstacles

    tiebreak : {"manipulability", "centre"}
        How bases reaching the same fraction are ordered: "manipulability" (`RANKING`, the
        default) or "centre", the reach alone: nearer the middle of the region first, then the
        grid order (what a ranking by reach without any other criterion picks)

    Returns
    -------
    Placement
        Best first (`RANKING`; with `tiebreak="centre"` as that says): by the fraction of targets reached; among equal fractions (often
        hundreds of bases reach every target) by the mean Yoshikawa manipulability of the base's
        solutions, higher first (compared to 9 significant digits, so rounding does not order
        bases that only differ by a heading the base joint absorbs); then by the mean joint-limit
        margin of those solutions, higher first (the same rounding); then nearer the middle of
        the region; then the grid order (heading, then y, then x, ascending).

    Notes
    -----
    Bad input (a range with lo > hi, `step` <= 0, `yaws` < 1, targets that are not
    rigid transforms) is a `ValueError` before any work, as are sizes beyond the bounds
    (`MAX_TARGETS` targets, `MAX_YAWS` headings, `MAX_CANDIDATES` candidate bases)
    and a `MemoryError` a problem whose solutions would not fit in half the memory available.
    """
    if tiebreak not in TIEBREAKS:
        raise ValueError(f"tiebreak must be one of {', '.join(map(repr, TIEBREAKS))}, got {tiebreak!r}")
    T, xr, yr, z0, method = _check_placement(robot, targets, x, y, step, yaws, z0, method)
    valid, world = _check_collision(robot, collision)

    # lo + k·step rounded to 1e-12 m (+ 0.0 turns -0.0 into 0.0): -1 + 10·0.1 is 0, not -2.2e-16
    xs, ys = (np.round(r[0] + step * np.arange(np.floor((r[1] - r[0]) / step + 0.5) + 1), 12) + 0.0 for r in (xr, yr))
    yaw = 2 * np.pi * np.arange(yaws) / yaws
    # candidate grid: x fastest, then y, then yaw (the node order of the maps)
    Y, X = np.meshgrid(ys, xs, indexing="ij")
    cx = np.tile(X.reshape(-1), yaws)
    cy = np.tile(Y.reshape(-1), yaws)
    cyaw = np.repeat(yaw, X.size)
    B = floor_poses(cx, cy, cyaw, z0)
    Binv = np.linalg.inv(B)
    C, M = len(B), len(T)
    reached = np.zeros((C, M), dtype=bool)
    qsol = np.full((C, M, robot.n), np.nan)
    # neighbours over (x, y, yaw): the yaw axis scaled so one heading step is one position step
    coords = np.stack([cx, cy, cyaw / (2 * np.pi / yaws) * step], axis=1)
    nb = node_neighbours(coords) if C > 1 else np.full((C, 0), -1, dtype=np.int64)
    settings = None if method == "exact" else search_settings(ik, seed=seed)
    _solve_targets(robot, T, Binv, nb, method, settings, valid, collision if world else None, progress, reached, qsol)
    score = reached.mean(axis=1)
    manip, margin = (_mean_score(f, robot, qsol, reached) for f in (manipulability, joint_margin))
    centre = np.hypot(cx - xr.mean(), cy - yr.mean())
    # 9 significant digits: bases whose solutions differ only in the base joint (a heading it
    # absorbs) have the same manipulability up to rounding, and fall to the joint margin, which
    # prefers the heading that leaves the base joint nearer the middle of its range
    keys = [-np.array([float(f"{v:.9g}") for v in a]) for a in (manip, margin)]
    scores = (keys[1], keys[0]) if tiebreak == "manipulability" else ()
    order = np.lexsort((np.arange(C), centre, *scores, -score))
    return Placement(poses=B[order], x=cx[order], y=cy[order], yaw=cyaw[order], score=score[order],
                     manipulability=manip[order], joint_margin=margin[order], reached=reached[order],
                     q=qsol[order[0]], method=method)


def _mean_score(score, robot, qsol: np.ndarray, reached: np.ndarray) -> np.ndarray:
    """`(C,)` the mean `score(robot, q)` (`wsmap.workspace.scores`) of each candidate's
    solutions `qsol` `(C, M, n)` of the targets it reaches (`reached` `(C, M)`); 0 where it
    reaches none."""
    total = np.zeros(len(reached))
    for m in range(reached.shape[1]):  # a target at a time: C Jacobians, not C x M, in memory
        hit = reached[:, m]
        if hit.any():
            total[hit] += score(robot, qsol[hit, m])
    count = reached.sum(axis=1)
    return np.where(count > 0, total / np.maximum(count, 1), 0.0)
