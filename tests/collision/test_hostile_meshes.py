"""Hostile collision meshes (issue 41): degenerate vertices that crash coal's convex hull, huge or
NaN coordinates, more triangles than a collision mesh may have. Each is one line naming the file,
before coal sees it; the crashing cases run in a subprocess, so that a segmentation fault fails the
test instead of killing pytest."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap

import numpy as np
import pytest
import trimesh

from wsmap.collision import CollisionError, Shape, load_scene
from wsmap.collision.checks import coal_shape
from wsmap.collision.shapes import mesh as mesh_module

TETRA_FACES = [[0, 1, 2], [0, 2, 3], [0, 1, 3], [1, 2, 3]]

#: name -> (vertices of a 4- or 5-vertex mesh, the message)
DEGENERATE = {
    "one point": ([[0.1, 0.2, 0.3]] * 5, "all its vertices are one point"),
    "one line": ([[0, 0, 0], [0.1, 0, 0], [0.2, 0, 0], [0.3, 0, 0]], "all its vertices lie on one line"),
    "one plane": ([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0.1, 0.1, 0]], "all its vertices lie in one plane"),
    "a plane to 1e-9": ([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0.03, 0.03, 1e-10]], "all its vertices lie in one plane"),
    "huge": ([[0, 0, 0], [1e300, 0, 0], [0, 1e300, 0], [0, 0, 1e300]], "a vertex 1e+300 m from its frame"),
}


def _obj(path, vertices, faces=TETRA_FACES):
    lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in vertices] + [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces]
    path.write_text("\n".join(lines) + "\n")
    return path


def _run(code: str, cwd) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], cwd=cwd, capture_output=True, text=True,
                          timeout=120)


@pytest.mark.parametrize("case", list(DEGENERATE))
def test_a_degenerate_scene_mesh_is_one_line_naming_the_file_not_a_crash(tmp_path, case):
    vertices, message = DEGENERATE[case]
    _obj(tmp_path / "part.obj", vertices)
    (tmp_path / "s.json").write_text(json.dumps({"obstacles": [{"name": "part", "shape": "mesh", "file": "part.obj"}]}))
    # the whole path a user takes: the scene read, then a checker built (coal's geometry of every obstacle)
    r = _run("""
        from wsmap.collision import CollisionError, checker_for, load_scene
        try:
            checker_for("ur5e", load_scene("s.json"), samples=10)
        except CollisionError as e:
            print("ERROR", e)
        """, tmp_path)
    assert r.returncode == 0, f"exit {r.returncode} (a negative code is a signal: -11 a segmentation fault)"
    out = r.stdout.strip()
    assert out.startswith("ERROR scene file") and "part.obj" in out and message in out, out
    assert len(out.splitlines()) == 1


def test_a_flat_mesh_through_the_command_line_exits_2_with_one_line_and_writes_nothing(tmp_path):
    _obj(tmp_path / "sheet.obj", DEGENERATE["one plane"][0])
    (tmp_path / "s.yaml").write_text("obstacles:\n  - {shape: mesh, file: sheet.obj, xyz: [0.4, 0, 0.3]}\n")
    r = subprocess.run([sys.executable, "-m", "wsmap", "map", "--robot", "ur5e", "--scene", "s.yaml", "--step", "0.5",
                        "--acm-samples", "10", "--quiet", "--out", "m.npz"], cwd=tmp_path, capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 2, r.stderr
    err = r.stderr.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    assert "sheet.obj" in err and "all its vertices lie in one plane" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.yaml", "sheet.obj"]


def test_a_flat_urdf_collision_mesh_names_the_urdf_and_the_link(tmp_path):
    trimesh.Trimesh([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0.1, 0.1, 0]], [[0, 1, 2], [1, 3, 2]]).export(
        tmp_path / "plate.stl")
    (tmp_path / "a.urdf").write_text(
        '<robot name="r"><link name="b"/><link name="h"><collision><geometry><mesh filename="plate.stl"/>'
        '</geometry></collision></link><joint name="j" type="revolute"><parent link="b"/><child link="h"/>'
        '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>')
    from wsmap.collision import from_urdf_collision

    with pytest.raises(CollisionError) as e:
        from_urdf_collision(tmp_path / "a.urdf")
    msg = str(e.value)
    assert msg.startswith("URDF file") and "a.urdf" in msg and "link 'h' <collision>" in msg
    assert "plate.stl" in msg and "in one plane" in msg and "\n" not in msg


def test_a_python_mesh_is_checked_before_coal_and_a_mutated_one_again_at_coal():
    with pytest.raises(CollisionError, match="all its vertices lie on one line"):
        Shape("mesh", (), np.eye(4), np.array(DEGENERATE["one line"][0], dtype=float), np.array(TETRA_FACES))
    with pytest.raises(CollisionError, match="faces must be"):
        Shape("mesh", (), np.eye(4), np.eye(4)[:, :3] * 0.1, np.array([[0, 1, 7]]))
    good = Shape("mesh", (), np.eye(4), np.array([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1]]),
                 np.array(TETRA_FACES), source="t.obj")
    assert coal_shape(good).num_points == 4
    good.vertices[:] = 0.0  # the array is the caller's: coal's geometry checks it once more
    with pytest.raises(CollisionError, match="collision mesh 't.obj' is not a solid: all its vertices are one point"):
        coal_shape(good)


def test_a_thin_but_solid_mesh_is_kept():
    # 1e-5 of its length thick: well above the flat bound (1e-6), and coal builds its hull
    v = np.array([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0.03, 0.03, 1e-6]])
    assert coal_shape(Shape("mesh", (), np.eye(4), v, np.array(TETRA_FACES))).num_points == 4


@pytest.mark.parametrize("text", ["v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 nan\nf 1 2 3\nf 1 2 4\n",
                                  "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 inf\nf 1 2 3\nf 1 2 4\n"])
def test_nan_and_infinite_vertices_are_refused(tmp_path, text):
    (tmp_path / "n.obj").write_text(text)
    (tmp_path / "s.yaml").write_text("obstacles:\n  - {shape: mesh, file: n.obj}\n")
    with pytest.raises(CollisionError, match=r"scene file .*s\.yaml.*n\.obj' has NaN or infinite vertices"):
        load_scene(tmp_path / "s.yaml")


def test_a_scale_that_takes_the_vertices_beyond_a_kilometre_is_refused(tmp_path):
    trimesh.creation.box((0.1, 0.1, 0.1)).export(tmp_path / "b.stl")
    (tmp_path / "s.yaml").write_text("obstacles:\n  - {shape: mesh, file: b.stl, scale: 100000}\n")
    with pytest.raises(CollisionError, match=r"scale is beyond 1000"):
        load_scene(tmp_path / "s.yaml")
    (tmp_path / "s.yaml").write_text("obstacles:\n  - {shape: mesh, file: b.stl, scale: 999}\n")
    assert load_scene(tmp_path / "s.yaml").obstacles[0].shape.vertices.max() == pytest.approx(49.95)
    (tmp_path / "s.yaml").write_text("obstacles:\n  - {shape: mesh, file: b.stl, scale: 999, xyz: [0, 0, 1.0e+308]}\n")
    with pytest.raises(CollisionError, match=r"obstacle 'mesh1' xyz is beyond 1000"):
        load_scene(tmp_path / "s.yaml")


def test_a_binary_stl_header_declaring_ten_million_triangles_is_refused_before_reading(tmp_path):
    p = tmp_path / "big.stl"
    p.write_bytes(b"\0" * 80 + (10_000_000).to_bytes(4, "little") + b"\0" * 100)
    (tmp_path / "s.yaml").write_text("obstacles:\n  - {shape: mesh, file: big.stl}\n")
    with pytest.raises(CollisionError, match=r"big\.stl' declares 10000000 triangles, more than 5000000"):
        load_scene(tmp_path / "s.yaml")
    p.write_bytes(b"\0" * 80 + (1000).to_bytes(4, "little") + b"\0" * 100)  # a header its size cannot hold
    with pytest.raises(CollisionError, match=r"header declares 1000 triangles \(50084 bytes\) but the file holds 184"):
        load_scene(tmp_path / "s.yaml")


def test_a_ply_header_declaring_too_many_faces_is_refused_before_reading(tmp_path):
    (tmp_path / "big.ply").write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
                                       b"property float y\nproperty float z\nelement face 99999999\n"
                                       b"property list uchar int vertex_indices\nend_header\n" + b"\0" * 64)
    (tmp_path / "s.yaml").write_text("obstacles:\n  - {shape: mesh, file: big.ply}\n")
    with pytest.raises(CollisionError, match=r"big\.ply' declares 99999999 triangles"):
        load_scene(tmp_path / "s.yaml")


@pytest.mark.parametrize("fmt", ["obj", "stl"])
def test_text_meshes_count_their_faces_before_trimesh_reads_them(tmp_path, monkeypatch, fmt):
    box = trimesh.creation.box((0.1, 0.1, 0.1))  # 12 triangles
    box.export(tmp_path / f"b.{fmt}", file_type=fmt if fmt == "obj" else "stl_ascii")
    assert mesh_module.mesh_header_triangles(str(tmp_path / f"b.{fmt}"), "x") == 12
    (tmp_path / "s.yaml").write_text(f"obstacles:\n  - {{shape: mesh, file: b.{fmt}}}\n")
    assert len(load_scene(tmp_path / "s.yaml").obstacles) == 1
    monkeypatch.setattr(mesh_module, "MAX_MESH_TRIANGLES", 11)
    with pytest.raises(CollisionError, match=rf"b\.{fmt}' declares 12 triangles, more than 11"):
        load_scene(tmp_path / "s.yaml")


def test_face_lines_straddling_the_reading_chunks_are_all_counted(tmp_path):
    # 4 MiB chunks: a file of several, face lines everywhere, every one counted once
    n = 600_000
    text = "v 0 0 0\nv 1 0 0\nv 0 1 0\n" + "f 1 2 3\n" * n
    (tmp_path / "m.obj").write_text(text)
    assert mesh_module.mesh_header_triangles(str(tmp_path / "m.obj"), "x") == n
