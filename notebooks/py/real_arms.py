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
# the 5 MB of plotly.js; the sliders under the scene set the threshold and a cut plane through the z-layers.
# Every second node along each axis (1/8 of the points) keeps the executed copy small; the standalone
# HTML in results/real_arms_html/ has every node.
part.figure_3d_of_shown(result, stride=2).show(renderer="plotly_mimetype")

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

# %% [markdown]
# ## What collisions remove
#
# The maps above are maps of the kinematic chain alone. For the arms with a collision model
# (capsules along their links, `wsmap.collision.named`: Panda, UR5e, iiwa 14) the tool-down map
# (`T = transl(p)·Rx(π)`) and the reachability index are computed three ways: the chain alone; with
# self-collision and the floor (a node counts only with a collision-free solution); and with a solid
# table in front of the arm as well (`collision.table`, base frame). The collision part has its own,
# coarser grid (`collision.step`, `collision.orientations`). `lost_pct` is against the chain alone;
# the floor takes every node below z = 0, so `lost_above_floor_pct` shows what self-collision and the
# table take.

# %%
result.collision

# %%
Image(filename=str(out.figures / "real_arms_collision.png"))

# %% [markdown]
# ## Base placement around a table
#
# Targets (tool down) 0.1 m above the top of a table in the world (`collision.placement`): ranked by
# the chain alone, the best base stands under the table; collision-aware (self-collision, the floor
# and the table, each candidate base checked where it stands) the Panda stands beside it. The
# colour is the best fraction of the targets reached over the headings at each base position.

# %%
result.metrics["collision_placement"]

# %%
result.collision_placement

# %%
Image(filename=str(out.figures / "real_arms_collision_placement.png"))
