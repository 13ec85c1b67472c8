"""The reach study's pictures (`wsmap.study_views`): PNG, HTML and PLY of a tiny real study
(a UR5e and a bar of a workpiece that reaches past the arm's reach), read back with trimesh, the HTML's
own plotly JSON and the PNG's header."""

from __future__ import annotations

import base64
import json
import struct

import matplotlib
import numpy as np
import pytest
import trimesh

from wsmap import robots
from wsmap.io import OutputPathError
from wsmap.workspace import study as st
from wsmap import study_views as sv
from wsmap.workspace.study_files import StudyResult
from wsmap.workspace.workpiece import TargetSet, targets_from_mesh

POSE = np.array([[1.0, 0, 0, 0.8], [0, 1, 0, 0.1], [0, 0, 1, 0.2], [0, 0, 0, 1]])  # the bar's frame in the world


@pytest.fixture(scope="module")
def study() -> StudyResult:
    """A bar 1.2 m long from x = 0.2 m to 1.4 m: its near half within the UR5e's reach, its far half not."""
    bar = trimesh.creation.box(extents=(1.2, 0.1, 0.1)).subdivide().subdivide()
    ts = targets_from_mesh(bar, 0.08, pose=POSE)
    V = st.tool_variants(turns=4)
    res = st.evaluate_targets(robots.load("ur5e"), ts.poses, variants=V)
    assert 0 < res.reached.sum() < len(ts)  # both kinds of target
    return StudyResult(names=["ur5e"], targets=ts, results=[[res]], variants=V,
                       settings={"targets": {"pose": POSE.reshape(-1).tolist()}})


@pytest.fixture(scope="module")
def cloud(study) -> StudyResult:
    """The same study with its targets as a point cloud (no mesh)."""
    t = study.targets
    ts = TargetSet(points=t.points, normals=t.normals, poses=t.poses, moved=t.moved, vertices=None, faces=None,
                   source="cloud")
    return StudyResult(names=study.names, targets=ts, results=study.results, variants=study.variants, settings={})


def _expected_rgb(values, hi):
    """Independently: matplotlib's viridis over [0, hi] in its own bytes, grey where NaN."""
    norm = matplotlib.colors.Normalize(0.0, hi)
    rgb = matplotlib.colormaps["viridis"](norm(np.nan_to_num(values, nan=0.0)), bytes=True)[:, :3]
    rgb[np.isnan(values)] = sv.UNREACHED_RGB
    return rgb


def _nearest_values(study):
    """Each mesh vertex's value by brute force: the score of its nearest target (NaN if unreached)."""
    t, res = study.targets, study.results[0][0]
    d = np.linalg.norm(t.vertices[:, None] - t.points[None], axis=-1)
    return np.where(res.reached, res.score, np.nan)[d.argmin(axis=1)]


def _plotly_data(html: str) -> list:
    marker = f'"{sv.HTML_DIV_ID}",'
    start = html.index(marker, html.index("Plotly.newPlot(")) + len(marker)
    data, _ = json.JSONDecoder().raw_decode(html[start:].lstrip())
    return data


def _array(v):
    """A plotly JSON array: a list, or a typed array `{dtype, bdata}` (base64)."""
    if isinstance(v, dict):
        return np.frombuffer(base64.b64decode(v["bdata"]), dtype=np.dtype(v["dtype"]))
    return np.asarray(v, dtype=np.float64)


def test_the_ply_is_the_mesh_coloured_by_the_nearest_targets_score(study, tmp_path):
    (ply,) = sv.save_views(study, ply=tmp_path / "s.ply")
    mesh = trimesh.load(ply, process=False)
    t = study.targets
    assert isinstance(mesh, trimesh.Trimesh)
    np.testing.assert_array_equal(mesh.faces, t.faces)
    np.testing.assert_allclose(mesh.vertices, t.vertices, atol=1e-6)  # float32 positions
    values = _nearest_values(study)
    assert np.isnan(values).any() and np.isfinite(values).any()
    hi = np.nanmax(study.results[0][0].score)
    np.testing.assert_array_equal(mesh.visual.vertex_colors[:, :3], _expected_rgb(values, hi))
    header = ply.read_bytes().split(b"end_header")[0].decode()
    assert "format binary_little_endian 1.0" in header and "property uchar red" in header


def test_without_a_mesh_the_ply_is_the_targets_as_coloured_points(cloud, tmp_path):
    (ply,) = sv.save_views(cloud, ply=tmp_path / "c.ply")
    pc = trimesh.load(ply)
    res = cloud.results[0][0]
    assert isinstance(pc, trimesh.PointCloud)
    np.testing.assert_allclose(pc.vertices, cloud.targets.points, atol=1e-6)
    values = np.where(res.reached, res.score, np.nan)
    np.testing.assert_array_equal(pc.colors[:, :3], _expected_rgb(values, np.nanmax(values)))


def test_the_html_holds_one_mesh3d_with_the_scores_as_intensities(study, tmp_path):
    (html,) = sv.save_views(study, html=tmp_path / "s.html")
    text = html.read_text()
    assert "<script src=" not in text.split(sv.HTML_DIV_ID)[0] and len(text) > 3_000_000  # plotly.js inlined
    data = _plotly_data(text)
    meshes = [d for d in data if d["type"] == "mesh3d"]
    assert len(meshes) == 1
    intensity = _array(meshes[0]["intensity"])
    values = _nearest_values(study)
    ok = np.isfinite(values)
    np.testing.assert_array_equal(intensity[ok], values[ok])
    hi = np.nanmax(study.results[0][0].score)
    np.testing.assert_allclose(intensity[~ok], -sv.UNREACHED_BAND * hi)  # the grey band below vmin = 0
    assert meshes[0]["cmin"] == pytest.approx(-sv.UNREACHED_BAND * hi) and meshes[0]["cmax"] == pytest.approx(hi)
    # hover: one text per target, a reached one with its solution in degrees and the tool's turn
    res = study.results[0][0]
    hover = [h for d in data if d["type"] == "scatter3d" and "hovertext" in d and d.get("mode") == "markers"
             for h in d["hovertext"]]
    assert len(hover) == len(res.status)
    m = int(np.flatnonzero(res.reached)[0])
    text_m = next(h for h in hover if h.startswith(f"target {m}: reached"))
    q_deg = ", ".join(f"{x:.1f}" for x in np.degrees(res.q[m]))
    turn = 90.0 * res.variant[m]  # four turns: 0, 90, 180, 270 degrees
    assert f"q (deg) [{q_deg}]" in text_m and f"tool turn {turn:.1f} deg, tilt 0.0 deg" in text_m
    assert f"score {res.score[m]:.4g}" in text_m
    assert any(h.endswith("certified unreachable") for h in hover)


def test_without_a_mesh_the_html_colours_the_target_markers(cloud, tmp_path):
    (html,) = sv.save_views(cloud, html=tmp_path / "c.html")
    data = _plotly_data(html.read_text())
    assert not [d for d in data if d["type"] == "mesh3d"]
    res = cloud.results[0][0]
    reached = next(d for d in data if d.get("name", "").startswith("reached"))
    np.testing.assert_array_equal(_array(reached["marker"]["color"]), res.score[res.reached])


def test_the_png_has_its_size_and_the_score_colours(study, tmp_path):
    (png,) = sv.save_views(study, png=tmp_path / "s.png")
    blob = png.read_bytes()
    assert blob[:8] == b"\x89PNG\r\n\x1a\n"
    assert struct.unpack(">II", blob[16:24]) == sv.PNG_SIZE == (1000, 800)
    img = matplotlib.image.imread(png)
    assert img.shape[:2] == (800, 1000)
    # the colour bar's top is viridis's last colour
    rgb = np.round(img[..., :3] * 255).astype(int).reshape(-1, 3)
    assert (np.abs(rgb - [253, 231, 36]).sum(axis=1) <= 3).any()


def test_two_writes_give_the_same_bytes(study, tmp_path):
    a = sv.save_views(study, png=tmp_path / "a.png", html=tmp_path / "a.html", ply=tmp_path / "a.ply")
    b = sv.save_views(study, png=tmp_path / "b.png", html=tmp_path / "b.html", ply=tmp_path / "b.ply")
    assert [p.suffix for p in a] == [".png", ".html", ".ply"]
    for x, y in zip(a, b):
        assert x.read_bytes() == y.read_bytes(), x.name


def test_tool_angles_name_the_turn_and_the_tilt():
    V = st.tool_variants(turns=4, cone=0.3, rings=1, per_ring=4)
    ang = sv.tool_angles(V)
    np.testing.assert_allclose(ang[:, 0], np.repeat([0.0, 90.0, 180.0, 270.0], 5), atol=1e-9)
    np.testing.assert_allclose(ang[:, 1], np.tile([0.0] + [np.degrees(0.3)] * 4, 4), atol=1e-9)


def test_the_title_counts_the_reached_targets(study):
    hm = sv.heat_map(study)
    res = study.results[0][0]
    n, total = int(res.reached.sum()), len(res.status)
    assert hm.title == (f"ur5e: reached {n} of {total} ({100 * n / total:.1f} %); "
                        "colour: score (manipulability x joint_margin)")
    np.testing.assert_array_equal(hm.workpiece, POSE)
    assert sv.heat_map(study, score="joint_margin").label == "joint_margin (1)"


def test_bad_outputs_and_choices_are_one_line_before_anything_is_written(study, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    with pytest.raises(ValueError, match=r"^the png view '.*s\.jpg' must end in \.png$"):
        sv.save_views(study, png=out / "s.jpg", ply=out / "s.ply")
    (tmp_path / "file").write_text("")
    with pytest.raises(OutputPathError):
        sv.save_views(study, png=out / "s.png", ply=tmp_path / "file" / "s.ply")
    with pytest.raises(ValueError, match=r"^the study has arms 0 to 0, got arm 1$"):
        sv.save_views(study, ply=out / "s.ply", arm=1)
    with pytest.raises(ValueError, match=r"^the study has no score 'clearance'; it has: score, manipulability, "
                                         r"joint_margin$"):
        sv.save_views(study, ply=out / "s.ply", score="clearance")
    with pytest.raises(ValueError, match=r"^the colour range must be finite with vmin < vmax, got \[1.0, 0.5\]$"):
        sv.save_views(study, ply=out / "s.ply", vmin=1.0, vmax=0.5)
    assert list(out.iterdir()) == []
