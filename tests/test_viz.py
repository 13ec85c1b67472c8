"""wsmap.viz, wsmap.io and wsmap.timing: the figure, table and timing helpers of the notebooks."""

import json
import math

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pandas as pd
import pytest

from wsmap import io, metrics, viz
from wsmap.kinematics import arm_batch
from wsmap.timing import time_call
from wsmap import robots
from wsmap.views import iso_mesh
from wsmap.viz import save_figure
from wsmap.learn.training import History


def _hist(values, key="grad_norm"):
    h = History()
    for i, v in enumerate(values):
        h.epoch.append(i)
        h.time.append(0.1 * i)
        for k in ("loss", "grad_norm", "val_loss"):
            h.__getattribute__(k).append(v if k == key else 1.0 / (i + 1))
    return h


def test_plot_mean_band_log_axis_with_sigma_above_mean(tmp_path):
    # one session spikes: mean - sigma < 0 at epoch 1, the log band must still draw
    curves = np.array([[1.0, 100.0, 0.5], [1.0, 0.01, 0.4], [2.0, 0.01, np.nan]])
    fig = viz.plot_mean_band(curves, logy=True, ylabel="g", title="t")
    ax = fig.axes[0]
    assert ax.get_yscale() == "log"
    save_figure(fig, tmp_path / "band.png")
    assert (tmp_path / "band.png").stat().st_size > 5_000


def test_plot_training_curves(tmp_path):
    hs = [_hist([1.0, 0.5, 0.2], key="loss"), _hist([2.0, 1.0], key="loss")]
    fig = viz.plot_training_curves(hs, ["a", "b"], best_epochs=[2, 1], title="x")
    save_figure(fig, tmp_path / "train.png")
    assert (tmp_path / "train.png").stat().st_size > 5_000
    with pytest.raises(ValueError):
        viz.plot_training_curves(hs, ["a"])


def test_plot_sections_grid(tmp_path):
    rng = np.random.default_rng(0)
    truth = rng.random((7, 5 * 4 * 3)) > 0.5
    pred = rng.random((7, 5 * 4 * 3)) > 0.5
    fig = viz.plot_sections(pred, truth, (5, 4, 3), layer=1, z_value=0.3, titles=[str(i) for i in range(7)], ncols=3)
    assert len([a for a in fig.axes if a.get_images()]) == 7
    save_figure(fig, tmp_path / "sections.png")
    assert (tmp_path / "sections.png").stat().st_size > 5_000
    with pytest.raises(ValueError):
        viz.plot_sections(pred, truth, (5, 4, 3), layer=3)


def test_plot_threshold_sweep_and_errors_and_histograms(tmp_path):
    rng = np.random.default_rng(1)
    truth = rng.random((50, 30)) > 0.6
    scores = (truth + rng.normal(0, 0.3, truth.shape)).astype(np.float32)
    sweep = metrics.threshold_sweep(scores, truth)
    save_figure(viz.plot_threshold_sweep(sweep, mark=0.5, title="s"), tmp_path / "sweep.png")
    save_figure(viz.plot_sample_errors(metrics.per_sample_error(scores, truth), title="e"), tmp_path / "err.png")
    h = metrics.error_histogram(scores, truth, bins=20)
    h2 = metrics.error_histogram(scores[:10], truth[:10], bins=h.edges)
    save_figure(viz.plot_error_histograms([h, h2, h], ["a", "b", "c"], ncols=2), tmp_path / "hist.png")
    for name in ("sweep", "err", "hist"):
        assert (tmp_path / f"{name}.png").stat().st_size > 5_000


def test_runtime_plot(tmp_path):
    calls = []
    t = np.asarray(time_call(lambda: calls.append(1), repeats=4, warmup=2).values)
    assert t.shape == (4,) and np.all(t >= 0) and len(calls) == 6
    fig = viz.plot_runtimes({"one": {"a": t, "assembled": 2 * t}, "many": {"a": t}}, unit="us")
    save_figure(fig, tmp_path / "rt.png")
    assert (tmp_path / "rt.png").stat().st_size > 5_000


def test_meshes_plot_and_export(tmp_path):
    import trimesh

    vol = np.zeros((6, 6, 6), dtype=bool)
    vol[1:4, 1:5, 2:5] = True
    mesh = iso_mesh(vol.reshape(-1), {"lo": -0.5, "step": 0.2, "shape": (6, 6, 6)}, 0.5)
    fig = viz.plot_meshes([mesh, trimesh.Trimesh(), None], ["box", "empty", "none"], lim=0.6, suptitle="m")
    save_figure(fig, tmp_path / "meshes.png")
    assert (tmp_path / "meshes.png").stat().st_size > 5_000
    for ext in ("stl", "glb"):
        path = viz.export_mesh(mesh, tmp_path / f"m.{ext}")
        back = trimesh.load(path, force="mesh")
        assert len(back.faces) == len(mesh.faces)
        np.testing.assert_allclose(back.volume, mesh.volume, rtol=1e-5)
    with pytest.raises(ValueError):
        viz.export_mesh(mesh, tmp_path / "nosuffix")


def test_write_table_and_markdown(tmp_path):
    df = pd.DataFrame({"name": ["a|b", "c"], "f": [0.123456, float("nan")], "n": [3, 4], "tiny": [1e-6, 2e6]})
    csv, md = io.write_table(df, tmp_path / "t")
    assert csv.name == "t.csv" and md.name == "t.md"
    back = pd.read_csv(csv)
    assert list(back.columns) == list(df.columns) and back["n"].tolist() == [3, 4]
    text = md.read_text().splitlines()
    assert text[0] == "| name | f | n | tiny |"
    assert text[1] == "|---|---|---|---|"
    assert text[2] == "| a\\|b | 0.1235 | 3 | 1e-06 |"
    assert text[3] == "| c | NaN | 4 | 2e+06 |"
    ints = pd.DataFrame({"e": [200, None]}).astype({"e": "Int64"})  # pandas' NA prints empty
    assert io.markdown_table(ints).splitlines()[2:] == ["| 200 |", "|  |"]


def test_write_json_converts_numpy_and_nan(tmp_path):
    path = io.write_json({"a": np.float32(0.5), "b": np.arange(3), "c": float("nan"), "d": [np.bool_(True)],
                         "e": np.int64(7)}, tmp_path / "m.json")
    assert json.loads(path.read_text()) == {"a": 0.5, "b": [0, 1, 2], "c": None, "d": [True], "e": 7}


def test_arm_batch():
    from wsmap import datasets
    from wsmap.paper.specs import PAPER_SPECS

    puma = robots.puma560()
    batch = arm_batch(puma)
    assert batch.batch_shape == (1,)
    np.testing.assert_array_equal(batch.d[0], puma.d)
    assert arm_batch(batch) is batch
    spec = PAPER_SPECS["sec62"]
    x = datasets.features_for(batch, spec)
    assert x.shape == (1, 84)
    labels = datasets.labels_for(batch, spec)
    assert labels.shape == (1, 9261) and labels.any()


# --------------------------------------------------------------------------------------------
# Map slices a roboticist reads: metres, units, a legend, no empty panels, settings in the PNG
# --------------------------------------------------------------------------------------------


def _ball_map():
    """A ball of radius 0.35 m about (0, 0, 0.2) on [-1, 1]³ at 0.1 m: reachable in z-layers 0.0 .. 0.5 only."""
    from wsmap.workspace import cartesian_grid

    nodes = cartesian_grid(-1.0, 1.0, 0.1)
    return np.linalg.norm(nodes - [0.0, 0.0, 0.2], axis=1) <= 0.35, nodes


def test_slices_drop_empty_layers_and_read_in_metres():
    import matplotlib.pyplot as plt

    reach, nodes = _ball_map()
    fig = viz.plot_slices(reach, (21, 21, 21), -1.0, 0.1, title="ball")
    panels = [ax for ax in fig.axes if ax.images]
    zs = sorted({round(z, 2) for z in nodes[reach, 2]})
    assert zs == [-0.1, 0.0, 0.1, 0.2, 0.3, 0.4, 0.5]
    assert [ax.get_title() for ax in panels] == [f"z = {z:.2f} m" for z in zs]
    # every cell is centred on its node: the image spans the grid plus half a step each side
    assert np.allclose(panels[0].images[0].get_extent(), [-1.05, 1.05, -1.05, 1.05])
    assert {ax.get_xlabel() for ax in panels if ax.get_xlabel()} == {"x (m)"}
    assert {ax.get_ylabel() for ax in panels if ax.get_ylabel()} == {"y (m)"}
    (legend,) = fig.legends
    assert [t.get_text() for t in legend.get_texts()] == ["reachable", "unreachable"]
    assert legend.get_title().get_text() == "14 empty z-layers left out"
    # the layer z = 0.2 m holds the ball's equator: 11 x 11 nodes within 0.35 m of its centre... in the picture
    (mid,) = [ax for ax in panels if ax.get_title() == "z = 0.20 m"]
    assert mid.images[0].get_array().sum() == reach[np.isclose(nodes[:, 2], 0.2)].sum()
    plt.close(fig)


def test_slices_show_the_nodes_not_found_apart_from_the_certified_ones():
    import matplotlib.pyplot as plt
    from wsmap.workspace.status import CERTIFIED, NOT_FOUND, REACHED

    reach, nodes = _ball_map()
    status = np.where(reach, REACHED, CERTIFIED).astype(np.int8)
    shell = ~reach & (np.linalg.norm(nodes - nodes[reach].mean(axis=0), axis=1) < 0.45)
    status[shell] = NOT_FOUND
    fig = viz.plot_slices(reach, (21, 21, 21), -1.0, 0.1, status=status)
    (legend,) = fig.legends
    assert [t.get_text() for t in legend.get_texts()] == ["reachable", "certified unreachable",
                                                          f"not found ({int(shell.sum())})"]
    (mid,) = [ax for ax in fig.axes if ax.images and ax.get_title() == "z = 0.20 m"]
    cells = mid.images[0].get_array()
    layer = np.isclose(nodes[:, 2], 0.2)
    assert (cells == 2).sum() == shell[layer].sum() > 0 and (cells == 1).sum() == reach[layer].sum()
    plt.close(fig)
    with pytest.raises(ValueError, match="status= colours one map's nodes; it cannot be drawn with compare="):
        viz.plot_slices(reach, (21, 21, 21), -1.0, 0.1, status=status, compare=reach)


def test_slices_thin_a_long_stack_and_keep_its_ends():
    import matplotlib.pyplot as plt

    reach = np.ones(5 * 5 * 30, dtype=bool)
    fig = viz.plot_slices(reach, (5, 5, 30), 0.0, 0.05, max_panels=8)
    titles = [ax.get_title() for ax in fig.axes if ax.images]
    assert len(titles) == 8 and titles[0] == "z = 0.00 m" and titles[-1] == "z = 1.45 m"
    # the note names the layers drawn (the gaps are 4 or 5 layers: not evenly spaced)
    drawn = ", ".join(t.split(" = ")[1][:-2] for t in titles)
    assert fig.legends[0].get_title().get_text() == f"8 of 30 non-empty z-layers shown: z = {drawn} m"
    assert drawn == "0.00, 0.20, 0.40, 0.60, 0.85, 1.05, 1.25, 1.45"
    plt.close(fig)
    # layers skipped for being empty, then thinned: the note names exactly the panels' layers
    values = np.zeros((30, 5, 5))
    values[[0, 1, 2, 10, 11, 20, 28, 29]] = 0.5
    fig = viz.plot_value_slices(values.reshape(-1), (5, 5, 30), 0.0, 0.05, label="index", max_panels=4)
    titles = [ax.get_title() for ax in fig.axes if ax.images]
    assert titles == ["z = 0.00 m", "z = 0.10 m", "z = 1.00 m", "z = 1.45 m"]
    assert fig.legends[0].get_title().get_text() == ("22 empty z-layers left out; 4 of 8 non-empty z-layers shown: "
                                                     "z = 0.00, 0.10, 1.00, 1.45 m")
    plt.close(fig)
    with pytest.raises(ValueError, match="max_panels must be at least 1, got 0"):
        viz.plot_slices(reach, (5, 5, 30), max_panels=0)


def test_value_slices_grey_out_unreachable_nodes_apart_from_the_scale():
    import matplotlib.pyplot as plt

    reach, nodes = _ball_map()
    values = np.where(reach, 0.5 + 0.5 * (nodes[:, 0] > 0), 0.0)
    fig = viz.plot_value_slices(values, (21, 21, 21), -1.0, 0.1, label="reachability index", vmin=0, vmax=1)
    panels = [ax for ax in fig.axes if ax.images]
    assert len(panels) == 7
    image = panels[3].images[0].get_array()
    assert image.mask.sum() == (~reach[np.isclose(nodes[:, 2], 0.2)]).sum()  # the unreachable cells
    (legend,) = fig.legends
    assert [t.get_text() for t in legend.get_texts()] == ["unreachable (0)"]
    plt.close(fig)


def test_map_title_names_arm_kind_orientation_and_convention():
    from wsmap.workspace.kinds import get_kind

    assert viz.map_title("panda", get_kind("constant"), rpy=(math.pi, 0, -math.pi / 2), convention="standard",
                         summary="1883 of 9261 nodes reachable") == (
        "panda: constant map, rpy (π, 0, -π/2) rad, standard convention T = transl(p)·R\n"
        "1883 of 9261 nodes reachable")
    # the index fixes its own convention and reads the orientations, not rpy
    assert viz.map_title("ur5e", get_kind("index"), rpy=(1, 2, 3), convention="paper", orientations=50) == (
        "ur5e: reachability index over 50 orientations, standard convention T = transl(p)·R")
    assert viz.map_title("puma560", get_kind("orientation"), point=(0.5, 0.5, 0.5)) == (
        "puma560: orientation map, at (0.5, 0.5, 0.5) m")


def test_png_keeps_the_settings_in_its_metadata(tmp_path):
    from PIL import Image

    reach, _ = _ball_map()
    settings = {"robot": "ball", "rpy": np.array([np.pi, 0.0, 0.0]), "ik": {"tol": 1e-10}}
    fig = viz.plot_slices(reach, (21, 21, 21), -1.0, 0.1, title="ball\n7 layers",
                          metadata=viz.png_metadata(settings, title="ball\n7 layers"))
    path = tmp_path / "ball.png"
    save_figure(fig, path)
    text = Image.open(path).text
    assert text["Title"] == "ball — 7 layers"
    assert json.loads(text["Description"]) == {"ik": {"tol": 1e-10}, "robot": "ball", "rpy": [math.pi, 0.0, 0.0]}
    assert text["Software"].startswith("wsmap ")


# ---------------------------------------------------------------------------- collision-aware pictures
def _box_triangles(lo, hi):
    """A box from corner `lo` to corner `hi` as 12 triangles (the collision layer's own box)."""
    from wsmap.collision import Shape

    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    T = np.eye(4)
    T[:3, 3] = (lo + hi) / 2
    box = Shape("box", tuple(hi - lo), T)
    v, f = box.record.triangles(box)
    return v + T[:3, 3], f


def test_plane_sections_of_a_turned_box_and_a_cylinder():
    from wsmap.collision import Obstacle, Scene, Shape

    T = np.eye(4)
    c, s = math.cos(math.pi / 6), math.sin(math.pi / 6)
    T[:3, :3] = [[c, -s, 0], [s, c, 0], [0, 0, 1]]
    T[:3, 3] = [0.5, 0.1, 0.3]
    cyl = np.eye(4)
    cyl[:3, 3] = [-0.4, 0.3, 0.4]
    scene = Scene(obstacles=(Obstacle("table", Shape("box", (0.6, 0.8, 0.04), T), "world"),
                             Obstacle("post", Shape("cylinder", (0.08, 0.8), cyl), "world")))
    (name, v, f), (_, cv, cf) = scene.triangles()
    assert name == "table" and v.shape == (8, 3) and f.shape == (12, 3)
    seg = viz.plane_section(v, f, 0.3)
    pts = (seg.reshape(-1, 2) - [0.5, 0.1]) @ T[:2, :2]  # back in the box's frame
    # every point on the 0.6 x 0.8 rectangle's boundary, and its four sides all there
    assert np.allclose(np.maximum(np.abs(pts[:, 0]) / 0.3, np.abs(pts[:, 1]) / 0.4), 1.0)
    assert np.allclose(pts.min(axis=0), [-0.3, -0.4]) and np.allclose(pts.max(axis=0), [0.3, 0.4])
    assert viz.plane_section(v, f, 0.33).shape == (0, 2, 2)  # above the table
    ring = viz.plane_section(cv, cf, 0.5).reshape(-1, 2) - [-0.4, 0.3]
    r = np.linalg.norm(ring, axis=1)
    assert len(ring) >= 64 and np.all(r <= 0.08 + 1e-12) and np.all(r >= 0.08 * math.cos(math.pi / 32) - 1e-12)


def test_slices_outline_the_obstacles_in_the_layers_that_cut_them():
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection

    reach, nodes = _ball_map()
    table = ("table", *_box_triangles([0.3, -0.4, 0.18], [0.9, 0.4, 0.22]))
    for fig in (viz.plot_slices(reach, (21, 21, 21), -1.0, 0.1, obstacles=[table]),
                viz.plot_value_slices(reach.astype(float), (21, 21, 21), -1.0, 0.1, label="index",
                                      obstacles=[table])):
        panels = {ax.get_title(): ax for ax in fig.axes if ax.images}
        lines = {t: [c for c in ax.collections if isinstance(c, LineCollection)] for t, ax in panels.items()}
        assert [t for t, cs in lines.items() if cs] == ["z = 0.20 m"]  # only that layer cuts the table
        (outline,) = lines["z = 0.20 m"]
        pts = np.concatenate(outline.get_segments())
        assert np.allclose(pts.min(axis=0), [0.3, -0.4]) and np.allclose(pts.max(axis=0), [0.9, 0.4])
        assert "obstacle" in [t.get_text() for t in fig.legends[0].get_texts()]
        plt.close(fig)
    with pytest.raises(ValueError, match=r"^obstacle 'bad': vertices must be \(V, 3\) and faces \(F, 3\) indices"):
        viz.plot_slices(reach, (21, 21, 21), -1.0, 0.1, obstacles=[("bad", np.zeros((3, 3)), [[0, 1, 3]])])


def test_map_title_of_a_collision_aware_map_says_what_it_is_free_of():
    from wsmap.workspace.kinds import get_kind

    assert viz.map_title("panda", get_kind("constant"), rpy=(math.pi, 0, 0), convention="standard",
                         summary="1108 of 9261 nodes reachable", collision="scene table.yaml") == (
        "panda: constant map, rpy (π, 0, 0) rad, standard convention T = transl(p)·R\n"
        "collision-free: scene table.yaml\n1108 of 9261 nodes reachable")


def test_a_collision_aware_maps_png_names_the_scene_and_outlines_its_table(tmp_path):
    pytest.importorskip("coal")
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection
    from PIL import Image

    from wsmap import jobs

    scene = tmp_path / "table.yaml"
    scene.write_text("floor: true\nobstacles:\n  - {name: table, shape: box, size: [0.6, 0.8, 0.04], "
                     "xyz: [0.55, 0, 0.25]}\n")
    png = {}
    for label, collision in (("free", jobs.CollisionSource(scene=str(scene), acm_samples=100)),
                             ("self", jobs.CollisionSource(collision=True, acm_samples=100)),
                             ("nofloor", jobs.CollisionSource(collision=True, acm_samples=100, floor=False)),
                             ("kinematic", jobs.CollisionSource())):
        job = jobs.MapJob(arm=jobs.ArmSource(robot="ur5e"), rpy=(np.pi, 0, 0), step=0.25, collision=collision,
                          outputs=jobs.MapOutputs(png=str(tmp_path / f"{label}.png")))
        result = job.run()
        fig = job._figure(result)
        cut = [ax.get_title() for ax in fig.axes if any(isinstance(c, LineCollection) for c in ax.collections)]
        assert cut == (["z = 0.25 m"] if label == "free" else [])  # the layer through the table
        plt.close(fig)
        job.save(result)
        png[label] = Image.open(tmp_path / f"{label}.png").text["Title"]
    assert png["free"].startswith("ur5e: constant map, rpy (π, 0, 0) rad") and \
        " — collision-free: scene table.yaml — " in png["free"]
    assert " — collision-free: self-collision and the floor — " in png["self"]
    assert " — collision-free: self-collision only — " in png["nofloor"]
    assert "collision-free" not in png["kinematic"]
