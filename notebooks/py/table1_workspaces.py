# %% [markdown]
# # Table 1: F-measures of other workspace models
#
# The paper's Table 1 trains the section 6.1 network ([125, 100, 100, 125] tanh, linear output,
# raw inputs, Nguyen–Widrow initialisation, full-batch Rprop on MSE) on eight other maps of the
# spherical-wrist family and reports the F-measure of each on a 1000-arm test set:
#
# * constant-orientation ("R3") maps over [-1, 1]³ at R = I, grid step 1 (27 nodes), 0.5 (125),
#   and 0.1: block 5 (1323 nodes, the section 6.1 subspace), the crop from block 5 to z = 0.8
#   (3087 nodes; the paper prints 3086) and the whole 21³ grid (9261);
# * orientation ("SO3") maps over [0, 2π]³ at step π/3 (343 nodes), π/8 (4913) and π/10 (9261) at a
#   fixed point (the paper's convention tests positions R·p, NOTES "Pose convention").
#
# One model per row, trained on the first `train_samples` arms of the row's dataset (the paper's
# counts are the table's `paper_samples`, from `wsmap.paper.published.PAPER_TABLE1`) for at most
# `max_epochs` epochs with early stopping after `max_fail` validation failures; F is pooled over
# every test arm and node (the paper's). The per-sample F mean ± σ is shown too: the paper's "± σ_f"
# of a single model is most likely that spread.
# Every number comes from `wsmap.paper.tables.table1`.

# %% parameters
params_file = None  # papermill passes the chosen params file; None: params.yaml (a notebook opened by hand)
output_root = None

# %%
import matplotlib.pyplot as plt
import numpy as np
from IPython.display import Image

from wsmap import paths
from wsmap.io import jsonable, plus_minus, write_json, write_table
from wsmap.learn.device import resolve_device
from wsmap.paper import tables as S
from wsmap.training import TrainConfig
from wsmap.viz import save_figure

out = paths.Outputs(output_root).make()
cfg = paths.notebook_params("table1_workspaces", params_file)
device = resolve_device(cfg["device"], f"{cfg.source} device")  # before any work: cuda without a GPU fails here
config = TrainConfig(optimizer=cfg["optimizer"], loss=cfg["loss"], max_fail=cfg["max_fail"], seed=cfg["seed"],
                     device=device)
cfg

# %% [markdown]
# ## Training and scoring, one model per workspace

# %%
table, runs = S.table1(out.data, cfg["datasets"], config=config, train_samples=cfg["train_samples"],
                       max_epochs=cfg["max_epochs"], sessions=cfg["sessions"], hidden=cfg["hidden"])

# %% [markdown]
# ## Table 1, ours beside the paper's
#
# `epochs`: optimiser steps taken (early stopping may end a run before `max_epochs`); `seconds`:
# training wall time; `difference` = F − paper F.

# %%
shown = table.assign(
    f_sample=[plus_minus(m, s) for m, s in zip(table.f_sample_mean, table.f_sample_std)],
    paper=[plus_minus(m, s, 4) for m, s in zip(table.paper_f, table.paper_f_std)],
)[["workspace", "delta", "nodes", "train_samples", "paper_samples", "epochs", "seconds", "precision", "recall",
   "f", "f_sample", "paper", "difference"]]
write_table(table, out.tables / "table1_workspaces", whole=S.COUNT_COLUMNS)
write_table(runs, out.tables / "table1_workspaces_runs", whole=S.COUNT_COLUMNS)
write_table(shown, out.tables / "table1_workspaces_display", whole=S.COUNT_COLUMNS)
shown

# %%
labels = [f"{w} Δ={d}\n{n} nodes" for w, d, n in zip(table.workspace, table.delta, table.nodes)]
x = np.arange(len(table))
fig, ax = plt.subplots(figsize=(11, 4.2))
ax.bar(x - 0.2, table.f, 0.4, label="ours (pooled F)", color="#1f4e79")
ax.bar(x + 0.2, table.paper_f, 0.4, label="paper", color="#bbbbbb", edgecolor="k", hatch="//")
for xi, f in zip(x, table.f):
    ax.text(xi - 0.2, (0 if np.isnan(f) else f) + 0.01, "NaN" if np.isnan(f) else f"{f:.3f}", ha="center", fontsize=8)
ax.set_xticks(x, labels, fontsize=8)
ax.set_ylim(0, 1.1)
ax.set_ylabel("F-measure")
ax.set_title("Table 1: F-measure of the [125, 100, 100, 125] network per workspace (Rprop + MSE)")
ax.legend(loc="lower left")
save_figure(fig, out.figures / "table1_workspaces.png")
Image(filename=str(out.figures / "table1_workspaces.png"))

# %%
def by_dataset(column):
    return {d: v for d, v in zip(table.dataset, table[column])}


metrics = jsonable({
    "f": by_dataset("f"),
    "precision": by_dataset("precision"),
    "recall": by_dataset("recall"),
    "f_sample_mean": by_dataset("f_sample_mean"),
    "f_sample_std": by_dataset("f_sample_std"),
    "paper_f": by_dataset("paper_f"),
    "difference": by_dataset("difference"),
    "nodes": by_dataset("nodes"),
    "train_samples": by_dataset("train_samples"),
    "epochs": by_dataset("epochs"),
    "seconds": by_dataset("seconds"),
    "total_training_seconds": float(runs.seconds.sum()),
    "device": str(device),
    "config": cfg,
})
write_json(metrics, out.results / "table1_workspaces.json")
# a smoke run checks what it produced, not just that it ran
assert list(table.dataset) == list(cfg["datasets"])
assert all(np.isnan(f) or 0.0 <= f <= 1.0 for f in table.f)
assert (out.figures / "table1_workspaces.png").stat().st_size > 10_000
metrics["f"]
