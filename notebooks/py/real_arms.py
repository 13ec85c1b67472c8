# %% [markdown]
# # The maps roboticists use, for real arms
#
# Beyond the paper's one-orientation maps: for every named arm (manufacturer kinematics and joint
# limits, `wsmap robots`), the **reachability index** (the fraction of a set of orientations spread
# over SO(3) that the arm reaches at each node, as Reuleaux and capability maps store it), the
# **reach** (some orientation) and **dexterous** (every orientation of the set) volumes, the
# **manipulability** map of the PUMA560 (the paper's future work), and **base placement**: where to
# stand a UR5e and a Panda so that they reach a row of pick poses on a table. Arms of a closed-form
# family (PUMA560, UR5e, UR10e) are mapped exactly; the others by the numerical search, whose every
# positive is a confirmed joint solution inside the limits. Every number comes from
# `wsmap.paper.parts.real_arms`; this notebook only runs it and shows it.

# %% parameters
params_file = None  # papermill passes the chosen params file; None: params.yaml (a notebook opened by hand)
output_root = None  # papermill/DVC pass the project root; None: scratch/<notebook>/ (opened by hand)

# %%
from IPython.display import Image

from wsmap import paths
from wsmap.paper.parts import real_arms as part

out = paths.notebook_outputs("real_arms", output_root)
cfg = paths.notebook_params("real_arms", params_file)
result = part.run(cfg, out)
part.save(result, out)
figures = part.figures(result, out)

# %% [markdown]
# ## Reachability index of every arm
#
# The grid is a cube around each arm's base of half-width `half_width[arm]` (params), sampled at
# `step`. Nodes the tool cannot reach at any orientation get index 0 without IK at each orientation.

# %%
result.volumes

# %%
Image(filename=str(out.figures / f"real_arms_index_{cfg['show_3d']}.png"))

# %% [markdown]
# ## A 3-D view
#
# Iso-surfaces of the index (drawn here with matplotlib; `results/real_arms/*.glb` and `*.ply` open in
# any 3-D viewer, and the interactive plotly view below is also written as standalone HTML).

# %%
Image(filename=str(out.figures / f"real_arms_index_{cfg['show_3d']}_3d.png"))

# %%
# the figure's data as plotly's MIME type: JupyterLab's plotly extension draws it without a network
# (notebook_connected would fetch plotly.js from a CDN), and the executed copy stays data only, without
# the 5 MB of plotly.js; the sliders under the scene set the threshold and a cut plane through the z-layers
part.figure_3d_of_shown(result).show(renderer="plotly_mimetype")

# %% [markdown]
# ## Manipulability of the PUMA560
#
# The largest Yoshikawa manipulability √det(J Jᵀ) over the closed form's 8 branches at each node, at
# the orientation `manipulability_rpy`; 0 where unreachable.

# %%
Image(filename=str(out.figures / "real_arms_puma560_manipulability.png"))

# %% [markdown]
# ## Base placement
#
# Pick poses on a table (world frame, tool pointing down): where on the floor should a UR5e and a
# Panda stand? Candidates: a grid of positions and headings; each ranked by the fraction of the
# targets it reaches, with a confirmed joint solution for each.

# %%
result.targets()

# %%
result.placement
