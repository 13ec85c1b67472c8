"""Smoke run of the section-6.1 notebook (params.smoke.yaml): what it wrote, not just that it ran."""

import json
import math

import numpy as np
import pandas as pd
import pytest

from wsmap import datasets, paths, robots
from wsmap.kinematics import arm_batch
from wsmap.learn import files as model_files
from wsmap.paper.parts import sec61_subspace
from wsmap.paper.published import SEC61
from wsmap.paper.specs import PAPER_SPECS

FIGURES = ("sec61_gradient", "sec61_loss", "sec61_test_error", "sec61_sections", "sec61_threshold_sweep")


@pytest.fixture(scope="module")
def out(smoke_notebook):
    return smoke_notebook("sec61_subspace")


@pytest.fixture(scope="module")
def metrics(out):
    return json.loads((out.results / "sec61_subspace.json").read_text())


def test_metrics_keys_and_ranges(metrics):
    smoke = paths.load_params("sec61_subspace", paths.ROOT / "params.smoke.yaml")
    sessions = smoke["sessions"]
    assert set(metrics) == set(sec61_subspace.Metrics.__annotations__)  # the part's schema
    assert metrics["sessions"] == sessions and len(metrics["f_sessions"]) == sessions
    assert len(metrics["seconds_per_session"]) == sessions and all(s > 0 for s in metrics["seconds_per_session"])
    assert metrics["train_samples"] == smoke["train_samples"] and metrics["test_samples"] > 0
    assert metrics["epochs"] == smoke["max_epochs"] and metrics["epochs_run"] == [smoke["max_epochs"]] * sessions
    assert metrics["nodes"] == 1323
    for key in ("f_mean", "best_session_f", "best_session_precision", "best_session_recall", "best_threshold_f",
                "precision_mean", "recall_mean"):
        assert 0.0 <= metrics[key] <= 1.0, key
    assert all(0.0 <= f <= 1.0 for f in metrics["f_sessions"])
    assert min(metrics["f_sessions"]) <= metrics["f_mean"] <= max(metrics["f_sessions"])
    assert metrics["f_std"] >= 0 and not math.isnan(metrics["f_std"])
    assert 0 <= metrics["best_session"] < sessions
    assert metrics["f_sessions"][metrics["best_session"]] == metrics["best_session_f"]
    assert 0.0 <= metrics["best_threshold"] <= 1.0
    assert metrics["best_threshold_f"] >= metrics["best_session_f"] - 1e-12  # the sweep includes 0.5
    assert 0.0 <= metrics["best_session_error_per_sample_mean"] <= 1.0
    assert metrics["paper"] == SEC61  # the paper's numbers, from wsmap.paper.published


def test_figures_and_tables(out):
    for name in FIGURES:
        assert (out.figures / f"{name}.png").stat().st_size > 5_000, name
    sweep = pd.read_csv(out.tables / "sec61_threshold_sweep.csv")
    assert list(sweep.columns[:4]) == ["threshold", "precision", "recall", "f"] and len(sweep) == 101
    assert (out.tables / "sec61_threshold_sweep.md").read_text().startswith("| threshold |")
    sessions = pd.read_csv(out.tables / "sec61_sessions.csv")
    assert len(sessions) == paths.load_params("sec61_subspace", paths.ROOT / "params.smoke.yaml")["sessions"]


def test_best_model_saved(out, metrics):
    model, meta = model_files.load(out.models / "sec61_subspace.pt")
    assert model.n_subspaces == 1
    assert model.config.n_outputs == 1323 and model.config.n_inputs == 84
    assert model.config.hidden == [125, 100, 100, 125]
    assert meta["dataset_spec"]["name"] == "sec61" and meta["dataset_spec"]["select"] == [5292, 6615]
    assert meta["train_config"]["optimizer"] == "rprop" and meta["train_config"]["loss"] == "mse"
    assert meta["extra"]["session"] == metrics["best_session"]
    # usable as a predictor: block 5 of the 21^3 grid, in node order
    assert meta["map_spec"]["nodes"] == [5292, 6615]
    np.testing.assert_allclose(model.map_nodes(), datasets.grid_nodes(PAPER_SPECS["sec62"])[5292:6615])
    puma = robots.puma560()
    x = datasets.features_for(arm_batch(puma), datasets.DatasetSpec.from_dict(meta["dataset_spec"]))
    np.testing.assert_array_equal(model.predict_maps(puma), model.predict(x).numpy().reshape(-1))
