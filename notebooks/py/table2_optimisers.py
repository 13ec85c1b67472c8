# %% [markdown]
# # Table 2: optimisers and losses
#
# The paper retrains the section 6.1 network ([125, 100, 100, 125] tanh, linear output, raw
# inputs) on the block-5 subspace (1323 nodes; 6e4 arms) with five of MATLAB's full-batch training
# functions and three performance measures, and reports the F-measure (± σ) on a 1000-arm test set.
# Its conclusion: resilient backpropagation on MSE converges best "given the same number of
# gradient updates" (its F ± σ: `wsmap.paper.published.PAPER_TABLE2`), so every cell here gets the
# same epoch budget.
#
# | name | MATLAB | algorithm |
# |---|---|---|
# | `cgb` | `traincgb` | conjugate gradient with Powell–Beale restarts |
# | `gdx` | `traingdx` | gradient descent with momentum and adaptive learning rate |
# | `oss` | `trainoss` | one-step secant |
# | `rprop` | `trainrp` | resilient backpropagation |
# | `scg` | `trainscg` | scaled conjugate gradient (Møller) |
#
# **Cross entropy.** MATLAB's `crossentropy` applied to the paper's linear output layer takes
# logarithms of raw outputs that can be negative or above 1 — not a well-defined loss for this
# network. Here cross entropy is binary cross entropy *on logits*: the linear output `z` is read
# as a logit, the loss is `−t·log σ(z) − (1 − t)·log(1 − σ(z))`, and the model
# (`output_kind="logit"`) predicts a node reachable where σ(z) > 0.5. MSE and MAE train the linear
# output directly and threshold it at 0.5, as the paper.
#
# Each cell is trained `sessions` times (seeds `seed`, `seed + 1`, …: different initial weights
# and 70/15/15 splits, the same across cells). `f_mean ± f_std`: pooled F, mean and standard
# deviation over the sessions; `f_sample_mean ± f_sample_std`: the spread of the per-arm F (the
# paper's σ is as large as the latter). Every number comes from `wsmap.paper.tables`.

# %% parameters
params_file = None  # papermill passes the chosen params file; None: params.yaml (a notebook opened by hand)
output_root = None

# %%
import matplotlib.pyplot as plt
import numpy as np
from IPython.display import Image

from wsmap import data as D
from wsmap import paths
from wsmap.io import jsonable, plus_minus, write_json, write_table
from wsmap.learn.device import resolve_device
from wsmap.paper import tables as S
from wsmap.paper.published import PAPER_TABLE2
from wsmap.training import TrainConfig
from wsmap.viz import save_figure

out = paths.Outputs(output_root).make()
cfg = paths.notebook_params("table2_optimisers", params_file)
device = resolve_device(cfg["device"], f"{cfg.source} device")  # before any work: cuda without a GPU fails here
train, test = D.load_pair(cfg["dataset"], out.data)
config = TrainConfig(max_epochs=cfg["max_epochs"], max_fail=cfg["max_fail"], seed=cfg["seed"], device=device)
print(f"{cfg['dataset']}: {len(train)} training arms (using {cfg['train_samples'] or len(train)}), "
      f"{len(test)} test arms, {train.n_nodes} nodes")
cfg

# %% [markdown]
# ## The grid: every optimiser with every loss

# %%
runs = S.table2(train, test, config=config, optimizers=cfg["optimizers"], losses=cfg["losses"],
                sessions=cfg["sessions"], hidden=cfg["hidden"], train_samples=cfg["train_samples"])
summary = S.table2_summary(runs)
write_table(summary, out.tables / "table2_optimisers", whole=S.COUNT_COLUMNS)
write_table(runs, out.tables / "table2_optimisers_runs", whole=S.COUNT_COLUMNS)

# %% [markdown]
# ## Table 2, ours beside the paper's (rows in the paper's order)

# %%
shown = summary.assign(
    ours=[plus_minus(m, s) for m, s in zip(summary.f_mean, summary.f_std)],
    per_arm=[plus_minus(m, s) for m, s in zip(summary.f_sample_mean, summary.f_sample_std)],
    paper=[plus_minus(m, s) for m, s in zip(summary.paper_f, summary.paper_f_std)],
)[["method", "loss", "sessions", "epochs", "seconds", "precision", "recall", "ours", "per_arm", "paper", "difference"]]
write_table(shown, out.tables / "table2_optimisers_display", whole=S.COUNT_COLUMNS)
shown

# %% [markdown]
# ## F by optimiser and loss (pooled F, mean over sessions; the paper's beside)

# %%
ours_wide = summary.pivot(index="optimizer", columns="loss_key", values="f_mean").reindex(
    index=cfg["optimizers"], columns=cfg["losses"])
paper_wide = summary.pivot(index="optimizer", columns="loss_key", values="paper_f").reindex(
    index=cfg["optimizers"], columns=cfg["losses"])
ours_wide.join(paper_wide, lsuffix=" (ours)", rsuffix=" (paper)")

# %%
fig, axes = plt.subplots(1, len(cfg["losses"]), figsize=(4.2 * len(cfg["losses"]), 4), sharey=True, squeeze=False)
for ax, loss in zip(axes[0], cfg["losses"]):
    rows = summary[summary.loss_key == loss].set_index("optimizer").reindex(cfg["optimizers"])
    x = np.arange(len(rows))
    ax.bar(x - 0.2, rows.f_mean, 0.4, yerr=np.nan_to_num(rows.f_std.to_numpy()), capsize=3, color="#1f4e79",
           label="ours (mean ± σ over sessions)")
    ax.bar(x + 0.2, rows.paper_f, 0.4, yerr=rows.paper_f_std, capsize=3, color="#bbbbbb", edgecolor="k",
           hatch="//", label="paper (± σ)")
    ax.set_xticks(x, rows.index)
    ax.set_title(S.LOSS_LABELS.get(loss, loss))
    ax.set_ylim(0, 1.15)
axes[0][0].set_ylabel("F-measure")
axes[0][0].legend(loc="upper left", fontsize=8)
fig.suptitle(f"Table 2: optimisers × losses, block 5 ({cfg['max_epochs']} epochs at most, "
             f"{int(summary.train_samples.iloc[0])} arms)")
save_figure(fig, out.figures / "table2_optimisers.png")
Image(filename=str(out.figures / "table2_optimisers.png"))

# %%
best = summary.loc[summary.f_mean.idxmax()] if summary.f_mean.notna().any() else None
paper_best = max(PAPER_TABLE2, key=lambda cell: PAPER_TABLE2[cell][0])  # (optimizer, loss) of the paper's best F
cells = {
    f"{r.optimizer}_{r.loss_key}": {
        "f_mean": r.f_mean, "f_std": r.f_std, "f_sample_mean": r.f_sample_mean, "f_sample_std": r.f_sample_std,
        "precision": r.precision, "recall": r.recall, "epochs": r.epochs, "seconds": r.seconds,
        "paper_f": r.paper_f, "paper_f_std": r.paper_f_std, "difference": r.difference,
    }
    for r in summary.itertuples()
}
metrics = jsonable({
    **cells,
    "best_cell": None if best is None else f"{best.optimizer}_{best.loss_key}",
    "paper_best_cell": "_".join(paper_best),
    "sessions": int(cfg["sessions"]),
    "train_samples": int(summary.train_samples.iloc[0]),
    "total_training_seconds": float(runs.seconds.sum()),
    "device": str(device),
    "config": cfg,
})
write_json(metrics, out.results / "table2_optimisers.json")
# a smoke run checks what it produced, not just that it ran
assert len(summary) == len(cfg["optimizers"]) * len(cfg["losses"])
assert len(runs) == len(summary) * cfg["sessions"]
assert all(np.isnan(f) or 0.0 <= f <= 1.0 for f in summary.f_mean)
assert (out.figures / "table2_optimisers.png").stat().st_size > 10_000
{k: metrics[k] for k in ("best_cell", "paper_best_cell")} | {"rprop_mse": metrics.get("rprop_mse")}
