# %% [markdown]
# # The reach study of real cells
#
# Can this arm, placed here, do this job on this workpiece without hitting anything? ROS-Industrial
# REACH's question, answered by `wsmap study` (`docs/study.md`) on committed cells (`data/cells/`):
#
# * **reach_demo** — REACH's own demo (`reach_ros`): a Motoman SIA20D, its TCP 0.1 m in front of
#   `tool0`, the targets of the demo's point cloud `part.pcd` (tool against each normal), the part
#   `part.ply` an obstacle tested on its triangles, self-collision on the vendor's meshes. REACH saved
#   its own answer for this cell (`reach.db.xml`): the two are compared target by target.
# * **catalogue** — a harder cell on the same part: a UR5e, a Panda and an iiwa 14 on a 0.5 m pedestal,
#   the part lowered 0.2 m, the tool free about its axis (4 turns) and within a 15° cone, the base
#   searched over a region with 4 headings: which arm, placed where, covers most of the part?
#
# Each target is *reached* (a solution inside the limits, confirmed by forward kinematics,
# collision-free), *certified unreachable* (a sound test proves no variant reachable), or *not found*.

# %% parameters
params_file = None  # papermill passes the chosen params file; None: params.yaml (a notebook opened by hand)
output_root = None  # papermill/DVC pass the project root; None: scratch/<notebook>/ (opened by hand)

# %%
from IPython.display import Image

from wsmap import paths
from wsmap.paper.parts import reach_study as part

out = paths.notebook_outputs("reach_study", output_root)
cfg = paths.notebook_params("reach_study", params_file)
result = part.run(cfg, out)
part.save(result, out)
figures = part.figures(result, out)

# %% [markdown]
# ## Coverage per cell and arm
#
# The best base of each arm (the catalogue's region searched exactly: candidates verified in the
# order of their kinematic coverage bound until no unverified one can beat the third best).

# %%
result.table

# %% [markdown]
# ## Against REACH's own answer
#
# REACH's database holds, per target of its demo, whether its MoveIt study reached it (three
# optimisation steps; the last is its answer). wsmap's tool poses equal REACH's goals to their single
# precision (`tests/workspace/test_reach_db.py`).

# %%
result.metrics["agreement"]

# %% [markdown]
# ## The heat map on the part
#
# Each target coloured by its combined score (manipulability × joint-limit margin), unreached targets
# grey; the interactive view and a PLY with vertex colours are beside the study file
# (`results/reach_study/`).

# %%
Image(filename=str(figures[0]))
