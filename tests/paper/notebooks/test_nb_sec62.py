"""Smoke run of the section-6.2 notebook (params.smoke.yaml): what it wrote, not just that it ran."""

import json

import numpy as np
import pandas as pd
import pytest
import trimesh

from wsmap import datasets, paths, robots
from wsmap.kinematics import arm_batch
from wsmap.learn import files as model_files
from wsmap.paper.parts import sec62_puma560

FIGURES = ("sec62_training", "sec62_error_histogram", "sec62_subspace_runtime", "puma560_workspace_predicted",
           "sec62_puma560_slices")


@pytest.fixture(scope="module")
def out(smoke_notebook):
    return smoke_notebook("sec62_puma560")


@pytest.fixture(scope="module")
def metrics(out):
    return json.loads((out.results / "sec62_puma560.json").read_text())


def test_metrics_keys_and_ranges(metrics):
    smoke = paths.load_params("sec62_puma560", paths.ROOT / "params.smoke.yaml")
    assert set(metrics) == set(sec62_puma560.Metrics.__annotations__)  # the part's schema
    assert metrics["subspaces"] == 7
    assert metrics["train_samples"] == smoke["train_samples"] and metrics["max_fail"] == smoke["max_fail"]
    assert len(metrics["f_blocks"]) == 7 and len(metrics["seconds_per_block"]) == 7
    assert all(1 <= e <= smoke["max_epochs"] for e in metrics["epochs_run"])
    for key in ("f_full", "precision_full", "recall_full", "puma560_f", "puma560_precision", "puma560_recall"):
        assert 0.0 <= metrics[key] <= 1.0, key
    assert all(f is None or 0.0 <= f <= 1.0 for f in metrics["f_blocks"])
    assert metrics["puma560_reachable_exact"] > 0
    assert 0 <= metrics["puma560_reachable_predicted"] <= 9261
    names = [f"block {k}" for k in range(1, 8)] + ["assembled (9261)"]
    for key in ("runtime_one_map_s", "runtime_test_set_s", "runtime_one_map_std_s"):
        assert list(metrics[key]) == names
        assert all(v >= 0 for v in metrics[key].values())
    assert all(metrics["runtime_one_map_s"][n] > 0 for n in names)


def test_figures_and_table(out):
    for name in FIGURES:
        assert (out.figures / f"{name}.png").stat().st_size > 5_000, name
    table = pd.read_csv(out.tables / "sec62_subspaces.csv")
    assert table["subspace"].tolist() == [f"block {k}" for k in range(1, 8)] + ["assembled"]
    assert table["nodes"].tolist() == [1323] * 7 + [9261]
    assert (out.tables / "sec62_subspaces.md").read_text().startswith("| subspace |")


def test_stacked_model_predicts_the_saved_puma560_map(out, metrics):
    model, meta = model_files.load(out.models / "sec62_puma560.pt")
    assert model.n_subspaces == 7 and model.config.n_outputs == 1323
    spec = datasets.DatasetSpec.from_dict(meta["dataset_spec"])
    assert spec.name == "sec62" and spec.select is None
    assert meta["train_config"]["max_fail"] == metrics["max_fail"]
    x = datasets.features_for(arm_batch(robots.puma560()), spec)
    pred = model.predict(x, assemble=True).numpy()[0]
    assert pred.shape == (9261,) and int(pred.sum()) == metrics["puma560_reachable_predicted"]
    # the saved model stands in for the classical map: predict_maps gives the assembled map
    assert meta["map_spec"]["assemble"] is True
    np.testing.assert_array_equal(model.predict_maps(robots.puma560()), pred)


def test_mesh_files_load(out, metrics):
    for ext in ("glb", "stl"):
        path = out.results / f"puma560_workspace_predicted.{ext}"
        assert path.stat().st_size > 0
        loaded = trimesh.load(path)
        if metrics["puma560_mesh_faces"]:
            mesh = trimesh.load(path, force="mesh")
            assert len(mesh.faces) == metrics["puma560_mesh_faces"]
            lo, hi = mesh.bounds
            assert np.all(lo >= -1.2) and np.all(hi <= 1.2)
        else:  # nothing predicted reachable: an empty scene
            assert isinstance(loaded, trimesh.Scene) and not loaded.geometry
