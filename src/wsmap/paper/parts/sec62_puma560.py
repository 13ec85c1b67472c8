"""§6.2: seven block subspaces of the 9261-node map, stacked; the PUMA560 they assemble.

The 21³ map (grid [-1, 1] m at 0.1 m, R = I) splits into 7 consecutive blocks of 1323 nodes; one
§6.1 network per block (same config and seed, trained one after another), stacked into one model
that predicts the whole map. Scored per block and assembled on the test set (pooled F at
`threshold`), and on the PUMA560 against its exact (closed-form) map.

The notebook (`run`) and the paper-scale runner (`wsmap.paper.full` through `SCALE`: one
block per resumable step) summarise the blocks with the same `summarise` into `Summary`, and
score the PUMA560 with the same `puma560_map`.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypedDict

import numpy as np
import pandas as pd

from ... import robots, viz, workspace
from ...datasets import Dataset, DatasetSpec, features_for, grid_axes, labels_for
from ...io import write_json, write_table
from ...kinematics import arm_batch
from ...learn.files import save as save_model
from ...learn.training import TrainConfig
from ...metrics import PRF, error_histogram, precision_recall_f
from ...paths import Outputs
from ...timing import time_call
from ...views import iso_mesh
from .. import fitting
from ..published import SEC62
from ..scale import Data, Planner, Scale, Unit, history, relative, save_model as save_step_model
from . import Part, check_metrics, register, save_figure


class Summary(TypedDict):
    """The blocks and the assembled map summarised (`summarise`): the notebook's and the
    paper-scale runner's keys."""

    f_full: float  #: pooled F of the assembled 9261-node map on the test set
    precision_full: float
    recall_full: float
    f_per_sample_full: float  #: mean over test arms of each arm's F
    f_blocks: list[float]  #: pooled F of each block on the test set
    precision_blocks: list[float]
    recall_blocks: list[float]
    epochs_run: list[int]  #: epochs each block trained (early stopping at `max_fail`)
    best_epochs: list[int]
    stop_reasons: list[str]
    seconds_per_block: list[float]  #: training wall time of each block (s)
    puma560_f: float  #: the PUMA560's predicted map against its exact one
    puma560_precision: float
    puma560_recall: float
    puma560_reachable_predicted: int
    puma560_reachable_exact: int
    train_samples: int
    test_samples: int
    max_fail: int
    paper: dict  #: `wsmap.paper.published.SEC62`


class Metrics(Summary):
    """`results/sec62_puma560.json`: `Summary` plus what the notebook measures beside it."""

    error_mean_blocks: list[float]  #: mean of truth − output per block
    error_std_blocks: list[float]
    puma560_mesh_faces: int  #: faces of the predicted map's marching-cubes mesh
    puma560_mesh_watertight: bool
    runtime_one_map_s: dict[str, float]  #: seconds to score one arm's map, per block and assembled
    runtime_one_map_std_s: dict[str, float]
    runtime_test_set_s: dict[str, float]  #: seconds to score the whole test set
    runtime_test_set_std_s: dict[str, float]
    subspaces: int
    epochs: int  #: `max_epochs`
    seconds_training_total: float
    torch_threads: int
    device: str
    hidden: list[int]


class PaperScaleMetrics(Summary):
    """`results/full/sec62_puma560.json`'s `metrics`."""

    max_epochs: int
    model_file: str  #: the stacked model, relative to the result folder


def puma560_map(model, spec: DatasetSpec, threshold: float) -> tuple[np.ndarray, np.ndarray, PRF]:
    """The PUMA560's map as the stacked `model` predicts it (assembled, at `threshold`), its
    exact map (closed form) on the dataset `spec`'s grid, and their precision/recall/F."""
    puma = arm_batch(robots.puma560())
    predicted = model.predict(features_for(puma, spec), threshold, assemble=True).cpu().numpy()[0]
    exact = labels_for(puma, spec)[0]
    return predicted, exact, precision_recall_f(predicted, exact)


def summarise(blocks: Sequence[Mapping[str, Any]], full: Mapping[str, Any], puma: tuple, *, train_samples: int,
              test_samples: int, max_fail: int) -> Summary:
    """The `Summary` of the blocks' rows (each with `f`, `precision`, `recall`,
    `epochs`, `best_epoch`, `stop_reason`, `seconds`), the assembled map's evaluation
    `full` (`wsmap.paper.fitting.evaluate`) and `puma560_map`'s `puma`."""
    predicted, exact, prf = puma
    return {
        "f_full": full["f"], "precision_full": full["precision"], "recall_full": full["recall"],
        "f_per_sample_full": full["f_mean"], "f_blocks": [b["f"] for b in blocks],
        "precision_blocks": [b["precision"] for b in blocks], "recall_blocks": [b["recall"] for b in blocks],
        "epochs_run": [int(b["epochs"]) for b in blocks], "best_epochs": [int(b["best_epoch"]) for b in blocks],
        "stop_reasons": [b["stop_reason"] for b in blocks], "seconds_per_block": [b["seconds"] for b in blocks],
        "puma560_f": prf.f, "puma560_precision": prf.precision, "puma560_recall": prf.recall,
        "puma560_reachable_predicted": int(predicted.sum()), "puma560_reachable_exact": int(exact.sum()),
        "train_samples": int(train_samples), "test_samples": int(test_samples), "max_fail": int(max_fail),
        "paper": dict(SEC62),
    }


@dataclass
class Result:
    """What `run` computed: the metrics and what the figures, tables and files draw from."""

    metrics: Metrics
    model: Any  #: the stacked `wsmap.learn.SubspaceMLP`
    results: list
    names: list[str]  #: "block 1", ...
    z_ranges: list[str]
    evals: list[dict]
    full: dict
    hists: list  #: `wsmap.metrics.ErrorHistogram` per block
    hist_full: Any
    one_arm: dict[str, np.ndarray]  #: timings (s) of one arm's map
    all_arms: dict[str, np.ndarray]  #: timings (s) of the test set's maps
    predicted: np.ndarray  #: the PUMA560's predicted map
    exact: np.ndarray
    puma: PRF
    mesh: Any  #: marching-cubes mesh of `predicted` (empty when nothing is predicted reachable)
    train: Dataset
    test: Dataset
    train_config: TrainConfig
    cfg: Mapping


def _times(fn, repeats):
    """Wall-clock seconds of `repeats` calls of `fn` after 2 untimed ones, as an array. `fn`
    returns a tensor, copied to the host inside the timing (on a GPU: the work is finished)."""
    return np.asarray(time_call(lambda: fn().cpu(), repeats, warmup=2).values)


def run(cfg: Mapping, out: Outputs, *, log: Callable[[str], Any] = print) -> Result:
    """Train the 7 blocks of params section `cfg`, score them, time them, map the PUMA560."""
    import trimesh

    device, threads, train_all, train, test = fitting.training_data(cfg, out.data)
    spec = train.spec
    blocks = [workspace.block_slice(k) for k in range(workspace.N_BLOCKS)]
    z_axis = grid_axes(spec)[2]
    names = [f"block {k + 1}" for k in range(len(blocks))]
    z_ranges = [f"{z_axis[3 * k]:+.1f}..{z_axis[3 * k + 2]:+.1f}" for k in range(len(blocks))]
    log(f"training on {len(train)} of {len(train_all)} arms, testing on {len(test)}; grid {spec.grid_shape}, "
        f"{len(blocks)} blocks of {workspace.BLOCK_NODES} nodes; torch threads {threads}; device {device}")

    train_config = fitting.paper_train_config(cfg, device)
    (model, results), t_fit = fitting.timed(lambda: fitting.fit_blocks(train, train_config, blocks,
                                                                       hidden=cfg["hidden"]))
    seconds = fitting.log_training(results, [f"{n} (z {z})" for n, z in zip(names, z_ranges)], t_fit, "blocks", log)
    if model.n_subspaces != len(blocks):
        raise RuntimeError(f"the stacked model has {model.n_subspaces} subspaces, not {len(blocks)}")

    evals = [fitting.evaluate(model, test, nodes=b, key=k, threshold=cfg["threshold"]) for k, b in enumerate(blocks)]
    full = fitting.evaluate(model, test, assemble=True, threshold=cfg["threshold"])
    hist_full = error_histogram(full["scores"], full["truth"], bins=cfg["histogram_bins"])
    hists = [error_histogram(e["scores"], e["truth"], bins=hist_full.edges) for e in evals]

    x_one = test.features[:1]
    reps = cfg["runtime_repeats"]
    one_arm = {n: _times(lambda k=k: model.score(x_one, key=k), reps) for k, n in enumerate(names)}
    one_arm["assembled (9261)"] = _times(lambda: model.score(x_one, assemble=True), reps)
    all_arms = {n: _times(lambda k=k: model.score(test.features, key=k), max(3, reps // 5))
                for k, n in enumerate(names)}
    all_arms["assembled (9261)"] = _times(lambda: model.score(test.features, assemble=True), max(3, reps // 5))

    t0 = time.perf_counter()
    puma = puma560_map(model, spec, cfg["threshold"])
    t_puma = time.perf_counter() - t0
    predicted, exact, puma_prf = puma
    log(f"PUMA560: {predicted.sum()} nodes predicted reachable, {exact.sum()} exact; precision "
        f"{puma_prf.precision:.4f}, recall {puma_prf.recall:.4f}, F {puma_prf.f:.4f}; {t_puma * 1e3:.1f} ms")
    mesh = (iso_mesh(predicted, {"lo": spec.lo, "step": spec.step, "shape": spec.grid_shape}, 0.5) if predicted.any()
            else trimesh.Trimesh())
    log(f"predicted mesh: {len(mesh.vertices)} vertices, {len(mesh.faces)} faces, watertight={mesh.is_watertight}")

    rows = [{"f": e["f"], "precision": e["precision"], "recall": e["recall"], "epochs": r.stop_epoch,
             "best_epoch": r.best_epoch, "stop_reason": r.stop_reason, "seconds": s}
            for e, r, s in zip(evals, results, seconds)]
    metrics: Metrics = {
        **summarise(rows, full, puma, train_samples=len(train), test_samples=len(test), max_fail=cfg["max_fail"]),
        "error_mean_blocks": [h.mean for h in hists],
        "error_std_blocks": [h.std for h in hists],
        "puma560_mesh_faces": int(len(mesh.faces)),
        "puma560_mesh_watertight": bool(mesh.is_watertight) if len(mesh.faces) else False,
        "runtime_one_map_s": {n: float(t.mean()) for n, t in one_arm.items()},
        "runtime_one_map_std_s": {n: float(t.std()) for n, t in one_arm.items()},
        "runtime_test_set_s": {n: float(t.mean()) for n, t in all_arms.items()},
        "runtime_test_set_std_s": {n: float(t.std()) for n, t in all_arms.items()},
        "subspaces": model.n_subspaces,
        "epochs": cfg["max_epochs"],
        "seconds_training_total": t_fit,
        "torch_threads": threads,
        "device": str(device),
        "hidden": list(cfg["hidden"]),
    }
    return Result(check_metrics(metrics, Metrics, PART.name), model, results, names, z_ranges, evals, full, hists,
                  hist_full, one_arm, all_arms, predicted, exact, puma_prf, mesh, train, test, train_config, cfg)


def table(result: Result) -> pd.DataFrame:
    """One row per block and one for the assembled map: accuracy, errors, training, run time."""
    r_ = result
    seconds = r_.metrics["seconds_per_block"]
    z_axis = grid_axes(r_.train.spec)[2]
    rows = []
    for k, (e, r, h) in enumerate(zip(r_.evals, r_.results, r_.hists)):
        rows.append({"subspace": r_.names[k], "z (m)": r_.z_ranges[k], "nodes": e["nodes"],
                     "reachable": float(e["truth"].mean()), "precision": e["precision"], "recall": e["recall"],
                     "f": e["f"], "f_per_sample": e["f_mean"], "error_mean": h.mean, "error_std": h.std,
                     "epochs": r.stop_epoch, "best_epoch": r.best_epoch, "stop": r.stop_reason,
                     "val_mse": r.best_val_loss, "train_s": seconds[k], "one_map_ms": 1e3 * r_.one_arm[r_.names[k]].mean(),
                     "one_map_ms_std": 1e3 * r_.one_arm[r_.names[k]].std()})
    full, hist_full, one = r_.full, r_.hist_full, r_.one_arm["assembled (9261)"]
    rows.append({"subspace": "assembled", "z (m)": f"{z_axis[0]:+.1f}..{z_axis[-1]:+.1f}", "nodes": full["nodes"],
                 "reachable": float(full["truth"].mean()), "precision": full["precision"], "recall": full["recall"],
                 "f": full["f"], "f_per_sample": full["f_mean"], "error_mean": hist_full.mean,
                 "error_std": hist_full.std, "epochs": None, "best_epoch": None, "stop": "", "val_mse": None,
                 "train_s": float(sum(seconds)), "one_map_ms": 1e3 * one.mean(), "one_map_ms_std": 1e3 * one.std()})
    return pd.DataFrame(rows).astype({"epochs": "Int64", "best_epoch": "Int64"})


def save(result: Result, out: Outputs) -> None:
    """The metrics file, the table, the predicted PUMA560 mesh (GLB, STL) and the stacked model (its
    map_spec: the 7 subspaces assembled in node order are the 9261-node map, so that
    `predict_maps` and `wsmap map --method model` use it as a stand-in for the classical map)."""
    cfg, model, spec = result.cfg, result.model, result.train.spec
    write_table(table(result), out.tables / "sec62_subspaces")
    viz.export_mesh(result.mesh, out.results / "puma560_workspace_predicted.glb")
    viz.export_mesh(result.mesh, out.results / "puma560_workspace_predicted.stl")
    blocks = [workspace.block_slice(k) for k in range(workspace.N_BLOCKS)]
    model.set_map_spec(spec, assemble=True, threshold=cfg["threshold"])
    save_model(model, out.models / "sec62_puma560.pt", dataset_spec=spec, train_config=result.train_config,
               extra={"blocks": [[b.start, b.stop] for b in blocks], "threshold": cfg["threshold"]})
    write_json(result.metrics, out.results / "sec62_puma560.json")


def figures(result: Result, out: Outputs) -> list[Path]:
    """Training curves of the blocks, histograms of the errors, run times, the PUMA560's predicted
    workspace (mesh beside the exact one; slices against the exact map)."""
    r, spec = result, result.train.spec
    shape = spec.grid_shape
    paths = []
    fig = viz.plot_training_curves([x.history for x in r.results], [f"{n} (z {z})" for n, z in zip(r.names, r.z_ranges)],
                                   best_epochs=[x.best_epoch for x in r.results],
                                   title="Subspace training of equal dimension")
    paths.append(save_figure(fig, out.figures / "sec62_training.png"))
    fig = viz.plot_error_histograms(r.hists + [r.hist_full], r.names + [f"assembled ({r.full['nodes']} nodes)"],
                                    title=f"Histogram of prediction errors ({len(r.test)} test arms)")
    paths.append(save_figure(fig, out.figures / "sec62_error_histogram.png"))
    fig = viz.plot_runtimes({"one arm's map": r.one_arm, f"maps of the {len(r.test)} test arms": r.all_arms},
                            title=f"Run time of subspace models (torch, {r.metrics['device']}, "
                                  f"{r.metrics['torch_threads']} thread(s))")
    paths.append(save_figure(fig, out.figures / "sec62_subspace_runtime.png"))
    mesh_exact = iso_mesh(r.exact, {"lo": spec.lo, "step": spec.step, "shape": shape}, 0.5)
    lim = float(np.max(np.abs(np.concatenate([np.ravel(spec.lo), np.ravel(spec.hi)]))))
    fig = viz.plot_meshes([mesh_exact, r.mesh],
                          ["PUMA560, exact (closed form)",
                           f"generated by {r.model.n_subspaces} subspace models (F {r.puma.f:.3f})"], lim=lim,
                          suptitle="Workspace of PUMA560 robot generated by 7 subspace models")
    paths.append(save_figure(fig, out.figures / "puma560_workspace_predicted.png"))
    fig = viz.plot_slices(r.predicted, shape, spec.lo, spec.step, compare=r.exact,
                          names=("predicted only (false positive)", "exact only (missed)", "both"),
                          title=f"PUMA560: constant map, R = I, paper convention T = R·transl(p)\n"
                                f"the 7 block models against the exact map, F {r.puma.f:.4f}")
    paths.append(save_figure(fig, out.figures / "sec62_puma560_slices.png"))
    return paths


# --------------------------------------------------------------------------------------------
# The paper's scale (`wsmap paper full sec62`): one unit, one block per step
# --------------------------------------------------------------------------------------------


def scale_plan(cfg: Mapping, planner: Planner) -> list[Unit]:
    """§6.2's one unit from params section `cfg`: a step per block (`block_1` .. `block_7`)."""
    values = {k: cfg[k] for k in ("dataset", "train_samples", "max_epochs", "max_fail", "hidden", "seed", "threshold")}
    return [planner.unit("sec62_puma560", SCALE, cfg, [f"block_{k + 1}" for k in range(workspace.N_BLOCKS)],
                         [cfg["dataset"]], values,
                         planner.train_config("rprop", "mse", cfg["max_epochs"], cfg["max_fail"], cfg["seed"],
                                              cfg.source),
                         "§6.2: 7 block subspaces, stacked; PUMA560")]


def scale_step(unit: Unit, step: str, data: Data, out: Path) -> dict:
    """One block (`block_k`, 1-based): as `wsmap.paper.fitting.fit_blocks` trains it, scored on
    the test set's nodes of the block, its model saved."""
    k = int(step.split("_")[1]) - 1
    sec = unit.values
    train_all, test = data.pairs[sec["dataset"]]
    train = train_all.head(sec["train_samples"])
    block = workspace.block_slice(k)
    config = unit.train_config
    t0 = time.perf_counter()
    (result,) = fitting.fit(train, config, nodes=block, sessions=1, hidden=sec["hidden"])
    t1 = time.perf_counter()
    ev = fitting.evaluate(result.model, test, nodes=block, key=0, threshold=float(sec["threshold"]))
    t2 = time.perf_counter()
    save_step_model(result.model, unit.model_file(out, step), train.spec, config,
                    {"part": unit.name, "step": step, "block": [block.start, block.stop], "settings_hash": unit.hash},
                    nodes=(block.start, block.stop), threshold=float(sec["threshold"]))
    t3 = time.perf_counter()
    metrics = {"block": k + 1, "nodes": [block.start, block.stop], "precision": ev["precision"],
               "recall": ev["recall"], "f": ev["f"], "f_per_sample": ev["f_mean"],
               "reachable": float(ev["truth"].mean()), "epochs": int(result.stop_epoch),
               "best_epoch": int(result.best_epoch), "stop_reason": result.stop_reason,
               "best_val_loss": float(result.best_val_loss), "train_samples": len(train),
               "seconds": float(result.history.time[-1])}
    return {"metrics": metrics, "history": history(result),
            "timings": {"train_s": t1 - t0, "score_s": t2 - t1, "save_s": t3 - t2, "epochs": int(result.stop_epoch),
                        "seconds_per_epoch": (t1 - t0) / max(1, int(result.stop_epoch))}}


def scale_summary(unit: Unit, done: dict) -> str:
    """A finished block in one line: its F, epochs and why it stopped."""
    m = done["metrics"]
    return f"F {m['f']:.4f}, {m['epochs']} epochs ({m['stop_reason']})"


def scale_finalize(unit: Unit, steps: dict[str, dict], data: Data, out: Path) -> tuple[PaperScaleMetrics, list[Path]]:
    """The 7 block models stacked into `models/sec62_puma560.pt` (under the result folder),
    scored on the whole map and on the PUMA560, `summarise`d with the blocks' scores."""
    from ...learn import SubspaceMLP
    from ...learn.device import resolve_device
    from ...learn.files import load

    sec = unit.values
    device = resolve_device(unit.device, unit.device_what)
    model = SubspaceMLP.from_models([load(unit.model_file(out, s), map_location=device)[0] for s in unit.steps])
    train_all, test = data.pairs[sec["dataset"]]
    spec = train_all.head(sec["train_samples"]).spec
    threshold = float(sec["threshold"])
    full = fitting.evaluate(model, test, assemble=True, threshold=threshold)
    puma = puma560_map(model, spec, threshold)
    model.set_map_spec(spec, assemble=True, threshold=threshold)
    stacked = Path(out) / "models" / f"{unit.name}.pt"
    save_model(model, stacked, dataset_spec=spec, train_config=unit.train_config,
               extra={"part": unit.name, "settings_hash": unit.hash, "threshold": threshold})
    blocks = [steps[s]["metrics"] for s in unit.steps]
    metrics = {
        **summarise(blocks, full, puma, train_samples=blocks[0]["train_samples"], test_samples=len(test),
                    max_fail=int(sec["max_fail"])),
        "max_epochs": int(sec["max_epochs"]), "model_file": relative(stacked, out),
    }
    return check_metrics(metrics, PaperScaleMetrics, f"{unit.name} (paper scale)"), [stacked]


SCALE = Scale(kind="sec62", plan=scale_plan, finalize=scale_finalize, step=scale_step, summary=scale_summary,
              loads_models=True, sessions=False, step_metrics=True, stops_early=True,
              step_nodes=workspace.BLOCK_NODES)

PART = Part("sec62_puma560", "§6.2: 7 block subspaces, stacked; the PUMA560", 30, outputs=(
    "models/sec62_puma560.pt", "results/sec62_puma560.json",
    "results/puma560_workspace_predicted.glb", "results/puma560_workspace_predicted.stl",
    "tables/sec62_subspaces.csv", "tables/sec62_subspaces.md",
    "figures/sec62_training.png", "figures/sec62_error_histogram.png", "figures/sec62_subspace_runtime.png",
    "figures/puma560_workspace_predicted.png", "figures/sec62_puma560_slices.png"), scale=SCALE)
register(PART)
