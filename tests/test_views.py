"""3-D views and exchange files of float maps (wsmap.views), the float z-slices of wsmap.viz, and
a standalone HTML view rendered in real headless Chromium (WebGL through SwiftShader)."""

from __future__ import annotations

import os
import re
import shutil
import subprocess

import numpy as np
import pytest
import trimesh

from wsmap.views import GLTF_FROM_GRID, figure_3d, iso_mesh, save_glb, save_html, save_ply
from wsmap.workspace import cartesian_grid, grid_spec

STEP = 0.1


@pytest.fixture(scope="module")
def sphere():
    """A reachability-index-like map on [-1, 1]³ at 0.1 m: clip(1 − r/0.8, 0, 1); 0.5 at r = 0.4 m."""
    grid = grid_spec("R3", -1.0, 1.0, STEP)
    nodes = cartesian_grid(grid["lo"], grid["hi"], grid["step"])
    values = np.clip(1.0 - np.linalg.norm(nodes, axis=1) / 0.8, 0.0, 1.0)
    return grid, nodes, values


@pytest.fixture(scope="module")
def small():
    """The same kind of map on a coarse grid (6³ nodes) for the browser."""
    grid = grid_spec("R3", -0.5, 0.5, 0.2)
    nodes = cartesian_grid(grid["lo"], grid["hi"], grid["step"])
    return grid, np.clip(1.0 - np.linalg.norm(nodes, axis=1) / 0.6, 0.0, 1.0)


# --------------------------------------------------------------------------------------------
# iso_mesh
# --------------------------------------------------------------------------------------------


def test_iso_surface_of_the_index_sphere_lies_at_its_radius(sphere):
    grid, _, values = sphere
    mesh = iso_mesh(values, grid, 0.5)
    assert len(mesh.faces) > 100
    radii = np.linalg.norm(mesh.vertices, axis=1)
    assert np.all(np.abs(radii - 0.4) < STEP), (radii.min(), radii.max())
    assert abs(np.median(radii) - 0.4) < 0.02
    assert mesh.is_watertight
    assert mesh.volume == pytest.approx(4 / 3 * np.pi * 0.4**3, rel=0.1)  # > 0: normals point outwards


def test_iso_surface_closes_at_the_grid_border_and_is_empty_above_the_data():
    grid = grid_spec("R3", 0.0, 0.3, 0.1)
    values = np.ones(64)  # above every level inside the grid: the surface is the grid's box
    box = iso_mesh(values, grid, 0.5)
    assert box.is_watertight
    lo, hi = box.bounds
    assert np.allclose(lo, -0.05) and np.allclose(hi, 0.35)  # half a step outside the border nodes
    for level in (1.0, 2.0):  # at or above the maximum: no node above the level
        empty = iso_mesh(values, grid, level)
        assert len(empty.vertices) == 0 and len(empty.faces) == 0


def test_iso_surface_is_placed_by_the_grid_frame():
    grid = grid_spec("R3", [1.0, 2.0, 3.0], [1.4, 2.4, 3.4], 0.1)
    values = np.zeros(125)
    values[62] = 1.0  # the middle node (2, 2, 2): (1.2, 2.2, 3.2)
    mesh = iso_mesh(values, grid, 0.5)
    assert np.allclose(mesh.vertices.mean(axis=0), [1.2, 2.2, 3.2])
    assert np.allclose(mesh.bounds, [[1.15, 2.15, 3.15], [1.25, 2.25, 3.25]])


# --------------------------------------------------------------------------------------------
# Files: GLB and PLY
# --------------------------------------------------------------------------------------------


def test_glb_round_trip_has_one_geometry_per_non_empty_level(sphere, tmp_path):
    grid, _, values = sphere
    path = save_glb(tmp_path / "index.glb", values, grid, levels=(0.25, 0.5, 0.75, 1.5))
    scene = trimesh.load(path)
    assert isinstance(scene, trimesh.Scene)
    assert sorted(scene.geometry) == ["level 0.25", "level 0.5", "level 0.75"]  # 1.5: empty, skipped
    colours = []
    for level in (0.25, 0.5, 0.75):
        geom = scene.geometry[f"level {level:g}"]
        radii = np.linalg.norm(geom.vertices, axis=1)  # the grid's frame
        assert np.all(np.abs(radii - 0.8 * (1 - level)) < STEP)
        material = geom.visual.material
        assert material.alphaMode == "BLEND" and 0 < material.baseColorFactor[3] < 255
        colours.append(tuple(material.baseColorFactor[:3]))
        node = next(n for n in scene.graph.nodes_geometry if scene.graph[n][1] == f"level {level:g}")
        assert np.allclose(scene.graph[node][0], GLTF_FROM_GRID)  # z up in the grid → y up in glTF
    assert len(set(colours)) == 3


def test_ply_has_the_nodes_above_the_threshold_coloured_by_value(sphere, tmp_path):
    grid, nodes, values = sphere
    threshold = 0.3
    path = save_ply(tmp_path / "index.ply", values, grid, threshold=threshold)
    cloud = trimesh.load(path)
    keep = values > threshold
    assert isinstance(cloud, trimesh.PointCloud)
    assert len(cloud.vertices) == keep.sum()
    assert np.allclose(cloud.vertices, nodes[keep], atol=1e-6)  # node order, metres
    raw = cloud.metadata["_ply_raw"]["vertex"]["data"]
    assert np.allclose(raw["value"], values[keep], atol=1e-6)
    colours = np.asarray(cloud.colors)
    assert colours.shape == (keep.sum(), 4) and np.all(colours[:, 3] == 255)
    order = np.argsort(values[keep], kind="stable")
    green = colours[order, 1].astype(int)  # viridis: green grows with the value
    assert np.all(np.diff(green) >= 0) and green[-1] - green[0] > 100
    assert len({tuple(c) for c in colours}) > 10


def test_ply_and_glb_show_the_nodes_not_found(sphere, tmp_path):
    grid, nodes, values = sphere
    status = np.where(values > 0, 0, 1).astype(np.int8)
    r = np.linalg.norm(nodes, axis=1)
    shell = (values == 0) & (r < 0.9)
    status[shell] = 2
    ply = save_ply(tmp_path / "index.ply", values, grid, status=status)
    cloud = trimesh.load(ply)
    raw = cloud.metadata["_ply_raw"]["vertex"]["data"]
    reached = values > 0
    assert len(cloud.vertices) == reached.sum() + shell.sum()
    assert np.allclose(cloud.vertices[reached.sum():], nodes[shell], atol=1e-6)  # the not-found nodes last
    assert list(raw["status"]) == [0] * reached.sum() + [2] * shell.sum()
    orange = np.asarray(cloud.colors)[reached.sum():]
    assert np.all(orange == [0xff, 0x9f, 0x1c, 255])
    assert b"comment status: 0 reached, 2 not found" in ply.read_bytes()[:1000]

    glb = save_glb(tmp_path / "index.glb", values, grid, status=status)
    scene = trimesh.load(glb)
    points = scene.geometry["not found"]
    assert isinstance(points, trimesh.PointCloud) and len(points.vertices) == shell.sum()
    node = next(n for n in scene.graph.nodes_geometry if scene.graph[n][1] == "not found")
    assert np.allclose(scene.graph[node][0], GLTF_FROM_GRID)
    assert np.allclose(np.sort(np.linalg.norm(points.vertices, axis=1)), np.sort(r[shell]), atol=1e-6)
    # every node decided: no point cloud, and the PLY has no orange vertex
    decided = np.where(values > 0, 0, 1).astype(np.int8)
    assert "not found" not in trimesh.load(save_glb(tmp_path / "d.glb", values, grid, status=decided)).geometry
    assert len(trimesh.load(save_ply(tmp_path / "d.ply", values, grid, status=decided)).vertices) == reached.sum()


@pytest.mark.parametrize("bad", [np.zeros(5, np.int8), np.full(21**3, 3, np.int8)])
def test_a_status_of_another_map_is_refused_before_writing(sphere, tmp_path, bad):
    grid, _, values = sphere
    for save, name in ((save_ply, "a.ply"), (save_glb, "a.glb")):
        with pytest.raises(ValueError, match="status must be the map's 9261 node codes"):
            save(tmp_path / name, values, grid, status=bad)
        assert not (tmp_path / name).exists()


# --------------------------------------------------------------------------------------------
# plotly
# --------------------------------------------------------------------------------------------


def test_figure_points_and_colour_bar(sphere):
    grid, nodes, values = sphere
    fig = figure_3d(values, grid, title="index", label="reachability index (1)")
    (trace,) = fig.data
    keep = values > 0
    assert trace.type == "scatter3d" and len(trace.x) == keep.sum()
    assert np.allclose(np.column_stack([trace.x, trace.y, trace.z]), nodes[keep])
    assert np.allclose(trace.marker.color, values[keep])
    assert fig.layout.coloraxis.colorbar.title.text == "reachability index (1)"
    assert fig.layout.scene.aspectmode == "data"
    assert [fig.layout.scene[a].title.text for a in ("xaxis", "yaxis", "zaxis")] == ["x (m)", "y (m)", "z (m)"]
    assert len(figure_3d(values, grid, threshold=0.5).data[0].x) == (values > 0.5).sum()


def test_figure_iso_and_so3_units(sphere):
    grid, _, values = sphere
    fig = figure_3d(values, grid, kind="iso", levels=(0.2, 0.6, 2.0), label="index")
    assert [t.type for t in fig.data] == ["isosurface", "isosurface"]  # 2.0 is above the data: no trace
    assert [(t.isomin, t.isomax) for t in fig.data] == [(0.2, 0.2), (0.6, 0.6)]
    assert len(fig.data[0].value) == values.size
    assert fig.layout.coloraxis.colorbar.title.text == "index"
    so3 = grid_spec("SO3", 0.0, np.pi, np.pi / 4)
    fig = figure_3d(np.linspace(0, 1, 125), so3)
    assert fig.layout.scene.xaxis.title.text == "r1 (rad)"


# --------------------------------------------------------------------------------------------
# Bad input: clear errors, nothing written
# --------------------------------------------------------------------------------------------

WRITERS = {
    "glb": lambda p, v, g: save_glb(p, v, g),
    "ply": lambda p, v, g: save_ply(p, v, g),
    "html": lambda p, v, g: save_html(p, v, g),
}


def _bad(values, kind):
    v = values.copy()
    if kind == "short":
        return v[:-1], r"values has 9260 nodes but the grid \[21, 21, 21\] has 9261"
    if kind == "nan":
        v[7] = np.nan
        return v, r"values contains 1 NaN or infinite values \(first at node 7\)"
    v[[3, 9]] = np.inf
    return v, r"values contains 2 NaN or infinite values \(first at node 3\)"


@pytest.mark.parametrize("suffix", sorted(WRITERS))
@pytest.mark.parametrize("kind", ["short", "nan", "inf"])
def test_bad_values_write_nothing(sphere, tmp_path, suffix, kind):
    grid, _, values = sphere
    bad, message = _bad(values, kind)
    path = tmp_path / "out" / f"map.{suffix}"
    with pytest.raises(ValueError, match=message):
        WRITERS[suffix](path, bad, grid)
    assert not path.exists() and not path.parent.exists()
    with pytest.raises(ValueError, match=message):
        iso_mesh(bad, grid, 0.5)


def test_bad_levels_thresholds_and_kinds(sphere, tmp_path):
    grid, _, values = sphere
    glb = tmp_path / "map.glb"
    with pytest.raises(ValueError, match=r"levels is empty: give at least one level"):
        save_glb(glb, values, grid, levels=())
    with pytest.raises(ValueError, match=r"every level must be a finite real number, got nan"):
        save_glb(glb, values, grid, levels=(0.5, float("nan")))
    with pytest.raises(ValueError, match=r"no node is above any of the levels \[1.0, 2.0\] "
                                         r"\(the map lies in \[0, 1\]\): no surface to write"):
        save_glb(glb, values, grid, levels=(1.0, 2.0))
    with pytest.raises(ValueError, match=r"level must be a finite real number, got inf"):
        iso_mesh(values, grid, np.inf)
    ply = tmp_path / "map.ply"
    with pytest.raises(ValueError, match=r"no node is above the threshold 1 .*: no point to write"):
        save_ply(ply, values, grid, threshold=1.0)
    with pytest.raises(ValueError, match=r"unknown colormap 'no-such-map'"):
        save_ply(ply, values, grid, colormap="no-such-map")
    html = tmp_path / "map.html"
    with pytest.raises(ValueError, match=r"kind must be 'points' or 'iso', got 'voxels'"):
        save_html(html, values, grid, kind="voxels")
    with pytest.raises(ValueError, match=r"grid 'shape' \[21, 21, 20\] does not match"):
        save_html(html, values[:-441], dict(grid, shape=[21, 21, 20]))
    with pytest.raises(ValueError, match=r"grid is missing \['step'\]"):
        figure_3d(values, {"lo": [0, 0, 0], "shape": [21, 21, 21]})
    with pytest.raises(ValueError, match=r"is a directory"):
        save_html(tmp_path, values, grid)
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_a_failed_write_keeps_the_old_file(sphere, tmp_path):
    grid, _, values = sphere
    path = tmp_path / "map.ply"
    save_ply(path, values, grid)
    before = path.read_bytes()
    with pytest.raises(ValueError):
        save_ply(path, np.full_like(values, np.nan), grid)
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["map.ply"]  # no temporary file left


# --------------------------------------------------------------------------------------------
# viz.plot_value_slices
# --------------------------------------------------------------------------------------------


def test_value_slices_share_one_labelled_colour_bar(small):
    import matplotlib.pyplot as plt

    from wsmap.viz import plot_value_slices

    grid, values = small
    fig = plot_value_slices(values, grid["shape"], grid["lo"], grid["step"], label="reachability index",
                            vmin=0.0, vmax=1.0, ncols=4)
    panels = [ax for ax in fig.axes if ax.images]
    assert len(panels) == grid["shape"][2]
    assert {ax.images[0].get_clim() for ax in panels} == {(0.0, 1.0)}
    (cbar,) = [ax for ax in fig.axes if ax.get_ylabel() == "reachability index"]
    assert cbar not in panels
    plt.close(fig)
    bad = values.copy()
    bad[2] = np.nan
    with pytest.raises(ValueError, match=r"values contain 1 NaN or infinite values \(first at node 2\)"):
        plot_value_slices(bad, grid["shape"], grid["lo"], grid["step"], label="index")


# --------------------------------------------------------------------------------------------
# Standalone HTML in real headless Chromium
# --------------------------------------------------------------------------------------------

#: Headless Chromium with WebGL on the CPU (SwiftShader through ANGLE); root needs --no-sandbox.
CHROMIUM_FLAGS = ("--headless=new", "--no-sandbox", "--disable-gpu", "--use-angle=swiftshader",
                  "--enable-unsafe-swiftshader", "--disable-dev-shm-usage", "--no-first-run",
                  "--virtual-time-budget=15000")


def _chromium() -> str | None:
    for name in ("chromium", "chromium-browser"):
        found = shutil.which(name)
        if found:
            return found
    return "/usr/bin/chromium" if os.access("/usr/bin/chromium", os.X_OK) else None


def test_html_renders_a_webgl_scene_in_headless_chromium(small, tmp_path):
    browser = _chromium()
    if browser is None:
        if os.environ.get("CI"):
            pytest.fail("chromium is not installed; CI (.ci/run) installs it with apt-get install chromium")
        pytest.skip("chromium is not installed (apt-get install chromium); CI runs this test")
    grid, values = small
    page = save_html(tmp_path / "view.html", values, grid, title="index sphere", label="reachability index")
    text = page.read_text()
    # plotly.js inline: no script is loaded from elsewhere (there is no network)
    assert "Plotly.newPlot" in text and len(text) > 1_000_000
    assert re.findall(r"<script\b[^>]*>", text) and not re.findall(r"<script\b[^>]*\bsrc=", text)
    run = subprocess.run([browser, *CHROMIUM_FLAGS, f"--user-data-dir={tmp_path / 'profile'}", "--dump-dom",
                          page.resolve().as_uri()], capture_output=True, text=True, timeout=90,
                         env=dict(os.environ, HOME=str(tmp_path)))
    assert run.returncode == 0, run.stderr[-2000:]
    # the dump repeats the inline plotly.js, whose source holds the "no WebGL" message: look outside scripts
    dom = re.sub(r"<script\b[^>]*>.*?</script>", "", run.stdout, flags=re.S | re.I)
    assert "plotly-graph-div" in dom
    assert "WebGL is not supported" not in dom and "no-webgl" not in dom
    # with WebGL the scene's canvas is sized to the plot; without it plotly leaves bare <canvas></canvas>
    sizes = [(int(w), int(h)) for w, h in re.findall(r'<canvas width="(\d+)" height="(\d+)"', dom)]
    assert sizes and all(w > 100 and h > 100 for w, h in sizes), re.findall(r"<canvas[^>]*>", dom)
    assert "reachability index" in dom  # the colour bar (SVG) was drawn after the scene


# --------------------------------------------------------------------------------------------
# figure_3d: threshold slider and cut plane
# --------------------------------------------------------------------------------------------


def test_threshold_slider_shows_one_trace_at_a_time(sphere):
    grid, nodes, values = sphere
    fig = figure_3d(values, grid, thresholds=[0.5, 0.0, 0.25, 2.0])  # sorted; 2.0 lies above the map: dropped
    assert [len(t.x) for t in fig.data] == [(values > t).sum() for t in (0.0, 0.25, 0.5)]
    assert [t.visible for t in fig.data] == [True, False, False]
    (slider,) = fig.layout.sliders
    assert [s.label for s in slider.steps] == ["0", "0.25", "0.5"]
    assert [s.args[0]["visible"] for s in slider.steps] == [[True, False, False], [False, True, False],
                                                            [False, False, True]]
    assert slider.currentvalue.prefix == "reachability index > "
    with pytest.raises(ValueError, match="thresholds must be a non-empty sequence of numbers"):
        figure_3d(values, grid, thresholds=[])


def test_cut_plane_ends_the_z_range_at_each_layer(sphere):
    grid, _, values = sphere
    fig = figure_3d(values, grid, cut_plane=True)
    (slider,) = fig.layout.sliders
    assert len(slider.steps) == 21 and slider.active == 20
    assert slider.steps[0].args[0]["scene.zaxis.range"] == pytest.approx([-1.05, -0.95])
    assert slider.steps[12].label == "0.20"
    assert slider.steps[12].args[0]["scene.zaxis.range"] == pytest.approx([-1.05, 0.25])
    # the scene keeps the whole grid's box while the z range shrinks
    assert fig.layout.scene.aspectmode == "manual"
    assert fig.layout.scene.xaxis.range == pytest.approx((-1.05, 1.05))
    assert slider.currentvalue.prefix == "z (m) ≤ "


def _table():
    """A table-top box (0.6 x 0.8 x 0.04 m at (0.55, 0, 0.3)) as the collision layer draws it."""
    from wsmap.collision import Obstacle, Scene, Shape

    T = np.eye(4)
    T[:3, 3] = [0.55, 0.0, 0.3]
    return Scene(obstacles=(Obstacle("table", Shape("box", (0.6, 0.8, 0.04), T), "world"),)).triangles()


def test_obstacles_are_solids_beside_the_map_and_stay_through_the_threshold_slider(sphere):
    grid, _, values = sphere
    fig = figure_3d(values, grid, thresholds=[0.0, 0.5], obstacles=_table(), title="panda: constant map")
    assert [t.type for t in fig.data] == ["scatter3d", "scatter3d", "mesh3d"]
    mesh = fig.data[2]
    assert mesh.name == "obstacle: table" and len(mesh.i) == 12
    assert (min(mesh.x), max(mesh.x), min(mesh.z), max(mesh.z)) == pytest.approx((0.25, 0.85, 0.28, 0.32))
    # the slider restyles the map's two traces only, so the table never disappears
    (slider,) = fig.layout.sliders
    assert [list(s.args[1]) for s in slider.steps] == [[0, 1], [0, 1]]
    with pytest.raises(ValueError, match="^obstacle 'table': vertices must be"):
        figure_3d(values, grid, obstacles=[("table", np.zeros((4, 2)), [[0, 1, 2]])])


def test_a_collision_aware_maps_html_names_the_scene_and_draws_its_table(tmp_path):
    pytest.importorskip("coal")
    pytest.importorskip("plotly")
    from wsmap import jobs

    scene = tmp_path / "table.yaml"
    scene.write_text("floor: true\nobstacles:\n  - {name: table, shape: box, size: [0.6, 0.8, 0.04], "
                     "xyz: [0.55, 0, 0.3]}\n")
    job = jobs.MapJob(arm=jobs.ArmSource(robot="ur5e"), rpy=(np.pi, 0, 0), step=0.25,
                      collision=jobs.CollisionSource(scene=str(scene), acm_samples=100),
                      outputs=jobs.MapOutputs(html=str(tmp_path / "m.html")))
    job.save(job.run())
    text = (tmp_path / "m.html").read_text()
    assert '"text":"ur5e: constant map, collision-free: scene table.yaml\\u003cbr\\u003enodes: ' in text  # then the counts
    assert '"name":"obstacle: table"' in text and '"type":"mesh3d"' in text
