"""The reproduction report: every reproduced number beside the paper's, with the difference.

`PAPER` holds the published numbers (`../shared/paper/NOTES.md`, "Published figures to
compare with"). `comparison_rows` reads the metrics JSON files the pipeline notebooks write
(`results/NAME.json`) and pairs each number with the paper's; `write_report` turns them
into `results/REPORT.md`, with the departures from the paper (`DEPARTURES`) and the
reductions of the committed parameters against the paper's scale.

A number that a stage has not produced (its JSON missing, or the key absent) is reported as
missing, never filled in.

Beside the committed run, the report has the paper's own scale as measured here: `wsmap paper
full` (`.full`) writes one `results/full/<part>.json` per part (a Table 1 row, §6.1, §6.2,
Table 2's Rprop + MSE cell, one Table 3 embedding). `PAPER_SCALE` maps each report row to
its paper-scale counterpart (part and key in the part's `metrics`), as `COMPARISONS` maps
it to a stage's metrics; `load_full` reads the parts that exist. A part not run yet is
reported as "not run yet", a row without a counterpart (run time, beyond the paper) as "—".
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..io import atomic_path, markdown_table
from .full import fmt_seconds
from .published import PAPER

__all__ = ["PAPER", "DEPARTURES", "PAPER_SCALE", "FULL_PARTS", "NOT_RUN", "Row", "markdown_table", "lookup",
           "load_metrics", "load_full", "wall_time", "comparison_rows", "reductions", "unknown_keys", "session_rows",
           "write_report"]

#: Where the project departs from the paper, and why (the report lists them all).
DEPARTURES: list[tuple[str, str]] = [
    ("Scale of the committed run",
     "`params.yaml` trains on fewer samples, epochs and sessions than the paper so that `dvc repro` "
     "fits in 45 minutes on 2 CPU cores; the README lists each reduction and the full-scale command."),
    ("Labels",
     "Spherical-wrist labels are exact (closed-form wrist-centre test), as the authors' published labels "
     "were; arbitrary 6-DOF labels (Table 3) come from the batched LM with several starts (the paper "
     "does not say how its were made). The label audit table measures how the paper's one-start "
     "numerical path would differ."),
    ("Pose convention",
     "The paper's convention `T = Rx Ry Rz · transl(p)` is reproduced (the datasets use it); the "
     "usual `transl(p) · R` is available and compared in the classical-workspace notebook."),
    ("Original code's quirks",
     "The original numerical path marked an empty IK result as reachable and forced `search` on; "
     "its 5-DOF labels were all zero. None of this is reproduced."),
    ("Cross entropy",
     "Cross entropy is computed on logits (sigmoid output) rather than MATLAB's cross entropy on a "
     "linear output layer."),
    ("Run time",
     "Our classical numbers are measured on this machine (2-core CPU, Python), the paper's on MATLAB "
     "R2017b on a Xeon E3-1505M; only ratios within one table are like for like."),
    ("Improved model",
     "Beyond the paper: inputs reduced to the four free DH parameters and standardised, wider layers, "
     "cross entropy on logits, Adam with minibatches; it stands beside, not in place of, the paper's "
     "setting."),
]


#: What a paper-scale cell says when its part has no `results/full/<part>.json` yet.
NOT_RUN = "not run yet"


@dataclass
class Row:
    """One line of the report: what, ours (the committed run), the paper's, where ours comes from;
    and the paper-scale counterpart (`wsmap paper full`): its part and key (`full_part` None:
    there is none), whether the part has run, its number and the part's wall time."""

    section: str
    what: str
    ours: float | None
    paper: float | None
    source: str
    note: str = ""
    full_part: str | None = None
    full_key: str = ""
    full_run: bool = False
    full: float | None = None
    full_wall_seconds: float | None = None

    @property
    def difference(self) -> float | None:
        if self.ours is None or self.paper is None or not _finite(self.ours) or not _finite(self.paper):
            return None
        return self.ours - self.paper

    @property
    def full_source(self) -> str:
        return "—" if self.full_part is None else f"results/full/{self.full_part}.json: {self.full_key}"

    @property
    def full_cell(self) -> float | str | None:
        """The "paper scale (measured)" cell: "—" (no counterpart), `NOT_RUN`, the number, or
        `None` (the part ran but its metrics lack the key: reported as missing)."""
        if self.full_part is None:
            return "—"
        return self.full if self.full_run else NOT_RUN

    @property
    def wall_time_cell(self) -> str | None:
        """The "wall time at paper scale" cell: "—", `NOT_RUN`, or `wall_time` of the
        part's `wall_seconds` (`None` where the part file lacks it)."""
        if self.full_part is None:
            return "—"
        if not self.full_run:
            return NOT_RUN
        return None if self.full_wall_seconds is None else wall_time(self.full_wall_seconds)


def wall_time(seconds) -> str:
    """A wall time as `wsmap paper full --list` prints it: `"45 s"`, `"4 min"`, `"3.2 h"`."""
    return fmt_seconds(seconds)


def _finite(v) -> bool:
    return isinstance(v, (int, float)) and math.isfinite(v)


def lookup(metrics: dict[str, Any], key: str):
    """`metrics[a][b]...` for `key = "a.b..."`; `None` where any part is missing."""
    cur: Any = metrics
    for part in key.split("."):
        if isinstance(cur, dict) and part in cur:
            cur = cur[part]
        elif isinstance(cur, list) and part.isdigit() and int(part) < len(cur):
            cur = cur[int(part)]
        else:
            return None
    if isinstance(cur, bool) or not isinstance(cur, (int, float)):
        return None
    return float(cur)


def load_metrics(results_dir) -> dict[str, dict]:
    """Every `results/*.json` (the stages' metrics) by stem; unreadable files raise `ValueError`."""
    out = {}
    for p in sorted(Path(results_dir).glob("*.json")):
        try:
            out[p.stem] = json.loads(p.read_text())
        except json.JSONDecodeError as e:
            raise ValueError(f"metrics file {p} is not valid JSON ({e})") from None
    return out


_TABLE1 = ("table1_r3_step1", "table1_r3_step05", "table1_r3_block5", "table1_r3_crop3087", "table1_r3_full",
           "table1_so3_pi3", "table1_so3_pi8", "table1_so3_pi10")
_TABLE3 = ("subspace", "workspace", "nosubspace")

#: (section, what, metrics file, key in it, PAPER key or None, note)
COMPARISONS: list[tuple[str, str, str, str, str | None, str]] = [
    ("Run time", "classical, 9261 nodes, per-node numerical (s)", "runtime_comparison",
     "classical_per_node_numerical.9261", "classical_time_9261", "extrapolated from a sample of nodes"),
    ("Run time", "classical, 125 nodes, per-node numerical (s)", "runtime_comparison",
     "classical_per_node_numerical.125", "classical_time_125", ""),
    ("Run time", "classical, 27 nodes, per-node numerical (s)", "runtime_comparison",
     "classical_per_node_numerical.27", "classical_time_27", ""),
    ("Run time", "classical, 9261 nodes, batched numerical (s)", "runtime_comparison",
     "classical_batched_numerical.9261", None, "not in the paper"),
    ("Run time", "classical, 9261 nodes, exact (s)", "runtime_comparison", "classical_exact.9261", None,
     "not in the paper"),
    ("Run time", "network, 9261 nodes (s)", "runtime_comparison", "network.9261", "network_time_9261", ""),
    ("Run time", "network, 125 nodes (s)", "runtime_comparison", "network.125", "network_time_125", ""),
    ("Run time", "network, 27 nodes (s)", "runtime_comparison", "network.27", "network_time_27", ""),
    ("Section 6.1", "F-measure, block 5, mean over sessions", "sec61_subspace", "f_mean", "sec61_f_mean", ""),
    ("Section 6.1", "F-measure, sigma over sessions", "sec61_subspace", "f_std", "sec61_f_std", ""),
    ("Section 6.1", "best-threshold F (sweep)", "sec61_subspace", "best_threshold_f", "sec61_best_threshold_f", ""),
    ("Section 6.2", "F-measure, full 9261 map from 7 block models", "sec62_puma560", "f_full", "table1_r3_full",
     "the paper reports Table 1's single 9261-output model"),
    ("Section 6.2", "F-measure, PUMA560 predicted vs exact", "sec62_puma560", "puma560_f", None, "not in the paper"),
    *[("Table 1", f"F-measure, {name}", "table1_workspaces", f"f.{name}", name, "") for name in _TABLE1],
    ("Table 2", "Rprop + MSE, F mean", "table2_optimisers", "rprop_mse.f_mean", "table2_rprop_mse_f_mean", ""),
    ("Table 2", "Rprop + MSE, F sigma", "table2_optimisers", "rprop_mse.f_std", "table2_rprop_mse_f_std",
     "ours: sigma of the pooled F over sessions; the paper does not say over what its sigma is taken"),
    ("Table 2", "Rprop + MSE, per-arm F mean", "table2_optimisers", "rprop_mse.f_sample_mean",
     "table2_rprop_mse_f_mean", "F of each test arm's map, averaged"),
    ("Table 2", "Rprop + MSE, per-arm F sigma", "table2_optimisers", "rprop_mse.f_sample_std",
     "table2_rprop_mse_f_std", "sigma over test arms: the paper's 0.1258 is of this size"),
    ("Table 3", "subspace model, own test set, precision", "table3_embeddings", "subspace.subspace.precision",
     "table3_subspace_precision", ""),
    ("Table 3", "subspace model, own test set, recall", "table3_embeddings", "subspace.subspace.recall",
     "table3_subspace_recall", ""),
    ("Table 3", "subspace model, own test set, F", "table3_embeddings", "subspace.subspace.f", "table3_subspace_f", ""),
    # The paper's three numbers read as means over test arms: a pooled F is exactly the harmonic
    # mean of the pooled P and R (0.84 for its 0.93 and 0.76), its F is 0.91; a mean of per-arm
    # F's is not bound to the means' harmonic mean.
    ("Table 3", "subspace model, own test set, per-arm precision mean", "table3_embeddings",
     "subspace.subspace.precision_sample_mean", "table3_subspace_precision", "each test arm's map, averaged"),
    ("Table 3", "subspace model, own test set, per-arm recall mean", "table3_embeddings",
     "subspace.subspace.recall_sample_mean", "table3_subspace_recall", "each test arm's map, averaged"),
    ("Table 3", "subspace model, own test set, per-arm F mean", "table3_embeddings",
     "subspace.subspace.f_sample_mean", "table3_subspace_f",
     "each test arm's map, averaged: the paper's F 0.91 is not the harmonic mean of its P and R (0.84), "
     "as a pooled F would be"),
    ("Table 3", "subspace model, own test set, per-arm F sigma", "table3_embeddings",
     "subspace.subspace.f_sample_std", "table3_subspace_f_std", "sigma over test arms"),
    ("Table 3", "workspace model, own test set, F", "table3_embeddings", "workspace.workspace.f",
     "table3_workspace_f", ""),
    ("Table 3", "no-subspace model, own test set, F", "table3_embeddings", "nosubspace.nosubspace.f",
     "table3_nosubspace_f", "the paper prints NaN: almost no reachable node in this test set"),
    ("Beyond the paper", "improved model, full 9261 map, F", "improved_model", "f", "table1_r3_full",
     "paper: its full-map model"),
    ("Beyond the paper", "improved model, PUMA560 predicted vs exact, F", "improved_model", "puma560_f", None, ""),
    ("Beyond the paper", "improved model, one 9261-node map (s)", "improved_model", "seconds_per_map",
     "network_time_9261", ""),
    ("Beyond the paper", "panda7 map model (7-DOF, joint limits), F on held-out arms", "learned_maps", "panda7.f",
     None, "the committed run's reduced model; the headline model is in the README"),
    ("Beyond the paper", "panda7 map model, one map against the numerical map (speed-up)", "learned_maps",
     "panda7.speed.speedup", None, "one thread each"),
    ("Beyond the paper", "spherical-wrist manipulability model, R² on held-out arms", "learned_maps",
     "manipulability.r2", None, "the paper's future work"),
]


#: Each report row's paper-scale counterpart: (metrics file, key) as in `COMPARISONS` ->
#: (`wsmap paper full` part, key in its `results/full/<part>.json` `metrics`). Rows not listed
#: have none: run time, beyond the paper.
PAPER_SCALE: dict[tuple[str, str], tuple[str, str]] = {
    ("sec61_subspace", "f_mean"): ("sec61_subspace", "f_mean"),
    ("sec61_subspace", "f_std"): ("sec61_subspace", "f_std"),
    ("sec61_subspace", "best_threshold_f"): ("sec61_subspace", "best_threshold_f"),
    ("sec62_puma560", "f_full"): ("sec62_puma560", "f_full"),
    ("sec62_puma560", "puma560_f"): ("sec62_puma560", "puma560_f"),
    **{("table1_workspaces", f"f.{name}"): (name, "f") for name in _TABLE1},
    **{("table2_optimisers", f"rprop_mse.{k}"): ("table2_rprop_mse", k)
       for k in ("f_mean", "f_std", "f_sample_mean", "f_sample_std")},
    **{("table3_embeddings", f"subspace.subspace.{k}"): ("table3_subspace", f"tests.subspace.{k}")
       for k in ("precision", "recall", "f", "precision_sample_mean", "recall_sample_mean", "f_sample_mean",
                 "f_sample_std")},
    **{("table3_embeddings", f"{emb}.{emb}.f"): (f"table3_{emb}", f"tests.{emb}.f") for emb in _TABLE3[1:]},
}

#: Every `wsmap paper full` part the report reads, in the runner's order (a test checks that
#: these are all of `wsmap.paper.full.plan`'s parts).
FULL_PARTS: list[str] = list(dict.fromkeys(part for part, _ in PAPER_SCALE.values()))


def unknown_keys() -> list[str]:
    """The keys of `COMPARISONS` that their part's metrics schema lacks
    (`wsmap.paper.parts.knows_key`), and those of `PAPER_SCALE` that the §6.1 and §6.2
    parts' paper-scale schemas lack, as `"<file>: <key>"`; empty when the report and the parts agree."""
    from .parts import knows_key, sec61_subspace, sec62_puma560

    bad = [f"results/{stem}.json: {key}" for _, _, stem, key, _, _ in COMPARISONS if not knows_key(stem, key)]
    paper_scale = {"sec61_subspace": sec61_subspace.PaperScaleMetrics, "sec62_puma560": sec62_puma560.PaperScaleMetrics}
    bad += [f"results/full/{part}.json: {key}" for part, key in PAPER_SCALE.values()
            if part in paper_scale and key.split(".")[0] not in paper_scale[part].__annotations__]
    return bad


def load_full(full_dir) -> dict[str, dict]:
    """The paper-scale results that exist, `full_dir/<part>.json` for each of `FULL_PARTS`,
    by part (`results/full/`; a missing directory: none); unreadable files raise `ValueError`."""
    out = {}
    for part in FULL_PARTS:
        p = Path(full_dir) / f"{part}.json"
        if not p.is_file():
            continue
        try:
            data = json.loads(p.read_text())
        except json.JSONDecodeError as e:
            raise ValueError(f"paper-scale result {p} is not valid JSON ({e})") from None
        if not isinstance(data, dict):
            raise ValueError(f"paper-scale result {p} is not a JSON object")
        out[part] = data
    return out


def _leaves(d: Any, prefix: str = "") -> dict[str, Any]:
    if isinstance(d, dict):
        out: dict[str, Any] = {}
        for k, v in d.items():
            out.update(_leaves(v, f"{prefix}.{k}" if prefix else str(k)))
        return out
    return {prefix: d}


def _aligned(a: Any, b: Any) -> tuple[Any, Any]:
    """`a` and `b` with a value given once on one side and per key (a mapping, `default` for
    the rest) on the other written per key on both: `sessions: 1` against `{default: 1,
    table1_so3_pi10: 5}` differs in `sessions.table1_so3_pi10` only."""
    if isinstance(a, dict) and isinstance(b, dict):
        pairs = {k: _aligned(a.get(k), b.get(k)) if k in a and k in b else (a.get(k), b.get(k))
                 for k in dict.fromkeys([*a, *b])}
        return ({k: v[0] for k, v in pairs.items() if k in a}, {k: v[1] for k, v in pairs.items() if k in b})
    if isinstance(b, dict) and not isinstance(a, (dict, list)) and a is not None:
        return {k: a for k in b}, b
    if isinstance(a, dict) and not isinstance(b, (dict, list)) and b is not None:
        return a, {k: b for k in a}
    return a, b


def reductions(committed: dict[str, Any], full: dict[str, Any]) -> list[dict[str, Any]]:
    """Every parameter whose committed value (`params.yaml`) differs from the paper-scale one
    (`params.full.yaml`), as rows `{stage, parameter, committed, paper scale}`; nested
    sections are flattened to dotted names (`train_samples.table1_r3_full`). A parameter
    present in only one of the two files is listed with `None` on the other side."""
    rows = []
    for stage in dict.fromkeys([*committed, *full]):
        c, f = _aligned(committed.get(stage, {}), full.get(stage, {}))
        c, f = _leaves(c), _leaves(f)
        for key in dict.fromkeys([*c, *f]):
            if c.get(key) != f.get(key):
                rows.append({"stage": stage, "parameter": key, "committed": c.get(key), "paper scale": f.get(key)})
    return rows


def comparison_rows(metrics: dict[str, dict], full: dict[str, dict] | None = None) -> list[Row]:
    """One `Row` per entry of `COMPARISONS`, ours read from `metrics`, the paper-scale
    number and wall time from `full` (`load_full`; `None`: no part has run)."""
    full = full or {}
    rows = []
    for section, what, stem, key, paper_key, note in COMPARISONS:
        ours = lookup(metrics.get(stem, {}), key)
        paper = PAPER.get(paper_key) if paper_key else None
        part, full_key = PAPER_SCALE.get((stem, key), (None, ""))
        result = full.get(part) if part else None
        rows.append(Row(section, what, ours, paper, f"results/{stem}.json: {key}", note, full_part=part,
                        full_key=full_key, full_run=result is not None,
                        full=None if result is None else lookup(result.get("metrics", {}), full_key),
                        full_wall_seconds=None if result is None else lookup(result, "wall_seconds")))
    return rows


def _parts_table(full: dict[str, dict]) -> list[dict[str, Any]]:
    """One row per part of `FULL_PARTS`: measured or not, wall time, when, where."""
    rows = []
    for part in FULL_PARTS:
        data = full.get(part)
        if data is None:
            rows.append({"part": part, "state": NOT_RUN, "wall time": "—", "finished": "—", "device": "—",
                         "machine": "—"})
            continue
        device, machine = data.get("device"), data.get("machine") or {}
        seconds = lookup(data, "wall_seconds")
        where = ", ".join(str(x) for x in (machine.get("host"), machine.get("cpus") and f"{machine['cpus']} CPUs",
                                           machine.get("torch") and f"torch {machine['torch']}") if x)
        rows.append({"part": part, "state": "measured", "wall time": None if seconds is None else wall_time(seconds),
                     "finished": data.get("finished"),
                     "device": device.get("used") if isinstance(device, dict) else device,
                     "machine": where or None})
    return rows


def session_rows(full: dict[str, dict]) -> list[dict[str, Any]]:
    """The Table 1 rows measured at the paper's scale with more than one session: one row each with
    every session's pooled F, their mean ± σ (ddof 1), the lowest and highest, the F of the session
    with the lowest validation loss (the one a MATLAB user keeps), the per-arm F mean (each test
    arm's map scored, then averaged) of the sessions and of the best-F session, and which of these
    readings lies nearest the paper's single number (`reading`)."""
    from .published import PAPER_TABLE1

    rows = []
    for name in _TABLE1:
        runs = (full.get(name) or {}).get("metrics", {}).get("runs") or []
        if len(runs) < 2 or name not in PAPER_TABLE1:
            continue
        f = [float(r["f"]) for r in runs]
        per_arm = [float(r["f_sample_mean"]) for r in runs]
        mean = sum(f) / len(f)
        std = math.sqrt(sum((x - mean) ** 2 for x in f) / (len(f) - 1))
        kept = min(range(len(runs)), key=lambda i: float(runs[i]["best_val_loss"]))
        best = max(range(len(f)), key=f.__getitem__)
        paper = float(PAPER_TABLE1[name]["paper_f"])
        readings = {"pooled F, mean over sessions": mean, "pooled F, best session": f[best],
                    "pooled F, lowest-validation-loss session": f[kept],
                    "per-arm F mean, mean over sessions": sum(per_arm) / len(per_arm),
                    "per-arm F mean, best session": per_arm[best],
                    "per-arm F mean, lowest-validation-loss session": per_arm[kept]}
        nearest = min(readings, key=lambda k: abs(readings[k] - paper))
        rows.append({"row": name, "sessions": len(runs), "F per session (seed)":
                     ", ".join(f"{x:.4f} ({int(r['seed'])})" for x, r in zip(f, runs)),
                     "F mean ± σ": f"{mean:.4f} ± {std:.4f}", "F lowest": min(f), "F highest": f[best],
                     "F of the lowest-validation-loss session": f[kept],
                     "per-arm F mean (mean over sessions)": readings["per-arm F mean, mean over sessions"],
                     "per-arm F mean, best session": per_arm[best],
                     "paper": f"{paper:.4f} ± {float(PAPER_TABLE1[name]['paper_f_std']):.2f}",
                     "reading nearest the paper": f"{nearest} ({readings[nearest]:.4f})"})
    return rows


def write_report(results_dir, path=None, *, reductions: list[dict] | None = None,
                 extra_sections: dict[str, str] | None = None, full_dir=None) -> Path:
    """Write the report (default `results_dir/REPORT.md`) atomically; returns its path.

    `reductions`: rows `{parameter, committed, paper}` listing where the committed run is
    smaller than the paper's; `extra_sections`: title → Markdown appended (e.g. the label audit);
    `full_dir`: the paper-scale results of `wsmap paper full` (default `results_dir/full`).
    """
    results_dir = Path(results_dir)
    path = Path(path) if path else results_dir / "REPORT.md"
    full = load_full(Path(full_dir) if full_dir else results_dir / "full")
    rows = comparison_rows(load_metrics(results_dir), full)
    pending = [p for p in FULL_PARTS if p not in full]
    still = (f"{len(FULL_PARTS) - len(pending)} of {len(FULL_PARTS)} parts measured; still missing: "
             f"{', '.join(f'`{p}`' for p in pending)} (\"{NOT_RUN}\"; `wsmap paper full --list` estimates each)."
             if pending else f"All {len(FULL_PARTS)} parts measured.")
    lines = [
        "# Reproduction report",
        "",
        "Generated by the `report` stage. **committed run**: the metrics the pipeline wrote "
        "(`results/*.json`, `params.yaml`), measured by this run, next to the paper's (NOTES.md). "
        "Difference = committed run − paper. \"missing\" means the stage did not produce the number; "
        "\"—\": the paper gives none.",
        "",
        "**paper scale (measured)**: the same number at the paper's own scale (`params.full.yaml`), from "
        "`wsmap paper full` (`results/full/<part>.json`), measured on this machine part by part; **wall time "
        "at paper scale**: that part's wall time (every step, resumed runs included). " + still + " \"—\" "
        "in these columns: the row has no paper-scale counterpart. Each part's machine and date: "
        "\"Paper scale, part by part\" below.",
        "",
    ]
    for section in dict.fromkeys(r.section for r in rows):
        lines += [f"## {section}", ""]
        lines.append(markdown_table(
            [{"what": r.what, "committed run": r.ours, "paper scale (measured)": r.full_cell,
              "paper": "—" if r.paper is None else r.paper,
              "difference": "—" if r.paper is None or not _finite(r.paper) else r.difference,
              "wall time at paper scale": r.wall_time_cell, "source": r.source, "paper-scale source": r.full_source,
              "note": r.note}
             for r in rows if r.section == section], missing="missing"))
    lines += ["## Paper scale, part by part", "",
              "`wsmap paper full` parts (`results/full/<part>.json`) at `params.full.yaml`'s settings. The report "
              "shows each part's file as it is; `wsmap paper full --list` also checks that its settings still "
              "match `params.full.yaml`.", "",
              markdown_table(_parts_table(full), missing="missing")]
    sessions = session_rows(full)
    if sessions:
        lines += ["## Table 1 at the paper's scale, session by session", "",
                  "Rows whose one session sat far below the paper, trained again with more seeds (session k: seed "
                  "k; `table1_workspaces.sessions` in `params.full.yaml`); the Table 1 row above is the mean over "
                  "them. The paper gives one number per row and does not say whether it is one session or the "
                  "best of several, pooled over nodes or averaged over arms; each reading is computed here and "
                  "the one nearest the paper's is named.", "",
                  markdown_table(sessions, missing="missing")]
    if reductions:
        lines += ["## Committed scale against the paper's", "", markdown_table(reductions, missing="missing")]
    for title, body in (extra_sections or {}).items():
        lines += [f"## {title}", "", body.rstrip() + "\n"]
    lines += ["## Where the project departs from the paper", ""]
    lines += [f"- **{t}.** {why}" for t, why in DEPARTURES]
    text = "\n".join(lines) + "\n"
    with atomic_path(path) as tmp:
        Path(tmp).write_text(text)
    return path
