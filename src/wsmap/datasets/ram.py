"""RAM's evaluation protocol: its random arms, its poses, its labels and its F1, in wsmap's terms.

RAM (T. Walter et al., *RAM: Reachability Across Morphologies*, arXiv 2606.09108; code
github.com/TimWalter/ram) predicts, for an arm of 5-7 revolute joints it never saw, whether a
pose `T` in SE(3) is reachable. Its published numbers: F1 0.86 on random poses (the paper's
abstract), 0.78 on a boundary set of held-out arms and F1 0.91 of its training labels (FK sampling
into SE(3) cells) against exact ones (as issue 42 quotes the paper; its full text was not readable
here, and `paper_archive/RQ2/boundary/table_a3.py` builds the boundary table from its W&B runs).
This module rebuilds the protocol so that wsmap's labels and models can be scored the same way
(`benchmarks/learn/bench_ram_protocol.py`; the numbers in `docs/morphologies.md`).

Where each detail comes from
----------------------------
The stored snapshot of `TimWalter/ram` holds `ram/dataset/workspace.py`, `se3.py`,
`generate_evaluation_set.py`, `generate_train_set.py`, `ram/metrics.py`, `ram/validate.py` and
`paper_archive/`; the modules they import (`ram/dataset/morphology.py`, `kinematics.py`,
`self_collision.py`, `manipulability.py`, `r3.py`, `so3/__init__.py`) were read from the same
package path in its predecessor repository `TimWalter/neural-reachability-manifold` (commit
e2fa9d4), whose `workspace.py` calls them the same way. Citations below are file and function (the
commits read: TimWalter/ram 983944b, 4d471da, ff430c6, c5ca864, 1e99149, 20279c4, 1522cfa; the
predecessor e2fa9d4), not line numbers, which differ between those commits.

* **Arm** (`morphology.py`, `_sample_morph`, `sample_morph`): `dof + 1` rows `(alpha, a, d)` of
  a modified-DH (Craig) table, link `i` = `Rx(alpha_i) Tx(a_i) Rz(theta_i) Tz(d_i)`
  (`kinematics.py`, `transformation_matrix`); rows `0 .. dof-1` are the joints, the last row is
  the fixed end effector (`theta = 0`). No joint offsets, no joint limits, no tool.
  Per row a link type uniform in {general (a, d != 0), d only, a only, none}; two "none" rows in
  a row are drawn again (`_reject_link_type`). Twists uniform in {0, pi/2, -pi/2}, drawn again
  (given the types) while three consecutive twists are 0, a twist-0 / none / twist-0 run
  occurs, two consecutive "d only" rows have the second twist 0 (collinear axes), or a "none" row
  has twist 0 (`_reject_link_twist`). Lengths: one Exp(1) draw per row, divided by their sum
  over the rows that are not "none" (so `sum_i sqrt(a_i^2 + d_i^2) = 1` m: every arm fits
  in the unit ball), a general row split by `|sin g|, |cos g|` with `g ~ U(0, 2 pi)`, `a` and `d`
  each with a random sign (`_sample_link_length`). An arm is dropped when a non-zero length is
  under `2 * LINK_RADIUS` or its first or last row is longer than `1 / (dof + 1)`
  (`_reject_link_length`), or when all of 1000 random configurations are in self-collision or
  all have a manipulability under 1e-4 (`_reject_morph`; manipulability = the product of the
  `min(6, dof)` largest singular values of the geometric Jacobian, `manipulability.py`).
* **Self-collision** (`self_collision.py`): two capsules per row, radius `LINK_RADIUS = 0.025`
  m, along `a` then along `d` (`get_capsules`); every pair two or more apart in that sequence
  whose capsules both have length (> 1e-4 m) and are not joined end to start is checked
  (`collision_check`), and a ball of the same radius at the base and at the end effector against
  the second and the second-to-last capsule of length. Collision: the segments' distance under
  twice the radius. `ram_collision` builds this as a `wsmap.collision.CollisionChecker` (one
  link per capsule, exactly those pairs).
* **IK labels** (`kinematics.py`, `inverse_kinematics`): EAIK's closed form where the arm has
  one, else Levenberg-Marquardt, 10 random starts in `[-pi, pi)`, 100 iterations; a pose is
  reachable when a solution lands within SE(3) distance 1e-4 (`sqrt(|dt|^2 / 8 + angle^2 /
  (2 pi^2))`, `se3.py`, `distance`) and is free of self-collision. No joint limits.
  Here: `wsmap.reachable` (the compiled multi-start search, 1e-6 m and rad, `starts` starts) with
  `ram_collision` as its `collision=` predicate (`ik_labels`).
* **Random poses** (`workspace.py`, `sample_poses_in_reach`, `ball_approximation`): the frame
  before the end effector uniform in a ball around the origin of row 0's frame (at `theta = 0`)
  of radius `sum_{i=1}^{dof-1} sqrt(a_i^2 + d_i^2) - 2/37` (the R3 cell size), its orientation
  uniform, times the end-effector row's transform. For arms of 5 joints (`morph.shape[0] < 7`,
  `synthesise_data`) a quarter of the poses are replaced by forward kinematics of random
  collision-free configurations, labelled reachable (`random_poses`).
* **Boundary set** (`paper_archive/RQ2/boundary/boundaries.py`): per arm `G` pairs of a reachable
  pose (FK of a collision-free random configuration) and an unreachable one (a random pose in the
  ball that the IK does not reach); `S` poses evenly along the SE(3) geodesic between them
  (translation linear, rotation `R_r exp(t log(R_r^T R_u))`, `t = linspace(0, 1, S)`, the ends
  included), each labelled by the IK (`boundary_poses`; RAM: `G = 1000`, `S = 100`,
  `generate_boundary_set.py`).
* **FK-sampling labels** (`workspace.py`, `fk_approximation`, `sample_workspace`; training set
  `generate_train_set.py`): random configurations, forward kinematics, the collision-free ones
  mark their SE(3) cell; a pose is reachable when its cell was marked (`fk_labels`). Cells
  (`se3.py` level 3): R3 a grid of 37 divisions on `[-1, 1]^3` (`r3.py`, `index`), times SO(3)
  cells. RAM's authors measured these labels against IK labels (`paper_archive/RQ1/label_validity.py`).
* **F1** (`ram/metrics.py`, `compute_metrics`): per arm `2 tp / (2 tp + fp + fn)`, an arm without
  a positive predicted or true and with true negatives counting 1; the mean over arms (`ram_f1`).
  The model's threshold is the one of the best macro balanced accuracy on a validation set
  (`ram/validate.py`).

Choices made here (not RAM's)
-----------------------------
* **SO(3) cells**: RAM's cell centres are binary files (`so3/cells_{level}.pt`) not in the
  stored code. Here a cubed-quaternion grid (`se3_cells`): the unit quaternion's largest
  component picks one of 4 cells of the 4-cube (`q ~ -q`), the other three as `atan(q_j / q_max)`
  on `k` divisions (`RAM_SO3_DIVISIONS`): at level 3, 4 * 17^3 = 19,652 cells, about RAM's
  level-3 count estimated from its neighbour spacing 0.157 rad (`so3/__init__.py`,
  `set_level`): `8 pi^2 / 0.157^3 ~ 20,400`. Level 3 has 50,653 x 19,652 ~ 1e9 SE(3) cells.
* **Configurations for FK sampling and arm rejection**: uniform over the full turn. RAM draws
  them inside `get_joint_limits` (`morphology.py`), ranges that cut away only angles where two
  adjacent capsules collide; the collision-free set sampled is the same, at a lower yield here.
* **Lengths' rejection**: each candidate arm is drawn once and dropped when rejected (RAM draws
  twice the count and resamples only while fewer than the count pass: the same distribution
  whenever half pass).
* **IK**: wsmap's search instead of EAIK / RAM's LM; its tolerance is stricter (1e-6 against
  RAM's 1e-4 in its SE(3) distance).
* The random streams are numpy's (`seed`); RAM's torch streams cannot be reproduced.
"""

from __future__ import annotations

import numpy as np

from ..kinematics.chain import SerialChain, from_dh
from .spec import check_int
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from collections.abc import Sequence

    from wsmap._typing import ArrayLike, NDArray
    from wsmap.collision import CollisionChecker

__all__ = ["RAM_DOFS", "RAM_LINK_RADIUS", "RAM_R3_DIVISIONS", "RAM_SO3_DIVISIONS", "RAM_PUBLISHED",
           "sample_morphologies", "ram_arms", "ram_collision", "reach_ball", "random_poses", "fk_samples",
           "boundary_poses", "ik_labels", "se3_cells", "fk_labels", "ram_f1"]

#: The joint counts of RAM's arms (`morphology.py`, `generate_*_set.py --dof`).
RAM_DOFS = (5, 6, 7)
#: Capsule radius (m) of every link (`self_collision.py`, `LINK_RADIUS`).
RAM_LINK_RADIUS = 0.025
#: R3 cells per axis on `[-1, 1]` m at RAM's levels 1-4 (`r3.py`, `set_level`); RAM trains at 3.
RAM_R3_DIVISIONS = {1: 10, 2: 19, 3: 37, 4: 69}
#: Divisions per axis of this module's SO(3) cells per level (a choice: module notes), `4 k^3`
#: cells: 256, 2,916, 19,652, 157,216 against RAM's neighbour spacings 0.628, 0.314, 0.157,
#: 0.079 rad (`so3/__init__.py`), about `8 pi^2 / spacing^3` = 318, 2,546, 20,400, 159,000 cells.
RAM_SO3_DIVISIONS = {1: 4, 2: 9, 3: 17, 4: 34}
#: RAM's published numbers (F1 of its model on random poses and on the boundary set; F1 of its
#: FK-sampling labels against exact ones): arXiv 2606.09108.
RAM_PUBLISHED = {"f1_random": 0.86, "f1_boundary": 0.78, "f1_fk_labels": 0.91}

_MAX_COUNT = 1_000_000
_MAX_SAMPLES = 100_000_000  # FK samples of fk_labels (drawn in chunks)
_MAX_POSES = 10_000_000  # poses or configurations held at once (1.3 GB of poses)
_TWISTS = np.array([0.0, np.pi / 2, -np.pi / 2])
_CAPSULE_EPS = 1e-4  # a capsule shorter than this has no length (self_collision.py, EPS)
_REJECT_CONFIGS = 1000  # random configurations of the arm rejection (morphology.py, _reject_morph)
_MIN_MANIPULABILITY = 1e-4


# ------------------------------------------------------------------------------------ checks
def _check_morph(morph) -> np.ndarray:
    """`morph` as float64 `(..., dof + 1, 3)` with `dof` in 5..7, or a one-line ValueError."""
    m = np.asarray(morph, dtype=np.float64)
    if m.ndim < 2 or m.shape[-1] != 3 or m.shape[-2] - 1 not in RAM_DOFS:
        raise ValueError(f"morph must be RAM's table (..., dof + 1, 3) of (alpha, a, d) rows with dof in 5..7, "
                         f"got shape {m.shape}")
    if not np.all(np.isfinite(m)):
        raise ValueError("morph contains NaN or infinite values")
    return m


def _one_morph(morph) -> np.ndarray:
    m = _check_morph(morph)
    if m.ndim != 2:
        raise ValueError(f"this function takes one arm's table (dof + 1, 3), got shape {m.shape}")
    return m


def _check_poses(T) -> np.ndarray:
    T = np.asarray(T, dtype=np.float64)
    if T.ndim < 2 or T.shape[-2:] != (4, 4):
        raise ValueError(f"poses must have shape (..., 4, 4), got {T.shape}")
    if not np.all(np.isfinite(T)):
        raise ValueError("poses contain NaN or infinite values")
    return T


# ------------------------------------------------------------------------------------ arms
def _draw_types(count: int, rows: int, rng) -> np.ndarray:
    out = np.empty((0, rows), dtype=np.int64)
    while len(out) < count:
        t = rng.integers(0, 4, size=(2 * count, rows))
        ok = ~np.any((t[:, 1:] == 3) & (t[:, :-1] == 3), axis=1)
        out = np.concatenate([out, t[ok]])
    return out[:count]


def _twist_rejected(al: np.ndarray, t: np.ndarray) -> np.ndarray:
    z = al == 0
    bad = np.any(z[:, :-2] & z[:, 1:-1] & z[:, 2:], axis=1)
    bad |= np.any(z[:, :-2] & (t[:, 1:-1] == 3) & z[:, 2:], axis=1)
    bad |= np.any((t[:, :-1] == 1) & (t[:, 1:] == 1) & z[:, 1:], axis=1)
    bad |= np.any((t == 3) & z, axis=1)
    return bad


def _draw_twists(types: np.ndarray, rng) -> np.ndarray:
    al = _TWISTS[rng.integers(0, 3, size=types.shape)]
    bad = _twist_rejected(al, types)
    while bad.any():  # drawn again given the types, as _reject_link_twist's loop
        al[bad] = _TWISTS[rng.integers(0, 3, size=(int(bad.sum()), types.shape[1]))]
        bad = _twist_rejected(al, types)
    return al


def _draw_lengths(types: np.ndarray, rng) -> tuple[np.ndarray, np.ndarray]:
    e = rng.exponential(1.0, size=types.shape)
    e = e / np.sum(e * (types != 3), axis=1, keepdims=True)
    sign = np.where(rng.random(types.shape + (2,)) < 0.5, -1.0, 1.0)
    g = rng.random(types.shape) * 2 * np.pi
    a = e * sign[..., 0] * np.where(types == 0, np.abs(np.sin(g)), 1.0)
    d = e * sign[..., 1] * np.where(types == 0, np.abs(np.cos(g)), 1.0)
    a = np.where((types == 1) | (types == 3), 0.0, a)
    d = np.where((types == 2) | (types == 3), 0.0, d)
    return a, d


def _length_rejected(a: np.ndarray, d: np.ndarray) -> np.ndarray:
    ad = np.stack([a, d], axis=-1)
    bad = np.any((np.abs(ad) < 2 * RAM_LINK_RADIUS) & (ad != 0), axis=(1, 2))
    limit = 1.0 / a.shape[1]
    bad |= np.hypot(a[:, 0], d[:, 0]) > limit
    bad |= np.hypot(a[:, -1], d[:, -1]) > limit
    return bad


def _morph_rejected(morph: np.ndarray, rng) -> np.ndarray:
    """RAM's `_reject_morph`: all of 1000 random configurations in self-collision, or all with a
    manipulability under 1e-4 (a loop over candidate arms; the configurations are one batch)."""
    out = np.zeros(len(morph), dtype=bool)
    n = morph.shape[1] - 1
    for k in range(len(morph)):
        chain = ram_arms(morph[k])
        q = rng.uniform(-np.pi, np.pi, size=(_REJECT_CONFIGS, n))
        s = np.linalg.svd(chain.jacob0(q), compute_uv=False)[..., :min(6, n)]
        if np.all(np.prod(s, axis=-1) < _MIN_MANIPULABILITY):
            out[k] = True
            continue
        out[k] = not np.any(ram_collision(morph[k])(q))
    return out


def sample_morphologies(count: int, dof: int, seed: int = 0) -> NDArray[np.float64]:
    """Random arms drawn as RAM draws them (module notes), as RAM's tables.

    Parameters
    ----------
    count : int
        Number of arms, 1 .. 1,000,000.
    dof : int
        Revolute joints, 5, 6 or 7.
    seed : int
        Seed of numpy's generator; the same `(count, dof, seed)` gives the same arms.

    Returns
    -------
    ndarray, shape (count, dof + 1, 3)
        Rows `(alpha, a, d)` (rad, m, m) of a modified-DH table, the last row the end effector;
        `ram_arms` makes them wsmap arms.
    """
    count = check_int("count", count, 1, _MAX_COUNT)
    if isinstance(dof, bool) or dof not in RAM_DOFS:
        raise ValueError(f"dof must be one of {', '.join(map(str, RAM_DOFS))} (RAM's arms), got {dof!r}")
    seed = check_int("seed", seed, 0)
    rng = np.random.default_rng(seed)
    rows = dof + 1
    out = np.empty((0, rows, 3))
    while len(out) < count:
        m = 2 * (count - len(out))
        types = _draw_types(m, rows, rng)
        al = _draw_twists(types, rng)
        a, d = _draw_lengths(types, rng)
        keep = ~_length_rejected(a, d)
        cand = np.stack([al, a, d], axis=-1)[keep]
        cand = cand[~_morph_rejected(cand, rng)]
        out = np.concatenate([out, cand[: count - len(out)]])
    return out


def _eef(morph: np.ndarray) -> np.ndarray:
    """`(..., 4, 4)` the end-effector row's `Rx(alpha) Tx(a) Tz(d)`."""
    al, a, d = morph[..., -1, 0], morph[..., -1, 1], morph[..., -1, 2]
    E = np.zeros(al.shape + (4, 4))
    ca, sa = np.cos(al), np.sin(al)
    E[..., 0, 0] = 1.0
    E[..., 1, 1], E[..., 1, 2], E[..., 2, 1], E[..., 2, 2] = ca, -sa, sa, ca
    E[..., 0, 3], E[..., 1, 3], E[..., 2, 3], E[..., 3, 3] = a, -d * sa, d * ca, 1.0
    return E


def ram_arms(morph: ArrayLike) -> SerialChain:
    """RAM tables as wsmap arms: a modified-DH `SerialChain`, no joint limits, no tool.

    Parameters
    ----------
    morph : array_like, shape (..., dof + 1, 3)
        Rows `(alpha, a, d)`; rows `0 .. dof-1` the joints, the last the end effector
        (`sample_morphologies`).

    Returns
    -------
    SerialChain
        `dof` revolute joints, batch shape `morph.shape[:-2]`; its flange (`fixed[..., dof]`)
        carries the end-effector row, so `fkine` is RAM's end-effector pose.
    """
    m = _check_morph(morph)
    n = m.shape[-2] - 1
    chain = from_dh(d=m[..., :n, 2], a=m[..., :n, 1], alpha=m[..., :n, 0], modified=True)
    fixed = chain.fixed.copy()
    fixed[..., n, :, :] = fixed[..., n, :, :] @ _eef(m)
    return chain.replace(fixed=fixed, name=f"ram{n}")


# ------------------------------------------------------------------------------------ collision
def _capsules(m: np.ndarray) -> list[tuple[str, int, np.ndarray, np.ndarray]]:
    """RAM's capsule sequence `a_0, d_0, ..., a_n, d_n` as `(name, body, p0, p1)` in the body
    frames of `ram_arms`' chain (body `k` rides after joint `k`; body 0 the base)."""
    n = m.shape[0] - 1
    out = []
    for i in range(n + 1):
        al, a, d = m[i]
        z0 = m[i - 1, 2] if 1 <= i <= n else 0.0  # the d of the row before, on the same body
        p = np.array([0.0, 0.0, z0])
        q = p + np.array([a, 0.0, 0.0])
        out.append((f"a{i}", i, p, q))
        if i < n:  # d_i along joint i + 1's axis, from that body's origin
            out.append((f"d{i}", i + 1, np.zeros(3), np.array([0.0, 0.0, d])))
        else:  # the end effector's d, along its own z (rotated by its twist)
            out.append((f"d{i}", n, q, q + d * np.array([0.0, -np.sin(al), np.cos(al)])))
    return out


def ram_collision(morph: ArrayLike, radius: float = RAM_LINK_RADIUS) -> CollisionChecker:
    """RAM's self-collision test of one arm as a `wsmap.collision.CollisionChecker`.

    Parameters
    ----------
    morph : array_like, shape (dof + 1, 3)
        One arm's table (`sample_morphologies`).
    radius : float
        Capsule and ball radius (m), RAM's 0.025.

    Returns
    -------
    CollisionChecker
        A configuration predicate of `ram_arms(morph)`: `checker(q)`, `q` `(C, dof)` rad, is True
        where free. One link per capsule of length (`a{i}`, `d{i}`) and the two balls
        (`base_ball`, `eef_ball`); exactly RAM's pairs are checked (module notes), no scene.
    """
    from ..collision import CollisionChecker, CollisionModel, Link, Scene, Shape
    from ..collision.geometry import segment_shape

    m = _one_morph(morph)
    if not (isinstance(radius, (int, float)) and 0 < radius <= 1):
        raise ValueError(f"radius must be a positive number of metres up to 1, got {radius!r}")
    chain = ram_arms(m)
    caps = _capsules(m)
    has = [np.linalg.norm(p1 - p0) > _CAPSULE_EPS for _, _, p0, p1 in caps]
    links = [Link(name, body, (segment_shape("capsule", p0, p1, float(radius)),))
             for (name, body, p0, p1), ok in zip(caps, has) if ok]
    index = {lk.name: k for k, lk in enumerate(links)}
    live = [k for k, ok in enumerate(has) if ok]
    pairs = []
    for u, i in enumerate(live):
        for j in live[u + 1:]:
            # two or more apart and not joined end to start (capsules between them all of no length)
            if j - i >= 2 and any(has[i + 1:j]):
                pairs.append((index[caps[i][0]], index[caps[j][0]]))
    n = m.shape[0] - 1
    eye = np.eye(4)
    tip = eye.copy()
    tip[:3, 3] = caps[-1][3]
    links.append(Link("base_ball", 0, (Shape("sphere", (float(radius),), eye),)))
    links.append(Link("eef_ball", n, (Shape("sphere", (float(radius),), tip),)))
    if len(live) >= 2:
        pairs.append((len(links) - 2, index[caps[live[1]][0]]))
        pairs.append((len(links) - 1, index[caps[live[-2]][0]]))
    model = CollisionModel(chain, tuple(links), source=f"RAM's capsules along the links, radius {radius:g} m")
    return CollisionChecker(model, Scene(), pairs=pairs)


# ------------------------------------------------------------------------------------ poses
def reach_ball(morph: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """RAM's ball of poses worth asking about (`ball_approximation` less one R3 cell).

    Parameters
    ----------
    morph : array_like, shape (..., dof + 1, 3)

    Returns
    -------
    centre : ndarray, shape (..., 3)
        The origin of row 0's frame at `theta = 0` (m, base frame).
    radius : ndarray, shape (...)
        `sum_{i=1}^{dof-1} sqrt(a_i^2 + d_i^2) - 2/37` m, at least 0: where the frame before the
        end effector can be.
    """
    m = _check_morph(morph)
    al, a, d = m[..., 0, 0], m[..., 0, 1], m[..., 0, 2]
    centre = np.stack([a, -d * np.sin(al), d * np.cos(al)], axis=-1)
    r = np.sum(np.hypot(m[..., 1:-1, 1], m[..., 1:-1, 2]), axis=-1)
    return centre, np.maximum(0.0, r - 2.0 / RAM_R3_DIVISIONS[3])


def _ball_poses(m: np.ndarray, count: int, rng) -> np.ndarray:
    from .sampling import uniform_rotations

    centre, radius = reach_ball(m)
    u = rng.standard_normal((count, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    P = np.zeros((count, 4, 4))
    P[:, :3, :3] = uniform_rotations(count, rng)
    P[:, :3, 3] = centre + radius * rng.random((count, 1)) ** (1 / 3) * u
    P[:, 3, 3] = 1.0
    return P @ _eef(m)


def fk_samples(morph: ArrayLike, count: int, seed: int = 0,
               collision: CollisionChecker | None = None) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Collision-free configurations and their end-effector poses (RAM's `sample_workspace`).

    Parameters
    ----------
    morph : array_like, shape (dof + 1, 3)
    count : int
        Configurations drawn, 1 .. 10,000,000, uniform over the full turn (module notes); the
        colliding ones are dropped, so fewer come back.
    seed : int
    collision : CollisionChecker, optional
        `ram_collision(morph)` (built when not given).

    Returns
    -------
    q : ndarray, shape (k, dof)
        The free configurations (rad), `k <= count`.
    T : ndarray, shape (k, 4, 4)
        Their end-effector poses (base frame, m).
    """
    m = _one_morph(morph)
    count = check_int("count", count, 1, _MAX_POSES)
    seed = check_int("seed", seed, 0)
    chain = ram_arms(m)
    checker = ram_collision(m) if collision is None else collision
    q = np.random.default_rng(seed).uniform(-np.pi, np.pi, size=(count, chain.n))
    q = q[checker(q)]
    return q, chain.fkine(q)


def random_poses(morph: ArrayLike, count: int, seed: int = 0) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """RAM's random evaluation poses of one arm (`synthesise_data` with `use_ik=True`).

    Parameters
    ----------
    morph : array_like, shape (dof + 1, 3)
    count : int
        Poses, 1 .. 10,000,000.
    seed : int

    Returns
    -------
    T : ndarray, shape (count, 4, 4)
        Poses in RAM's ball with uniform orientations; for a 5-joint arm the first
        `k <= count // 4` are forward kinematics of collision-free random configurations.
    known : ndarray of bool, shape (count,)
        True for those FK poses, which RAM labels reachable without IK.
    """
    m = _one_morph(morph)
    count = check_int("count", count, 1, _MAX_POSES)
    seed = check_int("seed", seed, 0)
    rng = np.random.default_rng(seed)
    T = _ball_poses(m, count, rng)
    known = np.zeros(count, dtype=bool)
    if m.shape[0] < 7 and count >= 4:  # RAM's `morph.shape[0] < 7`: the 5-joint arms
        _, Tf = fk_samples(m, count // 4, seed=int(rng.integers(2**31)))
        T[: len(Tf)] = Tf
        known[: len(Tf)] = True
    return T, known


def _geodesic(Ta: np.ndarray, Tb: np.ndarray, steps: int) -> np.ndarray:
    """`(steps, G, 4, 4)` poses along SE(3)'s geodesics (RAM's `se3.exp(se3.log)`), ends included."""
    from scipy.spatial.transform import Rotation

    t = np.linspace(0.0, 1.0, steps)[:, None, None]
    w = Rotation.from_matrix(np.swapaxes(Ta[:, :3, :3], -1, -2) @ Tb[:, :3, :3]).as_rotvec()
    G = len(Ta)
    R = Ta[None, :, :3, :3] @ Rotation.from_rotvec((t * w).reshape(-1, 3)).as_matrix().reshape(steps, G, 3, 3)
    out = np.zeros((steps, G, 4, 4))
    out[..., :3, :3] = R
    out[..., :3, 3] = Ta[None, :, :3, 3] + t * (Tb[:, :3, 3] - Ta[:, :3, 3])[None]
    out[..., 3, 3] = 1.0
    return out


def boundary_poses(morph: ArrayLike, geodesics: int, per_geodesic: int, seed: int = 0, *,
                   starts: int = 32) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """RAM's boundary set of one arm: poses along geodesics from reachable to unreachable poses.

    Parameters
    ----------
    morph : array_like, shape (dof + 1, 3)
    geodesics : int
        Pairs of a reachable pose (FK of a collision-free configuration) and an unreachable one
        (a random pose in the ball that `ik_labels` does not reach); RAM: 1000.
    per_geodesic : int
        Poses per geodesic, at least 2 (the ends included); RAM: 100.
    seed : int
    starts : int
        IK starts of the labels (`ik_labels`).

    Returns
    -------
    T : ndarray, shape (per_geodesic * geodesics, 4, 4)
        Step-major: the first `geodesics` poses are the reachable ends.
    labels : ndarray of bool, shape (per_geodesic * geodesics,)
        `ik_labels` of every pose.

    Raises
    ------
    RuntimeError
        No collision-free configuration or no unreachable pose in the ball was found after ten
        rounds (RAM raises the same).
    """
    m = _one_morph(morph)
    G = check_int("geodesics", geodesics, 1, _MAX_COUNT)
    S = check_int("per_geodesic", per_geodesic, 2, 10_000)
    seed = check_int("seed", seed, 0)
    rng = np.random.default_rng(seed)
    checker = ram_collision(m)
    reach, far = np.empty((0, 4, 4)), np.empty((0, 4, 4))
    for _ in range(10):  # RAM: ten more rounds, then repeat what was found
        if len(reach) < G:
            reach = np.concatenate([reach, fk_samples(m, 3 * (G - len(reach)), int(rng.integers(2**31)), checker)[1]])
        if len(far) < G:
            cand = _ball_poses(m, 3 * (G - len(far)), rng)
            far = np.concatenate([far, cand[~ik_labels(m, cand, starts=starts, collision=checker)]])
        if len(reach) >= G and len(far) >= G:
            break
    if len(reach) == 0 or len(far) == 0:
        raise RuntimeError(f"no {'collision-free configuration' if len(reach) == 0 else 'unreachable pose'} "
                           "found for this arm's boundary set")
    reach = np.resize(reach, (G, 4, 4)) if len(reach) < G else reach[:G]
    far = np.resize(far, (G, 4, 4)) if len(far) < G else far[:G]
    T = _geodesic(reach, far, S).reshape(-1, 4, 4)
    return T, ik_labels(m, T, starts=starts, collision=checker)


# ------------------------------------------------------------------------------------ labels
def ik_labels(morph: ArrayLike, T: ArrayLike, *, self_collision: bool = True, starts: int = 32, seed: int = 0,
              rounds: int = 8, collision: CollisionChecker | None = None) -> NDArray[np.bool_]:
    """RAM's label of poses by inverse kinematics: reachable by a solution free of self-collision.

    Parameters
    ----------
    morph : array_like, shape (dof + 1, 3)
        One arm (no joint limits: RAM has none).
    T : array_like, shape (..., 4, 4)
        End-effector poses (base frame, m).
    self_collision : bool
        Count only solutions free of RAM's capsule self-collision (RAM's definition); False: any
        solution (the kinematic reach).
    starts, seed :
        Starts of `wsmap.reachable`'s search and the seed of the random ones.
    rounds : int
        With `self_collision`: poses not reached are searched again this many times, each time
        from another random first start per pose (`q0`), beyond `wsmap.reachable`'s own retries
        (which also start from random configurations since they were found to restart at `q0` and
        find the same colliding solution: 15 of 19 collision-free FK poses of
        `sample_morphologies(1, 6, seed=7)` then, all 19 now without these rounds).
    collision : CollisionChecker, optional
        `ram_collision(morph)`, built when not given (ignored without `self_collision`).

    Returns
    -------
    ndarray of bool, shape `T.shape[:-2]`
    """
    from ..workspace.maps import reachable

    m = _one_morph(morph)
    T = _check_poses(T)
    starts = check_int("starts", starts, 1, 1000)
    seed = check_int("seed", seed, 0)
    chain = ram_arms(m)
    checker = None
    if self_collision:
        checker = ram_collision(m) if collision is None else collision
    rounds = check_int("rounds", rounds, 0, 1000)
    if T.size == 0:
        return np.zeros(T.shape[:-2], dtype=bool)
    ok = np.asarray(reachable(chain, T, starts=starts, seed=seed, collision=checker), dtype=bool).reshape(-1)
    if checker is not None:
        Tf = T.reshape(-1, 4, 4)
        rng = np.random.default_rng([seed, 1])
        for r in range(1, rounds + 1):  # a loop over rounds, each a batch of the poses left
            idx = np.flatnonzero(~ok)
            if not idx.size:
                break
            q0 = rng.uniform(-np.pi, np.pi, (idx.size, chain.n))
            ok[idx] = reachable(chain, Tf[idx], starts=starts, seed=seed + r, collision=checker, q0=q0)
    return ok.reshape(T.shape[:-2])


def se3_cells(T: ArrayLike, level: int = 3) -> NDArray[np.int64]:
    """SE(3) cell index of poses: RAM's R3 cells times this module's SO(3) cells.

    Parameters
    ----------
    T : array_like, shape (..., 4, 4)
        Poses; positions outside `[-1, 1]^3` m fall into the border cells (as RAM's `r3.index`).
    level : int
        RAM's discretisation level, 1-4 (`RAM_R3_DIVISIONS`, `RAM_SO3_DIVISIONS`; RAM trains at 3).

    Returns
    -------
    ndarray of int64, shape `T.shape[:-2]`
        `r3 + N^3 * so3` with `r3 = x + N y + N^2 z` (RAM's `se3.combine_index`, `N` R3
        divisions) and `so3` in `0 .. 4 k^3 - 1`.
    """
    from scipy.spatial.transform import Rotation

    T = _check_poses(T)
    if isinstance(level, bool) or level not in RAM_R3_DIVISIONS:
        raise ValueError(f"level must be one of 1, 2, 3, 4 (RAM's discretisation levels), got {level!r}")
    k, N = RAM_SO3_DIVISIONS[level], RAM_R3_DIVISIONS[level]
    shape = T.shape[:-2]
    T = T.reshape(-1, 4, 4)
    ijk = np.clip(np.floor((T[:, :3, 3] + 1.0) / 2.0 * N), 0, N - 1).astype(np.int64)
    r3 = ijk[:, 0] + N * ijk[:, 1] + N * N * ijk[:, 2]
    q = Rotation.from_matrix(T[:, :3, :3]).as_quat() if len(T) else np.zeros((0, 4))
    face = np.argmax(np.abs(q), axis=1)
    top = np.take_along_axis(q, face[:, None], axis=1)
    q = q * np.sign(top)  # q ~ -q: the largest component positive
    rest = q[~np.eye(4, dtype=bool)[face]].reshape(-1, 3)  # the other three, in order
    u = np.arctan(rest / np.abs(top))  # in [-pi/4, pi/4]
    b = np.clip(np.floor((u + np.pi / 4) / (np.pi / 2) * k), 0, k - 1).astype(np.int64)
    so3 = face * k**3 + b[:, 0] + k * b[:, 1] + k * k * b[:, 2]
    return (r3 + N**3 * so3).reshape(shape)


def fk_labels(morph: ArrayLike, T: ArrayLike, samples: int | Sequence[int], seed: int = 0, *,
              level: int | Sequence[int] = 3, chunk: int = 200_000) -> NDArray[np.bool_]:
    """RAM's training labels: a pose is reachable when forward-kinematics samples hit its SE(3) cell.

    Parameters
    ----------
    morph : array_like, shape (dof + 1, 3)
    T : array_like, shape (..., 4, 4)
        Poses to label (base frame, m).
    samples : int or sequence of int
        Random configurations (uniform over the full turn), 1 .. 100,000,000; the colliding ones
        (`ram_collision`) mark nothing. A strictly increasing sequence gives the labels after each
        budget from one stream (the labels of `b` samples are those of the first `b`).
    seed : int
    level : int or sequence of int
        RAM's discretisation level, 1-4 (`se3_cells`); RAM's training labels use 3. A sequence
        labels at each level from the same samples.
    chunk : int
        Configurations per batch (memory: about 2 kB each).

    Returns
    -------
    ndarray of bool, shape `(levels?, budgets?) + T.shape[:-2]`
        A leading axis for `level` and then one for `samples` where a sequence was given. True
        where the pose's cell holds the end-effector pose of a sampled collision-free
        configuration: the pose of a sampled configuration is always labelled reachable; a pose
        may be labelled reachable that is not (its cell is only partly reachable) and unreachable
        that is (its cell was not hit yet).
    """
    m = _one_morph(morph)
    T = _check_poses(T)
    many_b, many_l = np.ndim(samples) == 1, np.ndim(level) == 1
    budgets = [check_int("samples", b, 1, _MAX_SAMPLES) for b in np.atleast_1d(samples).tolist()]
    if not budgets or any(b1 <= b0 for b0, b1 in zip(budgets, budgets[1:])):
        raise ValueError(f"samples must be a positive count or a strictly increasing sequence of them, got {samples!r}")
    levels = list(np.atleast_1d(level).tolist())
    if not levels or any(isinstance(v, bool) or v not in RAM_R3_DIVISIONS for v in levels):
        raise ValueError(f"level must be one of 1, 2, 3, 4 (RAM's discretisation levels) or a sequence of them, "
                         f"got {level!r}")
    seed = check_int("seed", seed, 0)
    chunk = check_int("chunk", chunk, 1, 10_000_000)
    want = [se3_cells(T, v).reshape(-1) for v in levels]
    chain = ram_arms(m)
    checker = ram_collision(m)
    rng = np.random.default_rng(seed)
    got = np.zeros((len(levels), want[0].size), dtype=bool)
    out = np.zeros((len(levels), len(budgets), want[0].size), dtype=bool)
    done = 0
    for b, budget in enumerate(budgets):
        while done < budget:  # a loop over chunks of configurations, cut at each budget
            c = min(chunk, budget - done)
            q = rng.uniform(-np.pi, np.pi, size=(c, chain.n))
            P = chain.fkine(q[checker(q)])
            for li, v in enumerate(levels):
                got[li] |= np.isin(want[li], se3_cells(P, v))
            done += c
        out[:, b] = got
    out = out.reshape((len(levels), len(budgets)) + T.shape[:-2])
    return out[(slice(None) if many_l else 0, slice(None) if many_b else 0)]


# ------------------------------------------------------------------------------------ F1
def ram_f1(pred: ArrayLike, truth: ArrayLike) -> tuple[float, NDArray[np.float64]]:
    """RAM's F1: per arm `2 tp / (2 tp + fp + fn)` (1 for an arm with neither a true nor a
    predicted positive), averaged over the arms (`ram/metrics.py`, `compute_metrics`).

    Parameters
    ----------
    pred, truth : array_like of bool, shape (arms, poses)
        Predicted and true labels, one row per arm.

    Returns
    -------
    mean : float
        The mean over arms (RAM reports it in percent).
    per_arm : ndarray, shape (arms,)
    """
    from ..metrics import precision_recall_f

    p, t = np.asarray(pred), np.asarray(truth)
    if p.shape != t.shape or p.ndim != 2 or p.shape[1] == 0:
        raise ValueError(f"pred and truth must both be (arms, poses) with at least one pose, got {p.shape} and {t.shape}")
    res = precision_recall_f(p, t, average="samples", zero_division=1)
    f = np.asarray(res.per_sample["f"], dtype=np.float64)
    return float(f.mean()), f
