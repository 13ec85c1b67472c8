# %% [markdown]
# # Reproduction report
#
# Reads the metrics every other stage wrote (`results/*.json`), sets each reproduced number beside
# the paper's (`wsmap.paper.published.PAPER`, from NOTES.md), lists where the committed run is
# smaller than the paper's (`params.yaml` against `params.full.yaml`) and writes
# `results/REPORT.md` (`wsmap.paper.parts.report`). It computes nothing new: every number comes from a
# stage's metrics file.

# %% parameters
params_file = None  # papermill passes the chosen params file; None: params.yaml (a notebook opened by hand)
output_root = None  # papermill/DVC pass the project root; None: scratch/<notebook>/ (opened by hand)

# %%
from IPython.display import Image

from wsmap import paths
from wsmap.paper.parts import report as part

cfg = paths.notebook_params("report", params_file)
out = paths.notebook_outputs("report", output_root)
result = part.run(cfg, out)
figures = part.figures(result, out)
print(f"{len(result.metrics)} metrics files, {len(result.table)} comparisons, {len(result.missing)} missing")
result.table

# %% [markdown]
# ## F-measures: reproduced against published

# %%
Image(filename=str(out.figures / "reproduction_vs_paper.png"))

# %% [markdown]
# ## The committed scale against the paper's

# %%
import pandas as pd

pd.DataFrame(result.reductions)

# %%
path = part.save(result, out)
print(path.read_text())
