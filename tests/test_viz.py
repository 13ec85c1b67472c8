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
