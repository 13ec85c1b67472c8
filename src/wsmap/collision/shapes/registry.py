"""The record of a kind of collision shape (`ShapeKind`), the registry of them (`SHAPE_KINDS`),
and one shape placed in a body's frame (`Shape`).

A `ShapeKind` holds everything the collision layer asks about a kind of shape: the numbers of its
`size`, the spheres that enclose it (the checker's fast layer), its coal geometry (the exact test),
its distance to a point where there is a closed form, whether it is a sphere swept along a segment
(decided exactly in numpy), and how it is read from a URDF `<geometry>` element, an MJCF
`<geom type=...>` and a scene file. Each kind is one module of `wsmap.collision.shapes` that ends by
registering its record; nothing outside those modules names a kind.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..._plugins import Registry
from ..errors import CollisionError
from ..fields import MAX_COORDINATE, shown

__all__ = ["ShapeKind", "SHAPE_KINDS", "Shape", "shape_kind", "urdf_shape_kind", "mjcf_shape_kind", "revolved"]


@dataclass(frozen=True)
class ShapeKind(ABC):
    """One kind of collision shape; a module of `wsmap.collision.shapes` subclasses it with the
    methods below and registers one instance with `SHAPE_KINDS`.

    Shapes are centred on their own frame (metres), axis `z` for a cylinder and a capsule, as URDF.

    Attributes
    ----------
    name : str
        The kind's name (`Shape.kind`; a scene file's `shape:`).
    priority : int
        Its place in the listings (lower first).
    size_fields : tuple of str
        What the numbers of `Shape.size` are, in order (`("radius", "length")`); empty for a kind
        described by other data (a mesh's vertices).
    zero_allowed : tuple of str
        The fields of `size_fields` that may be 0 (the others must be positive).
    urdf_tag : str or None
        Its tag inside a URDF `<geometry>` (None: URDF has no such shape).
    mjcf_type : str or None
        Its member of MuJoCo's `mujoco.mjtGeom` (`"mjGEOM_BOX"`; None: MJCF has none).
    scene_keys : tuple of str
        The keys a scene-file obstacle of this kind takes besides name, shape, xyz, rpy, frame.
    reads_file : bool
        Whether it is read from a file of its own (a mesh): data a scene's text does not hold.
    """

    name: str
    priority: int
    size_fields: tuple[str, ...]
    zero_allowed: tuple[str, ...] = ()
    urdf_tag: str | None = None
    mjcf_type: str | None = None
    scene_keys: tuple[str, ...] = ()
    reads_file: bool = False

    # ------------------------------------------------------------------------- the shape itself
    def check_size(self, size) -> tuple[float, ...]:
        """`size` as floats, checked: `len(size_fields)` finite numbers, positive but for the
        fields of `zero_allowed` (non-negative), at most `MAX_COORDINATE` (m); a `CollisionError`
        otherwise."""
        size = tuple(float(x) for x in size)
        if len(size) != len(self.size_fields):
            raise CollisionError(f"a {self.name} has {len(self.size_fields)} size numbers, got {len(size)}")
        if not all(math.isfinite(x) for x in size):
            raise CollisionError(f"a {self.name} has a NaN or infinite size: {shown(size)}")
        if any(x < 0 or (x == 0 and f not in self.zero_allowed) for x, f in zip(size, self.size_fields)):
            raise CollisionError(f"a {self.name} needs positive dimensions, got {shown(size)}")
        if any(x > MAX_COORDINATE for x in size):
            raise CollisionError(f"a {self.name} of {shown(size)} m is beyond {MAX_COORDINATE:g} m (the largest "
                                 "collision geometry)")
        return size

    def check_data(self, shape: Shape) -> None:
        """Check (and set, as arrays) what a shape of this kind holds besides its size (a mesh's
        vertices); nothing for a primitive."""

    def describe(self, shape: Shape) -> dict:
        """What a map file records of `shape` besides its kind, size and origin (a mesh's file)."""
        return {}

    @abstractmethod
    def bounding_spheres(self, shape: Shape, max_spheres: int) -> tuple[np.ndarray, np.ndarray]:
        """`(centres (m, 3), radii (m,))` in the shape's frame (m) whose union contains the shape
        (a mesh's convex hull), `m <= max_spheres`."""

    @abstractmethod
    def coal_geometry(self, shape: Shape):
        """The coal collision geometry of `shape` (in its own frame)."""

    def point_distance(self, size: tuple, local: np.ndarray) -> np.ndarray | None:
        """The distance (m) from points `local` `(..., 3)`, in the shape's frame, to the solid shape
        (0 inside), or None where the kind has no closed form (its bounding spheres stand in)."""
        return None

    def encloses(self, shape: Shape, local: np.ndarray) -> np.ndarray | None:
        """Whether points `local` `(P, 3)` (in the shape's frame, m) lie inside the solid the shape
        bounds, for a kind whose exact test looks at its boundary only (a closed `surface`): a
        shape wholly inside such a solid crosses none of its triangles. None for the others (coal
        tests a primitive or a convex hull as a solid)."""
        return None

    def inner_point(self, shape: Shape) -> np.ndarray:
        """A point of the solid shape in its own frame (m): the centre of a primitive (the frame's
        origin), the vertices' mean for a mesh (inside its convex hull)."""
        return np.zeros(3) if shape.vertices is None else shape.vertices.mean(axis=0)

    def triangles(self, shape: Shape) -> tuple[np.ndarray, np.ndarray] | None:
        """A triangle mesh of the shape's surface for drawing (a scene's obstacles in a map's
        pictures): `(vertices (V, 3) m in the shape's frame, faces (F, 3) int)`, round surfaces
        as 32-sided polygons; a mesh's own triangles. None for a kind that cannot be drawn."""
        return None

    def swept_sphere(self, shape: Shape) -> tuple[float, float] | None:
        """`(half_length, radius)` (m) when the shape is the points within `radius` of the segment
        from `-half_length` to `half_length` along its `z` axis (a capsule, a sphere): such shapes
        are tested exactly by segment distances. None for the others."""
        return None

    # ------------------------------------------------------------------------- readers
    @abstractmethod
    def from_urdf(self, el: ET.Element, origin: np.ndarray, label: str, what: str, folder: str | None) -> Shape:
        """The shape of the URDF element `el` (the child of `<geometry>` with tag `urdf_tag`) at
        `origin` `(4, 4)`; `label` names the file and `what` the element in messages, `folder` is
        where the URDF is (for mesh files; None for URDF text)."""

    @abstractmethod
    def from_mjcf(self, model, geom: int, pose: np.ndarray) -> Shape:
        """The shape of geom `geom` of the compiled MuJoCo model `model` (its type is `mjcf_type`)
        at `pose` `(4, 4)`; MuJoCo's `geom_size` holds half-lengths."""

    @abstractmethod
    def from_scene(self, item: Mapping, pose: np.ndarray, label: str, name: str, folder: str | None) -> Shape:
        """The shape of the scene-file obstacle `item` (its keys checked against `scene_keys`) at
        `pose` `(4, 4)`; `label` names the file and `name` the obstacle in messages, `folder` is where
        relative files are."""


#: Every kind of collision shape, by `(priority, name)`.
SHAPE_KINDS: Registry[ShapeKind] = Registry("collision shape")


def revolved(radius: np.ndarray, z: np.ndarray, segments: int = 32) -> tuple[np.ndarray, np.ndarray]:
    """The triangles of a surface of revolution about `z` (`ShapeKind.triangles` of the round kinds):
    the profile `radius` `(P,)`, `z` `(P,)` (m, from the bottom up; a radius of 0 closes an end),
    turned through `segments` steps. Returns `(vertices (P * segments, 3), faces (F, 3))`."""
    radius, z = np.asarray(radius, dtype=np.float64), np.asarray(z, dtype=np.float64)
    a = np.linspace(0.0, 2 * np.pi, segments, endpoint=False)
    v = np.stack([np.outer(radius, np.cos(a)), np.outer(radius, np.sin(a)), np.repeat(z[:, None], segments, 1)], -1)
    i = np.arange(len(radius) - 1)[:, None] * segments
    j, k = np.arange(segments)[None], (np.arange(segments)[None] + 1) % segments
    quads = np.stack([i + j, i + k, i + segments + k, i + segments + j], -1).reshape(-1, 4)
    faces = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    return v.reshape(-1, 3), faces


def shape_kind(name: str) -> ShapeKind:
    """The record of the shape kind `name`; a `CollisionError` listing the kinds if there is none."""
    if name not in SHAPE_KINDS:
        raise CollisionError(f"unknown shape {name!r}; shapes are {', '.join(SHAPE_KINDS.names())}")
    return SHAPE_KINDS.get(name)


def urdf_shape_kind(tag: str) -> ShapeKind | None:
    """The kind read from the URDF `<geometry>` child `<tag>`, or None."""
    return next((k for k in SHAPE_KINDS if k.urdf_tag == tag), None)


def mjcf_shape_kind(geom_type: int) -> ShapeKind | None:
    """The kind of an MJCF geom of MuJoCo's type number `geom_type` (`model.geom_type[g]`), or None."""
    import mujoco

    return next((k for k in SHAPE_KINDS if k.mjcf_type and int(getattr(mujoco.mjtGeom, k.mjcf_type)) == geom_type),
                None)


@dataclass(frozen=True, eq=False)
class Shape:
    """One collision shape placed in a frame.

    Attributes
    ----------
    kind : str
        The name of its `ShapeKind` (`SHAPE_KINDS`: box, cylinder, sphere, capsule, mesh).
    size : tuple of float
        Its numbers (m), the kind's `size_fields`: a box `(x, y, z)` full edge lengths, a cylinder
        and a capsule `(radius, length)` (the capsule's length between the centres of its end
        spheres, as URDF's `<capsule>` and coal), a sphere `(radius,)`, a mesh none.
    origin : numpy.ndarray
        `(4, 4)` its pose in its body's frame (an obstacle's: in its scene frame).
    vertices, faces : numpy.ndarray or None
        A mesh's `(V, 3)` vertices (scaled, in the shape's frame, m) and `(F, 3)` triangles; the
        exact checks use its convex hull, which contains the mesh.
    source : str
        The mesh file, or `""`.
    """

    kind: str
    size: tuple
    origin: np.ndarray
    vertices: np.ndarray | None = None
    faces: np.ndarray | None = None
    source: str = ""

    def __post_init__(self):
        kind = shape_kind(self.kind)
        object.__setattr__(self, "size", kind.check_size(self.size))
        object.__setattr__(self, "origin", np.asarray(self.origin, dtype=np.float64).reshape(4, 4))
        kind.check_data(self)

    @property
    def record(self) -> ShapeKind:
        """The `ShapeKind` of this shape."""
        return SHAPE_KINDS.get(self.kind)

    def placed(self, T: np.ndarray) -> Shape:
        """The same shape at the pose `T @ origin` (`T` `(4, 4)`: its frame in another)."""
        return Shape(self.kind, self.size, T @ self.origin, self.vertices, self.faces, self.source)

    def describe(self) -> dict:
        """A JSON-able record (map files): kind, size, origin (4x4 list), and what the kind adds
        (a mesh's file and vertex count)."""
        d = {"kind": self.kind, "size": list(self.size), "origin": self.origin.round(12).tolist()}
        d.update(self.record.describe(self))
        return d
