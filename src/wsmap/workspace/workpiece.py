"""Targets on a workpiece: points on its surface, their outward normals and the tool poses that
point at them (the targets of a reach study, `wsmap.jobs.StudyJob`).

Two sources: a mesh (STL, OBJ, PLY read by trimesh) sampled every `spacing` metres
(`targets_from_mesh`), or a point cloud with normals (PLY, PCD, CSV; `targets_from_points`).

Frames and conventions
----------------------
Points and normals are given in the workpiece frame; `pose` `(4, 4)` places that frame in the
world frame, and every returned array is in the world frame (metres). Normals are unit vectors
pointing out of the workpiece. The tool pose of a target has its z axis against the normal
(`z = -n`, the tool points into the surface), its origin `standoff` m off the surface
(`point + standoff * n`), and its x axis by ROS-Industrial REACH's rule (`createFrame`, with z
flipped): the world x axis projected on the tangent plane, or, where the normal is within
`acos(0.9)` (about 26 degrees) of the world x axis, `a × n` with `a` the world y axis projected on
the tangent plane. These are the goals of REACH's own demo database (`reach.db.xml`: `z = -n` of
its `part.pcd`, whose normals point out of the part towards the arm), to single precision
(`tests/workspace/test_reach_db.py`).

Poses from single-precision normals are not rigid to the 1e-6 that `check_rigid` asks
(REACH's demo goals reach `RᵀR − I = 1.3e-6`): `orthonormalise` moves each rotation to the
nearest rotation and records by how much (`TargetSet.moved`).

Hostile files: a PLY or binary STL header that declares more elements than the file can hold is
refused before anything is allocated, and so is a PCD whose declared points exceed the bound or
the file's size.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._optional import require
from ..io import numeric_rows, read_text
from ..kinematics.transforms import check_rigid

__all__ = ["MAX_STUDY_TARGETS", "MOVED_LIMIT", "TargetSet", "orthonormalise", "targets_from_mesh",
           "targets_from_points", "tool_poses"]

#: The most targets one study takes (each is K IK problems per candidate base).
MAX_STUDY_TARGETS = 100_000
#: The largest `‖R − R_orthonormal‖_F` that `orthonormalise` accepts: past it a rotation is not a
#: rounded rotation but something else (a shear, a scale, a wrong matrix).
MOVED_LIMIT = 1e-3
#: A normal shorter than this (before renormalising) is no direction.
_MIN_NORMAL = 1e-6
#: Candidates drawn per target before the Poisson-disk thinning, and the thinning radius in
#: spacings: chosen so that a surface of area A gives about A / spacing² targets.
_OVERSAMPLE = 4
_RADIUS = 0.68
_HEADER_LIMIT = 65_536
_PLY_TYPES = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
              "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
              "float": "f4", "float32": "f4", "double": "f8", "float64": "f8"}
_NORMAL_NAMES = (("nx", "ny", "nz"), ("normal_x", "normal_y", "normal_z"))


@dataclass(frozen=True)
class TargetSet:
    """Targets on a workpiece, in the world frame.

    Attributes
    ----------
    points : (M, 3) float64
        Points on the workpiece's surface (m, world frame).
    normals : (M, 3) float64
        Unit outward surface normals at `points` (world frame).
    poses : (M, 4, 4) float64
        Rigid tool poses (world frame): z axis `-normals`, origin `points + standoff * normals`,
        x axis by the rule of the module notes.
    moved : (M,) float64
        By how much each pose's rotation was moved to make it rigid: `‖R_given − R‖_F` (0 for a
        pose built exactly; the renormalisation of a single-precision normal, `|‖n‖ − 1|`, for a
        cloud; `orthonormalise`'s measure for given poses).
    vertices : (V, 3) float64 or None
        The workpiece mesh's vertices (m, world frame) for pictures; None for a point cloud.
    faces : (F, 3) int64 or None
        The mesh's triangles (indices into `vertices`); None for a point cloud.
    source : str
        Where the targets came from (a file path, or `"arrays"`).
    """

    points: np.ndarray
    normals: np.ndarray
    poses: np.ndarray
    moved: np.ndarray
    vertices: np.ndarray | None
    faces: np.ndarray | None
    source: str

    def __len__(self) -> int:
        return len(self.points)


def orthonormalise(T, *, limit: float = MOVED_LIMIT, name: str = "poses") -> tuple[np.ndarray, np.ndarray]:
    """The nearest rigid transforms to nearly rigid poses, and how far each rotation moved.

    The rotation block `R` is replaced by the nearest rotation in the Frobenius norm (the polar
    factor by SVD, `U diag(1, 1, det(U Vᵀ)) Vᵀ`, so `det = +1`); the translation is kept. For poses
    built from single-precision normals, whose `RᵀR − I` is about 1e-6.

    Parameters
    ----------
    T : (..., 4, 4) array_like
        Poses (any frame; translations in m) whose rotation blocks are rotations up to rounding.
    limit : float
        The largest accepted move `‖R − R_rigid‖_F`; a pose past it is refused, not repaired.
    name : str
        What the messages call `T`.

    Returns
    -------
    T_rigid : (..., 4, 4) float64
        The poses with rigid rotation blocks and bottom row `[0, 0, 0, 1]`.
    moved : (...,) float64
        `‖R − R_rigid‖_F` for each pose.

    Raises
    ------
    ValueError
        One line naming `name`: a shape other than `(..., 4, 4)`, a NaN or infinite entry, a bottom
        row other than `[0, 0, 0, 1]`, or a rotation block that moves more than `limit` (with the
        first such index).
    """
    T = np.asarray(T, dtype=np.float64)
    if T.ndim < 2 or T.shape[-2:] != (4, 4):
        raise ValueError(f"{name} must have shape (..., 4, 4), got {T.shape}")
    if not np.all(np.isfinite(T)):
        raise ValueError(f"{name} contains NaN or infinite values")
    if np.any(np.abs(T[..., 3, :] - [0.0, 0.0, 0.0, 1.0]) > 1e-9):
        raise ValueError(f"{name}: a bottom row is not [0, 0, 0, 1]; give rigid transforms")
    R = T[..., :3, :3]
    U, _, Vt = np.linalg.svd(R)
    d = np.where(np.linalg.det(U @ Vt) < 0, -1.0, 1.0)
    U = U.copy()
    U[..., :, 2] *= d[..., None]
    R_rigid = U @ Vt
    moved = np.linalg.norm(R - R_rigid, axis=(-2, -1))
    if np.any(moved > limit):
        bad = np.argwhere(np.atleast_1d(moved > limit))[0]
        where = "" if T.ndim == 2 else f" (first at index {tuple(int(i) for i in bad)})"
        raise ValueError(f"{name}: a rotation block is {float(np.max(moved)):.3g} from the nearest rotation{where}, "
                         f"more than {limit:g}: not a rounded rotation (a shear, scale or reflection); "
                         "give rigid transforms")
    out = T.copy()
    out[..., :3, :3] = R_rigid
    out[..., 3, :] = [0.0, 0.0, 0.0, 1.0]
    return out, moved


def tool_poses(points, normals, standoff: float = 0.0) -> np.ndarray:
    """Tool poses pointing into a surface: z axis `-n`, origin `point + standoff * n`.

    Parameters
    ----------
    points : (M, 3) array_like
        Surface points (m, world frame).
    normals : (M, 3) array_like
        Unit outward normals (world frame).
    standoff : float
        Distance of the tool origin off the surface along the normal (m, >= 0).

    Returns
    -------
    (M, 4, 4) float64 rigid poses in the world frame; the x axis is the world x axis projected on
    the tangent plane, or where `|n · x_world| >= 0.9`, `a × n` with `a` the world y axis
    projected on the tangent plane; `y = z × x`. This is REACH's `createFrame(point, n)` turned
    half a turn about its x axis, and equals the goals REACH's demo database holds
    (`reach_ros/demo/results/reach_study/reach.db.xml`, from `part.pcd`) to their single precision.
    """
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    n = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    z = -n
    near_x = np.abs(n[:, 0]) >= 0.9
    ref = np.where(near_x[:, None], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0])
    a = ref - np.sum(ref * z, axis=1, keepdims=True) * z  # the reference axis on the tangent plane
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    x = np.where(near_x[:, None], np.cross(z, a), a)
    y = np.cross(z, x)
    T = np.zeros((len(p), 4, 4))
    T[:, :3, 0], T[:, :3, 1], T[:, :3, 2] = x, y, z
    T[:, :3, 3] = p + standoff * n
    T[:, 3, 3] = 1.0
    return T


# ---------------------------------------------------------------------------------------------
# checks shared by both sources


def _check_standoff(standoff, label: str) -> float:
    if isinstance(standoff, bool) or not isinstance(standoff, (int, float, np.floating, np.integer)) \
            or not np.isfinite(standoff) or standoff < 0:
        raise ValueError(f"{label}: standoff must be a finite number of metres >= 0, got {standoff!r}")
    return float(standoff)


def _check_max(max_targets, label: str) -> int:
    if isinstance(max_targets, bool) or not isinstance(max_targets, (int, np.integer)) or max_targets < 1:
        raise ValueError(f"{label}: max_targets must be a positive integer, got {max_targets!r}")
    return int(max_targets)


def _check_pose(pose) -> np.ndarray | None:
    if pose is None:
        return None
    T = check_rigid("pose", pose)
    if T.shape != (4, 4):
        raise ValueError(f"pose must be one 4x4 rigid transform placing the workpiece in the world, got {T.shape}")
    return T


def _check_file(path, label: str) -> Path:
    p = Path(path)
    if not p.is_file():
        raise ValueError(f"{label}: no such file")
    return p


def _placed(T, points, normals):
    """`points`, `normals` `(M, 3)` moved into the world frame by `T` `(4, 4)` (or as they are)."""
    if T is None:
        return points, normals
    return points @ T[:3, :3].T + T[:3, 3], normals @ T[:3, :3].T


# ---------------------------------------------------------------------------------------------
# meshes


def _stl_check(p: Path, label: str) -> None:
    """A binary STL declares its triangle count: refuse one the file cannot hold (50 bytes each)."""
    size = p.stat().st_size
    with p.open("rb") as f:
        head = f.read(84)
    if len(head) < 84 and not head.lstrip().startswith(b"solid"):
        raise ValueError(f"{label}: not a mesh (too short for a binary STL: {size} bytes)")
    if len(head) == 84 and not head.lstrip().startswith(b"solid"):
        count = int.from_bytes(head[80:84], "little")
        if 84 + 50 * count != size:
            raise ValueError(f"{label}: not a mesh: its binary STL header declares {count} triangles "
                             f"({84 + 50 * count} bytes) but the file holds {size} bytes")


def _load_mesh(p: Path, label: str):
    """The trimesh `Trimesh` of the file at `p` after the header checks (unprocessed)."""
    trimesh = require("trimesh", why="a workpiece mesh")
    suffix = p.suffix.lower()
    if suffix not in (".stl", ".obj", ".ply"):
        raise ValueError(f"{label}: not a mesh file: give an STL, OBJ or PLY (got {p.suffix or 'no extension'!r})")
    if suffix == ".stl":
        _stl_check(p, label)
    elif suffix == ".ply":
        _ply_header(p, label)  # the declared counts against the file's size
    try:
        mesh = trimesh.load(str(p), force="mesh", process=False)
    except Exception as e:  # noqa: BLE001 -- trimesh raises many kinds on a broken file; all are "unreadable"
        why = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise ValueError(f"{label}: not a readable mesh (STL, OBJ, PLY): {why:.120}") from None
    if not isinstance(mesh, trimesh.Trimesh):
        raise ValueError(f"{label}: not a mesh (trimesh read a {type(mesh).__name__})")  # noqa: TRY004 -- bad input
    return mesh


def _mesh_arrays(mesh, label: str) -> tuple[np.ndarray, np.ndarray]:
    """The checked `(V, 3)` float64 vertices and `(F, 3)` int64 faces of a trimesh mesh."""
    v = np.asarray(mesh.vertices, dtype=np.float64).reshape(-1, 3)
    f = np.asarray(mesh.faces, dtype=np.int64).reshape(-1, 3)
    if len(f) == 0 or len(v) == 0:
        raise ValueError(f"{label}: empty mesh (no triangles); give a surface mesh of the workpiece")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{label}: the mesh has NaN or infinite vertices (first at vertex "
                         f"{int(np.argwhere(~np.isfinite(v).all(axis=1))[0, 0])})")
    if f.min() < 0 or f.max() >= len(v):
        raise ValueError(f"{label}: a triangle names a vertex the mesh does not have")
    return v, f


def _thin(points: np.ndarray, radius: float) -> np.ndarray:
    """Indices of a Poisson-disk subset of `points` `(N, 3)`: taken in order, each kept point
    removes the later ones closer than `radius` (so the order of the draw decides, reproducibly)."""
    from scipy.spatial import cKDTree

    pairs = cKDTree(points).query_pairs(radius, output_type="ndarray")
    pairs = pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))] if len(pairs) else pairs.reshape(0, 2)
    starts = np.searchsorted(pairs[:, 0], np.arange(len(points) + 1))
    later = pairs[:, 1]
    dead = np.zeros(len(points), dtype=bool)
    keep = []
    for k in range(len(points)):
        if not dead[k]:
            keep.append(k)
            dead[later[starts[k]:starts[k + 1]]] = True
    return np.asarray(keep, dtype=np.int64)


def targets_from_mesh(mesh_or_path, spacing: float, *, pose=None, standoff: float = 0.0,
                      max_targets: int = MAX_STUDY_TARGETS, seed: int = 0) -> TargetSet:
    """Targets sampled on a workpiece mesh about every `spacing` metres.

    Points are drawn uniformly on the surface (area-weighted, seeded), `_OVERSAMPLE` per target,
    then thinned in the order drawn to a Poisson-disk set (no two closer than `0.68 * spacing`), so
    a surface of area `A` gets about `A / spacing²` targets. Each point's normal is its triangle's
    normal (by the winding; a closed mesh wound inwards, of negative volume, is turned outward).
    The same inputs and `seed` give the same targets bit for bit.

    Parameters
    ----------
    mesh_or_path : str, Path or trimesh.Trimesh
        An STL, OBJ or PLY file (metres, workpiece frame), or a mesh.
    spacing : float
        The distance between neighbouring targets (m, > 0).
    pose : (4, 4) array_like or None
        The workpiece frame in the world frame (rigid); None for the identity.
    standoff : float
        The tool origin's distance off the surface along the normal (m, >= 0).
    max_targets : int
        The most targets allowed; estimated as `area / spacing²` before sampling.
    seed : int
        The sampling seed.

    Returns
    -------
    TargetSet in the world frame, with the mesh's vertices and faces.

    Raises
    ------
    ValueError
        One line naming the file: not a mesh or unreadable, empty, NaN vertices, zero area, a
        spacing not > 0 or NaN, too many targets for `max_targets`, a standoff negative or NaN,
        a pose that is not rigid.
    """
    trimesh = require("trimesh", why="a workpiece mesh")
    is_mesh = isinstance(mesh_or_path, trimesh.Trimesh)
    source = "mesh" if is_mesh else str(mesh_or_path)
    label = source if is_mesh else f"mesh {source}"
    if isinstance(spacing, bool) or not isinstance(spacing, (int, float, np.floating, np.integer)) \
            or not np.isfinite(spacing) or spacing <= 0:
        raise ValueError(f"{label}: spacing must be a finite number of metres > 0, got {spacing!r}")
    standoff = _check_standoff(standoff, label)
    max_targets = _check_max(max_targets, label)
    T = _check_pose(pose)
    mesh = mesh_or_path if is_mesh else _load_mesh(_check_file(mesh_or_path, label), label)
    v, f = _mesh_arrays(mesh, label)
    mesh = trimesh.Trimesh(v, f, process=False)
    area = float(mesh.area)
    if not np.isfinite(area) or area <= 0:
        raise ValueError(f"{label}: degenerate mesh: its triangles have zero area")
    estimate = area / spacing ** 2
    if estimate > max_targets:
        raise ValueError(f"{label}: spacing {spacing:g} m gives about {estimate:.0f} targets on {area:.4g} m², more "
                         f"than {max_targets}; give a spacing of at least {math.sqrt(area / max_targets):.3g} m")
    count = max(1, math.ceil(_OVERSAMPLE * estimate))
    pts, face = trimesh.sample.sample_surface(mesh, count, seed=seed)
    keep = _thin(np.asarray(pts, dtype=np.float64), _RADIUS * spacing)
    pts, face = np.asarray(pts, dtype=np.float64)[keep], np.asarray(face)[keep]
    normals = np.asarray(mesh.face_normals, dtype=np.float64)[face]
    if mesh.is_watertight and mesh.is_winding_consistent and mesh.volume < 0:
        normals = -normals  # wound inwards: the winding gives inward normals
    pts, normals = _placed(T, pts, normals)
    vw = v if T is None else v @ T[:3, :3].T + T[:3, 3]
    moved = np.abs(np.linalg.norm(normals, axis=1) - 1.0)
    normals = normals / np.linalg.norm(normals, axis=1, keepdims=True)
    return TargetSet(points=pts, normals=normals, poses=tool_poses(pts, normals, standoff), moved=moved,
                     vertices=vw, faces=f, source=source)


# ---------------------------------------------------------------------------------------------
# point clouds


def _ply_header(p: Path, label: str) -> tuple[str, list, int]:
    """The format, elements `[(name, count, [(prop, dtype or ('list', count dtype, item dtype))])]`
    and header length (bytes) of a PLY file, after checking that the file can hold the declared
    elements (so a header declaring 10¹² vertices is refused before any allocation)."""
    with p.open("rb") as fh:
        head = fh.read(_HEADER_LIMIT)
    end = head.find(b"end_header")
    if not head.startswith(b"ply") or end < 0:
        raise ValueError(f"{label}: not a PLY file (no 'ply' ... 'end_header' header in its first "
                         f"{_HEADER_LIMIT} bytes)")
    nl = head.find(b"\n", end)
    length = (nl + 1) if nl >= 0 else len(head)
    fmt, elements = "", []
    for line in head[:end].decode("ascii", "replace").splitlines():
        w = line.split()
        if not w:
            continue
        if w[0] == "format" and len(w) >= 2:
            fmt = w[1]
        elif w[0] == "element" and len(w) == 3 and w[2].isdigit():
            elements.append((w[1], int(w[2]), []))
        elif w[0] == "property" and elements and len(w) == 5 and w[1] == "list" \
                and w[2] in _PLY_TYPES and w[3] in _PLY_TYPES:
            elements[-1][2].append((w[4], ("list", _PLY_TYPES[w[2]], _PLY_TYPES[w[3]])))
        elif w[0] == "property" and elements and len(w) == 3 and w[1] in _PLY_TYPES:
            elements[-1][2].append((w[2], _PLY_TYPES[w[1]]))
        elif w[0] in ("element", "property"):
            raise ValueError(f"{label}: not a readable PLY file: bad header line {line.strip()!r:.80}")
    if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
        raise ValueError(f"{label}: not a readable PLY file: unknown format {fmt!r}")
    need = 0
    for _, count, props in elements:
        if fmt == "ascii":
            row = 2 * len(props)  # a digit and a separator at least
        else:
            row = sum(np.dtype(t[1]).itemsize if isinstance(t, tuple) else np.dtype(t).itemsize for _, t in props)
        need += count * row
    have = p.stat().st_size - length
    if need > have:
        raise ValueError(f"{label}: its PLY header declares {sum(e[1] for e in elements)} elements needing at "
                         f"least {need} bytes, but the file holds {have}; the file is truncated or hostile")
    return fmt, elements, length


def _ply_vertices(p: Path, label: str, max_targets: int) -> tuple[np.ndarray, list]:
    """The vertex element of a PLY file as a structured array, and its property names."""
    fmt, elements, length = _ply_header(p, label)
    names = [e[0] for e in elements]
    if "vertex" not in names:
        raise ValueError(f"{label}: the PLY file has no vertex element")
    k = names.index("vertex")
    _, count, props = elements[k]
    if count > max_targets:
        raise ValueError(f"{label}: {count} points, more than {max_targets}; thin the cloud")
    if any(isinstance(t, tuple) for _, t in props):
        raise ValueError(f"{label}: the PLY vertex element has a list property; give scalar x y z nx ny nz")
    with p.open("rb") as fh:
        fh.seek(length)
        if fmt == "ascii":
            skip = sum(e[1] for e in elements[:k])
            text = fh.read().decode("ascii", "replace").splitlines()[skip:skip + count]
            try:
                rows = np.array([[float(c) for c in line.split()[:len(props)]] for line in text], dtype=np.float64)
            except ValueError:
                raise ValueError(f"{label}: a vertex row of the PLY file is not numbers") from None
            if rows.shape != (count, len(props)):
                raise ValueError(f"{label}: the PLY file holds fewer vertex rows than its header's {count}")
            return rows, [n for n, _ in props]
        if any(isinstance(t, tuple) for e in elements[:k] for _, t in e[2]):
            raise ValueError(f"{label}: a PLY element with lists comes before the vertices; put the vertices first")
        end = ">" if fmt == "binary_big_endian" else "<"
        fh.seek(sum(e[1] * sum(np.dtype(t).itemsize for _, t in e[2]) for e in elements[:k]), 1)
        dt = np.dtype([(n, end + t) for n, t in props])
        raw = fh.read(count * dt.itemsize)
    data = np.frombuffer(raw, dtype=dt)
    return np.stack([data[n].astype(np.float64) for n in dt.names], axis=1).reshape(count, -1), list(dt.names)


def _cloud_fields(names: list, label: str, normal_sets) -> tuple[str, ...]:
    """The six field names (x y z and a normal set) a cloud with fields `names` is read by."""
    if not all(c in names for c in "xyz"):
        raise ValueError(f"{label}: the cloud has no x y z fields (it has {' '.join(names)})")
    for nn in normal_sets:
        if all(c in names for c in nn):
            return ("x", "y", "z", *nn)
    want = " or ".join(" ".join(nn) for nn in normal_sets)
    raise ValueError(f"{label}: the cloud has no normals ({want}); targets need the surface normals: "
                     "compute them (e.g. PCL's NormalEstimation) and save them with the points")


def _columns(data: np.ndarray, names: list, label: str, normal_sets) -> tuple[np.ndarray, np.ndarray]:
    """Points and normals `(M, 3)` from the columns `names` of `data` `(M, C)`."""
    idx = [names.index(c) for c in _cloud_fields(names, label, normal_sets)]
    return data[:, idx[:3]], data[:, idx[3:]]


def _pcd_header(p: Path, label: str, max_targets: int) -> None:
    """Refuse a PCD file whose declared points exceed `max_targets` or what the file can hold."""
    with p.open("rb") as fh:
        head = fh.read(_HEADER_LIMIT)
    end = head.find(b"DATA")
    nl = head.find(b"\n", end)
    if end < 0 or nl < 0:
        raise ValueError(f"{label}: not a PCD file (no DATA line in its first {_HEADER_LIMIT} bytes)")
    fields = {}
    for line in head[:nl].decode("ascii", "replace").splitlines():
        w = line.split()
        if w and not w[0].startswith("#"):
            fields[w[0].upper()] = w[1:]
    try:
        points = int(fields.get("POINTS", ["-1"])[0])
        row = sum(int(s) * int(c) for s, c in zip(fields["SIZE"], fields.get("COUNT", ["1"] * len(fields["SIZE"]))))
        data = fields["DATA"][0].lower()
    except (KeyError, ValueError, IndexError):
        raise ValueError(f"{label}: not a readable PCD file: its header lacks POINTS, SIZE or DATA") from None
    if points < 0 or row <= 0:
        raise ValueError(f"{label}: not a readable PCD file: POINTS or SIZE is not a positive number")
    _cloud_fields(fields.get("FIELDS", []), label, _NORMAL_NAMES[1:])
    if points > max_targets:
        raise ValueError(f"{label}: {points} points, more than {max_targets}; thin the cloud")
    have = p.stat().st_size - nl - 1
    # ascii: a digit and a separator per value; LZF expands at most ~88 times (binary_compressed)
    need = {"ascii": points * 2 * len(fields["SIZE"]), "binary": points * row}.get(data, points * row / 100)
    if need > have:
        raise ValueError(f"{label}: its PCD header declares {points} points needing at least {need:.0f} bytes, "
                         f"but the file holds {have}; the file is truncated or hostile")
    if data == "binary_compressed":
        # the reader allocates the declared uncompressed size: it must be the declared points' bytes
        sizes = head[nl + 1:nl + 9]
        comp, raw = struct.unpack("<II", sizes) if len(sizes) == 8 else (-1, -1)
        if raw != points * row or not 0 <= comp <= have - 8:
            raise ValueError(f"{label}: its compressed PCD data declares {raw} bytes in {comp}, but {points} points "
                             f"of {row} bytes are {points * row} and the file holds {have - 8}; the file is "
                             "truncated or hostile")


def _read_pcd(p: Path, label: str, max_targets: int) -> tuple[np.ndarray, np.ndarray]:
    _pcd_header(p, label, max_targets)
    pypcd4 = require("pypcd4", extra="study", why="a PCD point cloud")
    try:
        pc = pypcd4.PointCloud.from_path(str(p))
    except Exception as e:  # noqa: BLE001 -- pypcd4 raises pydantic, struct and lzf errors on a broken file
        why = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise ValueError(f"{label}: not a readable PCD file: {why:.120}") from None
    data = np.asarray(pc.numpy(("x", "y", "z", *_NORMAL_NAMES[1])), dtype=np.float64).reshape(-1, 6)
    return data[:, :3], data[:, 3:]


def _read_csv(p: Path, label: str, max_targets: int) -> tuple[np.ndarray, np.ndarray]:
    if p.stat().st_size > 400 * max_targets:  # no row of 6 numbers needs 400 bytes
        raise ValueError(f"{label}: {p.stat().st_size} bytes, more than {max_targets} rows can take; thin the cloud")
    text = read_text(p, f"{label}:", "give a CSV of x y z nx ny nz", encoding="utf-8-sig")
    rows = numeric_rows(text, label)
    if not rows:
        raise ValueError(f"{label}: no points in the file")
    widths = sorted({len(r) for r in rows})
    if widths == [3]:
        raise ValueError(f"{label}: the cloud has no normals (3 columns x y z); targets need the surface normals: "
                         "give 6 columns x y z nx ny nz")
    if widths != [6]:
        raise ValueError(f"{label}: every row needs 6 values x y z nx ny nz; found rows of {widths} values")
    if len(rows) > max_targets:
        raise ValueError(f"{label}: {len(rows)} points, more than {max_targets}; thin the cloud")
    a = np.array(rows, dtype=np.float64)
    return a[:, :3], a[:, 3:]


def _read_cloud(p: Path, label: str, max_targets: int) -> tuple[np.ndarray, np.ndarray]:
    suffix = p.suffix.lower()
    if suffix == ".ply":
        data, names = _ply_vertices(p, label, max_targets)
        return _columns(data, names, label, _NORMAL_NAMES)
    if suffix == ".pcd":
        return _read_pcd(p, label, max_targets)
    if suffix in (".csv", ".txt", ".xyz"):
        return _read_csv(p, label, max_targets)
    raise ValueError(f"{label}: not a point cloud file: give a PLY, PCD or CSV (got {p.suffix or 'no extension'!r})")


def targets_from_points(path_or_arrays, *, pose=None, standoff: float = 0.0,
                        max_targets: int = MAX_STUDY_TARGETS, flip: bool = False) -> TargetSet:
    """Targets from a point cloud with normals.

    Parameters
    ----------
    path_or_arrays : str, Path or (points, normals)
        A PLY file (vertex properties x y z nx ny nz, or normal_x normal_y normal_z; ascii or
        binary), a PCD file (fields x y z normal_x normal_y normal_z; ascii, binary or
        binary_compressed, read by pypcd4), a CSV (x y z nx ny nz per row, a header line allowed),
        or two `(M, 3)` arrays. Metres, workpiece frame; normals pointing out of the workpiece.
    pose : (4, 4) array_like or None
        The workpiece frame in the world frame (rigid); None for the identity.
    standoff : float
        The tool origin's distance off the surface along the normal (m, >= 0).
    max_targets : int
        The most points allowed (checked against a file's declared count before reading).
    flip : bool
        True where the given normals point into the workpiece: they are negated, so the tool's z
        axis is `+n` of the file. REACH's demo cloud `part.pcd` needs no flip (its goals are
        `z = -n`, `tool_poses`).

    Returns
    -------
    TargetSet in the world frame, `vertices` and `faces` None. Normals are renormalised (a
    single-precision cloud's are unit only to about 1e-7); `moved` records `|‖n‖ − 1|`.

    Raises
    ------
    ValueError
        One line naming the file: unreadable, no normals, too many points, NaN values, a zero
        normal, a standoff negative or NaN, a pose that is not rigid.
    """
    if isinstance(path_or_arrays, (tuple, list)) and len(path_or_arrays) == 2:
        source, label = "arrays", "points"
    else:
        source = str(path_or_arrays)
        label = f"points {source}"
    standoff = _check_standoff(standoff, label)
    max_targets = _check_max(max_targets, label)
    T = _check_pose(pose)
    if source == "arrays":
        pts, nrm = (np.asarray(a, dtype=np.float64) for a in path_or_arrays)
        if pts.ndim != 2 or pts.shape[1:] != (3,) or nrm.shape != pts.shape:
            raise ValueError(f"{label}: give points and normals as two (M, 3) arrays, got {pts.shape} and {nrm.shape}")
        if len(pts) > max_targets:
            raise ValueError(f"{label}: {len(pts)} points, more than {max_targets}; thin the cloud")
    else:
        pts, nrm = _read_cloud(_check_file(path_or_arrays, label), label, max_targets)
    if flip:
        nrm = -nrm
    return _cloud_targets(pts, nrm, T, standoff, label, source)


def _cloud_targets(pts, nrm, T, standoff, label, source) -> TargetSet:
    if len(pts) == 0:
        raise ValueError(f"{label}: the cloud holds no points")
    if not (np.all(np.isfinite(pts)) and np.all(np.isfinite(nrm))):
        bad = int(np.argwhere(~(np.isfinite(pts).all(axis=1) & np.isfinite(nrm).all(axis=1)))[0, 0])
        raise ValueError(f"{label}: NaN or infinite values (first at point {bad})")
    length = np.linalg.norm(nrm, axis=1)
    if np.any(length < _MIN_NORMAL):
        bad = int(np.argwhere(length < _MIN_NORMAL)[0, 0])
        raise ValueError(f"{label}: a zero normal (first at point {bad}); every point needs its surface normal")
    moved = np.abs(length - 1.0)
    pts, nrm = _placed(T, pts, nrm / length[:, None])
    nrm = nrm / np.linalg.norm(nrm, axis=1, keepdims=True)
    return TargetSet(points=pts, normals=nrm, poses=tool_poses(pts, nrm, standoff), moved=moved,
                     vertices=None, faces=None, source=source)
