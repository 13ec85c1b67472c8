"""§6.1: one subspace (block 5, 1323 nodes) learnt in several sessions; F mean ± σ over them.

The paper's network (84 raw inputs, tanh [125, 100, 100, 125], linear output, Nguyen–Widrow,
full-batch Rprop on MSE, 70/15/15 split) trained `sessions` times (session `k`: seed
`seed + k`) on the first `train_samples` arms of the `sec61` dataset; each session scored on
the test set at `threshold` (pooled F); the best session (lowest validation loss) swept over
`sweep_points` thresholds from 0 to 1.

The notebook (`run`) and the paper-scale runner (`wsmap.paper.full` through `SCALE`: one
session per resumable step) summarise the sessions with the same `summarise` into `Summary`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypedDict

import numpy as np
import pandas as pd

from ... import viz
from ... import workspace
from ...datasets import Dataset, spec_nodes
from ...io import write_json, write_table
from ...learn.files import save as save_model
from ...learn.training import TrainConfig
from ...metrics import Sweep, per_sample_error, session_curves, threshold_sweep
from ...paths import Outputs
from .. import fitting
from ..published import SEC61
from ..scale import Data, Planner, Scale, Unit, step_runs
from ..specs import whole_param
from . import Part, check_metrics, register, save_figure


class Summary(TypedDict):
    """The sessions summarised (`summarise`): the notebook's and the paper-scale runner's keys."""

    f_mean: float  #: pooled F at `threshold`, mean over the sessions
    f_std: float  #: its sample standard deviation over the sessions (NaN for one session)
    f_sessions: list[float]  #: pooled F of each session
    precision_mean: float
    recall_mean: float
    precision_sessions: list[float]
    recall_sessions: list[float]
    best_session: int  #: the session of lowest validation loss
    best_session_f: float
    best_threshold: float  #: the best session's threshold of highest F (sweep)
    best_threshold_f: float  #: its F
    threshold: float
    sessions: int
    epochs: int  #: `max_epochs`
    epochs_run: list[int]  #: epochs each session ran (early stopping)
    best_epochs: list[int]
    stop_reasons: list[str]
    seconds_per_session: list[float]  #: training wall time of each session (s)
    seconds_per_session_mean: float
    train_samples: int  #: training arms used
    paper: dict  #: the paper's numbers (`wsmap.paper.published.SEC61`)


class Metrics(Summary):
    """`results/sec61_subspace.json`: `Summary` plus what the notebook measures beside it."""

    best_session_precision: float
    best_session_recall: float
    best_session_f_per_sample_mean: float  #: mean over test arms of each arm's F
    best_session_error_per_sample_mean: float  #: fraction of an arm's nodes predicted wrongly, mean
    best_session_error_per_sample_std: float
    best_session_arms_over_99_percent_right: float  #: fraction of test arms with < 1 % wrong nodes
    seconds_training_total: float
    torch_threads: int
    device: str
    test_samples: int
    nodes: int
    hidden: list[int]


class PaperScaleMetrics(Summary):
    """`results/full/sec61_subspace.json`'s `metrics`: `Summary`, the sweep, every session's row."""

    sweep: dict  #: `wsmap.metrics.Sweep.to_dict` of the best session
    runs: list[dict]  #: `wsmap.paper.tables.score_results` rows, one per session


def sweep_of(evaluation: Mapping, points: int) -> Sweep:
    """The threshold sweep of one evaluation (`wsmap.paper.fitting.evaluate`'s `scores` and
    `truth`) at `points` thresholds evenly from 0 to 1, as the paper's."""
    return threshold_sweep(evaluation["scores"], evaluation["truth"], np.linspace(0.0, 1.0, int(points)))


def summarise(sessions: Sequence[Mapping[str, Any]], sweep: Sweep, *, threshold: float, max_epochs: int,
              train_samples: int) -> Summary:
    """The `Summary` of the sessions' rows (each with `session`, `precision`, `recall`,
    `f`, `epochs`, `best_epoch`, `stop_reason`, `seconds`, `best_val_loss`, as
    `wsmap.paper.tables.score_results` makes them) and the best session's `sweep`."""
    runs = pd.DataFrame(list(sessions))
    f = runs.f.to_numpy(dtype=float)
    best = int(runs.best_val_loss.to_numpy(dtype=float).argmin())
    return {
        "f_mean": float(f.mean()), "f_std": float(f.std(ddof=1)) if len(f) > 1 else math.nan,
        "f_sessions": f.tolist(), "precision_mean": float(runs.precision.mean()),
        "recall_mean": float(runs.recall.mean()), "precision_sessions": runs.precision.tolist(),
        "recall_sessions": runs.recall.tolist(), "best_session": int(runs.session.iloc[best]),
        "best_session_f": float(f[best]), "best_threshold": sweep.best_threshold, "best_threshold_f": sweep.best_f,
        "threshold": float(threshold), "sessions": int(len(runs)), "epochs": int(max_epochs),
        "epochs_run": runs.epochs.astype(int).tolist(), "best_epochs": runs.best_epoch.astype(int).tolist(),
        "stop_reasons": runs.stop_reason.tolist(), "seconds_per_session": runs.seconds.tolist(),
        "seconds_per_session_mean": float(np.mean(runs.seconds)), "train_samples": int(train_samples),
        "paper": dict(SEC61),
    }


@dataclass
class Result:
    """What `run` computed: the metrics and what the figures and tables draw from."""

    metrics: Metrics
    results: list  #: `wsmap.learn.training.TrainResult` per session
    evals: list[dict]  #: `wsmap.paper.fitting.evaluate` of each session on the test set
    per_session: pd.DataFrame
    errors: np.ndarray  #: the best session's fraction of wrong nodes per test arm
    sweep: Sweep
    train: Dataset
    test: Dataset
    train_config: TrainConfig
    cfg: Mapping

    @property
    def best(self) -> int:
        return self.metrics["best_session"]


def run(cfg: Mapping, out: Outputs, *, log: Callable[[str], Any] = print) -> Result:
    """Train and score the sessions of params section `cfg` on `out.data`'s dataset."""
    device, threads, train_all, train, test = fitting.training_data(cfg, out.data)
    spec = train.spec
    block = workspace.block_slice(4)
    if spec.select != (block.start, block.stop):
        raise ValueError(f"§6.1 learns block 5 (nodes {block.start}..{block.stop}); dataset {cfg['dataset']!r} "
                         f"selects {spec.select}")
    log(f"training on {len(train)} of {len(train_all)} arms, testing on {len(test)}; "
        f"{train.n_nodes} nodes {spec.select}; torch threads {threads}; device {device}")
    train_config = fitting.paper_train_config(cfg, device)
    results, t_fit = fitting.timed(lambda: fitting.fit(train, train_config, sessions=cfg["sessions"],
                                                       hidden=cfg["hidden"]))
    seconds = fitting.log_training(results, [f"session {i}" for i in range(len(results))], t_fit, "sessions", log)

    evals = [fitting.evaluate(r.model, test, threshold=cfg["threshold"]) for r in results]
    per_session = pd.DataFrame({
        "session": range(len(results)),
        "epochs": [r.stop_epoch for r in results],
        "best_epoch": [r.best_epoch for r in results],
        "val_mse": [r.best_val_loss for r in results],
        "precision": [e["precision"] for e in evals],
        "recall": [e["recall"] for e in evals],
        "f": [e["f"] for e in evals],
        "seconds": seconds,
    })
    rows = [{"session": i, "precision": e["precision"], "recall": e["recall"], "f": e["f"],
             "epochs": int(r.stop_epoch), "best_epoch": int(r.best_epoch), "stop_reason": r.stop_reason,
             "seconds": seconds[i], "best_val_loss": r.best_val_loss} for i, (r, e) in enumerate(zip(results, evals))]
    best = int(np.argmin([r.best_val_loss for r in results]))
    ev = evals[best]
    err = per_sample_error(ev["scores"], ev["truth"], cfg["threshold"])
    sweep = sweep_of(ev, cfg["sweep_points"])
    summary = summarise(rows, sweep, threshold=cfg["threshold"], max_epochs=cfg["max_epochs"],
                        train_samples=len(train))
    metrics: Metrics = {
        **summary,
        "best_session_precision": ev["precision"],
        "best_session_recall": ev["recall"],
        "best_session_f_per_sample_mean": ev["f_mean"],
        "best_session_error_per_sample_mean": float(err.mean()),
        "best_session_error_per_sample_std": float(err.std()),
        "best_session_arms_over_99_percent_right": float(np.mean(err < 0.01)),
        "seconds_training_total": t_fit,
        "torch_threads": threads,
        "device": str(device),
        "test_samples": len(test),
        "nodes": train.n_nodes,
        "hidden": list(cfg["hidden"]),
    }
    f = metrics["f_sessions"]
    log(f"F-measure {metrics['f_mean']:.4f} ± {metrics['f_std']:.4f} over {len(f)} sessions "
        f"(paper: {SEC61['f_mean']:.4f} ± {SEC61['f_std']:.4f} over {SEC61['sessions']})")
    log(f"best session {best}: F {ev['f']:.4f}; nodes predicted wrongly per arm {err.mean():.4%} ± {err.std():.4%}; "
        f"{np.mean(err < 0.01):.1%} of the arms have over 99 % of their nodes right")
    log(f"best threshold {sweep.best_threshold:.2f}: F {sweep.best_f:.4f} (at {cfg['threshold']}: {ev['f']:.4f})")
    return Result(check_metrics(metrics, Metrics, PART.name), results, evals, per_session, err, sweep, train, test,
                  train_config, cfg)


def save(result: Result, out: Outputs) -> None:
    """The metrics file, the sessions' and the sweep's tables, and the best session's model (its
    map_spec says what the outputs are, block 5 of the 21³ grid, so that `predict_maps` and
    `wsmap map --method model` can use it)."""
    cfg, best, ev = result.cfg, result.best, result.evals[result.best]
    write_table(result.per_session, out.tables / "sec61_sessions")
    sweep_table = pd.DataFrame({k: getattr(result.sweep, k)
                                for k in ("thresholds", "precision", "recall", "f", "tp", "fp", "fn", "tn")})
    write_table(sweep_table.rename(columns={"thresholds": "threshold"}), out.tables / "sec61_threshold_sweep")
    model = result.results[best].model
    model.set_map_spec(result.train.spec, threshold=cfg["threshold"])
    save_model(model, out.models / "sec61_subspace.pt", dataset_spec=result.train.spec,
               train_config=result.train_config, extra={"session": best, "f": ev["f"], "threshold": cfg["threshold"]})
    write_json(result.metrics, out.results / "sec61_subspace.json")


def figures(result: Result, out: Outputs) -> list[Path]:
    """The section's figures: gradient and loss over the sessions, the best session's error per test
    arm, sections of `sections` random test arms (layer `section_layer`), the threshold sweep."""
    import matplotlib.pyplot as plt

    cfg, best, test = result.cfg, result.best, result.test
    ev = result.evals[best]
    histories = [r.history for r in result.results]
    n = len(result.results)
    paths = []
    fig = viz.plot_mean_band(session_curves(histories, "grad_norm"), label="gradient norm",
                             ylabel="‖∇ MSE‖ (L2, all weights and biases)",
                             title=f"Average gradient (± σ) of {n} training sessions")
    paths.append(save_figure(fig, out.figures / "sec61_gradient.png"))
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    viz.plot_mean_band(session_curves(histories, "loss"), ax=ax, label="training MSE", ylabel="MSE")
    viz.plot_mean_band(session_curves(histories, "val_loss"), ax=ax, label="validation MSE", color="#d62728",
                       ylabel="MSE", title=f"Loss of {n} training sessions (mean ± σ)", show_sessions=False)
    paths.append(save_figure(fig, out.figures / "sec61_loss.png"))
    fig = viz.plot_sample_errors(result.errors, title=f"Error of predictions on a test set of {len(test)} examples "
                                                      f"(session {best}, threshold {cfg['threshold']})")
    paths.append(save_figure(fig, out.figures / "sec61_test_error.png"))

    rng = np.random.default_rng(cfg["section_seed"])
    pick = np.sort(rng.choice(len(test), size=min(cfg["sections"], len(test)), replace=False))
    z_value = float(spec_nodes(result.train.spec)[cfg["section_layer"] * 21 * 21, 2])
    fs = ev["f_per_sample"]
    titles = [f"arm {i}: F {fs[i]:.3f}" if np.isfinite(fs[i]) else f"arm {i}: none reachable" for i in pick]
    fig = viz.plot_sections(ev["scores"][pick] > cfg["threshold"], ev["truth"][pick], (21, 21, 3),
                            layer=cfg["section_layer"], lo=-1.0, step=0.1, z_value=z_value, titles=titles,
                            title=f"DNN-generated workspace section of {len(pick)} random manipulators in the test set")
    paths.append(save_figure(fig, out.figures / "sec61_sections.png"))
    fig = viz.plot_threshold_sweep(result.sweep, mark=cfg["threshold"],
                                   title=f"Threshold sweep, session {best} (paper: {SEC61['best_threshold']:g} best, "
                                         f"F {SEC61['best_threshold_f']:.4f})")
    paths.append(save_figure(fig, out.figures / "sec61_threshold_sweep.png"))
    return paths


# --------------------------------------------------------------------------------------------
# The paper's scale (`wsmap paper full sec61`): one unit, one session per step
# --------------------------------------------------------------------------------------------


def scale_plan(cfg: Mapping, planner: Planner) -> list[Unit]:
    """§6.1's one unit from params section `cfg`: a step per session; the best session's sweep
    (`sweep_points`) is its analysis, not a hashed setting."""
    values = {k: cfg[k] for k in ("dataset", "train_samples", "sessions", "max_epochs", "max_fail", "hidden", "seed",
                                  "threshold")}
    return [planner.unit("sec61_subspace", SCALE, cfg, planner.sessions(cfg), [cfg["dataset"]], values,
                         planner.train_config("rprop", "mse", cfg["max_epochs"], cfg["max_fail"], cfg["seed"],
                                              cfg.source),
                         "§6.1: block-5 subspace, Rprop + MSE sessions",
                         analysis={"sweep_points": whole_param(cfg.source, "sweep_points", cfg["sweep_points"], 2)})]


def scale_sweep(unit: Unit, step: str, data: Data, out: Path) -> Sweep:
    """The threshold sweep of session `step` (the best one, of lowest validation loss), as the
    paper's: its model scored on the test set at `sweep_points` thresholds evenly from 0 to 1
    (`sweep_of`)."""
    from ...learn.device import resolve_device
    from ...learn.files import load

    sec = unit.values
    model, _ = load(unit.model_file(out, step), map_location=resolve_device(unit.device, unit.device_what))
    evaluation = fitting.evaluate(model, data.pairs[sec["dataset"]][1], threshold=float(sec["threshold"]))
    return sweep_of(evaluation, unit.analysis["sweep_points"])


def scale_finalize(unit: Unit, steps: dict[str, dict], data: Data, out: Path) -> tuple[PaperScaleMetrics, list]:
    """The unit's `PaperScaleMetrics`: the sessions `summarise`d with the best one's sweep."""
    sec = unit.values
    runs = step_runs(steps)
    best = int(runs.best_val_loss.to_numpy(dtype=float).argmin())
    sweep = scale_sweep(unit, f"session_{int(runs.session.iloc[best])}", data, out)
    metrics = {**summarise(runs.to_dict("records"), sweep, threshold=float(sec["threshold"]),
                           max_epochs=int(sec["max_epochs"]), train_samples=int(runs.train_samples.iloc[0])),
               "sweep": sweep.to_dict(), "runs": runs.to_dict("records")}
    return check_metrics(metrics, PaperScaleMetrics, f"{unit.name} (paper scale)"), []


SCALE = Scale(kind="sec61", plan=scale_plan, finalize=scale_finalize, loads_models=True)

PART = Part("sec61_subspace", "§6.1: the block-5 subspace, Rprop + MSE sessions", 20, outputs=(
    "models/sec61_subspace.pt", "results/sec61_subspace.json",
    "tables/sec61_sessions.csv", "tables/sec61_sessions.md",
    "tables/sec61_threshold_sweep.csv", "tables/sec61_threshold_sweep.md",
    "figures/sec61_gradient.png", "figures/sec61_loss.png", "figures/sec61_test_error.png",
    "figures/sec61_sections.png", "figures/sec61_threshold_sweep.png"), scale=SCALE)
register(PART)
