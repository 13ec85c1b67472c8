# %% [markdown]
# # The classical workspace map of the PUMA560
#
# The classical algorithm (the paper's section 1 and Appendix): a grid of positions at a fixed
# orientation, inverse kinematics at every node, one bit per node. This notebook draws the PUMA560's
# constant-orientation workspace (the paper's grid, [-1, 1] m at 0.1 m, R = I), compares the exact
# closed-form map with the paper's numerical Levenberg–Marquardt path, and sets the two pose
# conventions side by side. Every number comes from `wsmap.paper.parts.classical_workspace`; this
# notebook only runs it and shows it.

# %% parameters
params_file = None  # papermill passes the chosen params file; None: params.yaml (a notebook opened by hand)
output_root = None  # papermill/DVC pass the project root; None: scratch/<notebook>/ (opened by hand)

# %%
from IPython.display import Image

from wsmap import paths
from wsmap.paper.parts import classical_workspace as part

out = paths.notebook_outputs("classical_workspace", output_root)
cfg = paths.notebook_params("classical_workspace", params_file)
result = part.run(cfg, out)
part.save(result, out)
figures = part.figures(result, out)

# %% [markdown]
# ## Exact map and its 3-D surface

# %%
Image(filename=str(out.figures / "puma560_workspace_slices.png"))

# %%
Image(filename=str(out.figures / "puma560_workspace_exact.png"))

# %% [markdown]
# ## Exact against numerical (the paper's classical path: LM, tol 1e-10, q0 = 0, one start)

# %%
Image(filename=str(out.figures / "puma560_exact_vs_numerical.png"))

# %% [markdown]
# ## The two pose conventions
#
# The authors' code builds the target as `Rx Ry Rz · transl(p)`, so the position it tests is R·p;
# the usual convention is `transl(p) · R`. They agree at R = I and differ at the rotated
# orientation of Table 3.

# %%
Image(filename=str(out.figures / "puma560_conventions.png"))

# %% [markdown]
# ## Label audit: exact labels against the paper's numerical path
#
# The datasets of the spherical-wrist experiments use the exact closed-form labels (as the
# authors' published labels did). `wsmap.datasets.audit_table` measures, for `audit_arms` random
# arms of every distinct spherical-wrist dataset spec (`wsmap.paper.specs.audit_specs`: grid, node
# selection, orientation), how the paper's numerical path (LM from q0 = 0, one start, tol 1e-10, at
# most 500 iterations / 100 rejections) would label the same (arm, node) pairs: false negatives are
# reachable nodes LM misses, false positives nodes LM solves that the exact test rejects (every LM
# success is confirmed by forward kinematics). The arms come from an audit stream, independent of
# the training and test streams.

# %%
print(result.audit_markdown())

# %%
metrics = result.metrics
# a smoke run checks what it produced, not just that it ran
assert metrics["reachable_exact"] > 0 and metrics["numerical_false_positives"] == 0
assert metrics["conventions_equal_at_identity"]
assert (out.figures / "puma560_workspace_exact.png").stat().st_size > 10_000
metrics
