"""Collision geometry of an arm: shapes attached to the rigid bodies of its serial chain.

A chain of `n` joints (`wsmap.kinematics.SerialChain`) has `n + 1` rigid *bodies*: body
0 is the base (it never moves), body `k` moves with joint `k`. Body `k`'s frame, in the world,
is `B_k(q) = base · F_0 · M_1(q_1) · F_1 ··· M_k(q_k)` (the chain's notation): for a chain read
from a URDF it is the URDF frame of the child link of the `k`-th movable joint, body 0's the
base link's. A *link* of the model is a named set of shapes, each with its pose in its body's
frame; several links can ride on one body (a URDF link fixed to another, a hand on the flange).

Shapes (metres; `wsmap.collision.shapes`, one record per kind): `box`, `cylinder`, `sphere`,
`capsule`, `mesh` (`Shape`; each kind's sizes in its module's notes).

Sources: `from_urdf_collision` (the URDF's `<collision>` elements, meshes read by trimesh:
STL, OBJ, DAE, PLY), `capsule_model` (capsules given per body, e.g. a named arm's model
from its dimension drawing, `wsmap.collision.named`) and `capsules_along_links` (a DH
arm with link radii).
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..kinematics.chain import PRISMATIC, REVOLUTE, SerialChain, as_chain, joint_motion
from ..kinematics.urdf import URDFTree, from_urdf, parse_xml, read_source
from .errors import CollisionError
from .fields import urdf_origin
from .shapes import SHAPE_KINDS, SHAPES, Shape, urdf_shape_kind
from .shapes.mesh import read_mesh

__all__ = ["MAX_LINK_RADIUS", "SHAPES", "CollisionError", "Shape", "Link", "CollisionModel", "body_frames", "from_urdf_collision",
           "urdf_link_shapes", "capsule_model", "capsules_along_links", "read_mesh", "segment_shape"]


#: The largest radius (m) of the capsules along a link (`capsules_along_links`, `--link-radius`): the
#: widest link of an industrial arm is well under a metre; beyond 10 m a radius is a typo.
MAX_LINK_RADIUS = 10.0


@dataclass(frozen=True, eq=False)
class Link:
    """A named set of shapes riding on body `body` of the chain (0 = the base); `frame` (4, 4)
    is the link's own frame (a URDF link's) in the body's frame, the shapes' origins are in the
    body's frame already."""

    name: str
    body: int
    shapes: tuple
    parent: str | None = None  # the nearest link with geometry above it in the tree (adjacency)
    frame: np.ndarray = field(default_factory=lambda: np.eye(4))  # the link's own frame in its body's


@dataclass(eq=False)
class CollisionModel:
    """The collision geometry of one arm: `chain` and its `links` (each a `Link`).

    `acm` is the allowed-collision matrix (`wsmap.collision.acm.ACM`, from
    `wsmap.collision.acm.build_acm`; `wsmap.collision.checker_for` builds it when
    missing); `floor` whether the
    arm stands on the floor `z = 0` of the world (the default scene of a named arm has it);
    `source` where the geometry comes from.

    `margin` (m, at least 0) grows every shape of the model by that much for the checks: two links
    closer than twice it, or a link closer than it to an obstacle or the floor, collide (Bullet's
    collision margin around a convex hull; the vendor meshes carry it, `wsmap.collision.vendor`).

    `coarse` (optional) is a second model of the same links (names, bodies and parents alike) whose
    shapes enclose these: a checker asks it first and these shapes only where it says colliding
    (`wsmap.collision.checks`, the two-level check).
    """

    chain: SerialChain
    links: tuple
    source: str = ""
    floor: bool = False
    acm: object = None
    margin: float = 0.0
    coarse: CollisionModel | None = None
    _names: dict = field(default_factory=dict, repr=False)

    def __post_init__(self):
        self.chain = as_chain(self.chain)
        if self.chain.batch_shape != ():
            raise CollisionError("a collision model belongs to one arm, not a batch")
        names = [link.name for link in self.links]
        if len(set(names)) != len(names):
            twice = sorted({n for n in names if names.count(n) > 1})
            raise CollisionError(f"collision links must have distinct names; {', '.join(map(repr, twice))} "
                                 f"{'is' if len(twice) == 1 else 'are'} given more than once")
        for link in self.links:
            if not 0 <= link.body <= self.chain.n_joints:
                raise CollisionError(f"link {link.name!r} rides on body {link.body}; "
                                     f"the chain has bodies 0..{self.chain.n_joints}")
            if not link.shapes:
                raise CollisionError(f"link {link.name!r} has no shapes")
        self.links = tuple(self.links)
        self._names = {link.name: i for i, link in enumerate(self.links)}
        if not (np.isfinite(self.margin) and 0.0 <= self.margin <= 0.1):
            raise CollisionError(f"margin must be a distance from 0 to 0.1 m, got {self.margin!r}")
        c = self.coarse
        if c is not None and (not isinstance(c, CollisionModel) or c.coarse is not None
                              or [(lk.name, lk.body, lk.parent) for lk in c.links]
                              != [(lk.name, lk.body, lk.parent) for lk in self.links]):
            raise CollisionError("a coarse model must be a CollisionModel of the same links (names, bodies, parents), "
                                 "without a coarse model of its own")

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(link.name for link in self.links)

    def index(self, name: str) -> int:
        """The position of link `name`; a `CollisionError` listing the links if unknown."""
        if name not in self._names:
            raise CollisionError(f"unknown collision link {name!r}; the links are: {', '.join(self.names)}")
        return self._names[name]

    def shape_poses(self, q) -> tuple[np.ndarray, np.ndarray]:
        """World poses of every shape: `(poses (..., S, 4, 4), link_of (S,))` for `q` `(..., n)`."""
        B = body_frames(self.chain, q)
        bodies = np.array([link.body for link in self.links for _ in link.shapes], dtype=np.int64)
        origins = np.stack([s.origin for link in self.links for s in link.shapes])
        link_of = np.array([i for i, link in enumerate(self.links) for _ in link.shapes], dtype=np.int64)
        return B[..., bodies, :, :] @ origins, link_of

    def describe(self) -> dict:
        """A JSON-able record of the geometry (map files): source, links with body and shapes."""
        out = {"source": self.source, "floor": self.floor, "margin": self.margin,
               "links": [{"name": lk.name, "body": lk.body, "shapes": [s.describe() for s in lk.shapes]}
                         for lk in self.links]}
        if self.coarse is not None:
            out["coarse"] = self.coarse.describe()
        return out


def body_frames(chain: SerialChain, q) -> np.ndarray:
    """World frames of the chain's bodies, `(..., n_joints + 1, 4, 4)`: `B_0 = base` (the chain's base
    transform or the identity), `B_k = B_{k-1} · F_{k-1} · M_k(q_k + offset_k)`, `q` the joint
    coordinates of the variables `(..., n)` (`SerialChain.full_q`: themselves without coupled joints)."""
    q = chain.full_q(q)
    x = q + chain.offset
    shape = np.broadcast_shapes(x.shape[:-1], chain.batch_shape)
    out = np.empty(shape + (chain.n_joints + 1, 4, 4))
    T = np.broadcast_to(np.eye(4) if chain.base is None else chain.base, shape + (4, 4))
    out[..., 0, :, :] = T
    for i in range(chain.n_joints):  # a loop over joints, not over configurations
        T = T @ chain.fixed[..., i, :, :] @ joint_motion(chain.kinds[i], chain.axes[i], x[..., i])
        out[..., i + 1, :, :] = T
    return out


# ------------------------------------------------------------------------------------------- URDF
def urdf_link_shapes(link_el: ET.Element, label: str, urdf_dir: str | None) -> list[Shape]:
    """The shapes of a URDF `<link>`'s `<collision>` elements, each at its `<origin>`.

    Parameters
    ----------
    link_el : xml.etree.ElementTree.Element
        The `<link>` element.
    label : str
        The URDF named for messages (`wsmap.kinematics.urdf.read_source`).
    urdf_dir : str or None
        The URDF's folder, where relative and `package://` mesh files are looked for (None: the
        working directory).

    Returns
    -------
    list of Shape
        In the order of the elements, origins in the link's frame; meshes read now. Every problem
        (no or several shapes in a `<geometry>`, an unknown shape, bad numbers, a bad mesh file) is a
        `CollisionError` starting with `label` and naming the link.
    """
    name = link_el.get("name")
    shapes = []
    for col in link_el.findall("collision"):
        what = f"link {name!r} <collision>"
        origin = urdf_origin(col.find("origin"), label, what)
        geom = col.find("geometry")
        kids = [] if geom is None else [g for g in geom if isinstance(g.tag, str)]
        if len(kids) != 1:
            raise CollisionError(f"{label}: {what} needs one shape inside <geometry>")
        kind = urdf_shape_kind(kids[0].tag)
        if kind is None:
            tags = [k.urdf_tag for k in SHAPE_KINDS if k.urdf_tag]
            raise CollisionError(f"{label}: {what} has an unknown shape <{kids[0].tag}>; shapes are {', '.join(tags)}")
        try:
            shapes.append(kind.from_urdf(kids[0], origin, label, what, urdf_dir))
        except CollisionError as exc:
            if str(exc).startswith(label):
                raise
            raise CollisionError(f"{label}: {what}: {exc}") from None
    return shapes


def _off_chain_motion(el: ET.Element) -> np.ndarray:
    """The motion `(4, 4)` of a movable joint off the chain at its rest value: 0 clipped into its
    `<limit>` (the identity at 0, for a continuous joint, or for a zero axis)."""
    jtype = el.get("type")
    if jtype not in ("revolute", "prismatic", "continuous"):
        return np.eye(4)
    a = el.find("axis")
    axis = np.array([float(x) for x in (a.get("xyz") if a is not None else "1 0 0").split()])
    lim = el.find("limit")
    x0 = 0.0
    if lim is not None and jtype != "continuous":
        lo, hi = float(lim.get("lower", "0")), float(lim.get("upper", "0"))
        x0 = min(max(0.0, lo), hi)
    if x0 != 0.0 and np.linalg.norm(axis) > 0:
        return joint_motion(PRISMATIC if jtype == "prismatic" else REVOLUTE, axis / np.linalg.norm(axis), np.array(x0))
    return np.eye(4)


def _urdf_links(root: ET.Element, tree: URDFTree, base: str, movable: list[str], label: str,
                urdf_dir: str | None) -> list[Link]:
    """The `Link`s of the URDF links below `base` that have `<collision>` elements, walking down
    the tree: each rides on the body of its nearest movable joint of the chain `movable` above it
    (movable joints off the chain at their rest value)."""
    link_els = {el.get("name"): el for el in root.findall("link")}
    # (body, pose in body frame, nearest ancestor with geometry) per link, walking down from base
    place = {base: (0, np.eye(4), None)}
    links: list[Link] = []
    stack = [base]
    while stack:
        parent = stack.pop()
        body, Tp, above = place[parent]
        shapes = urdf_link_shapes(link_els[parent], label, urdf_dir)
        if shapes:
            links.append(Link(parent, body, tuple(s.placed(Tp) for s in shapes), parent=above, frame=Tp))
            above = parent
        for jname in reversed(tree.children[parent]):
            el = tree.joints[jname]
            child = tree.child(jname)
            origin = urdf_origin(el.find("origin"), label, f"joint {jname!r}")
            if jname in movable:
                place[child] = (movable.index(jname) + 1, np.eye(4), above)
            else:
                place[child] = (body, Tp @ origin @ _off_chain_motion(el), above)
            stack.append(child)
    return links


def from_urdf_collision(source, ee_link: str | None = None, base_link: str | None = None,
                        name: str | None = None, *, floor: bool = False) -> CollisionModel:
    """The collision model of a URDF's chain (`wsmap.kinematics.from_urdf`, same arguments).

    Every link below `base_link` with `<collision>` elements becomes a `Link`: a link of
    the chain rides on its body; a link fixed to one (a flange, a hand) on its parent's; a link
    hanging from a joint off the chain (a gripper's fingers) rides on its parent's body with that
    joint at 0 (clipped into its limits). Meshes are read now (a missing, empty or unreadable file
    is a `CollisionError` naming it); a URDF without any collision element is one too.
    """
    data, label, path = read_source(source)
    root = parse_xml(data, label)
    # the chain from the URDF without its collision elements: what yourdfpy does not know (a
    # <capsule>) or refuses is this module's to report, with the file named
    bare = ET.fromstring(data)
    for el in bare.findall("link"):
        for col in el.findall("collision"):
            el.remove(col)
    chain = from_urdf(ET.tostring(bare), ee_link=ee_link, base_link=base_link, name=name)
    chain = chain.replace(source=path if path is not None else "URDF text")
    tree = URDFTree(root, label)
    base = base_link or tree.root()
    on_path = tree.path(base, chain.links[-1])
    movable = [j for j in on_path if tree.joints[j].get("type") != "fixed"]
    urdf_dir = os.path.dirname(os.path.abspath(path)) if path else None
    links = _urdf_links(root, tree, base, movable, label, urdf_dir)
    if not links:
        raise CollisionError(f"{label} has no <collision> elements below {base!r}")
    return CollisionModel(chain, tuple(links), source=path or "URDF text", floor=floor)


# ------------------------------------------------------------------------------------------- capsules
def segment_shape(kind: str, p0, p1, radius: float) -> Shape:
    """A capsule or cylinder of `radius` (m) whose axis runs from `p0` to `p1` (the body frame; a
    capsule's segment, a cylinder's end faces' centres): its frame at the midpoint, `z` along it."""
    p0, p1 = np.asarray(p0, dtype=np.float64), np.asarray(p1, dtype=np.float64)
    d = p1 - p0
    length = float(np.linalg.norm(d))
    T = np.eye(4)
    T[:3, 3] = (p0 + p1) / 2
    if length > 1e-12:
        z = d / length
        x = np.cross(z, [1.0, 0, 0]) if abs(z[0]) < 0.9 else np.cross(z, [0, 1.0, 0])
        x /= np.linalg.norm(x)
        T[:3, :3] = np.stack([x, np.cross(z, x), z], axis=1)
    return Shape(kind, (float(radius), length), T)


def capsule_model(robot, capsules: Sequence, *, names: Sequence[str] | None = None, source: str = "",
                  floor: bool = False) -> CollisionModel:
    """A model of capsules: `capsules` is a sequence of `(body, p0, p1, radius)` (`p0`, `p1`
    the segment's ends in body `body`'s frame, m; `radius` m), several allowed per body; the
    links are the bodies that have capsules, named `names[body]` (default `"link{body}"`)."""
    chain = as_chain(robot)
    per: dict[int, list[Shape]] = {}
    for item in capsules:
        body, p0, p1, r = item
        if not isinstance(body, (int, np.integer)) or not 0 <= body <= chain.n_joints:
            raise CollisionError(f"capsule body must be an integer in 0..{chain.n_joints}, got {body!r}")
        per.setdefault(int(body), []).append(segment_shape("capsule", p0, p1, float(r)))
    if names is not None and len(names) != chain.n_joints + 1:
        raise CollisionError(f"names must name the {chain.n_joints + 1} bodies, got {len(names)}")
    label = (lambda k: names[k]) if names is not None else (lambda k: f"link{k}")
    links, above = [], None
    for k in sorted(per):
        links.append(Link(label(k), k, tuple(per[k]), parent=above))
        above = label(k)
    return CollisionModel(chain, tuple(links), source=source, floor=floor)


def capsules_along_links(robot, link_radius, *, floor: bool = False, source: str = "") -> CollisionModel:
    """Capsules along the links of a DH (or any) chain: body `k` (0..n) gets capsules of radius
    `link_radius[k]` (one number for all) from its frame's origin along `z` to `F_k`'s `z`
    offset, then to `F_k`'s origin (the next joint): the DH `d` then `a` of the link; a body
    whose link has no length gets a sphere (a capsule of length 0) at its origin."""
    chain = as_chain(robot)
    r = np.broadcast_to(np.asarray(link_radius, dtype=np.float64), (chain.n_joints + 1,))
    bad = np.flatnonzero(~(np.isfinite(r) & (r > 0) & (r <= MAX_LINK_RADIUS)))
    if len(bad):
        raise CollisionError(f"link_radius must be a positive number of metres, at most {MAX_LINK_RADIUS:g}; body "
                             f"{bad[0]} has {r[bad[0]]:g}")
    caps = []
    for k in range(chain.n_joints + 1):
        e = chain.fixed[k, :3, 3]
        c = np.array([0.0, 0.0, e[2]])
        pts = [np.zeros(3)] + [p for p in (c, e) if np.linalg.norm(p) > 1e-9]
        if len(pts) == 3 and np.linalg.norm(pts[2] - pts[1]) < 1e-9:
            pts = pts[:2]
        if len(pts) == 1:
            caps.append((k, pts[0], pts[0], float(r[k])))
        for a, b in zip(pts[:-1], pts[1:]):
            caps.append((k, a, b, float(r[k])))
    return capsule_model(chain, caps, source=source or f"capsules along the links, radii {r.tolist()} m",
                         floor=floor)
