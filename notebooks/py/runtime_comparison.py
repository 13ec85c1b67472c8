# %% [markdown]
# # Run time of the SL model against the classical algorithm
#
# The paper's figure "Run time (± sigma) of SL model compared to the classical algorithm": the
# PUMA560's constant-orientation workspace map (R = I, paper convention) on the 27-, 125- and
# 9261-node grids of [-1, 1]³ m (steps 1, 0.5 and 0.1). Measured here, per grid, mean ± sigma over
# repeated calls (`wsmap.paper.runtime.runtime_comparison`):
#
# * **classical, numerical, one node at a time** -- the paper's way: one `ikine_LM` call per node
#   (the Appendix's Levenberg–Marquardt: tol 1e-10, at most 500 iterations and 100 rejections,
#   q0 = 0) in a Python loop. On grids larger than `per_node_sample` nodes each repeat solves a
#   fresh random sample of that many nodes and the time is **extrapolated** to the whole grid
#   (x nodes / sample); smaller grids are solved whole;
# * **classical, numerical, batched** -- the same LM on all nodes at once (vectorised);
# * **classical, exact** -- the closed-form wrist-centre test, batched;
# * **SL network** -- `model.predict` on the PUMA560's feature row (`wsmap.datasets.features_for`),
#   network [125, 100, 100, 125] tanh; 27 and 125 outputs for the small grids, and for 9261 nodes
#   7 block subspaces of 1323 outputs assembled (section 6.2). The network is **freshly
#   initialised, not trained**: inference time does not depend on the values of the weights (the
#   same matrix products and tanh run whatever they are), so an untrained network times the same
#   as a trained one. "features + predict" adds building the feature row from the DH table.
#
# The paper's numbers (`wsmap.paper.published.RUNTIME_SECONDS`: MATLAB R2017b, Xeon E3-1505M;
# classical one node at a time) stand beside ours; different language and machine, so only ratios within one column are like for like.

# %% parameters
params_file = None  # papermill passes the chosen params file; None: params.yaml (a notebook opened by hand)
output_root = None  # papermill/DVC pass the project root; None: scratch/<notebook>/ (opened by hand)

# %%
from IPython.display import Image

from wsmap import paths
from wsmap.paper.parts import runtime_comparison as part

out = paths.notebook_outputs("runtime_comparison", output_root)
cfg = paths.notebook_params("runtime_comparison", params_file)
cfg

# %% [markdown]
# ## Measure

# %%
result = part.run(cfg, out)
part.save(result, out)
figures = part.figures(result, out)
result.metrics["machine"]

# %% [markdown]
# ## Table: ours beside the paper's

# %%
print(part.table_markdown(result))

# %% [markdown]
# ## Figure (log scale, error bars ± sigma)

# %%
Image(filename=str(out.figures / "runtime_comparison.png"))

# %%
metrics = result.metrics
# a smoke run checks what it produced, not just that it ran
for n, exact_s in metrics["classical_exact"].items():
    assert exact_s < metrics["classical_batched_numerical"][n]
assert (out.figures / "runtime_comparison.png").stat().st_size > 5_000
{k: metrics[k] for k in ("classical_per_node_numerical", "classical_batched_numerical", "classical_exact", "network")}
