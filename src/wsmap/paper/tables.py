"""The grids of experiments behind the paper's Tables 1-3, as pandas DataFrames.

Each table is a grid of `wsmap.paper.fitting.fit` runs scored by precision, recall and
F-measure on independent test sets. The functions here run a grid and return tidy frames
(one row per training session and test set) that `summarize` condenses into the table
(mean and standard deviation over sessions), with the paper's published numbers beside:

* `table1` -- one model per workspace (`table1_*` datasets: R3 grids at delta 1, 0.5, 0.1
  and SO3 grids at pi/3, pi/8, pi/10), the paper's [125, 100, 100, 125] network, Rprop + MSE;
* `table2` -- optimiser x loss on the section 6.1 subspace (dataset `table2`, block 5);
* `table3` -- three embeddings (`subspace`, `workspace`, `no subspace`), every model
  tested on every test set.

The paper's tables are `PAPER_TABLE1`, `PAPER_TABLE2`, `PAPER_TABLE3`
(transcribed from the paper's LaTeX source).

Scores
------
`precision`, `recall`, `f` are pooled over every test sample and node (micro: the paper's
F-measure, NOTES "Networks and training"); `*_sample_mean` / `*_sample_std` are the mean and
standard deviation of the per-sample values over the samples where they are defined (a sample
with no reachable node in truth and prediction has no precision, recall or F), which is the
spread the paper's "+- sigma_f" columns of Tables 1 and 3 most likely show (a single model cannot
have a spread over sessions). Undefined pooled values are NaN (the paper printed NaN).

Cross entropy
-------------
`loss="crossentropy"` trains the network's linear output as a *logit* (binary cross entropy on
`sigmoid(z)`, `wsmap.learn.training.make_loss`), and the model is built with
`output_kind="logit"` so that it predicts a node where `sigmoid(z) > 0.5`
(`mlp_options`). MATLAB's `crossentropy` on the paper's linear (`purelin`) output layer
takes logarithms of raw outputs that may be negative or above 1; it is not reproduced.

Reduced runs
------------
`train_samples` keeps the first `n` arms of a training set (`wsmap.datasets.Dataset.head`:
exactly the arms a smaller build would have drawn); the 70/15/15 split is drawn inside them.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import pandas as pd

from ..datasets import Dataset
from ..io import plus_minus
from ..learn.training import TrainConfig, optimizer_name
from ..metrics import confusion, precision_recall_f
from . import fitting
from .published import PAPER_TABLE1, PAPER_TABLE2, PAPER_TABLE3
from .specs import load_pair

__all__ = [
    "PAPER_HIDDEN",
    "TABLE3_HIDDEN",
    "TABLE1_DATASETS",
    "TABLE2_OPTIMIZERS",
    "TABLE2_LOSSES",
    "TABLE3_EMBEDDINGS",
    "OPTIMIZER_LABELS",
    "LOSS_LABELS",
    "METRIC_COLUMNS",
    "mlp_options",
    "scores",
    "fit_and_score",
    "score_results",
    "summarize",
    "table1",
    "table1_summary",
    "table2",
    "table2_summary",
    "table3",
    "table3_summary",
    "per_dataset",
    "plus_minus",
]

#: The paper's network for section 6.1, Table 1 and Table 2.
PAPER_HIDDEN = (125, 100, 100, 125)
#: Table 3: "a three-layer fully connected feedforward network of 80 neurons at each layer".
TABLE3_HIDDEN = (80, 80, 80)

TABLE1_DATASETS = ("table1_r3_step1", "table1_r3_step05", "table1_r3_block5", "table1_r3_crop3087",
                   "table1_r3_full", "table1_so3_pi3", "table1_so3_pi8", "table1_so3_pi10")
#: Table 2's optimisers in the paper's row order, by their `wsmap.learn.optim` names.
TABLE2_OPTIMIZERS = ("cgb", "gdx", "oss", "rprop", "scg")
TABLE2_LOSSES = ("crossentropy", "mse", "mae")
#: Table 3's embeddings: name -> dataset.
TABLE3_EMBEDDINGS = {"subspace": "table3_subspace", "workspace": "table3_workspace",
                     "nosubspace": "table3_nosubspace"}

OPTIMIZER_LABELS = {"cgb": "Conj. Gradient w. P/B Restarts", "gdx": "Variable Learning Rate G.D.",
                    "oss": "One Step Secant", "rprop": "Resilient Backpropagation",
                    "scg": "Scaled Conj. Gradient"}
LOSS_LABELS = {"crossentropy": "Cross entropy", "mse": "MSE", "mae": "MAE"}

_NAN = math.nan

#: Count columns: shown as integers when every value is whole (e.g. epochs averaged over sessions
#: that all ran the same number).
COUNT_COLUMNS = frozenset({"epochs", "best_epoch", "sessions", "session", "seed", "train_samples", "nodes",
                           "paper_nodes", "paper_samples", "test_samples", "tp", "fp", "fn", "positives",
                           "predicted", "f_undefined"})

#: Per-session score columns of the run frames (`scores`), averaged by `summarize`.
METRIC_COLUMNS = ("precision", "recall", "f", "precision_sample_mean", "precision_sample_std",
                  "recall_sample_mean", "recall_sample_std", "f_sample_mean", "f_sample_std")

Log = Callable[[str], Any] | None


def mlp_options(loss: str) -> dict[str, Any]:
    """Architecture options a loss needs: `output_kind="logit"` for cross entropy (see the
    module docstring), nothing for MSE/MAE (linear output, the paper's)."""
    return {"output_kind": "logit"} if str(loss).strip().lower() == "crossentropy" else {}


def scores(model, test: Dataset, threshold: float = 0.5) -> dict[str, Any]:
    """Pooled and per-sample precision, recall, F of `model` on `test` (all its nodes),
    plus the counts: `tp`, `fp`, `fn`, `positives` (true), `predicted` (positive) and
    `positive_rate` (fraction of reachable nodes in the test set)."""
    ev = fitting.evaluate(model, test, threshold=threshold)
    pred = ev["scores"] > threshold
    per = precision_recall_f(pred, ev["truth"], "samples")
    c = confusion(pred, ev["truth"])
    return dict(
        precision=ev["precision"], recall=ev["recall"], f=ev["f"],
        precision_sample_mean=per.precision, precision_sample_std=per.precision_std,
        recall_sample_mean=per.recall, recall_sample_std=per.recall_std,
        f_sample_mean=per.f, f_sample_std=per.f_std, f_undefined=per.undefined_f,
        tp=int(c.tp), fp=int(c.fp), fn=int(c.fn), positives=int(c.tp + c.fn), predicted=int(c.tp + c.fp),
        positive_rate=float((c.tp + c.fn) / max(1, pred.size)), test_samples=int(len(test)),
    )


def fit_and_score(train: Dataset, tests: Mapping[str, Dataset], config: TrainConfig, *, sessions: int = 1,
                  hidden: Sequence[int] = PAPER_HIDDEN, train_samples: int | None = None,
                  threshold: float = 0.5, **mlp) -> pd.DataFrame:
    """Train `sessions` models on the first `train_samples` arms of `train` and score each on
    every test set; cross entropy gets a logit output (`mlp_options`) unless `mlp` says.

    Returns one row per (session, test set): `session`, `test`, `train_samples` (arms used),
    `nodes`, `epochs` (optimiser steps taken), `best_epoch`, `stop_reason`, `seconds`
    (training wall time of the session), `final_loss` / `best_val_loss`, and `scores`.
    """
    ds = train.head(train_samples)
    mlp = {**mlp_options(config.loss), **mlp}
    results = fitting.fit(ds, config, sessions=sessions, hidden=hidden, **mlp)
    return pd.DataFrame(score_results(results, ds, tests, threshold))


def score_results(results: Sequence, train: Dataset, tests: Mapping[str, Dataset], threshold: float = 0.5,
                  *, first_session: int = 0) -> list[dict[str, Any]]:
    """The rows of `fit_and_score` for training results already in hand (`results` from
    `wsmap.paper.fitting.fit` on `train`, the arms actually used): one row per (session,
    test set); `session` counts from `first_session` (a run that trains session `k` alone,
    with seed `seed + k`, passes `first_session=k`)."""
    rows = []
    for s, r in enumerate(results, start=first_session):
        model = fitting.stack_sessions([r]) if r.session is not None else r.model
        best = r.history.loss[r.best_epoch]
        base = dict(session=s, seed=r.config.seed, train_samples=len(train), nodes=int(train.n_nodes),
                    epochs=int(r.stop_epoch), best_epoch=int(r.best_epoch), stop_reason=r.stop_reason,
                    seconds=float(r.history.time[-1]), best_train_loss=float(best),
                    best_val_loss=float(r.best_val_loss))
        for name, test in tests.items():
            rows.append({**base, "test": name, **scores(model, test, threshold)})
    return rows


def summarize(runs: pd.DataFrame, by: Sequence[str]) -> pd.DataFrame:
    """Mean over sessions of every score and of epochs/seconds per group of `by`, plus the
    standard deviation over sessions of the pooled scores (`*_session_std`; NaN for one
    session) and the number of sessions. Groups keep their first-seen order."""
    by = list(by)
    agg: dict[str, Any] = {c: "mean" for c in (*METRIC_COLUMNS, "epochs", "seconds", "train_samples", "nodes")
                           if c in runs}
    g = runs.groupby(by, sort=False, dropna=False)
    out = g.agg(agg)
    for c in ("precision", "recall", "f"):
        out[f"{c}_session_std"] = g[c].std(ddof=1)
    out["sessions"] = g["session"].nunique()
    return out.reset_index()


def _log(log: Log, msg: str) -> None:
    if log is not None:
        log(msg)


def per_dataset(value, name: str, default=None):
    """`value[name]` when `value` is a mapping (falling back to `value.get("default",
    default)`), else `value` itself: lets a parameter be one number or one per dataset."""
    if isinstance(value, Mapping):
        return value.get(name, value.get("default", default))
    return default if value is None else value


# --------------------------------------------------------------------------------------------
# Table 1
# --------------------------------------------------------------------------------------------


def table1(data_dir, names: Sequence[str] = TABLE1_DATASETS, *, config: TrainConfig | None = None,
           train_samples=None, max_epochs=None, sessions=1, hidden: Sequence[int] = PAPER_HIDDEN,
           log: Log = print) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Table 1: one model per workspace dataset in `data_dir` (`wsmap.paper.specs.load_pair`).

    `train_samples`, `max_epochs` and `sessions` are one value or a mapping dataset -> value
    (key `"default"` for the rest); `max_epochs` overrides `config.max_epochs`.

    Returns `(table, runs)`: `runs` from `fit_and_score` (column `dataset`); `table`
    one row per dataset: workspace, delta, nodes, train samples, epochs, seconds, pooled precision,
    recall, F (means over sessions), per-sample F mean and std, the paper's F +- sigma_f and batch
    size, and `difference` = F - paper F.
    """
    config = TrainConfig() if config is None else config
    frames = []
    for name in names:
        train, test = load_pair(name, data_dir)
        cfg = config.replace(max_epochs=int(per_dataset(max_epochs, name, config.max_epochs)))
        n = per_dataset(train_samples, name)
        t0 = time.perf_counter()
        runs = fit_and_score(train, {name: test}, cfg, sessions=int(per_dataset(sessions, name, 1)), hidden=hidden,
                             train_samples=n)
        runs.insert(0, "dataset", name)
        frames.append(runs)
        _log(log, f"{name}: {train.n_nodes} nodes, {int(runs.train_samples.iloc[0])} arms, "
                  f"{cfg.max_epochs} epochs max, F = {runs.f.mean():.4f} ({time.perf_counter() - t0:.1f} s)")
    runs = pd.concat(frames, ignore_index=True)
    return table1_summary(runs), runs


def table1_summary(runs: pd.DataFrame) -> pd.DataFrame:
    """Table 1 from the run frame of `table1` (column `dataset` plus `fit_and_score`'s):
    one row per dataset, in first-seen order (see `table1` for the columns)."""
    summary = summarize(runs, ["dataset"])
    sessions = int(summary.sessions.max()) if len(summary) else 0
    paper = pd.DataFrame([{"dataset": n, **PAPER_TABLE1[n]} for n in summary.dataset])
    table = paper[["dataset", "workspace", "delta"]].assign(nodes=summary.nodes.astype(int).to_numpy())
    table = table.assign(
        train_samples=summary.train_samples.astype(int).to_numpy(), epochs=summary.epochs.to_numpy(),
        seconds=summary.seconds.to_numpy(), precision=summary.precision.to_numpy(),
        recall=summary.recall.to_numpy(), f=summary.f.to_numpy(),
        f_sample_mean=summary.f_sample_mean.to_numpy(), f_sample_std=summary.f_sample_std.to_numpy(),
        paper_nodes=paper.paper_nodes.to_numpy(), paper_samples=paper.paper_samples.to_numpy(),
        paper_f=paper.paper_f.to_numpy(), paper_f_std=paper.paper_f_std.to_numpy(),
    )
    if sessions > 1:
        table.insert(table.columns.get_loc("f") + 1, "f_session_std", summary.f_session_std.to_numpy())
    table["difference"] = table.f - table.paper_f
    return table


# --------------------------------------------------------------------------------------------
# Table 2
# --------------------------------------------------------------------------------------------


def table2(train: Dataset, test: Dataset, *, config: TrainConfig | None = None,
           optimizers: Sequence[str] = TABLE2_OPTIMIZERS, losses: Sequence[str] = TABLE2_LOSSES,
           sessions: int = 2, hidden: Sequence[int] = PAPER_HIDDEN, train_samples: int | None = None,
           log: Log = print) -> pd.DataFrame:
    """Table 2's grid: every optimiser with every loss, `sessions` sessions each (seeds
    `config.seed + s`, so every cell starts from the same initial weights and split -- except
    that cross entropy's logit output reads them differently). Returns the run frame (columns
    `optimizer`, `loss` first); `table2_summary` makes the table."""
    config = TrainConfig() if config is None else config
    frames = []
    for loss in losses:
        for opt in optimizers:
            cfg = config.replace(optimizer=optimizer_name(opt), loss=loss)
            runs = fit_and_score(train, {"table2": test}, cfg, sessions=sessions, hidden=hidden,
                                 train_samples=train_samples)
            runs.insert(0, "loss", loss)
            runs.insert(0, "optimizer", cfg.optimizer)
            frames.append(runs)
            _log(log, f"{cfg.optimizer} + {loss}: F = {runs.f.mean():.4f} +- {runs.f.std(ddof=1):.4f} over "
                      f"{sessions} sessions, {runs.epochs.mean():.0f} epochs, {runs.seconds.sum():.1f} s")
    return pd.concat(frames, ignore_index=True)


def table2_summary(runs: pd.DataFrame) -> pd.DataFrame:
    """One row per (optimizer, loss) in the paper's order (by loss, then optimiser): F mean and
    standard deviation over sessions (`f_mean`, `f_std`), the per-sample F mean and std
    (averaged over sessions), precision, recall, epochs, seconds per session, the paper's F +-
    sigma and `difference` = f_mean - paper."""
    s = summarize(runs, ["optimizer", "loss"])
    rows = []
    for _, r in s.iterrows():
        pf, ps = PAPER_TABLE2.get((r.optimizer, r.loss), (_NAN, _NAN))
        rows.append(dict(
            optimizer=r.optimizer, method=OPTIMIZER_LABELS.get(r.optimizer, r.optimizer),
            loss=LOSS_LABELS.get(r.loss, r.loss), sessions=int(r.sessions), train_samples=int(r.train_samples),
            epochs=r.epochs, seconds=r.seconds, precision=r.precision, recall=r.recall,
            f_mean=r.f, f_std=r.f_session_std, f_sample_mean=r.f_sample_mean, f_sample_std=r.f_sample_std,
            paper_f=pf, paper_f_std=ps, difference=r.f - pf, loss_key=r.loss,
        ))
    return pd.DataFrame(rows)


# --------------------------------------------------------------------------------------------
# Table 3
# --------------------------------------------------------------------------------------------


def table3(pairs: Mapping[str, tuple[Dataset, Dataset]], *, config: TrainConfig | None = None,
           sessions: int = 1, hidden: Sequence[int] = TABLE3_HIDDEN, train_samples=None,
           log: Log = print) -> pd.DataFrame:
    """Table 3's grid: one model per embedding (`pairs`: embedding -> (train, test)), each
    tested on every embedding's test set. The datasets must share their feature layout and nodes
    (the `table3_*` specs do: 84 inputs, block 5's 1323 nodes). `train_samples`: one value or
    a mapping embedding -> value. Returns the run frame with columns `embedding` (the model)
    and `test` (the test set)."""
    config = TrainConfig() if config is None else config
    shapes = {name: (tr.features.shape[1], tr.n_nodes, te.features.shape[1], te.n_nodes)
              for name, (tr, te) in pairs.items()}
    if len(set(shapes.values())) != 1:
        raise ValueError(f"Table 3's datasets must share features and nodes; got {shapes}")
    tests = {name: te for name, (_, te) in pairs.items()}
    frames = []
    for name, (train, _) in pairs.items():
        runs = fit_and_score(train, tests, config, sessions=sessions, hidden=hidden,
                             train_samples=per_dataset(train_samples, name))
        runs.insert(0, "embedding", name)
        frames.append(runs)
        own = runs[runs.test == name]
        _log(log, f"{name} model ({int(runs.train_samples.iloc[0])} arms, {runs.epochs.mean():.0f} epochs, "
                  f"{own.seconds.sum():.1f} s): F on own test set {own.f.mean():.4f}")
    return pd.concat(frames, ignore_index=True)


def table3_summary(runs: pd.DataFrame) -> pd.DataFrame:
    """One row per (model embedding, test set): pooled precision, recall, F and their per-sample
    means and stds (averaged over sessions), with the paper's values (`paper_*`) beside."""
    s = summarize(runs, ["embedding", "test"])
    rows = []
    for _, r in s.iterrows():
        p = PAPER_TABLE3.get((r.embedding, r.test), {})
        rows.append(dict(
            embedding=r.embedding, test=r.test, sessions=int(r.sessions), train_samples=int(r.train_samples),
            epochs=r.epochs, seconds=r.seconds,
            precision=r.precision, recall=r.recall, f=r.f,
            precision_sample_mean=r.precision_sample_mean, precision_sample_std=r.precision_sample_std,
            recall_sample_mean=r.recall_sample_mean, recall_sample_std=r.recall_sample_std,
            f_sample_mean=r.f_sample_mean, f_sample_std=r.f_sample_std,
            **{f"paper_{k}": p.get(k, _NAN) for k in ("precision", "precision_std", "recall", "recall_std", "f", "f_std")},
        ))
    return pd.DataFrame(rows)
