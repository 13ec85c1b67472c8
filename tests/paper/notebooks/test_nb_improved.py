"""Smoke run of the improved-model notebook (params.smoke.yaml): the model it saves maps arms by
itself, and its metrics agree with what that model predicts."""

import json

import numpy as np
import pytest

from wsmap import datasets, paths, robots
from wsmap.kinematics import arm_batch
from wsmap.learn import files as model_files
from wsmap.metrics import precision_recall_f
from wsmap.paper.parts import improved_model


@pytest.fixture(scope="module")
def out(smoke_notebook):
    return smoke_notebook("improved_model")


@pytest.fixture(scope="module")
def metrics(out):
    return json.loads((out.results / "improved_model.json").read_text())


def test_metrics_and_figures(out, metrics):
    smoke = paths.load_params("improved_model", paths.ROOT / "params.smoke.yaml")
    assert list(metrics) == list(improved_model.Metrics.__annotations__)  # the part's schema
    assert metrics["train_samples"] == smoke["train_samples"]
    assert 1 <= metrics["epochs"] <= smoke["max_epochs"]
    # the inputs are the family's free DH parameters, found from the data (constant columns dropped)
    assert metrics["inputs"] == ["d_3", "d_4", "a_2", "a_3"]
    for key in ("f", "precision", "recall", "puma560_f"):
        assert 0.0 <= metrics[key] <= 1.0, key
    assert metrics["seconds_per_map"] > 0 and metrics["seconds_per_map_min"] <= metrics["seconds_per_map"]
    for name in ("improved_model_training", "puma560_workspace_improved"):
        assert (out.figures / f"{name}.png").stat().st_size > 5000, name
    assert (out.executed / "improved_model.ipynb").exists()


def test_saved_model_maps_the_puma560_as_the_notebook_reported(out, metrics):
    model, meta = model_files.load(out.models / "improved_model.pt")
    assert meta["map_spec"]["dataset"]["name"] == "sec62" and meta["map_spec"]["nodes"] == [0, 9261]
    predicted = model.predict_maps(robots.puma560())
    spec = datasets.DatasetSpec.from_dict(meta["map_spec"]["dataset"])
    exact = datasets.labels_for(arm_batch(robots.puma560()), spec)[0]
    assert predicted.shape == (9261,)
    assert int((predicted != exact).sum()) == metrics["puma560_nodes_differ"]
    np.testing.assert_allclose(precision_recall_f(predicted, exact).f, metrics["puma560_f"])
