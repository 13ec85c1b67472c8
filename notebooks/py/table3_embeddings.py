# %% [markdown]
# # Table 3: subspace, workspace and no-subspace embeddings
#
# The paper trains three models of the same architecture ("a three-layer fully connected
# feedforward network of 80 neurons at each layer"; tanh, linear output, raw inputs, Rprop + MSE)
# on three datasets that share the input layout (84 features) and the outputs (block 5's 1323
# nodes of the 21³ grid):
#
# * **subspace** (`table3_subspace`): the section 6.1 setup, spherical-wrist arms at R = I;
# * **workspace** (`table3_workspace`): spherical-wrist arms at an orientation drawn uniformly on
#   SO(3) per arm, given as input;
# * **no subspace** (`table3_nosubspace`): arbitrary 6-DOF arms (every d, a, α ~ U(0, 0.5)) at
#   orientation [0.312, 5.6719, 5.936]; their labels come from numerical IK (multi-start LM).
#
# Each model is tested on all three test sets. The paper prints NaN for every model on the
# no-subspace test set (its labels were presumably unusable); ours are defined wherever the test
# set has reachable nodes. Pooled precision / recall / F are the project's convention (NOTES:
# micro); the per-arm means ± σ are shown beside, since the paper's "± σ" (e.g. that of the
# subspace model's recall on its own test set, `wsmap.paper.published.PAPER_TABLE3`) is a spread
# over arms. Every number comes from `wsmap.paper.tables.table3`.

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
from wsmap.training import TrainConfig
from wsmap.viz import save_figure

out = paths.Outputs(output_root).make()
cfg = paths.notebook_params("table3_embeddings", params_file)
device = resolve_device(cfg["device"], f"{cfg.source} device")  # before any work: cuda without a GPU fails here
pairs = {emb: D.load_pair(name, out.data) for emb, name in cfg["embeddings"].items()}
for emb, (tr, te) in pairs.items():
    print(f"{emb}: {len(tr)} training arms, {len(te)} test arms, {tr.n_nodes} nodes, "
          f"{tr.labels.mean():.1%} of training labels reachable")
config = TrainConfig(optimizer=cfg["optimizer"], loss=cfg["loss"], max_epochs=cfg["max_epochs"],
                     max_fail=cfg["max_fail"], seed=cfg["seed"], device=device)
cfg

# %% [markdown]
# ## Three models, each on three test sets

# %%
runs = S.table3(pairs, config=config, sessions=cfg["sessions"], hidden=cfg["hidden"],
                train_samples=cfg["train_samples"])
summary = S.table3_summary(runs)
write_table(summary, out.tables / "table3_embeddings", whole=S.COUNT_COLUMNS)
write_table(runs, out.tables / "table3_embeddings_runs", whole=S.COUNT_COLUMNS)

# %% [markdown]
# ## Table 3, ours beside the paper's
#
# Rows: the model (its training embedding); `test`: the test set. `P`, `R`, `F` pooled;
# `*_per_arm`: mean ± σ over the arms where the value is defined.

# %%
shown = summary.assign(
    precision_per_arm=[plus_minus(m, s, 2) for m, s in zip(summary.precision_sample_mean, summary.precision_sample_std)],
    recall_per_arm=[plus_minus(m, s, 2) for m, s in zip(summary.recall_sample_mean, summary.recall_sample_std)],
    f_per_arm=[plus_minus(m, s, 2) for m, s in zip(summary.f_sample_mean, summary.f_sample_std)],
    paper_precision_=[plus_minus(m, s, 2) for m, s in zip(summary.paper_precision, summary.paper_precision_std)],
    paper_recall_=[plus_minus(m, s, 2) for m, s in zip(summary.paper_recall, summary.paper_recall_std)],
    paper_f_=[plus_minus(m, s, 2) for m, s in zip(summary.paper_f, summary.paper_f_std)],
)[["embedding", "test", "precision", "recall", "f", "precision_per_arm", "recall_per_arm", "f_per_arm",
   "paper_precision_", "paper_recall_", "paper_f_"]].rename(
    columns={"paper_precision_": "paper P", "paper_recall_": "paper R", "paper_f_": "paper F"})
write_table(shown, out.tables / "table3_embeddings_display", whole=S.COUNT_COLUMNS)
shown

# %% [markdown]
# ## The 3 × 3 F-measure (pooled), ours and the paper's

# %%
order = list(cfg["embeddings"])
wide = {k: summary.pivot(index="embedding", columns="test", values=k).reindex(index=order, columns=order)
        for k in ("precision", "recall", "f", "paper_f")}
fig, axes = plt.subplots(1, 2, figsize=(10, 4.2))
for ax, key, title in ((axes[0], "f", "ours (pooled F)"), (axes[1], "paper_f", "paper")):
    m = wide[key].to_numpy(dtype=float)
    ax.imshow(np.nan_to_num(m, nan=0.0), vmin=0, vmax=1, cmap="Blues")
    for i in range(len(order)):
        for j in range(len(order)):
            v = m[i, j]
            ax.text(j, i, "NaN" if np.isnan(v) else f"{v:.2f}", ha="center", va="center",
                    color="white" if (not np.isnan(v) and v > 0.6) else "black")
    ax.set_xticks(range(len(order)), order)
    ax.set_yticks(range(len(order)), order)
    ax.set_xlabel("test set")
    ax.set_ylabel("model (training embedding)")
    ax.set_title(title)
fig.suptitle(f"Table 3: F-measure, [{', '.join(map(str, cfg['hidden']))}] networks")
save_figure(fig, out.figures / "table3_embeddings.png")
Image(filename=str(out.figures / "table3_embeddings.png"))

# %%
wide["f"]

# %% [markdown]
# ## How many nodes are reachable in each test set
#
# Block 5 (z in {0.2, 0.3, 0.4}) at the no-subspace orientation is almost out of reach of arbitrary
# 6-DOF arms with links of at most 0.5: most of those arms reach none of its nodes. The no-subspace
# model therefore learns to predict (almost) nothing, and the spherical-wrist models, which never saw
# such arms, predict far more reachable nodes than there are. A model that predicts no reachable
# node has an undefined precision (0/0), and a test set without reachable nodes an undefined recall:
# the likely origin of the paper's NaN cells, and why every F on the no-subspace test set is small
# here.

# %%
rates = summary.assign(
    test_positive_rate=[float(runs[runs.test == t].positive_rate.iloc[0]) for t in summary.test],
    predicted_positive_rate=[float((runs[(runs.embedding == e) & (runs.test == t)].predicted
                                    / (runs.test_samples * runs.nodes)).mean())
                             for e, t in zip(summary.embedding, summary.test)],
)[["embedding", "test", "test_positive_rate", "predicted_positive_rate", "precision", "recall", "f"]]
rates

# %%
keys = ("precision", "recall", "f", "precision_sample_mean", "precision_sample_std", "recall_sample_mean",
        "recall_sample_std", "f_sample_mean", "f_sample_std", "paper_precision", "paper_recall", "paper_f")
cells = {emb: {} for emb in order}
for r in summary.itertuples():
    cells[r.embedding][r.test] = {k: getattr(r, k) for k in keys}
positive_rate = {t: float(runs[runs.test == t].positive_rate.iloc[0]) for t in order}
metrics = jsonable({
    **cells,
    "test_positive_rate": positive_rate,
    "train_samples": {e: int(runs[runs.embedding == e].train_samples.iloc[0]) for e in order},
    "epochs": {e: float(runs[runs.embedding == e].epochs.mean()) for e in order},
    "seconds": {e: float(runs[(runs.embedding == e) & (runs.test == e)].seconds.mean()) for e in order},
    "total_training_seconds": float(runs[runs.test == runs.embedding].seconds.sum()),
    "device": str(device),
    "config": cfg,
})
write_json(metrics, out.results / "table3_embeddings.json")
# a smoke run checks what it produced, not just that it ran
assert len(summary) == len(order) ** 2 and set(summary.embedding) == set(order) == set(summary.test)
assert all(np.isnan(v) or 0.0 <= v <= 1.0 for v in summary[["precision", "recall", "f"]].to_numpy().ravel())
assert (out.figures / "table3_embeddings.png").stat().st_size > 10_000
metrics["subspace"]["subspace"]
