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
# over arms. Every number comes from `wsmap.paper.parts.table3_embeddings` (`wsmap.paper.tables.table3`).

# %% parameters
params_file = None  # papermill passes the chosen params file; None: params.yaml (a notebook opened by hand)
output_root = None  # papermill/DVC pass the project root; None: scratch/<notebook>/ (opened by hand)

# %%
from IPython.display import Image

from wsmap import paths
from wsmap.paper.parts import table3_embeddings as part

out = paths.notebook_outputs("table3_embeddings", output_root)
cfg = paths.notebook_params("table3_embeddings", params_file)
cfg

# %% [markdown]
# ## Three models, each on three test sets

# %%
result = part.run(cfg, out)
part.save(result, out)
figures = part.figures(result, out)

# %% [markdown]
# ## Table 3, ours beside the paper's
#
# Rows: the model (its training embedding); `test`: the test set. `P`, `R`, `F` pooled;
# `*_per_arm`: mean ± σ over the arms where the value is defined.

# %%
result.shown()

# %% [markdown]
# ## The 3 × 3 F-measure (pooled), ours and the paper's

# %%
Image(filename=str(out.figures / "table3_embeddings.png"))

# %%
result.wide("f")

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
result.rates()

# %%
metrics = result.metrics
# a smoke run checks what it produced, not just that it ran
summary = result.summary
assert len(summary) == len(result.order) ** 2 and set(summary.embedding) == set(result.order) == set(summary.test)
assert all(v != v or 0.0 <= v <= 1.0 for v in summary[["precision", "recall", "f"]].to_numpy().ravel())
assert (out.figures / "table3_embeddings.png").stat().st_size > 10_000
metrics["subspace"]["subspace"]
