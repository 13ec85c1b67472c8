# %% [markdown]
# # Learned maps where they pay
#
# The paper's idea -- a network that gives an arm's workspace map from its parameters instead of
# running IK at every node -- on a family where the classical map is expensive: **panda7**, the
# Franka Panda with its six non-zero lengths each scaled by U(0.7, 1.3), joint limits and no
# closed form (the numerical map search labels its tool-down map on a 25³ grid in about a second
# per arm). Then the paper's future work, a **manipulability** model of the spherical-wrist family,
# and **design by gradient** through a map model against CMA-ES on the classical map, on both
# families. This run is reduced (`params.yaml`: a few hundred panda7 arms); the headline model (4000
# arms, 1000 held out) is `benchmarks/bench_panda7_model.py`, whose command and numbers are in the
# README. Every number comes from `wsmap.paper.parts.learned_maps`; this notebook only runs it and
# shows it.

# %% parameters
params_file = None  # papermill passes the chosen params file; None: params.yaml (a notebook opened by hand)
output_root = None  # papermill/DVC pass the project root; None: scratch/<notebook>/ (opened by hand)

# %%
from IPython.display import Image

from wsmap import paths
from wsmap.paper.parts import learned_maps as part

cfg = paths.notebook_params("learned_maps", params_file)
out = paths.notebook_outputs("learned_maps", output_root)

# %% [markdown]
# ## The panda7 map model, the manipulability model and the design studies
#
# panda7: the six scale factors (the columns that vary) as inputs, standardised; one logit per node;
# Adam on binary cross-entropy with a cosine schedule over a fixed number of epochs
# (`wsmap.learn.family`). Manipulability: Yoshikawa's √det(JJᵀ) (m³ for a 6-joint arm), the largest
# over the closed form's branches, on the paper's 21³ grid at R = I, from the four free parameters
# (d3, d4, a2, a3). Design: the shortest arm (total link length) whose map covers 20 task positions
# (corners and edge midpoints of a 0.4 m box) at tool-down: gradient descent through the map model
# (trilinear in its node logits), every candidate verified by the classical map at the tasks, against
# CMA-ES and random search that call the classical map directly; the time each needs to a verified
# design.

# %%
result = part.run(cfg, out)
part.save(result, out)
figures = part.figures(result, out)

# %% [markdown]
# ### More data against more epochs: F against the number of training arms (same recipe)

# %%
Image(filename=str(out.figures / "learned_maps_panda7_curve.png"))

# %%
result.curve

# %% [markdown]
# ### Predicted against labelled, one held-out arm

# %%
Image(filename=str(out.figures / "learned_maps_panda7_slices.png"))

# %% [markdown]
# ## Manipulability of the spherical-wrist family (the paper's future work)

# %%
Image(filename=str(out.figures / "learned_maps_puma560_manipulability_predicted.png"))

# %% [markdown]
# ## Design by gradient

# %%
result.design_table()

# %%
Image(filename=str(out.figures / "learned_maps_design_path.png"))

# %%
{k: v for k, v in result.metrics["panda7"].items() if k not in ("curve", "recipe")}
