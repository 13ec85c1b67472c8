"""Smoke runs of the Table 1-3 notebooks (params.smoke.yaml): what they wrote, not just that they ran."""

import json
import math

import numpy as np
import pandas as pd
import pytest

from wsmap import paths
from wsmap.paper import report, tables
from wsmap.paper.published import PAPER_TABLE1, PAPER_TABLE2, PAPER_TABLE3

SMOKE = paths.ROOT / "params.smoke.yaml"


def _unit_or_nan(values) -> bool:
    v = np.asarray([math.nan if x is None else x for x in values], dtype=float)
    return bool(np.all(np.isnan(v) | ((v >= 0.0) & (v <= 1.0))))


def _tables(out, name):
    for suffix in ("", "_display", "_runs"):
        assert (out.tables / f"{name}{suffix}.csv").stat().st_size > 0, suffix
        md = (out.tables / f"{name}{suffix}.md").read_text()
        assert md.startswith("| ") and md.count("\n") >= 3, suffix
    assert (out.figures / f"{name}.png").stat().st_size > 10_000
    assert (out.executed / f"{name}.ipynb").exists()
    return pd.read_csv(out.tables / f"{name}.csv"), pd.read_csv(out.tables / f"{name}_runs.csv")


def test_table1_workspaces(smoke_notebook):
    out = smoke_notebook("table1_workspaces")
    smoke = paths.load_params("table1_workspaces", SMOKE)
    table, runs = _tables(out, "table1_workspaces")
    assert list(table.dataset) == smoke["datasets"] == list(tables.TABLE1_DATASETS)
    assert list(table.nodes) == [27, 125, 1323, 3087, 9261, 343, 4913, 9261]
    for c in ("workspace", "delta", "nodes", "train_samples", "epochs", "seconds", "precision", "recall", "f",
              "paper_f", "difference"):
        assert c in table, c
    assert (table.train_samples == smoke["train_samples"]).all() and (table.epochs == smoke["max_epochs"]).all()
    assert _unit_or_nan(table.f) and _unit_or_nan(table.precision) and _unit_or_nan(table.recall)
    np.testing.assert_allclose(table.difference, table.f - table.paper_f)
    assert len(runs) == len(tables.TABLE1_DATASETS) * smoke["sessions"]
    metrics = json.loads((out.results / "table1_workspaces.json").read_text())
    assert set(metrics["f"]) == set(tables.TABLE1_DATASETS) and _unit_or_nan(metrics["f"].values())
    assert metrics["paper_f"] == {n: PAPER_TABLE1[n]["paper_f"] for n in tables.TABLE1_DATASETS}
    # the report finds its keys (None where F is undefined)
    for name, f in zip(table.dataset, table.f):
        got = report.lookup(metrics, f"f.{name}")
        assert (got is None and math.isnan(f)) or got == pytest.approx(f)


def test_table2_optimisers(smoke_notebook):
    out = smoke_notebook("table2_optimisers")
    smoke = paths.load_params("table2_optimisers", SMOKE)
    summary, runs = _tables(out, "table2_optimisers")
    cells = len(smoke["optimizers"]) * len(smoke["losses"])
    assert len(summary) == cells and len(runs) == cells * smoke["sessions"]
    assert set(zip(runs.optimizer, runs.loss)) == {(o, l) for o in smoke["optimizers"] for l in smoke["losses"]}
    for c in ("method", "loss", "sessions", "epochs", "f_mean", "f_std", "f_sample_mean", "f_sample_std", "paper_f",
              "paper_f_std", "difference"):
        assert c in summary, c
    assert (summary.sessions == smoke["sessions"]).all() and (runs.epochs == smoke["max_epochs"]).all()
    assert _unit_or_nan(summary.f_mean) and _unit_or_nan(runs.f)
    assert (summary.f_std.dropna() >= 0).all()
    metrics = json.loads((out.results / "table2_optimisers.json").read_text())
    assert metrics["sessions"] == smoke["sessions"] and metrics["paper_best_cell"] == "rprop_mse"
    for o in smoke["optimizers"]:
        for l in smoke["losses"]:
            cell = metrics[f"{o}_{l}"]
            assert _unit_or_nan([cell["f_mean"]]) and (cell["paper_f"], cell["paper_f_std"]) == PAPER_TABLE2[(o, l)]
    rprop = summary[(summary.optimizer == "rprop") & (summary.loss_key == "mse")].iloc[0]
    got = report.lookup(metrics, "rprop_mse.f_mean")
    assert (got is None and math.isnan(rprop.f_mean)) or got == pytest.approx(rprop.f_mean)


def test_table3_embeddings(smoke_notebook):
    out = smoke_notebook("table3_embeddings")
    smoke = paths.load_params("table3_embeddings", SMOKE)
    summary, runs = _tables(out, "table3_embeddings")
    emb = list(tables.TABLE3_EMBEDDINGS)
    assert len(summary) == 9 and set(zip(summary.embedding, summary.test)) == {(a, b) for a in emb for b in emb}
    assert len(runs) == 9 * smoke["sessions"] and (summary.sessions == smoke["sessions"]).all()
    assert _unit_or_nan(summary[["precision", "recall", "f"]].to_numpy().ravel())
    metrics = json.loads((out.results / "table3_embeddings.json").read_text())
    for a in emb:
        for b in emb:
            cell = metrics[a][b]
            assert _unit_or_nan([cell["precision"], cell["recall"], cell["f"]])
    own = metrics["subspace"]["subspace"]
    row = summary[(summary.embedding == "subspace") & (summary.test == "subspace")].iloc[0]
    got = report.lookup(metrics, "subspace.subspace.f")
    assert (got is None and math.isnan(row.f)) or got == pytest.approx(row.f)
    paper = PAPER_TABLE3[("subspace", "subspace")]
    assert (own["paper_precision"], own["paper_recall"], own["paper_f"]) == (paper["precision"], paper["recall"], paper["f"])
    # the paper's NaN cells stay NaN (null in JSON)
    assert metrics["workspace"]["nosubspace"]["paper_f"] is None
    assert set(metrics["train_samples"]) == set(emb) and metrics["train_samples"]["subspace"] == smoke["train_samples"]
    assert _unit_or_nan(metrics["test_positive_rate"].values())
