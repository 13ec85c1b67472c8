"""A mesh: `vertices` `(V, 3)` (scaled, in the shape's frame, m) and `faces` `(F, 3)`, no size
numbers. The exact checks use its convex hull (as PyBullet and MuJoCo do), which contains the mesh,
so a configuration free for the hull is free for the mesh.

URDF `<mesh filename="..." scale="sx sy sz"/>` (STL, OBJ, DAE, PLY, ... read by trimesh;
`package://`, `file://` and relative names, `resolve_mesh`); MJCF `<geom type="mesh">` (MuJoCo's
compiled vertices); a scene file's `{shape: mesh, file: PATH, scale: s or [sx, sy, sz]}`, the file
relative to the scene file.

**What is refused, before trimesh or coal sees it** (one-line `CollisionError` naming the file):
a file whose header declares more than `MAX_MESH_TRIANGLES` triangles (binary STL, PLY: read
from the header; OBJ: its face lines counted; any other format: after reading), vertices that are
NaN, infinite or beyond `MAX_COORDINATE` (1 km) once scaled, and a mesh whose convex hull has no
volume: all its vertices one point, on one line, or in one plane (the thinnest extent below
`FLAT_RATIO` of the largest). coal's `convexHull` crashes the process (a segmentation fault) on
such vertices, and a hull without volume is not a solid a link can be tested against. A flat part
(a sheet, a plate modelled by one face) is refused rather than thickened: the thickness is the
author's to choose, as a thin box or a mesh with its two faces; a `surface` obstacle tests such a
mesh on its triangles.

**Which files a URDF may name** (`resolve_mesh`): `package://NAME/REST` names a file inside a
package, so `NAME` is one folder name and `REST` has no `..`; a relative name may climb out of
the URDF's folder (`../meshes/x.stl`) but not above the description's tree: the nearest folder
above the URDF holding a ROS `package.xml`, or else the folder just above the URDF's. An
absolute name (or `file://`) is the author's explicit choice and is read where it points; every
mesh must be a regular file (a device or a pipe is "no such file", never read).
"""

from __future__ import annotations

import os

import numpy as np

from ..errors import CollisionError
from ..fields import MAX_COORDINATE, scene_vector, shown, urdf_numbers
from .registry import SHAPE_KINDS, Shape, ShapeKind

__all__ = ["MESH", "Mesh", "read_mesh", "read_scene_mesh", "resolve_mesh", "check_hull_vertices", "mesh_header_triangles",
           "MAX_MESH_TRIANGLES", "FLAT_RATIO"]

#: The most triangles a collision mesh may have: a vendor's collision meshes have thousands, a fine
#: scan a few million; beyond this trimesh's arrays alone take gigabytes.
MAX_MESH_TRIANGLES = 5_000_000
#: A mesh whose thinnest extent (along its principal axes) is below this fraction of its largest is
#: flat: coal's convex hull (qhull) crashes on vertices flat to about 1e-8; this keeps a margin of 100.
FLAT_RATIO = 1e-6


def _count_tokens(f, head: bytes, tokens: tuple[bytes, ...]) -> int:
    """How often `tokens` occur in a file read from `f` after its first bytes `head`, in chunks of
    4 MiB; a token straddling two chunks is counted (each chunk is searched with the end of the one
    before it). A text mesh's face lines are counted this way before trimesh parses them."""
    keep = max(len(t) for t in tokens) - 1
    count, tail, chunk = 0, b"\n", head
    while chunk:
        text = tail + chunk
        count += sum(text.count(t) for t in tokens)
        tail, chunk = text[-keep:] if keep else b"", f.read(1 << 22)
    return count


def mesh_header_triangles(path: str, label: str) -> int | None:
    """The number of triangles a mesh file declares, read without loading it, checked against
    `MAX_MESH_TRIANGLES`.

    Parameters
    ----------
    path : str
        The file (an existing regular file).
    label : str
        What reads it, for messages.

    Returns
    -------
    int or None
        A binary STL's header count, a PLY's `element face` count (polygons, at least one triangle
        each), an OBJ's number of face lines; None for other formats (checked after reading).

    Raises
    ------
    CollisionError
        A declared count over `MAX_MESH_TRIANGLES`, or a binary STL whose header count does not fit
        its size.
    """
    suffix = os.path.splitext(path)[1].lower()
    size = os.path.getsize(path)
    count = None
    with open(path, "rb") as f:
        head = f.read(65536)
        if suffix == ".stl" and not head[:5].lower().startswith(b"solid") and len(head) >= 84:
            count = int.from_bytes(head[80:84], "little")
            if 84 + 50 * count != size and count <= MAX_MESH_TRIANGLES:
                raise CollisionError(f"{label}: collision mesh {path!r} is not a mesh: its binary STL header declares "
                                     f"{count} triangles ({84 + 50 * count} bytes) but the file holds {size} bytes")
        elif suffix == ".ply" and head.startswith(b"ply"):
            for line in head.split(b"end_header")[0].splitlines():
                w = line.split()
                if len(w) == 3 and w[0] == b"element" and w[1] == b"face" and w[2].isdigit():
                    count = int(w[2])
        elif suffix == ".obj":
            count = _count_tokens(f, head, (b"\nf ", b"\nf\t"))
        elif suffix == ".stl":
            count = _count_tokens(f, head, (b"endfacet",))
    if count is not None and count > MAX_MESH_TRIANGLES:
        raise CollisionError(f"{label}: collision mesh {path!r} declares {count} triangles, more than "
                             f"{MAX_MESH_TRIANGLES} (the most a collision mesh may have; simplify it)")
    return count


def check_hull_vertices(v: np.ndarray, where: str) -> None:
    """Refuse vertices coal cannot make a convex hull of: NaN or infinite ones, coordinates beyond
    `MAX_COORDINATE` (m), and vertices whose hull has no volume (one point, one line, one plane:
    the thinnest extent along the principal axes below `FLAT_RATIO` of the largest).

    Parameters
    ----------
    v : numpy.ndarray
        `(V, 3)` float64 vertices (m, in the shape's frame).
    where : str
        The mesh named for messages (`"collision mesh 'hand.stl'"`).

    Raises
    ------
    CollisionError
        One line naming `where` and what is wrong.
    """
    if v.ndim != 2 or v.shape[1] != 3 or len(v) < 4:
        raise CollisionError(f"{where}: needs at least 4 finite vertices (V, 3), got {v.shape[0] if v.ndim else 0}")
    if not np.all(np.isfinite(v)):
        raise CollisionError(f"{where} has NaN or infinite vertices")
    big = float(np.max(np.abs(v)))
    if big > MAX_COORDINATE:
        raise CollisionError(f"{where} has a vertex {big:.3g} m from its frame, beyond {MAX_COORDINATE:g} m (check "
                             "its scale: a mesh in millimetres needs scale 0.001)")
    centred = v - v.mean(axis=0)
    # the principal axes from the 3x3 scatter matrix (cheap for millions of vertices); widths along them
    _, axes = np.linalg.eigh(centred.T @ centred)
    widths = np.ptp(centred @ axes, axis=0)[::-1]  # largest first
    if widths[0] <= 1e-12:
        raise CollisionError(f"{where} is not a solid: all its vertices are one point")
    for k, what, across in ((1, "on one line", "wide"), (2, "in one plane", "thick")):
        if widths[k] < FLAT_RATIO * widths[0]:
            raise CollisionError(f"{where} is not a solid: all its vertices lie {what} ({widths[k]:.3g} m {across}, "
                                 f"{widths[0]:.3g} m long), so its convex hull has no volume; model a flat part as a "
                                 "thin box (or a surface obstacle)")


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
        A missing, empty or unreadable file (a device or a pipe is no file), more than
        `MAX_MESH_TRIANGLES` triangles (counted from the header where the format has one, before
        reading), none, NaN or infinite vertices, or vertices beyond `MAX_COORDINATE` once scaled;
        the message names the file.
    """
    import trimesh

    if not os.path.isfile(path):
        raise CollisionError(f"{label}: collision mesh {path!r}: no such file")
    if os.path.getsize(path) == 0:
        raise CollisionError(f"{label}: collision mesh {path!r} is empty")
    mesh_header_triangles(path, label)
    try:
        mesh = trimesh.load(path, force="mesh", process=False)
    except Exception as exc:
        why = str(exc).strip().splitlines()[0][:120] if str(exc).strip() else ""
        raise CollisionError(f"{label}: collision mesh {path!r} is not a mesh trimesh can read "
                             f"({type(exc).__name__}{': ' + why if why else ''})") from None
    v = np.asarray(getattr(mesh, "vertices", np.zeros((0, 3))), dtype=np.float64)
    f = np.asarray(getattr(mesh, "faces", np.zeros((0, 3))), dtype=np.int64)
    if len(v) < 4 or len(f) == 0:
        raise CollisionError(f"{label}: collision mesh {path!r} is not a mesh: no triangles in it")
    if len(f) > MAX_MESH_TRIANGLES:
        raise CollisionError(f"{label}: collision mesh {path!r} has {len(f)} triangles, more than "
                             f"{MAX_MESH_TRIANGLES} (the most a collision mesh may have; simplify it)")
    if not np.all(np.isfinite(v)):
        raise CollisionError(f"{label}: collision mesh {path!r} has NaN or infinite vertices")
    with np.errstate(over="ignore", invalid="ignore"):
        v = v * np.asarray(scale, dtype=np.float64)
    big = float(np.max(np.abs(v))) if np.all(np.isfinite(v)) else np.inf
    if big > MAX_COORDINATE:
        raise CollisionError(f"{label}: collision mesh {path!r} has a vertex {big:.3g} m from its frame once "
                             f"scaled, beyond {MAX_COORDINATE:g} m (a mesh in millimetres needs scale 0.001)")
    return v, f


def _description_root(folder: str) -> str:
    """The top of the description's tree a URDF in `folder` may reach by relative names: the nearest
    folder at or above it holding a ROS `package.xml`, else the folder just above it."""
    d = folder
    while True:
        if os.path.isfile(os.path.join(d, "package.xml")):
            return d
        if os.path.dirname(d) == d:
            return os.path.dirname(folder)
        d = os.path.dirname(d)


def _inside(path: str, root: str) -> bool:
    return os.path.commonpath([path, root]) == root


def read_scene_mesh(item, label: str, name: str, folder: str | None, kind: str) -> tuple:
    """The triangles `(vertices, faces, path)` of a scene-file obstacle `{file: PATH, scale: s or
    [sx, sy, sz]}` of kind `kind` (a mesh, a surface), the file relative to `folder`; one-line
    `CollisionError`s naming the file and the obstacle."""
    where = f"{label}: obstacle {name!r}"
    fn = item.get("file")
    if not isinstance(fn, str) or not fn:
        raise CollisionError(f"{where}: a {kind} needs file: PATH")
    scale = item.get("scale", 1.0)
    scale = scene_vector(label, f"obstacle {name!r} scale", [scale] * 3 if isinstance(scale, (int, float))
                         and not isinstance(scale, bool) else scale)
    if np.any(scale <= 0):
        raise CollisionError(f"{where}: {kind} scale must be positive, got {shown(item.get('scale'))}")
    path = fn if os.path.isabs(fn) or folder is None else os.path.join(folder, fn)
    v, f = read_mesh(path, where, scale)
    return v, f, path


def resolve_mesh(filename: str, urdf_dir: str | None) -> str:
    """A URDF mesh reference as a path, kept inside the description's tree (module notes).

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

    Raises
    ------
    CollisionError
        A `package://` name whose package is not one folder name or whose rest climbs with `..`,
        and a relative name that climbs above the description's tree (the nearest folder holding a
        `package.xml`, else the folder above the URDF's): `package://../../etc/passwd` reads
        nothing.
    """
    if filename.startswith("file://"):
        filename = filename[len("file://"):]
    base = os.path.abspath(urdf_dir or os.getcwd())
    if filename.startswith("package://"):
        pkg, _, rest = filename[len("package://"):].partition("/")
        parts = rest.replace("\\", "/").split("/")
        if pkg in ("", ".", "..") or "\\" in pkg or not rest or rest.startswith("/") or ".." in parts:
            raise CollisionError(f"mesh {filename!r} climbs out of its package: a package:// name is "
                                 "package://PACKAGE/PATH inside that package, without '..'")
        d = base
        while True:
            for cand in (os.path.join(d, pkg, rest), os.path.join(d, rest)):
                if os.path.isfile(cand):
                    return cand
            if os.path.dirname(d) == d:
                return os.path.join(base, rest)
            d = os.path.dirname(d)
    if os.path.isabs(filename):
        return filename  # the author's explicit path
    path = os.path.normpath(os.path.join(base, filename))
    root = _description_root(base)
    if not _inside(path, root):
        raise CollisionError(f"mesh {filename!r} climbs out of the description's tree ({root!r}: the folder holding "
                             "its package.xml, else the one above the URDF's); a relative mesh name stays inside it")
    return path


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
        # every mesh passes here (URDF, MJCF, scene file, Python) before coal sees it
        v = np.asarray(shape.vertices, dtype=np.float64)
        where = f"collision mesh {shape.source!r}" if shape.source else "collision mesh"
        check_hull_vertices(v, where)
        if shape.faces is not None:
            f = np.asarray(shape.faces)
            if f.ndim != 2 or f.shape[1:] != (3,) or (len(f) and (f.min() < 0 or f.max() >= len(v))):
                raise CollisionError(f"{where}: faces must be (F, 3) indices of its {len(v)} vertices")
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

        # checked again here: the vertices are a mutable array, and coal's hull crashes the process on
        # degenerate ones instead of raising
        check_hull_vertices(np.asarray(shape.vertices, dtype=np.float64),
                            f"collision mesh {shape.source!r}" if shape.source else "collision mesh")
        pts = coal.StdVec_Vec3s()
        pts.extend([np.ascontiguousarray(p, dtype=np.float64) for p in shape.vertices])
        return coal.Convex.convexHull(pts, False, None)

    def triangles(self, shape):
        return shape.vertices, shape.faces

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
        v, f, path = read_scene_mesh(item, label, name, folder, "mesh")
        try:
            return Shape("mesh", (), pose, v, f, source=path)
        except CollisionError as exc:
            raise CollisionError(f"{where}: {exc}") from None


MESH = SHAPE_KINDS.register(Mesh(name="mesh", priority=50, size_fields=(), urdf_tag="mesh", mjcf_type="mjGEOM_MESH",
                                 scene_keys=("file", "scale"), reads_file=True))
