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
# positive is a confirmed joint solution inside the limits. Every number comes from `wsmap`; this
# notebook only orchestrates and plots.

# %% parameters
params_file = None  # papermill passes the chosen params file; None: params.yaml (a notebook opened by hand)
output_root = None

# %%
import time

import numpy as np
import pandas as pd

from wsmap import paths, robots
from wsmap import workspace as ws
from wsmap.io import write_json, write_table
from wsmap.viz import plot_value_slices, render_mesh, save_figure
from wsmap.views import figure_3d, iso_mesh, save_glb, save_html, save_ply

out = paths.Outputs(output_root).make()
cfg = paths.notebook_params("real_arms", params_file)
step, K = cfg["step"], cfg["orientations"]
R = ws.orientation_samples(K, seed=cfg["seed"])
arms = {name: robots.load(name) for name in cfg["arms"]}
views = out.results / "real_arms"
views.mkdir(parents=True, exist_ok=True)
print(f"{len(arms)} arms, {K} orientations (super-Fibonacci), grid step {step} m")

# %% [markdown]
# ## Reachability index of every arm
#
# The grid is a cube around each arm's base of half-width `half_width[arm]` (params), sampled at
# `step`. Nodes the tool cannot reach at any orientation get index 0 without IK at each orientation.

# %%
rows, index_maps = [], {}
for name, arm in arms.items():
    h = cfg["half_width"][name]
    grid = ws.grid_spec("R3", -h, h, step)
    nodes = ws.cartesian_grid(grid["lo"], grid["hi"], grid["step"])
    method = ws.resolve_method(arm)
    t0 = time.perf_counter()
    index = ws.reachability_index(arm, nodes, R)
    t_index = time.perf_counter() - t0
    t0 = time.perf_counter()
    reach = ws.position_map(arm, nodes)
    t_reach = time.perf_counter() - t0
    cell = step ** 3
    index_maps[name] = (index, grid)
    rows.append({"arm": name, "method": method, "nodes": len(nodes), "orientations": K,
                 "reach_volume_m3": reach.sum() * cell, "reachable_at_some_orientation_of_the_set_m3": (index > 0).sum() * cell,
                 "dexterous_volume_m3": (index == 1).sum() * cell,
                 "mean_index_where_reached": float(index[index > 0].mean()) if (index > 0).any() else 0.0,
                 "index_seconds": t_index, "reach_seconds": t_reach})
    fig = plot_value_slices(index, grid["shape"], grid["lo"], grid["step"], label="reachability index", vmin=0, vmax=1,
                            title=f"{name}: reachability index over {K} orientations ({method}), step {step} m")
    save_figure(fig, out.figures / f"real_arms_index_{name}.png")
    if (index > 0).any():
        save_ply(views / f"{name}_index.ply", index, grid, label="reachability index")
        save_glb(views / f"{name}_index.glb", index, grid, levels=cfg["iso_levels"])
    print(f"{name}: {method}, index in {t_index:.1f} s, reach map in {t_reach:.1f} s")
volumes = pd.DataFrame(rows)
write_table(volumes, out.tables / "real_arms_volumes")
volumes

# %% [markdown]
# ## A 3-D view
#
# Iso-surfaces of the index (drawn here with matplotlib; `results/real_arms/*.glb` and `*.ply` open in
# any 3-D viewer, and the interactive plotly view below is also written as standalone HTML).

# %%
show = cfg["show_3d"]
index, grid = index_maps[show]
mesh = iso_mesh(index, grid, 0.5)
ax = render_mesh(mesh, title=f"{show}: where at least half of the {K} orientations are reachable",
                 lim=cfg["half_width"][show])
save_figure(ax.figure, out.figures / f"real_arms_index_{show}_3d.png")
# the standalone page carries plotly.js (about 5 MB): a DVC-cached output, not committed to git
html_dir = out.results / "real_arms_html"
html_dir.mkdir(parents=True, exist_ok=True)
save_html(html_dir / f"{show}_index.html", index, grid, kind="points", label="reachability index",
          title=f"{show}: reachability index")
fig3d = figure_3d(index, grid, kind="points", label="reachability index", title=f"{show}: reachability index")
fig3d.show(renderer="notebook_connected")

# %% [markdown]
# ## Manipulability of the PUMA560
#
# The largest Yoshikawa manipulability √det(J Jᵀ) over the closed form's 8 branches at each node, at
# the orientation `manipulability_rpy`; 0 where unreachable.

# %%
h = cfg["half_width"]["puma560"]
mgrid = ws.grid_spec("R3", -h, h, step)
mnodes = ws.cartesian_grid(mgrid["lo"], mgrid["hi"], mgrid["step"])
manip = ws.manipulability_map(robots.puma560(), mnodes, cfg["manipulability_rpy"])
fig = plot_value_slices(manip, mgrid["shape"], mgrid["lo"], mgrid["step"], label="manipulability √det(J Jᵀ)",
                        title="PUMA560 manipulability (exact, best of 8 branches)")
save_figure(fig, out.figures / "real_arms_puma560_manipulability.png")
positive = manip[manip > 0]
levels = tuple(float(v) for v in np.quantile(positive, [0.5, 0.9])) if positive.size else (0.5,)
save_glb(views / "puma560_manipulability.glb", manip, mgrid, levels=levels)
mmesh = iso_mesh(manip, mgrid, levels[0])
ax = render_mesh(mmesh, title="PUMA560: manipulability above its median", lim=h)
save_figure(ax.figure, out.figures / "real_arms_puma560_manipulability_3d.png")
print(f"max manipulability {manip.max():.4f}, median where reachable {np.median(positive) if positive.size else 0:.4f}")

# %% [markdown]
# ## Base placement
#
# Pick poses on a table (world frame, tool pointing down): where on the floor should a UR5e and a
# Panda stand? Candidates: a grid of positions and headings; each ranked by the fraction of the
# targets it reaches, with a confirmed joint solution for each.

# %%
t = cfg["placement"]
targets = np.stack([ws.target_poses(p, t["rpy"], "standard") for p in t["positions"]])
place_rows = []
for name in t["arms"]:
    t0 = time.perf_counter()
    pl = ws.base_placement(robots.load(name), targets, x=t["x"], y=t["y"], step=t["step"], yaws=t["yaws"])
    seconds = time.perf_counter() - t0
    for r in range(t["top"]):
        place_rows.append({"arm": name, "rank": r + 1, "x_m": pl.x[r], "y_m": pl.y[r], "yaw_deg": np.degrees(pl.yaw[r]),
                           "targets_reached": int(pl.reached[r].sum()), "score": pl.score[r], "seconds": seconds})
    print(f"{name}: best base {pl.best()['x']:+.2f}, {pl.best()['y']:+.2f} m, "
          f"{np.degrees(pl.best()['yaw']):.0f} deg reaches {pl.score[0]:.0%} of {len(targets)} targets ({seconds:.1f} s)")
placement = pd.DataFrame(place_rows)
write_table(placement, out.tables / "real_arms_placement")
pd.DataFrame([{"target": i, "x_m": p[0], "y_m": p[1], "z_m": p[2]} for i, p in enumerate(t["positions"])])

# %%
placement

# %%
write_json({"arms": rows, "placement": place_rows, "orientations": K, "step": step,
            "puma560_manipulability_max": float(manip.max())}, out.results / "real_arms.json")
