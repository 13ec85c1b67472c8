"""Collision checks of configurations: a fast conservative layer of spheres, then coal's exact test.

**The exact check** (`exact_pairs`, `CollisionChecker.exact`) asks coal (the successor
of hpp-fcl) whether two shapes intersect: boxes, cylinders, spheres and capsules as coal's
primitives, meshes as their convex hulls (`wsmap.collision.geometry`), the floor as the
half-space `z <= floor`. Touching counts as a collision.

**Capsules in numpy**: a pair of links made of capsules and spheres only (the named arms' models),
and such a link against the floor, is decided exactly by segment distances
(`segment_distance`), vectorised over configurations; coal agrees (tests).

**The fast layer**: every other shape is enclosed in a few spheres (`bounding_spheres`; each
sphere contains its piece of the shape, together they contain all of it), carried by the shape's
body. For a batch of configurations the sphere centres are one array product, and a link pair
(or a link and an obstacle) whose spheres are all apart is free without asking coal. The exact
check decides only the pairs the spheres call "maybe".

**Standing on an obstacle**: a moving link that touches an obstacle at the default configuration
(a turntable on the floor or a pedestal) is not checked against it, but only when the base's origin
is within `STAND_MARGIN` of that obstacle's surface: an obstacle around the base (the arm inside a
solid box) or apart from it is checked against every moving link, so the arm inside a box collides
everywhere.

**The two-level check**: a model with a `coarse` model (`CollisionModel.coarse`: the same
links, each enclosed by the coarse one's shapes; the named arms' vendor meshes with the capsules
fitted around them, `wsmap.collision.vendor.two_level_model`) is checked on the coarse shapes
first, for the whole batch, with this checker's link pairs and the scene pairs it allows; only the
configurations the coarse shapes call colliding are checked on the model's own shapes, which
decide. Coarse shapes that enclose the fine ones cannot be apart where the fine ones meet, so the
answer is the fine model's, exactly; the coarse level only saves time.

**Guarantee**: a configuration `CollisionChecker` calls free is free for the exact check
on every pair it checks (enabled by the allowed-collision matrix, and moving links against the
scene): the spheres contain the shapes, so apart spheres mean apart shapes, and every other pair
goes to coal. The tests check this on random samples against `CollisionChecker.exact`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..kinematics.transforms import check_rigid
from .geometry import CollisionModel, Shape, body_frames
from .scene import Scene

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap._typing import ArrayLike

#: How far (m) the base's origin may be from the surface of an obstacle it stands on (the floor, a
#: table, a pedestal): within it, moving links touching that obstacle at the default configuration
#: stand on it and are not checked against it; deeper inside or farther away, they are.
STAND_MARGIN = 0.01
#: Unit directions to the 26 neighbours of a cube's centre: the probes of `_supports_base`.
_DIRECTIONS = np.array([(i, j, k) for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1) if i or j or k], float)
_DIRECTIONS /= np.linalg.norm(_DIRECTIONS, axis=1, keepdims=True)

__all__ = ["STAND_MARGIN", "bounding_spheres", "coal_shape", "coal_transform", "coal_collide", "exact_pairs", "segment_distance",
           "CollisionChecker", "CheckStats"]


# ------------------------------------------------------------------------------------ sphere layer
#: At most this many spheres enclose each obstacle (a link: `bounding_spheres`' default of 6).
OBSTACLE_SPHERES = 64

def bounding_spheres(shape: Shape, max_spheres: int = 6) -> tuple[np.ndarray, np.ndarray]:
    """Spheres whose union contains a shape (a mesh's convex hull).

    Parameters
    ----------
    shape : Shape
        The shape.
    max_spheres : int
        At most this many spheres: the shape is cut along its longest axis into `m <= max_spheres`
        pieces, each enclosed by one sphere (its kind's `ShapeKind.bounding_spheres`).

    Returns
    -------
    centres : numpy.ndarray
        `(m, 3)` in the shape's own frame (m).
    radii : numpy.ndarray
        `(m,)` (m).
    """
    return shape.record.bounding_spheres(shape, max_spheres)


# ------------------------------------------------------------------------------------ coal
def coal_shape(shape: Shape):
    """The coal collision geometry of `shape` (a mesh as its convex hull), in its own frame."""
    return shape.record.coal_geometry(shape)


def coal_transform(T):
    """coal's `Transform3s` of a pose `T` `(4, 4)`."""
    import coal

    return coal.Transform3s(np.ascontiguousarray(T[:3, :3]), np.ascontiguousarray(T[:3, 3]))


def coal_collide(g1, T1, g2, T2, margin: float = 0.0) -> bool:
    """Whether coal geometries `g1` at pose `T1` and `g2` at `T2` (`(4, 4)`) intersect
    (touching counts), or come closer than `margin` (m; coal's security margin)."""
    import coal

    req = coal.CollisionRequest()
    req.security_margin = float(margin)
    res = coal.CollisionResult()
    return coal.collide(g1, coal_transform(T1), g2, coal_transform(T2), req, res) > 0


@dataclass
class CheckStats:
    """What a checker has done: configurations checked, those decided without coal (by the spheres,
    the capsules in numpy, or the coarse model of a two-level check), those the coarse model called
    free (`coarse_free`; 0 without one), exact pair tests (coal calls) and the seconds spent in them."""

    configurations: int = 0
    decided_fast: int = 0
    exact_tests: int = 0
    exact_seconds: float = 0.0
    seconds: float = 0.0
    coarse_free: int = 0

    @property
    def fast_fraction(self) -> float:
        return self.decided_fast / self.configurations if self.configurations else float("nan")


def segment_distance(p0, p1, q0, q1) -> np.ndarray:
    """Distance between the segments `p0`-`p1` and `q0`-`q1` (arrays `(..., 3)`, m):
    Ericson's closest points of two segments (Real-Time Collision Detection, 5.1.9), vectorised,
    a point (zero-length segment) included."""
    d1, d2, r = p1 - p0, q1 - q0, p0 - q0
    a = np.einsum("...i,...i", d1, d1)
    e = np.einsum("...i,...i", d2, d2)
    f = np.einsum("...i,...i", d2, r)
    c = np.einsum("...i,...i", d1, r)
    b = np.einsum("...i,...i", d1, d2)
    eps = 1e-18
    denom = a * e - b * b
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(denom > eps * np.maximum(a * e, eps), np.clip((b * f - c * e) / denom, 0.0, 1.0), 0.0)
        t = np.where(e > eps, (b * s + f) / e, 0.0)
        s = np.where(t < 0.0, np.where(a > eps, np.clip(-c / a, 0.0, 1.0), 0.0),
                     np.where(t > 1.0, np.where(a > eps, np.clip((b - c) / a, 0.0, 1.0), 0.0), s))
    t = np.clip(t, 0.0, 1.0)
    return np.linalg.norm(p0 + s[..., None] * d1 - q0 - t[..., None] * d2, axis=-1)


class _Layer:
    """Spheres and coal geometries of a model's links (body frame) and of a scene (world frame)."""

    def __init__(self, model: CollisionModel, scene: Scene | None):
        self.model = model
        cs, rs, body, link, shape_of = [], [], [], [], []
        self.geoms, self.shape_body, self.shape_origin, self.shape_link = [], [], [], []
        self.shapes: list[Shape] = []
        self.link_shapes: list[list[int]] = []
        self.caps: dict[int, tuple] = {}  # shape -> (p0, p1, radius) in the body frame: exact tests in numpy
        for li, lk in enumerate(model.links):
            ids = []
            for s in lk.shapes:
                si = len(self.geoms)
                ids.append(si)
                self.geoms.append(coal_shape(s))
                self.shapes.append(s)
                self.shape_body.append(lk.body)
                self.shape_origin.append(s.origin)
                self.shape_link.append(li)
                swept = s.record.swept_sphere(s)
                if swept is not None:
                    half, radius = swept
                    ends = s.origin[:3, :3] @ np.array([[0, 0, -half], [0, 0, half]]).T + s.origin[:3, 3:4]
                    self.caps[si] = (ends[:, 0], ends[:, 1], radius + model.margin)
                c, r = bounding_spheres(s)
                cs.append(c @ s.origin[:3, :3].T + s.origin[:3, 3])
                rs.append(r + model.margin)  # the spheres hold the shape grown by the model's margin
                body += [lk.body] * len(r)
                link += [li] * len(r)
                shape_of += [si] * len(r)
            self.link_shapes.append(ids)
        self.analytic = np.array([all(si in self.caps for si in ids) for ids in self.link_shapes], dtype=bool)
        self.centres = np.concatenate(cs)  # (S, 3) body frame
        self.radii = np.concatenate(rs)
        self.sphere_body = np.array(body, dtype=np.int64)
        self.sphere_link = np.array(link, dtype=np.int64)
        self.shape_body = np.array(self.shape_body, dtype=np.int64)
        self.shape_origin = np.stack(self.shape_origin)
        base = model.chain.base
        self.scene = scene or Scene()
        self.obs_geoms, self.obs_pose, self.obs_spheres = [], [], []
        for ob in self.scene.obstacles:
            P = ob.pose(base)
            self.obs_geoms.append(coal_shape(ob.shape))
            self.obs_pose.append(P)
            # obstacles stand still: more, smaller spheres cost one array product and spare coal calls
            c, r = bounding_spheres(ob.shape, OBSTACLE_SPHERES)
            self.obs_spheres.append((c @ P[:3, :3].T + P[:3, 3], r))
        if self.scene.floor is not None:
            import coal

            self.floor_geom = coal.Halfspace(np.array([0.0, 0.0, 1.0]), float(self.scene.floor))

    def world_spheres(self, B):
        """Sphere centres `(C, S, 3)` in the world for body frames `B` `(C, n + 1, 4, 4)`."""
        Bs = B[:, self.sphere_body]
        return (Bs[..., :3, :3] @ self.centres[:, :, None])[..., 0] + Bs[..., :3, 3]

    def shape_pose(self, B, si):
        return B[self.shape_body[si]] @ self.shape_origin[si]


def _spheres_meet(cs, rs, oc, orad) -> np.ndarray:
    """`(C, S)`: sphere `s` (centres `cs` `(C, S, 3)`, radii `rs` `(S,)`) may meet one of the
    obstacle's spheres (`oc` `(O, 3)`, `orad` `(O,)`). Squared distances by one matrix product
    (`|c|² + |o|² − 2 c·o`); the rounding of that form (about 1e-15 m² here) is covered by the 1e-9 m²
    added to the threshold, which only ever calls more pairs "maybe"."""
    d2 = (np.einsum("csi,csi->cs", cs, cs)[..., None] + np.einsum("oi,oi->o", oc, oc) - 2.0 * (cs @ oc.T))
    return np.any(d2 <= (rs[:, None] + orad) ** 2 + 1e-9, axis=-1)


def _obstacle_maybe(shape, P, centres, radii):
    """`(C, S)` bool: the sphere may touch the obstacle `shape` at pose `P`: the exact
    point-to-solid distance of its kind (`ShapeKind.point_distance`) compared with the radius;
    None for a kind without one."""
    local = (centres - P[:3, 3]) @ P[:3, :3]
    d = shape.record.point_distance(shape.size, local)
    if d is None:
        return None
    return d <= radii + 1e-12


class CollisionChecker:
    """Which configurations of an arm are collision-free: a configuration predicate.

    Parameters
    ----------
    model : CollisionModel
        The arm's geometry; its allowed-collision matrix (`model.acm`, or `acm`; see
        `wsmap.collision.acm.build_acm`) says which link pairs count.
    scene : Scene, optional
        Obstacles (`wsmap.collision.scene`); default: the floor `z = 0` when the model stands
        on it (`model.floor`), else nothing.
    self_collision : bool
        Check the enabled link pairs (default); False checks the scene alone.

    Notes
    -----
    `checker(q)` with `q` `(C, n)` (rad / m) returns bool `(C,)`, True where collision-free
    (the guarantee in the module notes); `stats` counts the work. The same instance can be
    given to every map (`collision=`).
    """

    def __init__(self, model: CollisionModel, scene: Scene | None = None, *, acm=None, self_collision: bool = True,
                 pairs=None):
        if not isinstance(model, CollisionModel):
            raise TypeError(f"model must be a CollisionModel, got {type(model).__name__}")
        if scene is None:
            scene = Scene(floor=0.0) if model.floor else Scene()
        if not isinstance(scene, Scene):
            raise TypeError(f"scene must be a Scene, got {type(scene).__name__}")
        self.model = model
        self.scene = scene
        self.acm = model.acm if acm is None else acm
        if self.acm is None and pairs is None and self_collision:
            raise ValueError("the collision model has no allowed-collision matrix: model.acm = "
                             "wsmap.collision.build_acm(model) first (or wsmap.collision.checker_for)")
        self.self_collision = bool(self_collision)
        self.layer = _Layer(model, scene)
        self._set_pairs(pairs if pairs is not None else self.acm.enabled_pairs() if self_collision else [])
        self.stats = CheckStats()
        # a moving link that touches an obstacle (the floor) at the default configuration stands
        # on it, as the base does (a turntable on the floor): that pair is allowed, as the
        # matrix's "default" pairs (MoveIt's matrix covers world objects the same way). Only an
        # obstacle the base stands on, though: one holding the base deep inside (a box around the
        # arm) or apart from it (a shelf the forearm touches at q = 0) was silently ignored
        chain = model.chain
        q0 = np.clip(np.zeros(chain.n), chain.limits[:, 0], chain.limits[:, 1])
        B0 = body_frames(chain, q0[None])[0]
        nob = len(scene.obstacles) + (scene.floor is not None)
        support = np.array([self._supports_base(B0[0, :3, 3], k) for k in range(nob)], dtype=bool)
        self.scene_allowed = np.array([[bool(support[k]) and self._scene_collides(B0, li, k) for k in range(nob)]
                                       for li in self.moving], dtype=bool).reshape(len(self.moving), nob)
        self.stats = CheckStats()
        # the two-level check: the coarse model with this checker's pairs and allowed scene pairs
        # (those of the fine shapes: the coarse ones may touch an obstacle at q = 0 that these do not)
        self.coarse = None
        if model.coarse is not None:
            self.coarse = CollisionChecker(model.coarse, self.scene, pairs=self.pairs, self_collision=self_collision)
            self.coarse.scene_allowed = self.scene_allowed

    def _supports_base(self, origin, k) -> bool:
        """Whether obstacle `k` (the floor last) is what the base stands on: its surface within
        `STAND_MARGIN` of the base's origin `origin` `(3,)` (world, m), neither around it nor apart.
        Outside distances are coal's (exact); "not deep inside" is some point at `STAND_MARGIN`
        from the origin (26 directions) lying outside: coal's penetration depth of a point in a
        cylinder is not its distance to the nearest face."""
        import coal

        L = self.layer
        floor = k == len(self.scene.obstacles)
        geom, P = (L.floor_geom, np.eye(4)) if floor else (L.obs_geoms[k], L.obs_pose[k])
        ob = None if floor else self.scene.obstacles[k].shape
        probe, T = coal.Sphere(1e-9), np.eye(4)

        def distance(p) -> float:
            T[:3, 3] = p
            res = coal.DistanceResult()
            coal.distance(probe, coal_transform(T), geom, coal_transform(P), coal.DistanceRequest(), res)
            return res.min_distance

        def outside(p) -> bool:
            inside = None if ob is None else ob.record.encloses(ob, ((p - P[:3, 3]) @ P[:3, :3])[None])
            return not (inside is not None and inside[0]) and distance(p) > 2e-9  # a closed surface: its inside

        if distance(origin) > STAND_MARGIN:
            return False
        return any(outside(origin + STAND_MARGIN * u) for u in _DIRECTIONS)

    def _set_pairs(self, pairs):
        """The link pairs checked, `(P, 2)` link indices, and their sphere pairs."""
        self.pairs = np.array(pairs, dtype=np.int64).reshape(-1, 2)
        L = self.layer
        cat = (lambda x: np.concatenate(x) if x else np.zeros(0, dtype=np.int64))
        # pairs of capsules and spheres only are decided exactly in numpy (segment distances);
        # the others by the spheres, then coal
        an = np.array([L.analytic[i] and L.analytic[j] for i, j in self.pairs], dtype=bool).reshape(-1)
        self._an, self._non = np.flatnonzero(an), np.flatnonzero(~an)
        sa, sb, pid = [], [], []
        for p, (i, j) in enumerate(self.pairs[self._non]):
            A, Bm = np.meshgrid(np.flatnonzero(L.sphere_link == i), np.flatnonzero(L.sphere_link == j), indexing="ij")
            sa.append(A.ravel())
            sb.append(Bm.ravel())
            pid.append(np.full(A.size, p))
        self._sa, self._sb, self._pid = cat(sa), cat(sb), cat(pid)
        self._first = np.searchsorted(self._pid, np.arange(len(self._non)))  # every pair has spheres
        ca, cb, cid = [], [], []
        for p, (i, j) in enumerate(self.pairs[self._an]):
            A, Bm = np.meshgrid(L.link_shapes[i], L.link_shapes[j], indexing="ij")
            ca.append(A.ravel())
            cb.append(Bm.ravel())
            cid.append(np.full(A.size, p))
        self._ca, self._cb, cid = cat(ca), cat(cb), cat(cid)
        self._cfirst = np.searchsorted(cid, np.arange(len(self._an)))
        self.moving = np.flatnonzero([lk.body > 0 for lk in self.model.links])

    @property
    def n(self) -> int:
        return self.model.chain.n

    def describe(self) -> dict:
        """A JSON-able record for map files: the geometry, the matrix, the scene (with the links
        allowed to touch an obstacle, those touching it at the default configuration)."""
        names = self.model.names
        obs = [o.name for o in self.scene.obstacles] + (["floor"] if self.scene.floor is not None else [])
        standing = [[names[self.moving[m]], obs[k]] for m, k in zip(*np.nonzero(self.scene_allowed))]
        return {"geometry": self.model.describe(), "acm": None if self.acm is None else self.acm.describe(),
                "scene": {**self.scene.describe(), "allowed": standing}, "self_collision": self.self_collision}

    # -------------------------------------------------------------------------------- fast layer
    def _maybe(self, B, allowed=None):
        """`(C, P)` maybe per enabled link pair and `(C, L_moving, O)` per link and obstacle
        (the floor last), from the spheres; `allowed` (default `scene_allowed`) the link and
        obstacle pairs not checked."""
        L = self.layer
        c = L.world_spheres(B)
        r = L.radii
        C = c.shape[0]
        pair = np.zeros((C, len(self.pairs)), dtype=bool)
        if len(self._sa):
            d = np.linalg.norm(c[:, self._sa] - c[:, self._sb], axis=-1)
            hit = d <= r[self._sa] + r[self._sb] + 1e-12
            # any over each pair's sphere pairs (contiguous, in pair order)
            pair[:, self._non] = np.logical_or.reduceat(hit, self._first, axis=1)
        obs = self.scene.obstacles
        nob = len(obs) + (self.scene.floor is not None)
        scene = np.zeros((C, len(self.moving), nob), dtype=bool)
        if nob:
            for mi, li in enumerate(self.moving):
                s = np.flatnonzero(L.sphere_link == li)
                cs, rs = c[:, s], r[s]
                for k, ob in enumerate(obs):
                    m = _obstacle_maybe(ob.shape, L.obs_pose[k], cs, rs)
                    if m is None:  # a mesh: its own spheres
                        m = _spheres_meet(cs, rs, *L.obs_spheres[k])
                    scene[:, mi, k] = m.any(axis=-1)
                if self.scene.floor is not None and not L.analytic[li]:
                    scene[:, mi, -1] = np.any(cs[..., 2] - rs <= self.scene.floor + 1e-12, axis=-1)
        return pair, scene & ~(self.scene_allowed if allowed is None else allowed)

    def _analytic(self, B, per_pair: bool = False, allowed=None) -> np.ndarray:
        """`(C,)` True where a capsule pair (or a capsule link and the floor) collides, exactly;
        `per_pair`: `(C, P)` for the checked pairs instead (False for the others), no floor."""
        L = self.layer
        C = B.shape[0]
        out = np.zeros(C, dtype=bool)
        pairs = np.zeros((C, len(self.pairs)), dtype=bool)
        if not L.caps:
            return pairs if per_pair else out
        ids = np.array(sorted(L.caps))
        where = {si: k for k, si in enumerate(ids)}
        body = L.shape_body[ids]
        p0 = np.stack([L.caps[si][0] for si in ids])
        p1 = np.stack([L.caps[si][1] for si in ids])
        rad = np.array([L.caps[si][2] for si in ids])
        Bk = B[:, body]  # (C, K, 4, 4); one advanced index, so the axes stay in place
        R, t = Bk[..., :3, :3], Bk[..., :3, 3]
        w0 = (R @ p0[:, :, None])[..., 0] + t  # (C, K, 3) world ends
        w1 = (R @ p1[:, :, None])[..., 0] + t
        if len(self._ca):
            a = np.array([where[x] for x in self._ca])
            b = np.array([where[x] for x in self._cb])
            # each capsule's bounding sphere (its segment's midpoint, half its length plus its radius):
            # two apart are two capsules apart; segment distances only for the others
            half = np.linalg.norm(p1 - p0, axis=1) / 2 + rad
            mid = (w0 + w1) / 2
            touch = rad[a] + rad[b]
            near = np.linalg.norm(mid[:, a] - mid[:, b], axis=-1) <= half[a] + half[b] + 1e-12
            hit = np.zeros(near.shape, dtype=bool)
            c, k = np.nonzero(near)
            hit[c, k] = segment_distance(w0[c, a[k]], w1[c, a[k]], w0[c, b[k]], w1[c, b[k]]) <= touch[k]
            pairs[:, self._an] = np.logical_or.reduceat(hit, self._cfirst, axis=1)
            out |= pairs.any(axis=1)
        if per_pair:
            return pairs
        if self.scene.floor is not None:
            allowed = self.scene_allowed if allowed is None else allowed
            nob = allowed.shape[1]
            for mi, li in enumerate(self.moving):
                if L.analytic[li] and not allowed[mi, nob - 1]:
                    k = np.array([where[x] for x in L.link_shapes[li]])
                    low = np.minimum(w0[:, k, 2], w1[:, k, 2]) - rad[k]
                    out |= (low <= self.scene.floor).any(axis=1)
        return out

    # -------------------------------------------------------------------------------- exact
    def _pair_collides(self, B, i, j) -> bool:
        L = self.layer
        for si in L.link_shapes[i]:
            Ti = L.shape_pose(B, si)
            for sj in L.link_shapes[j]:
                self.stats.exact_tests += 1
                if coal_collide(L.geoms[si], Ti, L.geoms[sj], L.shape_pose(B, sj), 2 * self.model.margin):
                    return True
        return False

    def _scene_collides(self, B, li, k) -> bool:
        L = self.layer
        floor = k == len(self.scene.obstacles)
        for si in L.link_shapes[li]:
            self.stats.exact_tests += 1
            Ti = L.shape_pose(B, si)
            if floor:
                hit = coal_collide(L.geoms[si], Ti, L.floor_geom, np.eye(4), self.model.margin)
            else:
                hit = (coal_collide(L.geoms[si], Ti, L.obs_geoms[k], L.obs_pose[k], self.model.margin)
                       or self._enclosed(si, Ti, k))
            if hit:
                return True
        return False

    def _enclosed(self, si, Ti, k) -> bool:
        # a link shape wholly inside a closed surface crosses none of its triangles: coal's answer
        # for a boundary-only kind is completed by one inner point of the (connected) link shape
        ob, P = self.scene.obstacles[k].shape, self.layer.obs_pose[k]
        if ob.record.encloses(ob, np.zeros((0, 3))) is None:  # no inside (a primitive, an open sheet)
            return False
        shape = self.layer.shapes[si]
        p = Ti[:3, :3] @ shape.record.inner_point(shape) + Ti[:3, 3]
        inside = ob.record.encloses(ob, (p - P[:3, 3]) @ P[:3, :3])
        return bool(inside is not None and inside[0])

    def _q(self, q) -> np.ndarray:
        q = np.asarray(q, dtype=np.float64)
        if q.ndim != 2 or q.shape[1] != self.n:
            raise ValueError(f"configurations must have shape (C, {self.n}), got {q.shape}")
        if not np.all(np.isfinite(q)):
            raise ValueError("configurations contain NaN or infinite values")
        return q

    def __call__(self, q) -> np.ndarray:
        """Collision-free, bool `(C,)`, for configurations `q` `(C, n)`: spheres, then coal."""
        return self._free(self._q(q))

    def at_bases(self, q: ArrayLike, bases: ArrayLike) -> np.ndarray:
        """Collision-free, bool `(C,)`, for configurations `q` `(C, n)` of an arm whose base
        stands at a pose of its own for each: `bases` `(C, 4, 4)` (or one `(4, 4)`), the world
        pose of the frame the chain's forward kinematics is expressed in (metres). Base placement
        asks this: each candidate base sees the scene's world-frame obstacles (a table) from
        elsewhere. The bases stand on the floor (`z` of the frame at the floor height, turned
        about `z` only): the floor is then the same for all of them. World-frame obstacles are
        checked against every moving link (none stands on them: a candidate's default pose means
        nothing to a table elsewhere); base-frame obstacles are refused (they would move with each
        base: check them with `checker(q)`). The same guarantee as `checker(q)`."""
        q = self._q(q)
        bases = check_rigid("bases", bases)
        bases = np.broadcast_to(bases, (len(q), 4, 4)) if bases.ndim == 2 else bases
        if bases.shape != (len(q), 4, 4):
            raise ValueError(f"bases must have shape ({len(q)}, 4, 4) or (4, 4), got {bases.shape}")
        if any(ob.frame == "base" for ob in self.scene.obstacles):
            raise ValueError("at_bases takes world-frame obstacles only (base-frame ones move with each base)")
        allowed = self.scene_allowed.copy()
        allowed[:, :len(self.scene.obstacles)] = False
        return self._free(q, bases, allowed)

    def _free(self, q, bases=None, allowed=None) -> np.ndarray:
        if self.coarse is None:
            return self._layers(q, bases, allowed)
        # two levels: the coarse model on the whole batch, this model on what it calls colliding
        t0, before = time.perf_counter(), self.stats.seconds
        free = self.coarse._layers(q, bases, self.scene_allowed if allowed is None else allowed)
        flagged = np.flatnonzero(~free)
        if flagged.size:
            free[flagged] = self._layers(q[flagged], None if bases is None else bases[flagged], allowed)
        st = self.stats
        st.configurations += len(q) - flagged.size  # the flagged ones were counted by _layers
        st.decided_fast += len(q) - flagged.size
        st.coarse_free += len(q) - flagged.size
        st.seconds = before + time.perf_counter() - t0
        return free

    def _layers(self, q, bases=None, allowed=None) -> np.ndarray:
        """Collision-free `(C,)` by this model's shapes alone: capsules in numpy, spheres, then coal."""
        t0 = time.perf_counter()
        free = np.ones(len(q), dtype=bool)
        for s0 in range(0, len(q), 2048):
            B = body_frames(self.model.chain, q[s0 : s0 + 2048])
            if bases is not None:
                B = bases[s0 : s0 + len(B), None] @ B
            hit = self._analytic(B, allowed=allowed)
            free[s0 : s0 + len(B)] = ~hit
            pair, scene = self._maybe(B, allowed)
            need = ~hit & (pair.any(axis=1) | scene.any(axis=(1, 2)))
            self.stats.decided_fast += int((~need).sum())
            te = time.perf_counter()
            for c in np.flatnonzero(need):
                hit = any(self._pair_collides(B[c], *self.pairs[p]) for p in np.flatnonzero(pair[c]))
                if not hit:
                    mi, k = np.nonzero(scene[c])
                    hit = any(self._scene_collides(B[c], self.moving[a], b) for a, b in zip(mi, k))
                free[s0 + c] = not hit
            self.stats.exact_seconds += time.perf_counter() - te
        self.stats.configurations += len(q)
        self.stats.seconds += time.perf_counter() - t0
        return free

    free = __call__

    def exact(self, q) -> np.ndarray:
        """Collision-free by coal alone (every enabled pair and scene pair, no spheres): bool `(C,)`;
        the reference the fast layer is tested against."""
        q = self._q(q)
        B = body_frames(self.model.chain, q)
        nob = len(self.scene.obstacles) + (self.scene.floor is not None)
        out = np.ones(len(q), dtype=bool)
        for c in range(len(q)):
            hit = any(self._pair_collides(B[c], i, j) for i, j in self.pairs)
            if not hit:
                hit = any(self._scene_collides(B[c], li, k) for m, li in enumerate(self.moving) for k in range(nob)
                          if not self.scene_allowed[m, k])
            out[c] = not hit
        return out

    def colliding(self, q) -> list[tuple[str, str]]:
        """The colliding pairs of one configuration `q` `(n,)` by coal alone: link names, an
        obstacle's name or `"floor"` for the scene."""
        B = body_frames(self.model.chain, self._q(np.asarray(q, dtype=np.float64)[None]))[0]
        names = self.model.names
        out = [(names[i], names[j]) for i, j in self.pairs if self._pair_collides(B, i, j)]
        obs = [o.name for o in self.scene.obstacles] + (["floor"] if self.scene.floor is not None else [])
        out += [(names[li], obs[k]) for m, li in enumerate(self.moving) for k in range(len(obs))
                if not self.scene_allowed[m, k] and self._scene_collides(B, li, k)]
        return out

    def distance(self, q: ArrayLike, bases: ArrayLike | None = None, *, cap: float = np.inf) -> np.ndarray:
        """The clearance `(C,)` (m) of configurations `q` `(C, n)`: the smallest distance between two
        shapes this checker checks (the enabled link pairs; the moving links against the obstacles and
        the floor, less the pairs allowed to touch; each link shape grown by the model's `margin`),
        by coal's distance query; 0 where two touch or
        overlap (no penetration depth). `bases` `(C, 4, 4)` or `(4, 4)` places the arm's base as in
        `at_bases` (world-frame obstacles against every moving link). A clearance at or above `cap`
        (m) comes back as `cap`.

        Exact, and vectorised over configurations: the enclosing spheres bound each pair's distance
        from below for the whole batch at once, and coal is asked, nearest bound first, only for the
        pairs whose bound is below the smallest distance found so far (and below `cap`).
        """
        q = self._q(q)
        cap = float(cap)
        if not cap > 0:
            raise ValueError(f"cap must be a positive distance (m) or inf, got {cap!r}")
        allowed = self.scene_allowed
        if bases is not None:
            bases = check_rigid("bases", bases)
            bases = np.broadcast_to(bases, (len(q), 4, 4)) if bases.ndim == 2 else bases
            if bases.shape != (len(q), 4, 4):
                raise ValueError(f"bases must have shape ({len(q)}, 4, 4) or (4, 4), got {bases.shape}")
            if any(ob.frame == "base" for ob in self.scene.obstacles):
                raise ValueError("distance with bases takes world-frame obstacles only (base-frame ones move with "
                                 "each base)")
            allowed = allowed.copy()
            allowed[:, :len(self.scene.obstacles)] = False
        # an item is a link pair (i, j), or a link and obstacle k as (i, -1 - k), the floor last
        items = [(int(i), int(j)) for i, j in self.pairs]
        items += [(int(li), -1 - k) for m, li in enumerate(self.moving) for k in range(allowed.shape[1])
                  if not allowed[m, k]]
        out = np.full(len(q), cap)
        for s0 in range(0, len(q), 2048):
            B = body_frames(self.model.chain, q[s0 : s0 + 2048])
            if bases is not None:
                B = bases[s0 : s0 + len(B), None] @ B
            c = self.layer.world_spheres(B)
            bound = np.stack([self._distance_bound(c, i, j) for i, j in items] + [np.full(len(B), np.inf)], axis=1)
            for ci in range(len(B)):
                for it in np.argsort(bound[ci], kind="stable"):
                    if bound[ci, it] >= out[s0 + ci]:  # no item left can be nearer (0 found: none can)
                        break
                    out[s0 + ci] = min(out[s0 + ci], self._item_distance(B[ci], *items[it]))
        return out

    def _distance_bound(self, c, i, j) -> np.ndarray:
        """`(C,)` a lower bound (m, at least 0) of `distance`'s item `(i, j)` from the sphere centres
        `c` `(C, S, 3)`: the spheres contain the shapes, so no two points are nearer than the spheres."""
        L = self.layer
        si = L.sphere_link == i
        ci, ri = c[:, si], L.radii[si]
        k = -1 - j
        if j >= 0:
            sj = L.sphere_link == j
            d = np.linalg.norm(ci[:, :, None] - c[:, None, sj], axis=-1) - ri[:, None] - L.radii[sj]
        elif k == len(self.scene.obstacles):
            d = ci[..., 2] - ri - self.scene.floor
        else:
            ob, P = self.scene.obstacles[k].shape, L.obs_pose[k]
            pd = ob.record.point_distance(ob.size, (ci - P[:3, 3]) @ P[:3, :3])
            oc, orad = L.obs_spheres[k]
            d = pd - ri if pd is not None else np.linalg.norm(ci[:, :, None] - oc, axis=-1) - ri[:, None] - orad
        return np.maximum(d.reshape(len(c), -1).min(axis=1), 0.0)

    def _item_distance(self, B, i, j) -> float:
        """coal's distance (m, at least 0) of `distance`'s item `(i, j)` at body frames `B` `(n + 1, 4, 4)`;
        0 for a link shape wholly inside a closed surface obstacle (the checker calls it colliding)."""
        import coal

        L, k = self.layer, -1 - j
        obstacle = j < 0 and k < len(self.scene.obstacles)
        if j >= 0:
            others = [(L.geoms[s], L.shape_pose(B, s)) for s in L.link_shapes[j]]
        else:
            others = [(L.obs_geoms[k], L.obs_pose[k]) if obstacle else (L.floor_geom, np.eye(4))]
        best = np.inf
        for s in L.link_shapes[i]:
            if obstacle and self._enclosed(s, L.shape_pose(B, s), k):
                return 0.0
            Ts = coal_transform(L.shape_pose(B, s))
            for g, T in others:
                self.stats.exact_tests += 1
                best = min(best, coal.distance(L.geoms[s], Ts, g, coal_transform(T), coal.DistanceRequest(),
                                               coal.DistanceResult()))
        return max(best - self.model.margin * (2 if j >= 0 else 1), 0.0)  # the shapes grown by the margin


def exact_pairs(model: CollisionModel, pairs, q) -> np.ndarray:
    """Whether each link pair `pairs` `(P, 2)` (link indices) collides, by coal, for each
    configuration `q` `(C, n)`: bool `(C, P)`; the spheres skip pairs that are surely apart.
    The allowed-collision matrix is built with it (`wsmap.collision.acm.build_acm`)."""
    chk = CollisionChecker(model, Scene(), pairs=np.asarray(pairs, dtype=np.int64).reshape(-1, 2))
    q = chk._q(q)
    out = np.zeros((len(q), len(chk.pairs)), dtype=bool)
    for s0 in range(0, len(q), 2048):
        B = body_frames(model.chain, q[s0 : s0 + 2048])
        maybe, _ = chk._maybe(B)
        out[s0 : s0 + len(B)] = chk._analytic(B, per_pair=True)
        for c, p in zip(*np.nonzero(maybe)):
            out[s0 + c, p] = chk._pair_collides(B[c], *chk.pairs[p])
    return out
