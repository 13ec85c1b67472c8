# %% [markdown]
# # Section 6.1: analysis of one subspace (block 5)
#
# The paper's first subspace learns the constant-orientation workspace (R = I, grid [-1, 1] m at
# 0.1 m) of 6-DOF spherical-wrist arms, only on the output block 5: flat nodes 5293..6615 (1-based),
# z in {0.2, 0.3, 0.4}, 1323 nodes. Network: 84 raw inputs, tanh hidden layers [125, 100, 100, 125],
# linear output, Nguyen–Widrow initialisation, full-batch Rprop on MSE, the batch split 70/15/15 at
# random; several independent sessions of many epochs. The paper reports the F-measure's mean ± σ
# over the sessions (threshold 0.5, pooled over the 1000-arm test set) and, sweeping the threshold,
# 0.5 best with a slightly higher F. Its numbers (sessions, epochs, training arms, F) are
# `wsmap.paper.published.SEC61`; the notebook prints them beside ours.
#
# This notebook trains `sessions` sessions on the first `train_samples` arms of the `sec61` dataset
# (the committed run is smaller than the paper's: see params.yaml) and draws the paper's three
# figures of the section:
#
# * **Average gradient (± σ) of the training sessions**: the L2 norm of the MSE gradient per epoch,
#   mean ± σ over the sessions;
# * **Average error of predictions on a test set of 1000 examples**: the paper's text says this
#   figure is "the prediction error of an independent test set of 10^3 samples evaluated on the best
#   performing session after training" and that "the network is able to predict over 99 % of the
#   samples correctly", so it is drawn *per test sample*: the fraction of each test arm's 1323 nodes
#   that the best session predicts wrongly at threshold 0.5 (the best session is the one with the
#   lowest validation loss, so that the test set plays no part in choosing it);
# * **DNN-generated workspace section of 25 random manipulators in the test set**: the middle z-layer
#   (z = 0.3 m) of the block, predicted against exact.
#
# plus the training/validation loss over the sessions and the threshold sweep of the best session.
# Every number comes from `wsmap.paper.parts.sec61_subspace` (the paper-scale runner `wsmap paper
# full` summarises its sessions with the same code); this notebook only runs it and shows it.

# %% parameters
params_file = None  # papermill passes the chosen params file; None: params.yaml (a notebook opened by hand)
output_root = None  # papermill/DVC pass the project root; None: scratch/<notebook>/ (opened by hand)

# %%
from IPython.display import Image

from wsmap import paths
from wsmap.paper.parts import sec61_subspace as part

out = paths.notebook_outputs("sec61_subspace", output_root)
cfg = paths.notebook_params("sec61_subspace", params_file)

# %% [markdown]
# ## Training `sessions` independent sessions (seed, split and initial weights differ), scoring each
# on the independent test set (threshold 0.5, pooled), sweeping the best one's threshold

# %%
result = part.run(cfg, out)
part.save(result, out)
figures = part.figures(result, out)
result.per_session

# %% [markdown]
# ## Gradient and loss over the sessions

# %%
Image(filename=str(out.figures / "sec61_gradient.png"))

# %%
Image(filename=str(out.figures / "sec61_loss.png"))

# %% [markdown]
# ## The best session (lowest validation loss): error per test sample, workspace sections, threshold sweep

# %%
Image(filename=str(out.figures / "sec61_test_error.png"))

# %%
Image(filename=str(out.figures / "sec61_sections.png"))

# %%
Image(filename=str(out.figures / "sec61_threshold_sweep.png"))

# %%
metrics = result.metrics
# a smoke run checks what it produced, not just that it ran
assert len(metrics["f_sessions"]) == cfg["sessions"] and all(0 <= f <= 1 for f in metrics["f_sessions"])
assert (out.figures / "sec61_gradient.png").stat().st_size > 5_000
{k: v for k, v in metrics.items() if not isinstance(v, (list, dict))}
