"""Collision shapes: one module per kind, each ending by registering its `ShapeKind` record.

Everything the collision layer asks about a kind of shape is its record's (`registry.ShapeKind`):
its size numbers, the spheres that enclose it, its coal geometry, its distance to a point, and how it
is read from a URDF `<geometry>`, an MJCF `<geom type=...>` and a scene file. The geometry, the
checker and the scene readers ask the registry (`shape_kind`, `urdf_shape_kind`,
`mjcf_shape_kind`); none of them names a kind.

Kinds (by priority): `.box`, `.cylinder`, `.sphere`, `.capsule`, `.mesh` (its convex hull in the
exact tests), `.surface` (a mesh tested on its triangles: a concave workpiece). A new kind is one new module here (a `ShapeKind` subclass and its registration) and
its tests.
"""

from ..._plugins import discover
from .registry import SHAPE_KINDS, Shape, ShapeKind, mjcf_shape_kind, shape_kind, urdf_shape_kind

discover(__name__, __path__)

#: The names of the shape kinds, by priority (those registered when the package was imported).
SHAPES = tuple(SHAPE_KINDS.names())

__all__ = ["SHAPES", "SHAPE_KINDS", "Shape", "ShapeKind", "mjcf_shape_kind", "shape_kind", "urdf_shape_kind"]
