"""Smoke run of notebooks/runtime_comparison.ipynb on params.smoke.yaml, into a temporary root."""

import json

import pandas as pd

from wsmap import paths
from wsmap.paper.pipeline import run_notebook
from wsmap.paper.published import RUNTIME_SECONDS

SMOKE = paths.ROOT / "params.smoke.yaml"


def test_runtime_comparison_smoke(tmp_path):
    dest = run_notebook("runtime_comparison", SMOKE, tmp_path, timeout=600)
    assert dest == tmp_path / "results" / "notebooks" / "runtime_comparison.ipynb"

    df = pd.read_csv(tmp_path / "tables" / "runtime_comparison.csv")
    assert sorted(df["nodes"].unique()) == [27, 125, 9261]
    methods = {"classical_per_node_numerical", "classical_batched_numerical", "classical_exact", "network",
               "network_end_to_end"}
    for n in (27, 125, 9261):
        assert set(df.loc[df["nodes"] == n, "method"]) == methods
    assert (df["mean_s"] > 0).all() and (df["std_s"] >= 0).all()
    by = df.set_index(["method", "nodes"])
    # which method is faster is the benchmark's and the committed run's to say, not a timed test's
    # (a smoke run's few repeats on a busy machine can order them either way)
    for n in (27, 125, 9261):
        assert by.loc[("classical_batched_numerical", n), "agreement_with_exact"] > 0.95
    # the smoke sample (4 nodes) is smaller than every grid: all per-node rows are extrapolated
    assert by.loc[("classical_per_node_numerical", 9261), "extrapolated"]
    assert by.loc[("classical_per_node_numerical", 9261), "timed_nodes"] == 4
    paper = lambda m: df[df["method"] == m].sort_values("nodes")["paper_s"].tolist()  # noqa: E731
    assert paper("classical_per_node_numerical") == [RUNTIME_SECONDS[n][0] for n in (27, 125, 9261)]
    assert paper("network") == [RUNTIME_SECONDS[n][1] for n in (27, 125, 9261)]

    md = (tmp_path / "tables" / "runtime_comparison.md").read_text()
    assert md.count("\n|") >= 15 and "9261" in md

    metrics = json.loads((tmp_path / "results" / "runtime_comparison.json").read_text())
    for key in ("classical_per_node_numerical", "classical_batched_numerical", "classical_exact", "network"):
        assert set(metrics[key]) == {"27", "125", "9261"} and all(v > 0 for v in metrics[key].values())
    assert metrics["paper"]["classical"] == {str(n): c for n, (c, _) in RUNTIME_SECONDS.items()}
    assert metrics["paper"]["network"] == {str(n): w for n, (_, w) in RUNTIME_SECONDS.items()}
    assert metrics["settings"]["repeats"] == paths.load_params("runtime_comparison", SMOKE)["repeats"]
    assert (tmp_path / "figures" / "runtime_comparison.png").stat().st_size > 5_000
