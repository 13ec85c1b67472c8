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
# Every number comes from `wsmap.paper.parts.table1_workspaces` (`wsmap.paper.tables.table1`).

# %% parameters
params_file = None  # papermill passes the chosen params file; None: params.yaml (a notebook opened by hand)
output_root = None  # papermill/DVC pass the project root; None: scratch/<notebook>/ (opened by hand)

# %%
from IPython.display import Image

from wsmap import paths
from wsmap.paper.parts import table1_workspaces as part

out = paths.notebook_outputs("table1_workspaces", output_root)
cfg = paths.notebook_params("table1_workspaces", params_file)
cfg

# %% [markdown]
# ## Training and scoring, one model per workspace

# %%
result = part.run(cfg, out)
part.save(result, out)
figures = part.figures(result, out)

# %% [markdown]
# ## Table 1, ours beside the paper's
#
# `epochs`: optimiser steps taken (early stopping may end a run before `max_epochs`); `seconds`:
# training wall time; `difference` = F − paper F.

# %%
result.shown()

# %%
Image(filename=str(out.figures / "table1_workspaces.png"))

# %%
metrics = result.metrics
# a smoke run checks what it produced, not just that it ran
assert list(metrics["f"]) == list(cfg["datasets"])
assert all(f is None or f != f or 0.0 <= f <= 1.0 for f in metrics["f"].values())
assert (out.figures / "table1_workspaces.png").stat().st_size > 10_000
metrics["f"]
