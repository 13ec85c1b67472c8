"""The report: comparisons read from metrics files, reductions, and the smoke report stage."""

import json

import pytest

from wsmap import paths
from wsmap.paper import report


def test_lookup_nested_and_missing():
    m = {"a": {"b": [0.1, 0.2]}, "flag": True, "s": "x"}
    assert report.lookup(m, "a.b.1") == 0.2
    assert report.lookup(m, "a.c") is None and report.lookup(m, "a.b.5") is None
    assert report.lookup(m, "flag") is None and report.lookup(m, "s") is None  # not numbers


def test_comparison_rows_pair_ours_with_the_paper_and_never_fill_in():
    rows = report.comparison_rows({"sec61_subspace": {"f_mean": 0.95}})
    row = next(r for r in rows if r.source == "results/sec61_subspace.json: f_mean")
    assert row.ours == 0.95 and row.paper == 0.9665 and row.difference == pytest.approx(0.95 - 0.9665)
    others = [r for r in rows if r is not row and not r.source.startswith("results/sec61_subspace.json")]
    assert others and all(r.ours is None and r.difference is None for r in others)


def test_reductions_flatten_and_list_only_differences():
    committed = {"a": {"n": 10, "sizes": {"x": 1, "y": 2}, "same": [1, 2]}, "b": {"k": 1}}
    full = {"a": {"n": 100, "sizes": {"x": 1, "y": 20}, "same": [1, 2]}, "c": {"k": 3}}
    assert report.reductions(committed, full) == [
        {"stage": "a", "parameter": "n", "committed": 10, "paper scale": 100},
        {"stage": "a", "parameter": "sizes.y", "committed": 2, "paper scale": 20},
        {"stage": "b", "parameter": "k", "committed": 1, "paper scale": None},
        {"stage": "c", "parameter": "k", "committed": None, "paper scale": 3},
    ]


def test_committed_params_differ_from_full_scale_only_in_scale():
    """params.full.yaml undoes reductions; it never changes a method (optimiser, loss, sizes). It may
    also run on a GPU where there is one (``device: auto``; the committed run: ``cpu``)."""
    rows = report.reductions(paths.load_params(), paths.load_params(path=paths.ROOT / "params.full.yaml"))
    device = [r for r in rows if r["parameter"] == "device"]
    assert all((r["committed"], r["paper scale"]) == ("cpu", "auto") for r in device)
    rows = [r for r in rows if r["parameter"] != "device"]
    # the morphology study's headline: more arms, a finer grid, more samples and epochs, a cluster
    morph = {r["parameter"] for r in rows if r["stage"] == "morphologies"}
    assert morph <= {"step", "shards", "arms_per_shard", "test_arms", "fk.samples", "train.epochs",
                     "timing_repeats", "workers", "family.panda.samples"}, morph
    rows = [r for r in rows if r["stage"] != "morphologies"]
    # RAM's protocol at RAM's training scale: more arms (in more shards), more held-out arms, samples, epochs
    ram = {r["parameter"] for r in rows if r["stage"] == "ram_protocol"}
    assert ram <= {"train_arms", "arms_per_shard", "test_arms", "fk.samples", "train.epochs"}, ram
    rows = [r for r in rows if r["stage"] != "ram_protocol"]
    # one Table 1 row runs more sessions: written per row, the others keep one
    assert {"stage": "table1_workspaces", "parameter": "sessions.table1_so3_pi10", "committed": 1,
            "paper scale": 5} in rows
    scale = ("samples", "sessions", "epochs", "audit_arms", "per_node_sample", "repeats")
    assert rows and all(any(w in r["parameter"] for w in scale) for r in rows), rows
    assert all(r["committed"] <= r["paper scale"] for r in rows)


def test_markdown_table_formats_numbers_and_missing():
    text = report.markdown_table([{"what": "F", "ours": 0.91234, "n": 100000, "paper": None}], missing="missing")
    assert text.splitlines()[2] == "| F | 0.9123 | 100000 | missing |"


def test_write_report_is_complete_on_the_smoke_pipeline(smoke_notebook):
    out = smoke_notebook("report")
    text = (out.results / "REPORT.md").read_text()
    rows = report.comparison_rows(report.load_metrics(out.results))
    missing = [r.source for r in rows if r.ours is None]
    # The smoke's 8 no-subspace test arms can have no reachable node that the model finds: F is 0/0,
    # written as null (the paper printed NaN for this cell); the key must still be there.
    undefined = "results/table3_embeddings.json: nosubspace.nosubspace.f"
    assert "f" in json.loads((out.results / "table3_embeddings.json").read_text())["nosubspace"]["nosubspace"]
    missing = [m for m in missing if m != undefined]
    assert not missing, f"stages did not write: {missing}"
    assert not [line for line in text.split("## Committed scale")[0].splitlines()
                if "| missing |" in line and "nosubspace.nosubspace.f" not in line]
    assert "## Committed scale against the paper's" in text and "| sec61_subspace | sessions |" in text
    assert "Label audit" in text
    assert (out.figures / "reproduction_vs_paper.png").stat().st_size > 5000


def test_load_metrics_names_a_corrupt_file(tmp_path):
    (tmp_path / "good.json").write_text(json.dumps({"f": 1.0}))
    (tmp_path / "bad.json").write_text("{not json")
    with pytest.raises(ValueError, match="bad.json is not valid JSON"):
        report.load_metrics(tmp_path)


# --------------------------------------------------------------------------------------------
# The paper-scale column (`wsmap paper full`, results/full/<part>.json)
# --------------------------------------------------------------------------------------------


def _part(tmp_path, part, metrics, wall_seconds=258.3):
    """A fake `wsmap paper full` result file: the keys the report reads, shaped like the runner's."""
    full = tmp_path / "full"
    full.mkdir(exist_ok=True)
    data = {"part": part, "metrics": metrics, "wall_seconds": wall_seconds, "settings": {"part": part},
            "device": {"used": "cpu"}, "machine": {"host": "box", "cpus": 2, "torch": "2.x"},
            "finished": "2026-12-01T20:18:11+00:00"}
    (full / f"{part}.json").write_text(json.dumps(data))
    return data


def _row(rows, source):
    return next(r for r in rows if r.source == source)


def test_the_paper_scale_column_is_filled_from_a_part_file(tmp_path):
    _part(tmp_path, "table1_r3_step1", {"f": 0.9916, "precision": 1.0, "paper_f": 1.0})
    _part(tmp_path, "table3_workspace", {"tests": {"workspace": {"f": 0.5}, "subspace": {"f": 0.7}}},
          wall_seconds=3 * 3600)
    full = report.load_full(tmp_path / "full")
    assert set(full) == {"table1_r3_step1", "table3_workspace"}
    rows = report.comparison_rows({"table1_workspaces": {"f": {"table1_r3_step1": 0.99}}}, full)
    row = _row(rows, "results/table1_workspaces.json: f.table1_r3_step1")
    assert (row.ours, row.full, row.full_run, row.full_part) == (0.99, 0.9916, True, "table1_r3_step1")
    assert row.full_cell == 0.9916 and row.wall_time_cell == "4 min"
    assert row.full_source == "results/full/table1_r3_step1.json: f"
    assert row.difference == pytest.approx(0.99 - 1.0)  # still committed run - paper
    t3 = _row(rows, "results/table3_embeddings.json: workspace.workspace.f")
    assert (t3.full, t3.wall_time_cell) == (0.5, "3.0 h")

    (tmp_path / "table1_workspaces.json").write_text(json.dumps({"f": {"table1_r3_step1": 0.99}}))
    text = report.write_report(tmp_path).read_text()
    head = text.split("## Run time")[0]
    assert "`wsmap paper full`" in head and "results/full/" in head and "on this machine part by part" in head
    assert "2 of 14 parts measured" in head and "`sec61_subspace`" in head and "`table1_r3_step1`" not in head
    assert ("| F-measure, table1_r3_step1 | 0.9900 | 0.9916 | 1.0000 | -0.0100 | 4 min | "
            "results/table1_workspaces.json: f.table1_r3_step1 | results/full/table1_r3_step1.json: f |") in text
    assert "| table1_r3_step1 | measured | 4 min | 2026-12-01T20:18:11+00:00 | cpu | box, 2 CPUs, torch 2.x |" in text


def test_a_row_of_several_sessions_gets_its_spread_and_the_reading_nearest_the_paper(tmp_path):
    runs = [{"session": k, "seed": k, "f": f, "f_sample_mean": m, "best_val_loss": v}
            for k, (f, m, v) in enumerate([(0.90, 0.97, 0.03), (0.98, 0.99, 0.02), (0.94, 0.98, 0.01)])]
    _part(tmp_path, "table1_so3_pi10", {"f": 0.94, "runs": runs})
    _part(tmp_path, "table1_r3_step1", {"f": 0.99, "runs": runs[:1]})  # one session: no row
    (row,) = report.session_rows(report.load_full(tmp_path / "full"))
    assert row["row"] == "table1_so3_pi10" and row["sessions"] == 3
    assert row["F per session (seed)"] == "0.9000 (0), 0.9800 (1), 0.9400 (2)"
    assert row["F mean ± σ"] == "0.9400 ± 0.0400"
    assert (row["F lowest"], row["F highest"], row["F of the lowest-validation-loss session"]) == (0.90, 0.98, 0.94)
    assert row["per-arm F mean (mean over sessions)"] == pytest.approx(0.98)
    assert row["per-arm F mean, best session"] == 0.99
    assert row["paper"] == "0.9920 ± 0.03"  # Table 1: F 0.992 ± 0.03 at pi/10
    assert row["reading nearest the paper"] == "per-arm F mean, best session (0.9900)"
    text = report.write_report(tmp_path).read_text()
    assert "## Table 1 at the paper's scale, session by session" in text and "0.9400 ± 0.0400" in text


def test_the_paper_scale_column_says_not_run_yet_without_the_part(tmp_path):
    rows = report.comparison_rows({"sec61_subspace": {"f_mean": 0.95}}, report.load_full(tmp_path / "full"))
    row = _row(rows, "results/sec61_subspace.json: f_mean")
    assert (row.full_run, row.full, row.full_cell, row.wall_time_cell) == (False, None, report.NOT_RUN, report.NOT_RUN)
    assert row.ours == 0.95  # the committed run's column is untouched
    (tmp_path / "sec61_subspace.json").write_text(json.dumps({"f_mean": 0.95}))
    text = report.write_report(tmp_path).read_text()
    assert "0 of 14 parts measured; still missing: `sec61_subspace`, `sec62_puma560`, `table1_r3_step1`" in text
    assert "| F-measure, block 5, mean over sessions | 0.9500 | not run yet | 0.9665 | -0.0165 | not run yet |" in text
    # a part that ran without the key: "missing", never filled in
    _part(tmp_path, "sec61_subspace", {"f_std": 0.01})
    row = _row(report.comparison_rows({}, report.load_full(tmp_path / "full")), "results/sec61_subspace.json: f_mean")
    assert row.full_run and row.full is None and row.full_cell is None and row.wall_time_cell == "4 min"


def test_rows_without_a_paper_scale_counterpart_say_so(tmp_path):
    for part in report.FULL_PARTS:
        _part(tmp_path, part, {})
    rows = report.comparison_rows({}, report.load_full(tmp_path / "full"))
    none = [r for r in rows if r.full_part is None]
    assert {r.section for r in none} >= {"Run time", "Beyond the paper"}
    assert all(r.full_cell == "—" and r.wall_time_cell == "—" and r.full_source == "—" for r in none)
    assert "All 14 parts measured." in report.write_report(tmp_path).read_text()


def test_load_full_names_a_corrupt_part(tmp_path):
    (tmp_path / "table2_rprop_mse.json").write_text("{not json")
    (tmp_path / "estimates.json").write_text("{not json either, and not a part}")
    with pytest.raises(ValueError, match="table2_rprop_mse.json is not valid JSON"):
        report.load_full(tmp_path)
    assert report.load_full(tmp_path / "absent") == {}


@pytest.mark.parametrize("seconds, text", [(45, "45 s"), (119.4, "119 s"), (258.3, "4 min"), (168.3, "3 min"),
                                           (5400, "90 min"), (7200, "2.0 h"), (39.6 * 3600, "39.6 h")])
def test_wall_time_format(seconds, text):
    assert report.wall_time(seconds) == text


def test_the_committed_parts_read_as_the_runner_wrote_them():
    """The committed paper-scale results (Table 1, delta 1 and 0.5 at least) fill their rows."""
    full = report.load_full(paths.RESULTS / "full")
    assert {"table1_r3_step1", "table1_r3_step05"} <= set(full)
    rows = report.comparison_rows({}, full)
    for part in ("table1_r3_step1", "table1_r3_step05"):
        row = _row(rows, f"results/table1_workspaces.json: f.{part}")
        assert row.full == full[part]["metrics"]["f"] and 0.9 < row.full <= 1.0
        assert row.wall_time_cell == report.wall_time(full[part]["wall_seconds"]) and row.wall_time_cell.endswith(" min")


def _fake_runs(**columns):
    """A run frame as fit_and_score makes it (two sessions), for the runner's summary functions."""
    import pandas as pd

    from wsmap.paper import tables

    base = {c: [0.8, 0.9] for c in tables.METRIC_COLUMNS}
    base.update(epochs=[10, 10], seconds=[1.0, 1.0], train_samples=[100, 100], nodes=[1323, 1323], session=[0, 1])
    return pd.DataFrame({**base, **columns})


def test_the_row_mapping_covers_every_paper_scale_number():
    """Every Table 1 row, §6.1's F mean, Table 2's Rprop + MSE cell and Table 3's three embeddings map to
    their part, with a key that the part's metrics hold (the summaries full.py writes)."""
    from wsmap.paper import tables
    from wsmap.paper.published import PAPER_TABLE1

    by_source = {r.source: (r.full_part, r.full_key) for r in report.comparison_rows({})}
    for name in PAPER_TABLE1:
        assert by_source[f"results/table1_workspaces.json: f.{name}"] == (name, "f")
    assert by_source["results/sec61_subspace.json: f_mean"] == ("sec61_subspace", "f_mean")
    assert by_source["results/sec62_puma560.json: f_full"] == ("sec62_puma560", "f_full")
    assert by_source["results/table2_optimisers.json: rprop_mse.f_mean"] == ("table2_rprop_mse", "f_mean")
    for emb in ("subspace", "workspace", "nosubspace"):
        assert by_source[f"results/table3_embeddings.json: {emb}.{emb}.f"] == (f"table3_{emb}", f"tests.{emb}.f")
    assert by_source["results/table3_embeddings.json: subspace.subspace.f_sample_mean"] == (
        "table3_subspace", "tests.subspace.f_sample_mean")
    # every mapped report row exists, and every key is one the runner's summaries produce
    assert {f"results/{stem}.json: {key}" for stem, key in report.PAPER_SCALE} <= set(by_source)
    table1 = tables.table1_summary(_fake_runs(dataset=["table1_r3_step1"] * 2)).iloc[0].to_dict()
    table2 = tables.table2_summary(_fake_runs(optimizer=["rprop"] * 2, loss=["mse"] * 2)).iloc[0].to_dict()
    table3 = {"tests": {r["test"]: r for r in tables.table3_summary(
        _fake_runs(embedding=["subspace"] * 2, test=["subspace", "workspace"], session=[0, 0])).to_dict("records")}}
    for part, key in report.PAPER_SCALE.values():
        if part.startswith("table1_"):
            assert report.lookup(table1, key) is not None, (part, key)
        elif part == "table2_rprop_mse":
            assert report.lookup(table2, key) is not None, (part, key)
        elif part == "table3_subspace":
            assert report.lookup(table3, key) is not None, (part, key)


def test_the_report_reads_every_part_of_the_runner():
    from wsmap.paper import full

    assert report.FULL_PARTS == [p.name for p in full.plan(paths.ROOT / "params.full.yaml")]


def test_reproduction_figure_rows_read_as_the_paper_names_them():
    from wsmap.paper.parts import report as part

    assert part._bar_label("Table 1", "F-measure, table1_r3_step05") == "Table 1: R3, δ 0.5 (125 nodes)"
    assert part._bar_label("Table 1", "F-measure, table1_so3_pi10") == "Table 1: SO3, δ π/10 (9261 nodes)"
    assert part._bar_label("Section 6.1", "F-measure, block 5, mean over sessions") == (
        "Section 6.1: block 5, mean over sessions")
    assert part._bar_label("Table 2", "Rprop + MSE, F mean") == "Table 2: Rprop + MSE"


def test_reproduction_table_carries_the_paper_scale_column(tmp_path):
    """The committed results (results/*.json, results/full/*.json) read through the report's schema."""
    from wsmap.paper.parts import report as part

    out = paths.Outputs(tmp_path, inputs=paths.ROOT).make()
    result = part.run(paths.notebook_params("report"), out)
    table = result.table.set_index("source")
    full = report.load_full(paths.RESULTS / "full")
    row = table.loc["results/table1_workspaces.json: f.table1_r3_full"]
    assert row["paper_scale"] == full["table1_r3_full"]["metrics"]["f"] and row["paper_scale_note"] == ""
    assert table.loc["results/improved_model.json: f", "paper_scale_note"] == "—"
    (png,) = part.figures(result, out)
    assert png == tmp_path.resolve() / "figures" / "reproduction_vs_paper.png" and png.stat().st_size > 5000
    assert not (tmp_path / "results" / "REPORT.md").exists()
