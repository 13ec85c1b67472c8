"""A surface: a mesh tested on its own triangles, never on its convex hull.

A workpiece is concave (a bracket, a car door, the REACH demo's curved panel): its convex hull
fills the space the tool works in, so a reach study that checks the hull calls reachable targets
colliding. A `surface` is checked exactly: coal's bounding-volume hierarchy (OBB + RSS) of the
triangles, against which every link shape is tested triangle by triangle (MoveIt tests a mesh
collision object the same way).

**Open and closed meshes.** A triangle test finds every shape that crosses the surface. A shape
wholly inside a *closed* mesh (a watertight solid) crosses no triangle; for a closed mesh the
record also answers `encloses(points)` (the generalised winding number of the triangles, robust to
a mesh that is closed but not perfectly oriented), and the checker calls a link whose inner point
is enclosed colliding. An open mesh (a sheet, a scan) has no inside: it is the sheet itself.

The fast sphere layer is conservative, as for every kind: a closed mesh's spheres enclose its convex
hull (the solid inside it included); an open sheet's enclose its triangles, grouped by a grid (each
sphere holds every vertex of its group, so every point of its triangles), up to 64 spheres for an
obstacle. Degenerate inputs (fewer than one triangle of positive area, NaN vertices) are
refused with one line naming the file.

A scene file's `{shape: surface, file: PATH, scale: s or [sx, sy, sz]}`; a study's
`collision: {workpiece: PATH}` (the workpiece at the targets' pose). URDF and MJCF have no such
element (their meshes are convex hulls, as their consumers load them).
"""

from __future__ import annotations


import numpy as np

from ..errors import CollisionError
from .mesh import read_scene_mesh
from .registry import SHAPE_KINDS, Shape, ShapeKind

__all__ = ["SURFACE", "Surface", "winding_number"]

#: A triangle of area below this (m²) carries no surface.
_MIN_AREA = 1e-14
#: Whether a surface is closed, by its faces array (held, so that its id is not reused).
_CLOSED: dict = {}


def winding_number(vertices: np.ndarray, faces: np.ndarray, points: np.ndarray) -> np.ndarray:
    """The generalised winding number of a triangle mesh at points (Jacobson et al. 2013).

    Parameters
    ----------
    vertices : numpy.ndarray
        `(V, 3)` float64 (m).
    faces : numpy.ndarray
        `(F, 3)` int vertex indices.
    points : numpy.ndarray
        `(P, 3)` query points in the mesh's frame (m).

    Returns
    -------
    numpy.ndarray
        `(P,)`: the sum of the triangles' signed solid angles over 4π — 1 inside a closed
        outward-wound mesh, 0 outside, ±1 for either winding (use `abs(w) > 0.5` for "inside").
    """
    out = np.empty(len(points))
    tri = vertices[faces]
    for s in range(0, len(points), 64):  # (64, F, 3, 3) at a time: memory, not per point
        a = tri[None, :, 0] - points[s : s + 64, None]
        b = tri[None, :, 1] - points[s : s + 64, None]
        c = tri[None, :, 2] - points[s : s + 64, None]
        la, lb, lc = (np.linalg.norm(x, axis=-1) for x in (a, b, c))
        det = np.einsum("pfi,pfi->pf", a, np.cross(b, c))
        den = (la * lb * lc + np.einsum("pfi,pfi->pf", a, b) * lc + np.einsum("pfi,pfi->pf", b, c) * la
               + np.einsum("pfi,pfi->pf", c, a) * lb)
        out[s : s + 64] = np.arctan2(det, den).sum(axis=1) / (2 * np.pi)
    return out


class Surface(ShapeKind):
    """The record of surfaces (module notes)."""

    def check_data(self, shape):
        v = np.asarray(shape.vertices, dtype=np.float64)
        f = np.asarray(shape.faces, dtype=np.int64) if shape.faces is not None else np.zeros((0, 3), np.int64)
        where = f"surface {shape.source!r}" if shape.source else "surface"
        if v.ndim != 2 or v.shape[1:] != (3,) or not np.all(np.isfinite(v)):
            raise CollisionError(f"{where}: vertices must be finite (V, 3) numbers")
        if f.ndim != 2 or f.shape[1:] != (3,) or len(f) == 0 or f.min() < 0 or f.max() >= len(v):
            raise CollisionError(f"{where}: faces must be (F, 3) indices of its {len(v)} vertices")
        area = np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1) / 2
        if not np.any(area > _MIN_AREA):
            raise CollisionError(f"{where}: no triangle has a positive area (a degenerate mesh)")
        object.__setattr__(shape, "vertices", v)
        object.__setattr__(shape, "faces", f[area > _MIN_AREA])

    def describe(self, shape):
        return {"file": shape.source, "vertices": int(len(shape.vertices)), "triangles": int(len(shape.faces)),
                "closed": self.closed(shape)}

    @staticmethod
    def closed(shape: Shape) -> bool:
        """Whether the mesh is watertight (every edge shared by exactly two triangles): a solid.
        Computed once per shape's triangles (the checker asks it for every link it tests)."""
        key = (id(shape.faces), len(shape.faces))
        cached = _CLOSED.get(key)
        if cached is not None and cached[0] is shape.faces:
            return cached[1]
        f = shape.faces
        edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
        _, counts = np.unique(edges, axis=0, return_counts=True)
        closed = bool(np.all(counts == 2))
        if len(_CLOSED) > 256:
            _CLOSED.clear()
        _CLOSED[key] = (shape.faces, closed)
        return closed

    def bounding_spheres(self, shape, max_spheres):
        from .mesh import MESH

        if self.closed(shape):  # a solid: its inside too, so the hull's spheres
            return MESH.bounding_spheres(shape, max_spheres)
        # an open sheet is its triangles alone: triangles grouped by the cell of a grid their centres
        # fall in, each group's vertices (hence its triangles) in one sphere; the finest grid whose
        # groups number at most max_spheres
        tri = shape.vertices[shape.faces]
        centre = tri.mean(axis=1)
        lo, extent = centre.min(axis=0), np.ptp(shape.vertices, axis=0).max()
        for n in range(16, 0, -1):
            cell = np.floor((centre - lo) / (extent / n + 1e-12)).astype(np.int64)
            keys, group = np.unique(cell, axis=0, return_inverse=True)
            if len(keys) <= max_spheres or n == 1:
                break
        if len(keys) > max_spheres:
            return MESH.bounding_spheres(shape, max_spheres)
        group = group.reshape(-1)
        pts = tri.reshape(-1, 3)
        pg = np.repeat(group, 3)
        lo_g = np.full((len(keys), 3), np.inf)
        hi_g = np.full((len(keys), 3), -np.inf)
        np.minimum.at(lo_g, pg, pts)
        np.maximum.at(hi_g, pg, pts)
        c = (lo_g + hi_g) / 2
        r = np.zeros(len(keys))
        np.maximum.at(r, pg, np.linalg.norm(pts - c[pg], axis=1))
        return c, r * (1 + 1e-9) + 1e-12

    def coal_geometry(self, shape):
        import coal

        bvh = coal.BVHModelOBBRSS()
        bvh.beginModel(len(shape.faces), len(shape.vertices))
        bvh.addVertices(np.ascontiguousarray(shape.vertices))
        bvh.addTriangles(np.ascontiguousarray(shape.faces))
        bvh.endModel()
        return bvh

    def encloses(self, shape, local):
        if not self.closed(shape):
            return None
        local = np.asarray(local, dtype=np.float64).reshape(-1, 3)
        return np.abs(winding_number(shape.vertices, shape.faces, local)) > 0.5

    def triangles(self, shape):
        return shape.vertices, shape.faces

    def from_urdf(self, el, origin, label, what, folder):  # pragma: no cover - URDF has no surface tag
        raise CollisionError(f"{label}: {what}: URDF has no surface element")

    def from_mjcf(self, model, geom, pose):  # pragma: no cover - MJCF has no surface type
        raise CollisionError("MJCF has no surface geom")

    def from_scene(self, item, pose, label, name, folder):
        v, f, path = read_scene_mesh(item, label, name, folder, "surface")
        return Shape("surface", (), pose, v, f, source=path)


SURFACE = SHAPE_KINDS.register(Surface(name="surface", priority=60, size_fields=(), scene_keys=("file", "scale"),
                                       reads_file=True))
