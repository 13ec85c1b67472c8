# %% [markdown]
# # One network for every arm: maps of arms it has never seen
#
# The paper's networks map one family of arms. Here one implicit network `f(morphology, point)`
# maps any serial 6R or 7R arm in the range of industrial and collaborative arms: it reads the arm's
# canonical modified-DH description (`wsmap.kinematics.morphology`) and a point, and says whether
# the tool reaches the point pointing down. It is trained on random arms of the `morph6` and
# `morph7` families (the named arms held out) labelled by the map search, and tested on arms it has
# never seen, beside three baselines: the same network trained on forward-kinematics samples only
# (no inverse kinematics, as RAM's experience), the map of the nearest training arm, and the
# held-out arm's own forward-kinematics-sampled map. Every number comes from
# `wsmap.paper.parts.morphologies`; this notebook only runs it and shows it. `params.yaml` runs a
# reduced scale; `docs/morphologies.md` has the larger runs.

# %% parameters
params_file = None  # papermill passes the chosen params file; None: params.yaml (a notebook opened by hand)
output_root = None  # papermill/DVC pass the project root; None: scratch/<notebook>/ (opened by hand)

# %%
from IPython.display import Image

from wsmap import paths
from wsmap.paper.parts import morphologies as part

out = paths.notebook_outputs("morphologies", output_root)
cfg = paths.notebook_params("morphologies", params_file)
result = part.run(cfg, out)
part.save(result, out)
figures = part.figures(result, out)

# %% [markdown]
# ## F, precision and recall on arms never trained on
#
# Scored against the map-search labels of each arm: pooled over the held-out random arms, and for
# each named arm. `distance` (in `result.metrics["named"]`) is how far the nearest training arm is.

# %%
result.arms.pivot(index="arms", columns="method", values="f")

# %%
result.arms

# %% [markdown]
# A named arm that belongs to a family also gets that family's own map model, trained here on the
# same grid (`family_model`; the Panda is `panda7` at scale 1):

# %%
result.metrics["family"]

# %%
Image(filename=str(out.figures / "morphologies_f.png"))

# %% [markdown]
# ## One named arm, slice by slice

# %%
Image(filename=str(out.figures / "morphologies_slices.png"))

# %% [markdown]
# ## One 3-D map of a new arm: the model against the classical map, side by side
#
# `model_ms` is the map as `wsmap map --method model` makes it, coarse to fine
# (`predict_morph_grid`); `dense_ms` the network at every node; `same_map` says the two agree.

# %%
result.speed

# %% [markdown]
# ## Design across morphologies
#
# The shortest 6R arm of any twist pattern (0, +90 or -90 degrees between consecutive axes) whose
# tool-down map covers a box of task positions: gradient descent through the model against CMA-ES
# and random search on the classical map, every answer verified by the classical map
# (`wsmap.morph_design`).

# %%
result.design

# %%
{m: a["dh_modified"] for m, a in result.metrics["design"]["answers"].items()}

# %%
{k: result.metrics[k] for k in ("train_arms", "test_arms", "nodes", "label_seconds", "arms_per_second",
                                 "fk_label_seconds", "train", "hold_out")}
