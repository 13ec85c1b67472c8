"""A mesh: `vertices` `(V, 3)` (scaled, in the shape's frame, m) and `faces` `(F, 3)`, no size
numbers. The exact checks use its convex hull (as PyBullet and MuJoCo do), which contains the mesh,
so a configuration free for the hull is free for the mesh.

URDF `<mesh filename="..." scale="sx sy sz"/>` (STL, OBJ, DAE, PLY, ... read by trimesh;
`package://`, `file://` and relative names, `resolve_mesh`); MJCF `<geom type="mesh">` (MuJoCo's
compiled vertices); a scene file's `{shape: mesh, file: PATH, scale: s or [sx, sy, sz]}`, the file
relative to the scene file.
"""

from __future__ import annotations

import os

import numpy as np

from ..errors import CollisionError
from ..fields import scene_vector, urdf_numbers
from .registry import SHAPE_KINDS, Shape, ShapeKind

__all__ = ["MESH", "Mesh", "read_mesh", "resolve_mesh"]


def read_mesh(path: str, label: str, scale=(1.0, 1.0, 1.0)) -> tuple[np.ndarray, np.ndarray]:
    """The triangles of a mesh file, read by trimesh (STL, OBJ, DAE, PLY, ...).

    Parameters
    ----------
    path : str
        The file.
    label : str
        What reads it, for messages (`"URDF file 'arm.urdf', link 'hand' <collision>"`).
    scale : array_like
        `(3,)` factors of the vertices' coordinates.

    Returns
    -------
    vertices : numpy.ndarray
        `(V, 3)` float64, scaled (m).
    faces : numpy.ndarray
        `(F, 3)` int64 vertex indices.

    Raises
    ------
    CollisionError
        A missing, empty or unreadable file, one without triangles or with NaN vertices; the
        message names the file.
    """
    import trimesh

    if not os.path.isfile(path):
        raise CollisionError(f"{label}: collision mesh {path!r}: no such file")
    if os.path.getsize(path) == 0:
        raise CollisionError(f"{label}: collision mesh {path!r} is empty")
    try:
        mesh = trimesh.load(path, force="mesh", process=False)
    except Exception as exc:
        raise CollisionError(f"{label}: collision mesh {path!r} is not a mesh trimesh can read "
                             f"({type(exc).__name__}: {exc})") from None
    v = np.asarray(getattr(mesh, "vertices", np.zeros((0, 3))), dtype=np.float64)
    f = np.asarray(getattr(mesh, "faces", np.zeros((0, 3))), dtype=np.int64)
    if len(v) < 4 or len(f) == 0:
        raise CollisionError(f"{label}: collision mesh {path!r} is not a mesh: no triangles in it")
    if not np.all(np.isfinite(v)):
        raise CollisionError(f"{label}: collision mesh {path!r} has NaN or infinite vertices")
    return v * np.asarray(scale, dtype=np.float64), f


def resolve_mesh(filename: str, urdf_dir: str | None) -> str:
    """A URDF mesh reference as a path.

    Parameters
    ----------
    filename : str
        The `<mesh filename>`: absolute, `file://PATH`, `package://NAME/rest` (looked for beside
        the URDF and in the folders above it, with and without `NAME`) or relative to the URDF.
    urdf_dir : str or None
        The URDF's folder (None: the working directory, for URDF text).

    Returns
    -------
    str
        The path (a `package://` reference found nowhere: `rest` beside the URDF, which the reader
        then reports as missing).
    """
    if filename.startswith("file://"):
        filename = filename[len("file://"):]
    base = urdf_dir or os.getcwd()
    if filename.startswith("package://"):
        pkg, _, rest = filename[len("package://"):].partition("/")
        d = os.path.abspath(base)
        while True:
            for cand in (os.path.join(d, pkg, rest), os.path.join(d, rest)):
                if os.path.isfile(cand):
                    return cand
            if os.path.dirname(d) == d:
                return os.path.join(base, rest)
            d = os.path.dirname(d)
    return filename if os.path.isabs(filename) else os.path.join(base, filename)


def _hull_slab_points(hull_v, edges, axis, lo, hi):
    """Points whose convex hull is the part of a convex polytope (vertices `hull_v`, edges
    `edges`) between the planes `axis·x = lo` and `hi`: its vertices there and its edges'
    crossings of the two planes."""
    s = hull_v @ axis
    pts = [hull_v[(s >= lo) & (s <= hi)]]
    a, b = s[edges[:, 0]], s[edges[:, 1]]
    for plane in (lo, hi):
        cross = (a - plane) * (b - plane) < 0
        if cross.any():
            t = (plane - a[cross]) / (b[cross] - a[cross])
            va, vb = hull_v[edges[cross, 0]], hull_v[edges[cross, 1]]
            pts.append(va + t[:, None] * (vb - va))
    return np.concatenate(pts)


class Mesh(ShapeKind):
    """The record of meshes (module notes)."""

    def check_data(self, shape):
        v = np.asarray(shape.vertices, dtype=np.float64)
        if v.ndim != 2 or v.shape[1] != 3 or len(v) < 4 or not np.all(np.isfinite(v)):
            raise CollisionError(f"mesh {shape.source or ''}: needs at least 4 finite vertices (V, 3)")
        object.__setattr__(shape, "vertices", v)

    def describe(self, shape):
        return {"file": shape.source, "vertices": int(len(shape.vertices))}

    def bounding_spheres(self, shape, max_spheres):
        # the hull cut across its principal axis into slabs about as long as it is wide, each slab
        # enclosed by the sphere around its bounding box's centre
        import trimesh

        hull = trimesh.Trimesh(shape.vertices, shape.faces, process=False).convex_hull
        v, edges = np.asarray(hull.vertices), np.asarray(hull.edges_unique)
        centred = v - v.mean(axis=0)
        _, sv, vt = np.linalg.svd(centred, full_matrices=False)
        axis = vt[0]
        s = v @ axis
        lo, hi = s.min(), s.max()
        width = 2 * np.sqrt(np.max(np.sum((centred - np.outer(centred @ axis, axis)) ** 2, axis=1)))
        m = int(np.clip(np.ceil((hi - lo) / max(width, 1e-9)), 1, max_spheres))
        cuts = np.linspace(lo, hi, m + 1)
        centres, radii = [], []
        for i in range(m):
            p = _hull_slab_points(v, edges, axis, cuts[i], cuts[i + 1])
            c = (p.min(axis=0) + p.max(axis=0)) / 2
            centres.append(c)
            radii.append(np.sqrt(np.max(np.sum((p - c) ** 2, axis=1))) * (1 + 1e-9) + 1e-12)
        return np.array(centres), np.array(radii)

    def coal_geometry(self, shape):
        import coal

        pts = coal.StdVec_Vec3s()
        pts.extend([np.ascontiguousarray(p, dtype=np.float64) for p in shape.vertices])
        return coal.Convex.convexHull(pts, False, None)

    def from_urdf(self, el, origin, label, what, folder):
        fn = el.get("filename")
        if not fn:
            raise CollisionError(f"{label}: {what} <mesh> has no filename")
        scale = urdf_numbers(label, f"{what} <mesh scale>", el.get("scale"), 3) if el.get("scale") else (1, 1, 1)
        path = resolve_mesh(fn, folder)
        v, f = read_mesh(path, f"{label}, {what}", scale)
        return Shape("mesh", (), origin, v, f, source=path)

    def from_mjcf(self, model, geom, pose):
        import mujoco

        mid = int(model.geom_dataid[geom])
        v0, nv = int(model.mesh_vertadr[mid]), int(model.mesh_vertnum[mid])
        f0, nf = int(model.mesh_faceadr[mid]), int(model.mesh_facenum[mid])
        return Shape("mesh", (), pose, np.array(model.mesh_vert[v0 : v0 + nv], dtype=np.float64),
                     np.array(model.mesh_face[f0 : f0 + nf], dtype=np.int64),
                     source=mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_MESH, mid) or f"mesh {mid}")

    def from_scene(self, item, pose, label, name, folder):
        where = f"{label}: obstacle {name!r}"
        fn = item.get("file")
        if not isinstance(fn, str) or not fn:
            raise CollisionError(f"{where}: a mesh needs file: PATH")
        scale = item.get("scale", 1.0)
        scale = scene_vector(label, f"obstacle {name!r} scale", [scale] * 3 if isinstance(scale, (int, float))
                             and not isinstance(scale, bool) else scale)
        if np.any(scale <= 0):
            raise CollisionError(f"{where}: mesh scale must be positive, got {item.get('scale')!r}")
        path = fn if os.path.isabs(fn) or folder is None else os.path.join(folder, fn)
        v, f = read_mesh(path, where, scale)
        return Shape("mesh", (), pose, v, f, source=path)


MESH = SHAPE_KINDS.register(Mesh(name="mesh", priority=50, size_fields=(), urdf_tag="mesh", mjcf_type="mjGEOM_MESH",
                                 scene_keys=("file", "scale"), reads_file=True))
