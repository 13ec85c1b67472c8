"""Learned maps where they pay (beyond the paper).

The paper's idea on a family whose classical map is expensive: **panda7** (the Franka Panda with
its six non-zero lengths scaled by U(0.7, 1.3), joint limits, no closed form; its tool-down map
labelled by the numerical search), a map model trained on it (`wsmap.learn.family`), its
learning curve and speed against the numerical map; the paper's future work, a **manipulability**
model of the spherical-wrist family (`wsmap.learn.manipulability`); and **design by
gradient** through a map model against CMA-ES and random search on the classical map
(`wsmap.design`), for the spherical-wrist family (`improved_model`'s model) and panda7.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypedDict

import numpy as np
import pandas as pd

from ... import design, robots, viz, workspace
from ...datasets import Dataset
from ...io import write_json, write_table
from ...kinematics import lm_compiled
from ...learn import family as learn_family
from ...learn import manipulability as learn_manipulability
from ...learn.device import resolve_device
from ...learn.files import load as load_model
from ...learn.files import save as save_model
from ...paths import Outputs
from ...views import iso_mesh
from ..specs import load_pair
from . import Part, check_metrics, register, save_figure


class Panda7Metrics(TypedDict):
    train_arms: int
    test_arms: int
    f: float  #: pooled F on the held-out arms
    precision: float
    recall: float
    f_mean: float  #: per-arm F, mean and σ
    f_std: float
    epochs: int
    train_seconds: float
    recipe: dict  #: `wsmap.learn.family.MapRecipe`
    curve: list[dict]  #: F against the number of training arms
    speed: dict  #: one map from the model against the numerical map (`speedup`)


class Metrics(TypedDict):
    """`results/learned_maps.json`."""

    panda7: Panda7Metrics
    manipulability: dict  #: train/test arms, epochs and `wsmap.learn.manipulability.regression_metrics`
    design: dict  #: family -> rows of `wsmap.design.compare_designs`
    device: str


PART = Part("learned_maps", "Learned maps where they pay", 100, reads=("improved_model",), outputs=(
    "models/panda7_map.pt", "results/learned_maps.json",
    "tables/learned_maps_panda7_curve.csv", "tables/learned_maps_panda7_curve.md",
    "tables/learned_maps_design.csv", "tables/learned_maps_design.md",
    "figures/learned_maps_panda7_curve.png", "figures/learned_maps_panda7_slices.png",
    "figures/learned_maps_panda7_3d.png", "figures/learned_maps_puma560_manipulability_predicted.png",
    "figures/learned_maps_puma560_manipulability_exact.png", "figures/learned_maps_design_path.png",
    "figures/learned_maps_panda7_design_map.png"))


@dataclass
class Result:
    metrics: Metrics
    model: Any  #: the panda7 map model
    recipe: Any
    train: Dataset
    test: Dataset
    curve: pd.DataFrame
    shown: dict  #: the held-out arm shown: index, scales, predicted and labelled maps, F
    manipulability: dict  #: the PUMA560's predicted and exact manipulability, the grid
    studies: dict  #: family -> (tasks, rows, results) of the design comparison
    design_map: np.ndarray  #: the classical map of the verified panda7 design
    cfg: Mapping

    def design_table(self) -> pd.DataFrame:
        return pd.DataFrame([r for _, rows, _ in self.studies.values() for r in rows]).drop(columns=["params"])


def _panda7(p7: Mapping, device_setting: str, out: Outputs, log) -> dict:
    """The panda7 map model of section `p7`: trained, scored on the held-out arms, its learning
    curve, one held-out arm's maps and its speed against the classical map."""
    train, test = load_pair(p7["dataset"], out.data)
    spec = train.spec
    log(f"panda7: {len(train)} training arms, {len(test)} held-out arms, {train.n_nodes} nodes "
        f"({' x '.join(map(str, spec.grid_shape))}, tool-down); reachable share {train.labels.mean():.3f}")

    # inputs: the six scale factors (the columns that vary), standardised; one logit per node; Adam
    # on binary cross-entropy with a cosine schedule over a fixed number of epochs
    recipe = learn_family.MapRecipe.from_dict({**p7["recipe"], "device": device_setting})
    model, result = learn_family.fit_map_model(train, recipe)
    model = model.cpu()
    ev = learn_family.evaluate_map_model(model, test)
    history = result.history.to_frame()
    log(f"trained {result.stop_epoch} epochs in {history['time'].iloc[-1]:.0f} s; held-out F {ev['f']:.4f} "
        f"(P {ev['precision']:.4f}, R {ev['recall']:.4f}; per arm {ev['f_mean']:.4f} ± {ev['f_std']:.4f})")

    curve = learn_family.learning_curve(train, test, [n for n in p7["curve"] if n < len(train)], recipe)
    curve.append(learn_family.curve_row(len(train), ev, history["time"].iloc[-1], result.stop_epoch))
    curve = pd.DataFrame(curve).sort_values("train_arms")

    k = p7["show_arm"]
    scales = test.features[k, :spec.n_arm_features]
    predicted = model.predict_maps(scales[None])[0]
    labelled = test.labels[k]
    shown = {"arm": k, "scales": scales, "predicted": predicted, "labelled": labelled,
             "f": learn_family.score_maps(predicted[None], labelled[None])["f"]}

    speed = learn_family.speed_against_classical(model, test, arms=p7["speed_arms"], repeats=p7["timing_repeats"],
                                                 threads=1)
    log(f"one thread: model {speed['model_s'] * 1e3:.3f} ms per map, numerical map {speed['classical_s']:.3f} s "
        f"per map: {speed['speedup']:.0f}x")
    metrics = check_metrics(dict(
        train_arms=len(train), test_arms=len(test), f=ev["f"], precision=ev["precision"], recall=ev["recall"],
        f_mean=ev["f_mean"], f_std=ev["f_std"], epochs=int(result.stop_epoch),
        train_seconds=float(history["time"].iloc[-1]), recipe=recipe.to_dict(),
        curve=curve.to_dict(orient="records"), speed=speed), Panda7Metrics, f"{PART.name} panda7")
    return {"model": model, "recipe": recipe, "train": train, "test": test, "curve": curve, "shown": shown,
            "metrics": metrics}


def _manipulability(mc: Mapping, log) -> tuple[dict, dict]:
    """Yoshikawa's √det(JJᵀ) (m³ for a 6-joint arm), the largest over the closed form's branches,
    on the paper's 21³ grid at R = I: a network from the four free parameters (d3, d4, a2, a3) of
    section `mc`, scored on held-out arms; returns its metrics and the PUMA560's grid, predicted
    and exact maps."""
    p_train, y_train = learn_manipulability.manipulability_dataset(mc["train_arms"], seed=mc["seed"])
    p_test, y_test = learn_manipulability.manipulability_dataset(mc["test_arms"], seed=mc["seed"] + 1)
    mconfig = learn_manipulability.ManipulabilityTrainConfig(**{**mc["config"], "hidden": tuple(mc["config"]["hidden"])})
    mmodel, mresult = learn_manipulability.train_manipulability_model(p_train, y_train, mconfig)
    # held-out arms are drawn from the same range; a few may lie just beyond the training arms' min/max
    m_pred = learn_manipulability.predict_manipulability(mmodel, p_test, allow_extrapolation=True)
    mm = learn_manipulability.regression_metrics(m_pred, y_test)
    log(f"{len(p_train)} training arms, {int(np.max(mresult.stop_epoch))} epochs: held-out R² {mm['r2']:.4f} "
        f"(goal 0.98), MAE {mm['mae']:.5f} m³; on reachable nodes R² {mm['r2_reachable']:.4f}")
    puma = robots.puma560()
    exact = learn_manipulability.manipulability_targets(puma)
    maps = {"grid": learn_manipulability.manipulability_grid(),
            "predicted": learn_manipulability.predict_manipulability(mmodel, puma), "exact": exact}
    metrics = dict(train_arms=len(p_train), test_arms=len(p_test), epochs=int(np.max(mresult.stop_epoch)), **mm)
    return metrics, maps


def _designs(dc: Mapping, out: Outputs, panda7_model, spec, log) -> tuple[dict, np.ndarray]:
    """The shortest arm (total link length) whose map covers 20 task positions (corners and edge
    midpoints of a box) at tool-down, per family of section `dc`: gradient descent through the
    map model, every candidate verified by the classical map, against CMA-ES and random search on
    the classical map. Returns the studies (family -> tasks, table rows, results) and the
    classical map of the best panda7 design on `spec`'s grid."""
    studies = {}
    sw_model, _ = load_model(out.inputs.models / dc["sw_model"])  # another stage's output
    for fam, mdl, box in (("spherical_wrist", sw_model, dc["sw_box"]), ("panda7", panda7_model, dc["panda7_box"])):
        tasks = design.box_tasks(box["centre"], box["size"])
        rows, results = design.compare_designs(fam, tasks, mdl, max_calls=dc["max_calls"],
                                               max_seconds=dc["max_seconds"], seed=dc["seed"],
                                               gradient=dc["gradient"])
        studies[fam] = (tasks, rows, results)
        log(fam)
        log(design.format_design_table(rows))
    best = studies["panda7"][2]["gradient"]
    arm = robots.family_arm("panda7", best.params)
    nodes = workspace.cartesian_grid(spec.lo, spec.hi, spec.step)
    return studies, workspace.constant_orientation_map(arm, nodes, spec.fixed, convention=spec.convention)


def run(cfg: Mapping, out: Outputs, *, log=print) -> Result:
    """The panda7 model, the manipulability model and the design studies of params section `cfg`
    (the datasets in `out.data`; `improved_model`'s model in `out.inputs.models`)."""
    import torch

    device = resolve_device(cfg["device"], f"{cfg.source} device")  # before any work
    torch.set_num_threads(cfg["threads"])
    lm_compiled.set_threads(cfg["threads"])
    p7 = _panda7(cfg["panda7"], cfg["device"], out, log)
    manipulability_metrics, manipulability = _manipulability(cfg["manipulability"], log)
    studies, design_map = _designs(cfg["design"], out, p7["model"], p7["train"].spec, log)
    metrics: Metrics = dict(
        panda7=p7["metrics"],
        manipulability=manipulability_metrics,
        design={fam: rows for fam, (_, rows, _) in studies.items()},
        device=str(device),
    )
    return Result(check_metrics(metrics, Metrics, PART.name), p7["model"], p7["recipe"], p7["train"], p7["test"],
                  p7["curve"], p7["shown"], manipulability, studies, design_map, cfg)


def save(result: Result, out: Outputs) -> None:
    """The panda7 model, the curve's and the design's tables, the metrics file."""
    save_model(result.model, out.models / "panda7_map.pt", dataset_spec=result.train.spec,
               train_config=result.recipe.train_config(),
               extra={"recipe": result.recipe.to_dict(), "test_f": result.metrics["panda7"]["f"]})
    write_table(result.curve, out.tables / "learned_maps_panda7_curve")
    write_table(result.design_table(), out.tables / "learned_maps_design")
    write_json(result.metrics, out.results / "learned_maps.json")


def figures(result: Result, out: Outputs) -> list[Path]:
    """The learning curve, the shown arm (slices, 3-D), the PUMA560's manipulability (predicted,
    exact), the design's gradient paths and the verified panda7 design's classical map."""
    import matplotlib.pyplot as plt

    spec, curve, s = result.train.spec, result.curve, result.shown
    paths = []
    fig, ax = plt.subplots(figsize=(5, 3.5))
    ax.plot(curve["train_arms"], curve["f"], "o-")
    ax.set_xscale("log")
    ax.set_xlabel("training arms")
    ax.set_ylabel("F on held-out arms")
    ax.set_title(f"panda7 map model, {result.recipe.epochs} epochs each")
    ax.grid(True, alpha=0.3)
    paths.append(save_figure(fig, out.figures / "learned_maps_panda7_curve.png"))

    fig = viz.plot_slices(s["predicted"], spec.grid_shape, spec.lo, spec.step, compare=s["labelled"],
                          names=("model only (false positive)", "labels only (missed)", "both"),
                          title=f"panda7 held-out arm {s['arm']}: tool-down map, standard convention T = transl(p)·R\n"
                                f"the map model against its labels, F {s['f']:.4f} "
                                f"(scales {np.round(s['scales'], 3).tolist()})")
    paths.append(save_figure(fig, out.figures / "learned_maps_panda7_slices.png"))
    grid = workspace.grid_spec(spec.scope, spec.lo, spec.hi, spec.step)
    ax = viz.render_mesh(iso_mesh(s["predicted"], grid, 0.5),
                         title=f"held-out arm {s['arm']}: predicted tool-down workspace", lim=spec.hi)
    paths.append(save_figure(ax.figure, out.figures / "learned_maps_panda7_3d.png"))

    m = result.manipulability
    g = m["grid"]
    shape = workspace.grid_spec("R3", g["lo"], g["hi"], g["step"])["shape"]
    for what in ("predicted", "exact"):
        fig = viz.plot_value_slices(m[what], shape, g["lo"], g["step"], label="manipulability (m³)", vmin=0.0,
                                    vmax=float(m["exact"].max()), title=f"PUMA560: {what} manipulability, R = I")
        paths.append(save_figure(fig, out.figures / f"learned_maps_puma560_manipulability_{what}.png"))

    fig, axes = plt.subplots(1, 2, figsize=(10, 3.5))
    for ax, (fam, (_, _, results)) in zip(axes, result.studies.items()):
        g_path = results["gradient"].path
        ax.plot(np.arange(len(g_path)), g_path[:, 0], label="gradient (descent steps)")
        ax.set_xlabel("step")
        ax.set_ylabel("total length (m)")
        ax.set_title(f"{fam}: gradient descent path, verified {results['gradient'].total_length:.3f} m")
        ax.grid(True, alpha=0.3)
    paths.append(save_figure(fig, out.figures / "learned_maps_design_path.png"))
    best = result.studies["panda7"][2]["gradient"]
    fig = viz.plot_slices(result.design_map, spec.grid_shape, spec.lo, spec.step,
                          title=f"panda7 design by gradient (scales {np.round(best.params, 3).tolist()}): classical map")
    paths.append(save_figure(fig, out.figures / "learned_maps_panda7_design_map.png"))
    return paths


register(PART)
