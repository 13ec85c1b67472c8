# %% [markdown]
# # RAM's protocol: wsmap's labels and its pose-conditioned network beside RAM's numbers
#
# RAM (Walter et al., arXiv 2606.09108; code TimWalter/ram) learns, for arms of 5-7 revolute joints it
# never saw, whether a pose in SE(3) is reachable, and reports F1 0.86 on random poses and 0.78 on a
# boundary set of held-out arms. Its protocol is rebuilt from its public code in `wsmap.datasets.ram`:
# its random arms, its random and boundary poses, its label definition (inverse kinematics with capsule
# self-collision), its per-arm F1. Here, on held-out RAM arms: (a) wsmap's classical labels against
# RAM's definition, (b) an FK-sampling labeller like RAM's (its training labels) against the exact
# labels, (c) wsmap's pose-conditioned network `f(arm, pose)` trained on exact IK labels. Every number
# comes from `wsmap.paper.parts.ram_protocol`; this notebook only runs it and shows it. `params.yaml`
# runs a reduced scale; `params.full.yaml` RAM's 3·10⁴ training arms.

# %% parameters
params_file = None  # papermill passes the chosen params file; None: params.yaml (a notebook opened by hand)
output_root = None  # papermill/DVC pass the project root; None: scratch/<notebook>/ (opened by hand)

# %%
from IPython.display import Image

from wsmap import paths
from wsmap.paper.parts import ram_protocol as part

out = paths.notebook_outputs("ram_protocol", output_root)
cfg = paths.notebook_params("ram_protocol", params_file)
result = part.run(cfg, out)
part.save(result, out)
figures = part.figures(result, out)

# %% [markdown]
# ## F1 beside RAM's published numbers
#
# F1 per arm, then the mean over the held-out arms (RAM's score), on RAM's random poses and on its
# boundary set. RAM's rows are its published numbers (its checkpoint is not reachable from here).

# %%
result.table

# %%
Image(filename=str(figures[0]))

# %% [markdown]
# ## By joint count
#
# A 5-joint arm's reachable poses have measure zero in SE(3): its only reachable poses are those built
# reachable (RAM's FK poses), so every labeller that keeps them agrees on it, and a network must
# single them out of pose coordinates.

# %%
{"model": {s: result.metrics["model"][s]["f1_by_dof"] for s in ("random", "boundary")},
 **{v: {s: result.metrics["labels"][v][s]["f1_by_dof"] for s in ("random", "boundary")}
    for v in result.metrics["labels"]}}

# %% [markdown]
# ## What it cost
#
# Seconds of wall clock and of process CPU (all threads) for the labels and the training, the cores
# and threads used; RAM: 360 H100-hours of data and 57 h of training.

# %%
result.metrics["compute"]

# %%
{k: result.metrics[k] for k in ("arms", "poses", "reachable_share")} | {
    "model": {k: result.metrics["model"][k] for k in ("threshold", "epochs", "best_epoch", "training_arms",
                                                       "training_poses", "training_reachable_share")}}
