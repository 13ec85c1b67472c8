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
# paper's σ is as large as the latter). Every number comes from `wsmap.paper.parts.table2_optimisers`
# (`wsmap.paper.tables`).

# %% parameters
params_file = None  # papermill passes the chosen params file; None: params.yaml (a notebook opened by hand)
output_root = None  # papermill/DVC pass the project root; None: scratch/<notebook>/ (opened by hand)

# %%
from IPython.display import Image

from wsmap import paths
from wsmap.paper.parts import table2_optimisers as part

out = paths.notebook_outputs("table2_optimisers", output_root)
cfg = paths.notebook_params("table2_optimisers", params_file)
cfg

# %% [markdown]
# ## The grid: every optimiser with every loss

# %%
result = part.run(cfg, out)
part.save(result, out)
figures = part.figures(result, out)

# %% [markdown]
# ## Table 2, ours beside the paper's (rows in the paper's order)

# %%
result.shown()

# %% [markdown]
# ## F by optimiser and loss (pooled F, mean over sessions; the paper's beside)

# %%
result.wide()

# %%
Image(filename=str(out.figures / "table2_optimisers.png"))

# %%
metrics = result.metrics
# a smoke run checks what it produced, not just that it ran
assert len(result.summary) == len(cfg["optimizers"]) * len(cfg["losses"])
assert len(result.runs) == len(result.summary) * cfg["sessions"]
assert all(f != f or 0.0 <= f <= 1.0 for f in result.summary.f_mean)
assert (out.figures / "table2_optimisers.png").stat().st_size > 10_000
{k: metrics[k] for k in ("best_cell", "paper_best_cell")} | {"rprop_mse": metrics.get("rprop_mse")}
