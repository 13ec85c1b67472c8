# %% [markdown]
# # Learned maps where they pay
#
# The paper's idea -- a network that gives an arm's workspace map from its parameters instead of
# running IK at every node -- on a family where the classical map is expensive: **panda7**, the
# Franka Panda with its six non-zero lengths each scaled by U(0.7, 1.3), joint limits and no
# closed form (the numerical map search labels its tool-down map on a 25³ grid in about a second
# per arm). Then the paper's future work, a **manipulability** model of the spherical-wrist family,
# and **design by gradient** through a map model against CMA-ES on the classical map, on both
# families. This run is reduced (`params.yaml`: a few hundred panda7 arms); the headline model (4000
# arms, 1000 held out) is `benchmarks/bench_panda7_model.py`, whose command and numbers are in the
# README. Every number comes from `wsmap`; this notebook only orchestrates and plots.

# %% parameters
params_file = None  # papermill passes the chosen params file; None: params.yaml (a notebook opened by hand)
output_root = None

# %%
import numpy as np
import pandas as pd
import torch

from wsmap import design, models, paths, robots
from wsmap import workspace as ws
from wsmap.io import write_json, write_table
from wsmap.kinematics import lm_compiled
from wsmap.learn import family as LF
from wsmap.learn import manipulability as LM
from wsmap.learn.device import resolve_device
from wsmap.paper.specs import load_pair
from wsmap.viz import plot_slices, plot_value_slices, save_figure

cfg = paths.notebook_params("learned_maps", params_file)
device = resolve_device(cfg["device"], f"{cfg.source} device")  # before any work
torch.set_num_threads(cfg["threads"])
lm_compiled.set_threads(cfg["threads"])
out = paths.Outputs(output_root).make()
p7 = cfg["panda7"]
train, test = load_pair(p7["dataset"], out.data)
spec = train.spec
print(f"panda7: {len(train)} training arms, {len(test)} held-out arms, {train.n_nodes} nodes "
      f"({' x '.join(map(str, spec.grid_shape))}, tool-down); reachable share {train.labels.mean():.3f}")

# %% [markdown]
# ## The panda7 map model
#
# Inputs: the six scale factors (the columns that vary), standardised; one logit per node; Adam on
# binary cross-entropy with a cosine schedule over a fixed number of epochs (`wsmap.learn.family`).

# %%
recipe = LF.MapRecipe.from_dict({**p7["recipe"], "device": cfg["device"]})
model, result = LF.fit_map_model(train, recipe)
model = model.cpu()
ev = LF.evaluate_map_model(model, test)
history = result.history.to_frame()
print(f"trained {result.stop_epoch} epochs in {history['time'].iloc[-1]:.0f} s; held-out F {ev['f']:.4f} "
      f"(P {ev['precision']:.4f}, R {ev['recall']:.4f}; per arm {ev['f_mean']:.4f} ± {ev['f_std']:.4f})")
model_path = models.save(model, out.models / "panda7_map.pt", dataset_spec=spec,
                         train_config=recipe.train_config(), extra={"recipe": recipe.to_dict(), "test_f": ev["f"]})

# %% [markdown]
# ### More data against more epochs: F against the number of training arms (same recipe)

# %%
curve = LF.learning_curve(train, test, [n for n in p7["curve"] if n < len(train)], recipe)
curve.append(LF.curve_row(len(train), ev, history["time"].iloc[-1], result.stop_epoch))
curve = pd.DataFrame(curve).sort_values("train_arms")
write_table(curve, out.tables / "learned_maps_panda7_curve")

import matplotlib.pyplot as plt

fig, ax = plt.subplots(figsize=(5, 3.5))
ax.plot(curve["train_arms"], curve["f"], "o-")
ax.set_xscale("log")
ax.set_xlabel("training arms")
ax.set_ylabel("F on held-out arms")
ax.set_title(f"panda7 map model, {recipe.epochs} epochs each")
ax.grid(True, alpha=0.3)
save_figure(fig, out.figures / "learned_maps_panda7_curve.png")
curve

# %% [markdown]
# ### Predicted against labelled, one held-out arm

# %%
k = p7["show_arm"]
scales = test.features[k, :spec.n_arm_features]
predicted = model.predict_maps(scales[None])[0]
labelled = test.labels[k]
one = LF.score_maps(predicted[None], labelled[None])
fig = plot_slices(predicted, spec.grid_shape, spec.lo, spec.step, compare=labelled,
                  title=f"held-out arm {k} (scales {np.round(scales, 3).tolist()}): model (first) vs labels "
                        f"(second), F {one['f']:.4f}")
save_figure(fig, out.figures / "learned_maps_panda7_slices.png")

from wsmap.viz import render_mesh
from wsmap.views import iso_mesh

grid = ws.grid_spec(spec.scope, spec.lo, spec.hi, spec.step)
ax = render_mesh(iso_mesh(predicted, grid, 0.5), title=f"held-out arm {k}: predicted tool-down workspace",
                 lim=spec.hi)
save_figure(ax.figure, out.figures / "learned_maps_panda7_3d.png")

# %% [markdown]
# ### Speed: one map from the model against the numerical map that labelled it

# %%
speed = LF.speed_against_classical(model, test, arms=p7["speed_arms"], repeats=p7["timing_repeats"], threads=1)
print(f"one thread: model {speed['model_s'] * 1e3:.3f} ms per map, numerical map {speed['classical_s']:.3f} s "
      f"per map: {speed['speedup']:.0f}x")

# %% [markdown]
# ## Manipulability of the spherical-wrist family (the paper's future work)
#
# Yoshikawa's √det(JJᵀ) (m³ for a 6-joint arm), the largest over the closed form's branches, on
# the paper's 21³ grid at R = I; a network from the four free parameters (d3, d4, a2, a3).

# %%
mc = cfg["manipulability"]
p_train, y_train = LM.manipulability_dataset(mc["train_arms"], seed=mc["seed"])
p_test, y_test = LM.manipulability_dataset(mc["test_arms"], seed=mc["seed"] + 1)
mconfig = LM.ManipulabilityTrainConfig(**{**mc["config"], "hidden": tuple(mc["config"]["hidden"])})
mmodel, mresult = LM.train_manipulability_model(p_train, y_train, mconfig)
# held-out arms are drawn from the same range; a few may lie just beyond the training arms' min/max
m_pred = LM.predict_manipulability(mmodel, p_test, allow_extrapolation=True)
mm = LM.regression_metrics(m_pred, y_test)
print(f"{len(p_train)} training arms, {int(np.max(mresult.stop_epoch))} epochs: held-out R² {mm['r2']:.4f} (goal 0.98), "
      f"MAE {mm['mae']:.5f} m³; on reachable nodes R² {mm['r2_reachable']:.4f}")
g = LM.manipulability_grid()
puma = robots.puma560()
shape = ws.grid_spec("R3", g["lo"], g["hi"], g["step"])["shape"]
exact_puma = LM.manipulability_targets(puma)
for what, values in (("predicted", LM.predict_manipulability(mmodel, puma)), ("exact", exact_puma)):
    fig = plot_value_slices(values, shape, g["lo"], g["step"], label="manipulability (m³)", vmin=0.0,
                            vmax=float(exact_puma.max()), title=f"PUMA560: {what} manipulability, R = I")
    save_figure(fig, out.figures / f"learned_maps_puma560_manipulability_{what}.png")

# %% [markdown]
# ## Design by gradient
#
# The shortest arm (total link length) whose map covers 20 task positions (corners and edge
# midpoints of a 0.4 m box) at tool-down: gradient descent through the map model (trilinear in its
# node logits), every candidate verified by the classical map at the tasks, against CMA-ES and random
# search that call the classical map directly; the time each needs to a verified design.

# %%
dc = cfg["design"]
studies = {}
sw_model, _ = models.load(out.models / dc["sw_model"])
for fam, mdl, box in (("spherical_wrist", sw_model, dc["sw_box"]), ("panda7", model, dc["panda7_box"])):
    tasks = design.box_tasks(box["centre"], box["size"])
    rows, results = design.compare_designs(fam, tasks, mdl, max_calls=dc["max_calls"],
                                           max_seconds=dc["max_seconds"], seed=dc["seed"], gradient=dc["gradient"])
    studies[fam] = (tasks, rows, results)
    print(fam)
    print(design.format_design_table(rows))
table = pd.DataFrame([r for _, rows, _ in studies.values() for r in rows])
write_table(table.drop(columns=["params"]), out.tables / "learned_maps_design")

fig, axes = plt.subplots(1, 2, figsize=(10, 3.5))
for ax, (fam, (_, _, results)) in zip(axes, studies.items()):
    g_path = results["gradient"].path
    ax.plot(np.arange(len(g_path)), g_path[:, 0], label="gradient (descent steps)")
    ax.set_xlabel("step")
    ax.set_ylabel("total length (m)")
    ax.set_title(f"{fam}: gradient descent path, verified {results['gradient'].total_length:.3f} m")
    ax.grid(True, alpha=0.3)
save_figure(fig, out.figures / "learned_maps_design_path.png")

# the verified panda7 design: its classical map on the model's grid, the tasks on it
tasks, _, results = studies["panda7"]
best = results["gradient"]
arm = robots.family_arm("panda7", best.params)
nodes = ws.cartesian_grid(spec.lo, spec.hi, spec.step)
classical = ws.constant_orientation_map(arm, nodes, spec.fixed, convention=spec.convention)
fig = plot_slices(classical, spec.grid_shape, spec.lo, spec.step,
                  title=f"panda7 design by gradient (scales {np.round(best.params, 3).tolist()}): classical map")
save_figure(fig, out.figures / "learned_maps_panda7_design_map.png")

# %%
metrics = dict(
    panda7=dict(train_arms=len(train), test_arms=len(test), f=ev["f"], precision=ev["precision"],
                recall=ev["recall"], f_mean=ev["f_mean"], f_std=ev["f_std"], epochs=int(result.stop_epoch),
                train_seconds=float(history["time"].iloc[-1]), recipe=recipe.to_dict(),
                curve=curve.to_dict(orient="records"), speed=speed),
    manipulability=dict(train_arms=len(p_train), test_arms=len(p_test), epochs=int(np.max(mresult.stop_epoch)), **mm),
    design={fam: rows for fam, (_, rows, _) in studies.items()},
    device=str(device),
)
write_json(metrics, out.results / "learned_maps.json")
{k: v for k, v in metrics["panda7"].items() if k not in ("curve", "recipe")}
