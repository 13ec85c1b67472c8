"""One network for every arm: workspace maps of arms it has never seen (beyond the paper, issue 28).

The experience: arms of the `morph6` and `morph7` families (`wsmap.robots.morph`: every
serial 6R/7R arm in the range of industrial and collaborative arms, the named arms held out), their
tool-down map (`R = Rx(pi)`, `T = transl(p)·R`) on `[-1.5, 1.5]³` at `step` labelled by the
numerical map search, built in resumable shards (`wsmap.learn.morph_model.build_morph_shards`,
on a local Dask cluster with `workers`). The model: the implicit network `f(morphology, point)`
of `wsmap.learn.morph_model`. Beside it, on the same held-out arms:

* `fk_model`: the same network trained on labels from forward kinematics alone
  (`fk_labels`: no inverse kinematics, as RAM's experience);
* `nearest_arm`: the map-search map of the training arm nearest in the description space;
* `fk_sampled`: the held-out arm's own forward-kinematics-sampled map (no learning: what
  sampling that arm directly gives for the same number of samples);
* `family_model`, for a named arm that belongs to a family (params `family`: the Panda is
  `panda7` at scale 1): that family's map model (`wsmap.learn.family.fit_map_model`, the
  `learned_maps` recipe) trained here on the same grid, orientation and label search.

Held out: the random arms of shard 0's test streams (never trained on) and the six named arms
(labelled here by the same map search; no training arm within
`HOLD_OUT_RADIUS` of them, checked). Then one 3-D map of `time_step`
by the model against the classical map of the same arm, side by side. Last, design across
morphologies (`wsmap.morph_design`): the shortest 6R arm of any twist pattern whose
tool-down map covers a box of task positions, by gradient through the model against CMA-ES and
random search on the classical map (params `design`), every answer verified by the classical map.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypedDict

import numpy as np
import pandas as pd
import torch

from ... import robots, viz, workspace
from ...io import write_json, write_table
from ...kinematics.morphology import describe, morphology_distance
from ...learn import TrainConfig
from ...learn.device import resolve_device
from ...learn import morph_model as mm
from ...learn.training_range import ExtrapolationWarning
from ...metrics import score_maps
from ...paths import Outputs
from ...robots.morph import HELD_OUT, HOLD_OUT_RADIUS, MORPH_GRID
from . import Part, check_metrics, register, save_figure

#: The methods scored on the held-out arms, in the tables' order.
METHODS = ("model", "fk_model", "nearest_arm", "fk_sampled")


class Metrics(TypedDict):
    """`results/morphologies.json`."""

    step: float  #: label grid step (m) on [-1.5, 1.5]³
    nodes: int  #: nodes of the label grid
    train_arms: dict  #: family -> training arms
    test_arms: dict  #: family -> held-out random arms
    label_seconds: float  #: map-search labels of every training and held-out random arm (s)
    arms_per_second: float  #: of those labels
    fk_label_seconds: float  #: forward-kinematics labels of the training arms (s)
    fk: dict  #: samples, angle_tol (rad) of the forward-kinematics labels
    train: dict  #: per model: epochs, seconds, threshold
    pooled: dict  #: method -> F, precision, recall, per-arm F mean over the held-out random arms
    named: dict  #: arm -> method -> F, precision, recall; and its distance to the nearest training arm (m)
    hold_out: dict  #: the least distance (m) from a training arm to a named arm, and the radius kept clear
    speed: list  #: one 3-D map of an arm by the model against the classical map (s, speed-up)
    design: dict  #: tasks (m), and per method: time, classical calls, total length (m), verified, DH table
    family: dict  #: named arm -> its family, training arms, seconds, and the family model's F, precision, recall
    device: str


PART = Part("morphologies", "One network for every arm: maps of arms it has never seen", 105, outputs=(
    "data/morph", "models/morph.pt", "models/morph_fk.pt", "results/morphologies.json",
    "tables/morphologies_arms.csv", "tables/morphologies_arms.md",
    "tables/morphologies_speed.csv", "tables/morphologies_speed.md",
    "tables/morphologies_design.csv", "tables/morphologies_design.md",
    "figures/morphologies_f.png", "figures/morphologies_slices.png"))


@dataclass
class Result:
    metrics: Metrics
    model: Any
    fk_model: Any
    arms: pd.DataFrame  #: one row per (arm group, method): F, precision, recall
    speed: pd.DataFrame
    design: pd.DataFrame  #: one row per design method (`wsmap.design.format_design_table`'s columns)
    shown: dict  #: the named arm shown: name, labels and each method's map, grid shape


def _scores(pred, truth) -> dict[str, float]:
    s = score_maps(np.atleast_2d(pred), np.atleast_2d(truth))
    return {"f": float(s["f"]), "precision": float(s["precision"]), "recall": float(s["recall"]),
            "f_mean": float(s["f_mean"])}


def _predict(model, features) -> np.ndarray:
    """Maps `(B, N)` of arms by their features, at the model's nodes and threshold."""
    with torch.no_grad():
        prob = torch.sigmoid(model(torch.as_tensor(features, dtype=torch.float32))).numpy()
    return prob > model.threshold


def _train_config(t: Mapping, seed: int, device: str = "cpu") -> TrainConfig:
    return TrainConfig(optimizer="adam", optimizer_kwargs={"lr": float(t["lr"])}, loss="crossentropy",
                       batch_size=int(t["batch_size"]), lr_decay="cosine", max_epochs=int(t["epochs"]), max_fail=1000,
                       fractions=(0.95, 0.05, 0.0), seed=seed, pos_weight=t.get("pos_weight"), device=device)


def _experience(cfg: Mapping, data_dir: Path, step: float, seed: int, fk: dict) -> dict:
    """The labelled arms (`morph6` and `morph7` shards, each family's last shard the held-out
    test set; built once into `data_dir`) and the FK-sampled labels of the training arms, with
    the seconds each took."""
    train_sets, test_sets = [], []
    t0 = time.perf_counter()
    for n in (6, 7):
        built, _ = mm.build_morph_shards(data_dir, n, int(cfg["shards"]), int(cfg["arms_per_shard"]), step=step,
                                         box=MORPH_GRID, first_seed=seed, test_samples=int(cfg["test_arms"]),
                                         workers=cfg["workers"])
        train_sets += built[:-1]
        test_sets.append(built[-1])
    label_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    fk_train = [mm.fk_labels(d, seed=seed, **fk) for d in train_sets]
    return {"train": train_sets, "test": test_sets, "fk_train": fk_train, "label_s": label_s,
            "fk_label_s": time.perf_counter() - t0}


def _train_both(cfg: Mapping, exp: dict, model_cfg, seed: int, device: str) -> dict:
    """The model (on the map-search labels) and the FK-only model (on the FK-sampled labels):
    name -> (model, its epochs, seconds and threshold)."""
    trained = {}
    for name, labels in (("model", None), ("fk_model", exp["fk_train"])):
        t0 = time.perf_counter()
        model, res = mm.fit_morph_model(exp["train"], model_cfg, _train_config(cfg["train"], seed, device),
                                        seed=seed,
                                        labels=labels)
        trained[name] = (model, {"epochs": int(res.stop_epoch), "seconds": time.perf_counter() - t0,
                                 "threshold": float(model.threshold)})
    return trained


def _named_arms(cfg: Mapping, model, fk_model, train_F, train_Y, spec, nodes, seed: int, fk: dict, rows: list):
    """Every method on each named arm the families hold out (`HELD_OUT`), its distance to the
    nearest training arm; rows appended to `rows`. Returns (name -> scores, the arm `show`'s
    maps, the least distance); a training arm inside the hold-out radius is a `RuntimeError`."""
    named, shown = {}, None
    least = math.inf
    for name in HELD_OUT:
        arm = robots.load(name)
        f = describe(arm).features()
        d = morphology_distance(train_F, f[None]).min()
        least = min(least, float(d))
        truth = workspace.constant_orientation_map(arm, nodes, mm.TOOL_DOWN, convention="standard")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ExtrapolationWarning)  # recorded below as in_range
            p = {m: mm.predict_morph_map(mdl, arm, nodes, allow_extrapolation=True)
                 for m, mdl in (("model", model), ("fk_model", fk_model))}
        p["nearest_arm"] = mm.nearest_arm_maps(train_F, train_Y, f[None])[0][0]
        p["fk_sampled"] = workspace.fk_sampled_maps(arm, spec.lo, spec.hi, spec.step, mm.TOOL_DOWN, seed=seed + 2,
                                                    **fk)
        named[name] = {"distance": float(d), "reachable_nodes": int(truth.sum()),
                       **{m: _scores(p[m], truth) for m in METHODS}}
        rows += [{"arms": name, "method": m, **named[name][m]} for m in METHODS]
        if name == cfg["show"]:
            shown = {"name": name, "truth": truth, "maps": p, "shape": spec.grid_shape, "lo": spec.lo,
                     "step": spec.step}
    if least <= HOLD_OUT_RADIUS:
        raise RuntimeError(f"a training arm lies {least:.3f} m from a named arm, inside the hold-out radius "
                           f"{HOLD_OUT_RADIUS} m")
    return named, shown, least


def _stacked(sets) -> tuple[np.ndarray, np.ndarray]:
    """The morphology features and the labels of datasets `sets`, one row per arm."""
    return (np.concatenate([mm.morph_features(list(d.features[:, :d.spec.n_arm_features])) for d in sets]),
            np.concatenate([d.labels for d in sets]))


def run(cfg: Mapping, out: Outputs) -> Result:
    """Build (or reuse) the experience, train the model and the FK-only model, score every method on
    the held-out arms, time one map (module notes). `cfg`: the `morphologies` params section."""
    device = resolve_device(cfg["device"], f"{cfg.source} device")  # before any work: cuda without a GPU fails here
    torch.set_num_threads(int(cfg["threads"]))
    step, seed = float(cfg["step"]), int(cfg["seed"])
    members = _family_members(cfg["family"], cfg.source)  # before any work
    model_cfg = mm.MorphModelConfig(**{k: tuple(v) if isinstance(v, list) else v for k, v in cfg["model"].items()})
    fk = {"samples": int(cfg["fk"]["samples"]), "angle_tol": float(cfg["fk"]["angle_tol"])}
    data_dir = Path(out.root) / "data" / "morph"
    exp = _experience(cfg, data_dir, step, seed, fk)
    train_sets, test_sets = exp["train"], exp["test"]
    n_labelled = sum(len(d.features) for d in (*train_sets, *test_sets))
    trained = _train_both(cfg, exp, model_cfg, seed, str(device))
    model, fk_model = trained["model"][0], trained["fk_model"][0]

    spec = train_sets[0].spec
    nodes = workspace.cartesian_grid(spec.lo, spec.hi, spec.step)
    train_F, train_Y = _stacked(train_sets)
    test_F, test_Y = _stacked(test_sets)
    test_fk = np.concatenate([mm.fk_labels(d, seed=seed + 1, **fk) for d in test_sets])
    nearest, _ = mm.nearest_arm_maps(train_F, train_Y, test_F)
    preds = {"model": _predict(model, test_F), "fk_model": _predict(fk_model, test_F), "nearest_arm": nearest,
             "fk_sampled": test_fk}
    pooled = {m: _scores(preds[m], test_Y) for m in METHODS}
    rows = [{"arms": f"held-out random ({len(test_Y)})", **{"method": m, **pooled[m]}} for m in METHODS]
    named, shown, least = _named_arms(cfg, model, fk_model, train_F, train_Y, spec, nodes, seed, fk, rows)

    family = {}
    for name, fcfg in cfg["family"].items():
        family[name] = _family_model(name, fcfg, members[name], spec, data_dir, seed, nodes, str(device))
        rows.append({"arms": name, "method": "family_model",
                     **{k: family[name][k] for k in ("f", "precision", "recall", "f_mean")}})
    speed = _speed(model, cfg, test_sets)
    design_rows, design_out = _design(model, cfg["design"], seed)
    label_s = exp["label_s"]
    metrics: Metrics = {
        "step": step, "nodes": int(len(nodes)),
        "train_arms": {f"morph{n}": sum(len(d.features) for d in train_sets if d.spec.family == f"morph{n}")
                       for n in (6, 7)},
        "test_arms": {d.spec.family: int(len(d.features)) for d in test_sets},
        "label_seconds": label_s, "arms_per_second": n_labelled / label_s if label_s > 0 else math.nan,
        "fk_label_seconds": exp["fk_label_s"], "fk": fk,
        "train": {k: v[1] for k, v in trained.items()},
        "pooled": pooled, "named": named,
        "hold_out": {"least_distance": least, "radius": HOLD_OUT_RADIUS},
        "speed": speed.to_dict("records"), "design": design_out, "family": family, "device": str(device),
    }
    check_metrics(metrics, Metrics, "morphologies")
    return Result(metrics, model, fk_model, pd.DataFrame(rows), speed, pd.DataFrame(design_rows), shown)


def _family_members(family: Mapping, where: str) -> dict[str, np.ndarray]:
    """Each named arm of params `family` as a member of its family: its family parameters, checked
    before any work (an unknown family, or an arm that is not a member, is a `ValueError` naming
    the entry)."""
    members = {}
    for name, f in family.items():
        fam = robots.FAMILIES.get(f["family"])
        if fam is None:
            raise ValueError(f"{where}: family.{name}.family {f['family']!r} is not a family; known: "
                             f"{', '.join(robots.FAMILIES)}")
        try:
            members[name] = np.asarray(fam.params_of(robots.load(name)), dtype=np.float64)
        except (TypeError, ValueError) as e:
            raise ValueError(f"{where}: family.{name}: the arm is not a member of {f['family']!r} ({e})") from None
    return members


def _family_model(name: str, f: Mapping, params: np.ndarray, spec, data_dir: Path, seed: int, nodes,
                  device: str = "cpu") -> dict:
    """The family baseline of named arm `name` (its family parameters `params`): a map model of
    family `f["family"]` (`f["samples"]` arms on the stage's grid, tool down, labelled by the
    numerical map search; built once into `data_dir`) trained with `f["recipe"]`, scored on the
    arm's map-search map."""
    from ...datasets import DatasetError, DatasetSpec, build_dataset_files, load_dataset
    from ...learn import family as learn_family

    arm = robots.load(name)
    fspec = DatasetSpec(f"{f['family']}_morphgrid", family=f["family"], method="numerical", fixed=mm.TOOL_DOWN,
                        convention="standard", lo=spec.lo, hi=spec.hi, step=spec.step, samples=int(f["samples"]),
                        seed=seed)
    path = data_dir / f"{fspec.name}_{fspec.samples}_{spec.step:g}.npz"
    t0 = time.perf_counter()
    try:
        ds = load_dataset(path, expect_spec=fspec)
    except (FileNotFoundError, DatasetError):  # not built yet, or built with other settings: build it
        build_dataset_files(fspec, path)
        ds = load_dataset(path, expect_spec=fspec)
    label_s = time.perf_counter() - t0
    recipe = learn_family.MapRecipe.from_dict({**f["recipe"], "device": device})
    t0 = time.perf_counter()
    model, result = learn_family.fit_map_model(ds, recipe)
    train_s = time.perf_counter() - t0
    pred = model.predict_maps(params[None])[0]
    truth = workspace.constant_orientation_map(arm, nodes, mm.TOOL_DOWN, convention="standard")
    return {"family": f["family"], "train_arms": int(len(ds)), "label_seconds": label_s, "train_seconds": train_s,
            "epochs": int(result.stop_epoch), **_scores(pred, truth)}


def _design(model, d: Mapping, seed: int) -> tuple[list[dict], dict]:
    """The design study (`wsmap.morph_design.compare_morph_designs`) on the box of tasks of
    params `design`: rows of the table and the record of each method's answer."""
    from ... import morph_design as md
    from ...design import box_tasks

    tasks = box_tasks(d["centre"], float(d["size"]))
    space = md.MorphDesignSpace()
    rows, results = md.compare_morph_designs(
        model, tasks, space, length_tol=float(d["length_tol"]), max_calls=int(d["max_calls"]),
        max_seconds=float(d["max_seconds"]), seed=seed,
        gradient={"screen": int(d["screen"]), "keep": int(d["keep"]), "starts_per_pattern": int(d["starts"]),
                  "steps": int(d["steps"]), "verify_top": int(d["verify_top"])})
    for r in rows:
        r.pop("params")
        r.pop("family")
    answers = {m: {"total_length_m": r.total_length, "verified": r.verified,
                   "dh_modified": space.tables(r.params)[0].tolist()} for m, r in results.items()}
    return rows, {"tasks": tasks.tolist(), "rows": rows, "answers": answers}


def _speed(model, cfg: Mapping, test_sets) -> pd.DataFrame:
    """One map of `time_step` on `[-1.5, 1.5]³` by the model, coarse to fine as `wsmap map
    --method model` maps a grid (`predict_morph_grid`, `model_ms`)
    and at every node (`dense_ms`), best of `timing_repeats` each, beside the classical numerical
    map (one call, after an untimed call on a small grid), for a held-out `morph7` arm and each of
    `speed_arms`. `same_map`: the two model maps are equal."""
    step = float(cfg["time_step"])
    nodes = workspace.cartesian_grid(-MORPH_GRID, MORPH_GRID, step)
    small = workspace.cartesian_grid(-MORPH_GRID, MORPH_GRID, 0.5)
    d7 = next(d for d in test_sets if d.spec.family == "morph7")
    arms = [("held-out morph7 arm", robots.FAMILIES["morph7"].arms(d7.features[0, :d7.spec.n_arm_features]))]
    arms += [(name, robots.load(name)) for name in cfg["speed_arms"]]

    def best(f) -> float:
        times = []
        for _ in range(int(cfg["timing_repeats"])):
            t0 = time.perf_counter()
            f()
            times.append(time.perf_counter() - t0)
        return min(times)

    rows = []
    for label, arm in arms:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ExtrapolationWarning)
            mm.predict_morph_map(model, arm, small, allow_extrapolation=True)
            grid = best(lambda: mm.predict_morph_grid(model, arm, -MORPH_GRID, MORPH_GRID, step,
                                                      allow_extrapolation=True))
            dense = best(lambda: mm.predict_morph_map(model, arm, nodes, allow_extrapolation=True))
            same = bool(np.array_equal(mm.predict_morph_grid(model, arm, -MORPH_GRID, MORPH_GRID, step,
                                                             allow_extrapolation=True),
                                       mm.predict_morph_map(model, arm, nodes, allow_extrapolation=True)))
        workspace.constant_orientation_map(arm, small, mm.TOOL_DOWN, convention="standard")
        t0 = time.perf_counter()
        workspace.constant_orientation_map(arm, nodes, mm.TOOL_DOWN, convention="standard")
        classical = time.perf_counter() - t0
        rows.append({"arm": label, "nodes": int(len(nodes)), "model_ms": 1e3 * grid, "dense_ms": 1e3 * dense,
                     "same_map": same, "classical_s": classical, "speedup": classical / grid})
    return pd.DataFrame(rows)


def save(result: Result, out: Outputs) -> None:
    """Both models, the per-arm and speed tables, the metrics file."""
    mm.save_morph_model(result.model, out.models / "morph.pt", extra={"pooled_f": result.metrics["pooled"]["model"]["f"]})
    mm.save_morph_model(result.fk_model, out.models / "morph_fk.pt",
                        extra={"labels": "forward kinematics only", **result.metrics["fk"]})
    write_table(result.arms, out.tables / "morphologies_arms")
    write_table(result.speed, out.tables / "morphologies_speed")
    write_table(result.design, out.tables / "morphologies_design")
    write_json(result.metrics, out.results / "morphologies.json")


def figures(result: Result, out: Outputs) -> list[Path]:
    """F by method for the held-out random arms and each named arm; the shown arm's slices."""
    import matplotlib.pyplot as plt

    t = result.arms
    groups = list(dict.fromkeys(t.arms))
    fig, ax = plt.subplots(figsize=(9, 3.6))
    width = 0.8 / len(METHODS)
    for k, m in enumerate(METHODS):
        f = [float(t[(t.arms == g) & (t.method == m)].f.iloc[0]) for g in groups]
        ax.bar(np.arange(len(groups)) + (k - (len(METHODS) - 1) / 2) * width, f, width, label=m)
    ax.set_xticks(np.arange(len(groups)), groups, rotation=20, ha="right")
    ax.set_ylabel("F (map-search labels)")
    ax.set_ylim(0, 1)
    ax.set_title(f"tool-down maps of arms never trained on, {result.metrics['step']:g} m grid")
    ax.legend(fontsize=8, ncol=len(METHODS))
    ax.grid(True, axis="y", alpha=0.3)
    fig.tight_layout()
    paths = [save_figure(fig, out.figures / "morphologies_f.png")]
    s = result.shown
    if s is not None:
        f = result.metrics["named"][s["name"]]["model"]["f"]
        fig = viz.plot_slices(s["maps"]["model"], s["shape"], s["lo"], s["step"], compare=s["truth"],
                              names=("model only (false positive)", "labels only (missed)", "both"),
                              title=f"{s['name']} (never trained on): the morphology model's tool-down map against the "
                                    f"map search, F {f:.3f}")
        paths.append(save_figure(fig, out.figures / "morphologies_slices.png"))
    return paths


register(PART)
