"""Targets on a workpiece (wsmap.workspace.workpiece): a box mesh of known area sampled at a
spacing, point clouds with normals from PLY / PCD / CSV, REACH's demo part where present,
orthonormalised single-precision poses, and every bad input's one-line message."""

from __future__ import annotations

import struct
import sys
from pathlib import Path

import numpy as np
import pytest

trimesh = pytest.importorskip("trimesh")

from wsmap.kinematics.transforms import check_rigid
from wsmap.workspace.workpiece import (
    MAX_STUDY_TARGETS,
    TargetSet,
    orthonormalise,
    targets_from_mesh,
    targets_from_points,
    tool_poses,
)

HALF = np.array([0.2, 0.15, 0.1])  # the box's half extents (m)
AREA = 8 * (HALF[0] * HALF[1] + HALF[1] * HALF[2] + HALF[0] * HALF[2])  # 0.52 m²
ROOT = Path(__file__).resolve().parents[2]
DEMO = [Path("/tmp"), ROOT / "data" / "cells" / "reach_demo"]  # where REACH's demo part may lie


def _box():
    return trimesh.creation.box(extents=2 * HALF)


def _pose():
    """A rigid placement: 30 degrees about z then 20 about x, moved by (1, -0.5, 0.3) m."""
    a, b = np.radians(30.0), np.radians(20.0)
    Rz = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    Rx = np.array([[1, 0, 0], [0, np.cos(b), -np.sin(b)], [0, np.sin(b), np.cos(b)]])
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = Rz @ Rx, [1.0, -0.5, 0.3]
    return T


def _check_frames(ts: TargetSet, standoff: float):
    """Poses rigid, tool z against the normal, origin standoff m off the surface."""
    check_rigid("poses", ts.poses)
    np.testing.assert_allclose(ts.poses[:, :3, 2], -ts.normals, atol=1e-12)
    np.testing.assert_allclose(ts.poses[:, :3, 3], ts.points + standoff * ts.normals, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(ts.normals, axis=1), 1.0, atol=1e-12)
    assert ts.poses.shape == (len(ts), 4, 4) and ts.moved.shape == (len(ts),)


# ---------------------------------------------------------------------------------------------
# meshes


@pytest.mark.parametrize("spacing", [0.05, 0.02, 0.01])
def test_box_targets_count_surface_normals_and_poses(spacing):
    ts = targets_from_mesh(_box(), spacing, standoff=0.03)
    # about area / spacing² targets (the Poisson-disk thinning is calibrated to it)
    assert 0.85 * AREA / spacing**2 <= len(ts) <= 1.15 * AREA / spacing**2
    # every point on the surface: inside the box, on one face
    assert np.all(np.abs(ts.points) <= HALF + 1e-12)
    np.testing.assert_allclose(np.max(np.abs(ts.points) / HALF, axis=1), 1.0, atol=1e-9)
    # each normal is its face's: an outward axis, and the point lies on that face's plane
    axis = np.argmax(np.abs(ts.normals), axis=1)
    expected = np.zeros_like(ts.normals)
    expected[np.arange(len(ts)), axis] = np.sign(ts.normals[np.arange(len(ts)), axis])
    np.testing.assert_allclose(ts.normals, expected, atol=1e-12)
    np.testing.assert_allclose(np.sum(ts.points * ts.normals, axis=1), HALF[axis], atol=1e-12)
    _check_frames(ts, 0.03)
    assert np.all(ts.moved < 1e-12)
    # no two targets closer than the thinning radius
    from scipy.spatial import cKDTree
    assert len(cKDTree(ts.points).query_pairs(0.68 * spacing * (1 - 1e-9))) == 0
    assert ts.vertices.shape == (8, 3) and ts.faces.shape == (12, 3) and ts.source == "mesh"


def test_x_axis_rule():
    """The world x axis projected on the tangent plane; near-x normals take `a × n` with `a` world y
    on the plane, so that y is minus world y there (REACH's demo goals, tests/workspace/test_reach_db.py)."""
    n = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [-0.95, 0.0, np.sqrt(1 - 0.95**2)]])
    T = tool_poses(np.zeros((4, 3)), n)
    np.testing.assert_allclose(T[0, :3, :3], np.diag([1.0, -1.0, -1.0]), atol=1e-15)
    np.testing.assert_allclose(T[1, :3, 0], [1.0, 0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(T[2, :3, 1], [0.0, -1.0, 0.0], atol=1e-15)  # y is minus world y on the plane
    np.testing.assert_allclose(T[3, :3, 1], [0.0, -1.0, 0.0], atol=1e-15)
    check_rigid("T", T)


def test_deterministic_bit_for_bit_and_seeded():
    a = targets_from_mesh(_box(), 0.02, standoff=0.01, seed=3)
    b = targets_from_mesh(_box(), 0.02, standoff=0.01, seed=3)
    for name in ("points", "normals", "poses", "moved", "vertices", "faces"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    c = targets_from_mesh(_box(), 0.02, standoff=0.01, seed=4)
    assert len(c) != len(a) or not np.array_equal(c.points, a.points)


def test_pose_places_the_workpiece():
    T = _pose()
    local = targets_from_mesh(_box(), 0.03, standoff=0.02)
    world = targets_from_mesh(_box(), 0.03, pose=T, standoff=0.02)
    np.testing.assert_allclose(world.points, local.points @ T[:3, :3].T + T[:3, 3], atol=1e-12)
    np.testing.assert_allclose(world.normals, local.normals @ T[:3, :3].T, atol=1e-12)
    np.testing.assert_allclose(world.vertices, local.vertices @ T[:3, :3].T + T[:3, 3], atol=1e-12)
    _check_frames(world, 0.02)


@pytest.mark.parametrize("suffix", ["stl", "obj", "ply"])
def test_mesh_files(tmp_path, suffix):
    path = tmp_path / f"box.{suffix}"
    _box().export(path)
    ts = targets_from_mesh(path, 0.02)
    assert ts.source == str(path)
    assert 0.85 * AREA / 0.02**2 <= len(ts) <= 1.15 * AREA / 0.02**2
    assert np.all(np.sum(ts.points * ts.normals, axis=1) > 0)  # outward from the centre
    _check_frames(ts, 0.0)


def test_inward_wound_mesh_gets_outward_normals():
    box = _box()
    inward = trimesh.Trimesh(box.vertices, box.faces[:, ::-1], process=False)
    assert inward.volume < 0
    ts = targets_from_mesh(inward, 0.03)
    assert np.all(np.sum(ts.points * ts.normals, axis=1) > 0)


def _demo(name: str) -> Path:
    for folder in DEMO:
        if (folder / name).is_file():
            return folder / name
    pytest.skip(f"REACH's demo {name} is not at /tmp or data/cells/reach_demo")


def test_reach_demo_mesh():
    path = _demo("part.ply")
    ts = targets_from_mesh(path, 0.02, standoff=0.1)
    mesh = trimesh.load(path, force="mesh")
    assert 0.8 * mesh.area / 0.02**2 <= len(ts) <= 1.2 * mesh.area / 0.02**2
    _check_frames(ts, 0.1)
    # every target on the surface
    _, dist, _ = trimesh.proximity.closest_point(mesh, ts.points)
    assert np.max(dist) < 1e-6


# ---------------------------------------------------------------------------------------------
# orthonormalise


def _single_precision_poses(m=200, noise=2e-6, seed=0):
    """Tool poses as a single-precision pipeline leaves them: rotations off by about `noise`."""
    rng = np.random.default_rng(seed)
    n = rng.normal(size=(m, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    T = tool_poses(rng.uniform(-1, 1, (m, 3)), n, 0.05)
    T[:, :3, :3] += noise * rng.normal(size=(m, 3, 3))
    return T.astype(np.float32).astype(np.float64)


def test_orthonormalise_single_precision_poses():
    T = _single_precision_poses()
    with pytest.raises(ValueError, match="not a rigid transform"):
        check_rigid("targets", T)
    rigid, moved = orthonormalise(T)
    check_rigid("targets", rigid, atol=1e-12)
    assert np.all(np.abs(np.linalg.det(rigid[:, :3, :3]) - 1) < 1e-12)
    np.testing.assert_array_equal(rigid[:, :3, 3], T[:, :3, 3])
    np.testing.assert_allclose(moved, np.linalg.norm(T[:, :3, :3] - rigid[:, :3, :3], axis=(1, 2)), rtol=1e-12)
    assert np.all(moved > 1e-7) and np.all(moved < 1e-4)
    # the nearest rotation: no sampled rotation is closer
    rng = np.random.default_rng(1)
    for k in range(5):
        w = 1e-4 * rng.normal(size=3)
        K = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
        other = rigid[k, :3, :3] @ (np.eye(3) + K + K @ K / 2)
        assert np.linalg.norm(T[k, :3, :3] - other) >= moved[k] - 1e-12
    # already rigid: moved about 0, unchanged up to rounding
    again, moved2 = orthonormalise(rigid)
    np.testing.assert_allclose(again, rigid, atol=1e-15)
    assert np.all(moved2 < 1e-14)


def test_orthonormalise_refuses():
    T = np.eye(4)
    shear = T.copy()
    shear[0, 1] = 0.01
    with pytest.raises(ValueError) as e:
        orthonormalise(shear)
    assert str(e.value) == ("poses: a rotation block is 0.00707 from the nearest rotation, more than 0.001: not a "
                            "rounded rotation (a shear, scale or reflection); give rigid transforms")
    many = np.stack([T, T, np.diag([1.0, 1.0, -1.0, 1.0])])
    with pytest.raises(ValueError) as e:
        orthonormalise(many, name="targets")
    assert str(e.value) == ("targets: a rotation block is 2 from the nearest rotation (first at index (2,)), more "
                            "than 0.001: not a rounded rotation (a shear, scale or reflection); give rigid transforms")
    nan = T.copy()
    nan[0, 3] = np.nan
    with pytest.raises(ValueError) as e:
        orthonormalise(nan)
    assert str(e.value) == "poses contains NaN or infinite values"
    bottom = T.copy()
    bottom[3, 0] = 0.5
    with pytest.raises(ValueError) as e:
        orthonormalise(bottom)
    assert str(e.value) == "poses: a bottom row is not [0, 0, 0, 1]; give rigid transforms"
    with pytest.raises(ValueError) as e:
        orthonormalise(np.eye(3))
    assert str(e.value) == "poses must have shape (..., 4, 4), got (3, 3)"


# ---------------------------------------------------------------------------------------------
# point clouds


def _cloud(m=50, seed=0):
    """Points on the box's faces and their outward normals, in single precision (as PCL saves them)."""
    ts = targets_from_mesh(_box(), 0.1, seed=seed)
    return ts.points[:m].astype(np.float32), ts.normals[:m].astype(np.float32)


def _write_ply(path: Path, data: np.ndarray, names, fmt="ascii"):
    head = [f"ply\nformat {fmt} 1.0\ncomment workpiece test cloud\nelement vertex {len(data)}\n"]
    head += [f"property float {n}\n" for n in names]
    head.append("end_header\n")
    with path.open("wb") as f:
        f.write("".join(head).encode())
        if fmt == "ascii":
            f.write("".join(" ".join(repr(float(v)) for v in row) + "\n" for row in data).encode())
        else:
            f.write(data.astype("<f4" if fmt == "binary_little_endian" else ">f4").tobytes())


def _lzf_literal(raw: bytes) -> bytes:
    """LZF data holding `raw` as literal runs only (a control byte `len - 1` < 32, then the bytes):
    valid input for any LZF decompressor, so PCL's binary_compressed can be written without lzf."""
    return b"".join(bytes([len(raw[i:i + 32]) - 1]) + raw[i:i + 32] for i in range(0, len(raw), 32))


def _write_pcd(path: Path, data: np.ndarray, names, encoding: str, points: int | None = None):
    n = len(names)
    head = (f"# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS {' '.join(names)}\n"
            f"SIZE {' '.join(['4'] * n)}\nTYPE {' '.join(['F'] * n)}\nCOUNT {' '.join(['1'] * n)}\n"
            f"WIDTH {len(data)}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {points or len(data)}\nDATA {encoding}\n")
    f32 = data.astype("<f4")
    if encoding == "ascii":
        body = "".join(" ".join(repr(float(v)) for v in row) + "\n" for row in f32).encode()
    elif encoding == "binary":
        body = f32.tobytes()
    else:
        raw = b"".join(np.ascontiguousarray(f32[:, k]).tobytes() for k in range(n))
        comp = _lzf_literal(raw)
        body = struct.pack("<II", len(comp), len(raw)) + comp
    path.write_bytes(head.encode() + body)


def _check_cloud(ts: TargetSet, p32, n32, standoff=0.0):
    np.testing.assert_allclose(ts.points, p32.astype(np.float64), atol=0)
    n64 = n32.astype(np.float64)
    np.testing.assert_allclose(ts.normals, n64 / np.linalg.norm(n64, axis=1, keepdims=True), atol=1e-15)
    np.testing.assert_allclose(ts.moved, np.abs(np.linalg.norm(n64, axis=1) - 1), atol=1e-15)
    assert ts.vertices is None and ts.faces is None
    _check_frames(ts, standoff)


@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian", "binary_big_endian"])
def test_ply_cloud(tmp_path, fmt):
    p, n = _cloud()
    path = tmp_path / "cloud.ply"
    _write_ply(path, np.hstack([p, n]), ["x", "y", "z", "nx", "ny", "nz"], fmt)
    ts = targets_from_points(path, standoff=0.05)
    _check_cloud(ts, p, n, 0.05)
    assert ts.source == str(path)


def test_ply_cloud_pcl_field_names_and_extra_fields(tmp_path):
    p, n = _cloud()
    path = tmp_path / "cloud.ply"
    curv = np.zeros((len(p), 1), np.float32)
    _write_ply(path, np.hstack([curv, p, n]), ["curvature", "x", "y", "z", "normal_x", "normal_y", "normal_z"],
               "binary_little_endian")
    _check_cloud(targets_from_points(path), p, n)


def test_csv_cloud_with_header_and_pose(tmp_path):
    p, n = _cloud()
    path = tmp_path / "cloud.csv"
    rows = "\n".join(",".join(repr(float(v)) for v in row) for row in np.hstack([p, n]))
    path.write_text("x,y,z,nx,ny,nz\n" + rows + "\n")
    _check_cloud(targets_from_points(path), p, n)
    T = _pose()
    ts = targets_from_points(path, pose=T, standoff=0.01)
    np.testing.assert_allclose(ts.points, p.astype(np.float64) @ T[:3, :3].T + T[:3, 3], atol=1e-12)
    _check_frames(ts, 0.01)


def test_arrays_renormalised():
    p = np.zeros((2, 3))
    n = np.array([[0.0, 0.0, 2.0], [0.0, 3.0, 4.0]])
    ts = targets_from_points((p, n))
    np.testing.assert_allclose(ts.normals, [[0, 0, 1], [0, 0.6, 0.8]], atol=1e-15)
    np.testing.assert_allclose(ts.moved, [1.0, 4.0])
    assert ts.source == "arrays" and len(ts) == 2
    flipped = targets_from_points((p, n), flip=True, standoff=0.1)
    np.testing.assert_array_equal(flipped.normals, -ts.normals)
    np.testing.assert_allclose(flipped.poses[:, :3, 2], ts.normals, atol=1e-15)  # the tool points along the given normals
    _check_frames(flipped, 0.1)


@pytest.mark.parametrize("encoding", ["ascii", "binary", "binary_compressed"])
def test_pcd_cloud(tmp_path, encoding):
    pytest.importorskip("pypcd4")
    p, n = _cloud()
    path = tmp_path / "cloud.pcd"
    _write_pcd(path, np.hstack([p, n, np.zeros((len(p), 1))]),
               ["x", "y", "z", "normal_x", "normal_y", "normal_z", "curvature"], encoding)
    _check_cloud(targets_from_points(path, standoff=0.1), p, n, 0.1)


def test_pcd_without_pypcd4_names_the_extra(tmp_path, monkeypatch):
    p, n = _cloud(5)
    path = tmp_path / "cloud.pcd"
    _write_pcd(path, np.hstack([p, n]), ["x", "y", "z", "normal_x", "normal_y", "normal_z"], "binary")
    monkeypatch.setitem(sys.modules, "pypcd4", None)  # as if not installed
    assert _message(targets_from_points, path) == (
        "a PCD point cloud needs pypcd4, which is not installed: pip install 'wsmap[study]'")


def test_reach_demo_cloud():
    pytest.importorskip("pypcd4")
    ts = targets_from_points(_demo("part.pcd"), standoff=0.0)
    assert len(ts) == 262
    _check_frames(ts, 0.0)
    assert np.all(ts.moved < 1e-5)  # single-precision unit normals
    # its normals agree with the demo mesh's winding and point towards the arm's base (the z axis)
    assert np.mean(np.sum(ts.normals[:, :2] * -ts.points[:, :2], axis=1) > 0) > 0.9


# ---------------------------------------------------------------------------------------------
# bad input: one line each, naming the file


def _message(fn, *args, **kwargs) -> str:
    with pytest.raises(ValueError) as e:
        fn(*args, **kwargs)
    assert "\n" not in str(e.value)
    return str(e.value)


@pytest.mark.parametrize(("spacing", "shown"), [(0, "0"), (-0.1, "-0.1"), (float("nan"), "nan"), (True, "True"),
                                                ("1", "'1'")])
def test_bad_spacing(spacing, shown):
    assert _message(targets_from_mesh, _box(), spacing) == (
        f"mesh: spacing must be a finite number of metres > 0, got {shown}")


@pytest.mark.parametrize(("standoff", "shown"), [(-0.01, "-0.01"), (float("nan"), "nan"), (float("inf"), "inf")])
def test_bad_standoff(tmp_path, standoff, shown):
    assert _message(targets_from_mesh, _box(), 0.05, standoff=standoff) == (
        f"mesh: standoff must be a finite number of metres >= 0, got {shown}")
    assert _message(targets_from_points, (np.zeros((1, 3)), np.ones((1, 3))), standoff=standoff) == (
        f"points: standoff must be a finite number of metres >= 0, got {shown}")


def test_too_many_targets_before_sampling():
    assert _message(targets_from_mesh, _box(), 1e-4) == (
        "mesh: spacing 0.0001 m gives about 52000000 targets on 0.52 m², more than 100000; give a spacing of at "
        "least 0.00228 m")
    assert _message(targets_from_mesh, _box(), 0.01, max_targets=1000) == (
        "mesh: spacing 0.01 m gives about 5200 targets on 0.52 m², more than 1000; give a spacing of at least "
        "0.0228 m")
    assert MAX_STUDY_TARGETS == 100_000


def test_bad_pose():
    bad = np.eye(4)
    bad[0, 0] = 2.0
    assert _message(targets_from_mesh, _box(), 0.05, pose=bad).startswith("pose is not a rigid transform")
    assert _message(targets_from_points, (np.zeros((1, 3)), np.ones((1, 3))), pose=np.eye(3)) == (
        "pose must have shape (..., 4, 4), got (3, 3)")


def test_bad_mesh_files(tmp_path):
    def write(name, text):
        path = tmp_path / name
        path.write_text(text)
        return path

    cases = {
        write("noface.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n"):
            "empty mesh (no triangles); give a surface mesh of the workpiece",
        write("nan.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n"):
            "the mesh has NaN or infinite vertices (first at vertex 1)",
        write("flat.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n"): "degenerate mesh: its triangles have zero area",
        write("junk.stl", "hello\n"): "not a mesh (too short for a binary STL: 6 bytes)",
        write("part.step", "ISO-10303-21;\n"): "not a mesh file: give an STL, OBJ or PLY (got '.step')",
        write("junk.ply", "hello\n"): "not a PLY file (no 'ply' ... 'end_header' header in its first 65536 bytes)",
    }
    for path, why in cases.items():
        assert _message(targets_from_mesh, path, 0.05) == f"mesh {path}: {why}"
    missing = tmp_path / "none.stl"
    assert _message(targets_from_mesh, missing, 0.05) == f"mesh {missing}: no such file"


def test_hostile_headers_refused_before_allocation(tmp_path):
    ply = tmp_path / "huge.ply"
    ply.write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\nproperty float x\n"
                    b"property float y\nproperty float z\nelement face 1000000000000\n"
                    b"property list uchar int vertex_indices\nend_header\n" + bytes(64))
    assert _message(targets_from_mesh, ply, 0.05) == (
        f"mesh {ply}: its PLY header declares 2000000000000 elements needing at least 13000000000000 bytes, but "
        "the file holds 64; the file is truncated or hostile")
    stl = tmp_path / "huge.stl"
    stl.write_bytes(bytes(80) + struct.pack("<I", 4_000_000_000) + bytes(100))
    assert _message(targets_from_mesh, stl, 0.05) == (
        f"mesh {stl}: not a mesh: its binary STL header declares 4000000000 triangles (200000000084 bytes) but the "
        "file holds 184 bytes")
    pcd = tmp_path / "huge.pcd"
    p, n = _cloud(5)
    names = ["x", "y", "z", "normal_x", "normal_y", "normal_z"]
    _write_pcd(pcd, np.hstack([p, n]), names, "binary", points=50_000)
    assert _message(targets_from_points, pcd) == (
        f"points {pcd}: its PCD header declares 50000 points needing at least 1200000 bytes, but the file holds "
        "120; the file is truncated or hostile")
    _write_pcd(pcd, np.hstack([p, n]), names, "binary_compressed")
    body = bytearray(pcd.read_bytes())
    at = body.index(b"DATA binary_compressed\n") + len("DATA binary_compressed\n")
    body[at + 4:at + 8] = struct.pack("<I", 4_000_000_000)  # the uncompressed size the reader would allocate
    pcd.write_bytes(bytes(body))
    assert _message(targets_from_points, pcd) == (
        f"points {pcd}: its compressed PCD data declares 4000000000 bytes in 124, but 5 points of 24 bytes are 120 "
        "and the file holds 124; the file is truncated or hostile")
    _write_pcd(pcd, np.hstack([p, n]), names, "binary", points=10**12)
    assert _message(targets_from_points, pcd) == f"points {pcd}: 1000000000000 points, more than 100000; thin the cloud"


def test_clouds_without_normals(tmp_path):
    p, _ = _cloud()
    ply = tmp_path / "xyz.ply"
    _write_ply(ply, p, ["x", "y", "z"])
    assert _message(targets_from_points, ply) == (
        f"points {ply}: the cloud has no normals (nx ny nz or normal_x normal_y normal_z); targets need the surface "
        "normals: compute them (e.g. PCL's NormalEstimation) and save them with the points")
    pcd = tmp_path / "xyz.pcd"
    _write_pcd(pcd, p, ["x", "y", "z"], "binary")
    assert _message(targets_from_points, pcd) == (
        f"points {pcd}: the cloud has no normals (normal_x normal_y normal_z); targets need the surface normals: "
        "compute them (e.g. PCL's NormalEstimation) and save them with the points")
    csv = tmp_path / "xyz.csv"
    csv.write_text("x y z\n1 2 3\n4 5 6\n")
    assert _message(targets_from_points, csv) == (
        f"points {csv}: the cloud has no normals (3 columns x y z); targets need the surface normals: give 6 "
        "columns x y z nx ny nz")
    # a mesh file's vertices alone are no cloud with normals
    box = tmp_path / "box.ply"
    _box().export(box)
    assert "the cloud has no normals" in _message(targets_from_points, box)


def test_bad_clouds(tmp_path):
    p, n = _cloud(4)
    n[2] = 0.0
    assert _message(targets_from_points, (p, n)) == (
        "points: a zero normal (first at point 2); every point needs its surface normal")
    p, n = _cloud(4)
    p[1, 0] = np.nan
    assert _message(targets_from_points, (p, n)) == "points: NaN or infinite values (first at point 1)"
    p, n = _cloud(4)
    assert _message(targets_from_points, (p, n), max_targets=3) == "points: 4 points, more than 3; thin the cloud"
    ply = tmp_path / "cloud.ply"
    _write_ply(ply, np.hstack([p, n]), ["x", "y", "z", "nx", "ny", "nz"], "binary_little_endian")
    assert _message(targets_from_points, ply, max_targets=3) == f"points {ply}: 4 points, more than 3; thin the cloud"
    csv = tmp_path / "bad.csv"
    csv.write_text("x,y,z,nx,ny,nz\n0,0,0,0,0,1\n0,0,oops,0,0,1\n")
    assert _message(targets_from_points, csv) == f"points {csv}: line 3, cell 3 is not a number: 'oops'"
    csv.write_text("0,0,0,0,0,1\n0,0,0,0,1\n")
    assert _message(targets_from_points, csv) == (
        f"points {csv}: every row needs 6 values x y z nx ny nz; found rows of [5, 6] values")
    other = tmp_path / "cloud.las"
    other.write_text("x")
    assert _message(targets_from_points, other) == (
        f"points {other}: not a point cloud file: give a PLY, PCD or CSV (got '.las')")
    assert _message(targets_from_points, (np.zeros((2, 3)), np.zeros((3, 3)))) == (
        "points: give points and normals as two (M, 3) arrays, got (2, 3) and (3, 3)")
