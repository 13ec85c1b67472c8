"""The report: comparisons read from metrics files, reductions, and the smoke report stage."""

import json

import pytest

from wsmap import paths
from wsmap.paper import report as R


def test_lookup_nested_and_missing():
    m = {"a": {"b": [0.1, 0.2]}, "flag": True, "s": "x"}
    assert R.lookup(m, "a.b.1") == 0.2
    assert R.lookup(m, "a.c") is None and R.lookup(m, "a.b.5") is None
    assert R.lookup(m, "flag") is None and R.lookup(m, "s") is None  # not numbers


def test_comparison_rows_pair_ours_with_the_paper_and_never_fill_in():
    rows = R.comparison_rows({"sec61_subspace": {"f_mean": 0.95}})
    row = next(r for r in rows if r.source == "results/sec61_subspace.json: f_mean")
    assert row.ours == 0.95 and row.paper == 0.9665 and row.difference == pytest.approx(0.95 - 0.9665)
    others = [r for r in rows if r is not row and not r.source.startswith("results/sec61_subspace.json")]
    assert others and all(r.ours is None and r.difference is None for r in others)


def test_reductions_flatten_and_list_only_differences():
    committed = {"a": {"n": 10, "sizes": {"x": 1, "y": 2}, "same": [1, 2]}, "b": {"k": 1}}
    full = {"a": {"n": 100, "sizes": {"x": 1, "y": 20}, "same": [1, 2]}, "c": {"k": 3}}
    assert R.reductions(committed, full) == [
        {"stage": "a", "parameter": "n", "committed": 10, "paper scale": 100},
        {"stage": "a", "parameter": "sizes.y", "committed": 2, "paper scale": 20},
        {"stage": "b", "parameter": "k", "committed": 1, "paper scale": None},
        {"stage": "c", "parameter": "k", "committed": None, "paper scale": 3},
    ]


def test_committed_params_differ_from_full_scale_only_in_scale():
    """params.full.yaml undoes reductions; it never changes a method (optimiser, loss, sizes). It may
    also run on a GPU where there is one (``device: auto``; the committed run: ``cpu``)."""
    rows = R.reductions(paths.load_params(), paths.load_params(path=paths.ROOT / "params.full.yaml"))
    device = [r for r in rows if r["parameter"] == "device"]
    assert all((r["committed"], r["paper scale"]) == ("cpu", "auto") for r in device)
    rows = [r for r in rows if r["parameter"] != "device"]
    scale = ("samples", "sessions", "epochs", "audit_arms", "per_node_sample", "repeats")
    assert rows and all(any(w in r["parameter"] for w in scale) for r in rows), rows
    assert all(r["committed"] <= r["paper scale"] for r in rows)


def test_markdown_table_formats_numbers_and_missing():
    text = R.markdown_table([{"what": "F", "ours": 0.91234, "n": 100000, "paper": None}], missing="missing")
    assert text.splitlines()[2] == "| F | 0.9123 | 100000 | missing |"


def test_write_report_is_complete_on_the_smoke_pipeline(smoke_notebook):
    out = smoke_notebook("report")
    text = (out.results / "REPORT.md").read_text()
    rows = R.comparison_rows(R.load_metrics(out.results))
    missing = [r.source for r in rows if r.ours is None]
    assert not missing, f"stages did not write: {missing}"
    assert "| missing |" not in text.split("## Committed scale")[0]
    assert "## Committed scale against the paper's" in text and "| sec61_subspace | sessions |" in text
    assert "Label audit" in text
    assert (out.figures / "reproduction_vs_paper.png").stat().st_size > 5000


def test_load_metrics_names_a_corrupt_file(tmp_path):
    (tmp_path / "good.json").write_text(json.dumps({"f": 1.0}))
    (tmp_path / "bad.json").write_text("{not json")
    with pytest.raises(ValueError, match="bad.json is not valid JSON"):
        R.load_metrics(tmp_path)
