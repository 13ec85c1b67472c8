# %% [markdown]
# # Reproduction report
#
# Reads the metrics every other stage wrote (`results/*.json`), sets each reproduced number beside
# the paper's (`wsmap.paper.published.PAPER`, from NOTES.md), lists where the committed run is
# smaller than the paper's (`params.yaml` against `params.full.yaml`) and writes
# `results/REPORT.md`. It computes nothing new: every number comes from a stage's metrics file.

# %% parameters
params_file = None  # papermill passes the chosen params file; None: params.yaml (a notebook opened by hand)
output_root = None

# %%
import pandas as pd

from wsmap import paths
from wsmap.paper import report as R
from wsmap.viz import save_figure

cfg = paths.notebook_params("report", params_file)
out = paths.Outputs(output_root).make()
metrics = R.load_metrics(out.results)
rows = R.comparison_rows(metrics)
table = pd.DataFrame([dict(section=r.section, what=r.what, ours=r.ours, paper=r.paper, difference=r.difference,
                           source=r.source) for r in rows])
missing = table[table["ours"].isna()]
print(f"{len(metrics)} metrics files, {len(table)} comparisons, {len(missing)} missing")
table

# %% [markdown]
# ## F-measures: reproduced against published

# %%
import matplotlib.pyplot as plt
import numpy as np

f_rows = table[table["what"].str.contains("F", regex=False) & table["paper"].notna() & table["ours"].notna()
               & ~table["what"].str.contains("sigma")]
fig, ax = plt.subplots(figsize=(7, 0.35 * len(f_rows) + 1.2))
y = np.arange(len(f_rows))
ax.barh(y - 0.2, f_rows["paper"], height=0.4, label="paper", color="0.7")
ax.barh(y + 0.2, f_rows["ours"], height=0.4, label="this run", color="C0")
ax.set_yticks(y, [f"{s}: {w}" for s, w in zip(f_rows["section"], f_rows["what"])], fontsize=7)
ax.invert_yaxis()
ax.set_xlim(min(0.5, float(np.nanmin(f_rows[["paper", "ours"]].to_numpy())) - 0.02), 1.0)
ax.set_xlabel("F-measure")
ax.legend(loc="lower right")
ax.set_title("Reproduced F-measures against the paper's")
fig.tight_layout()
save_figure(fig, out.figures / "reproduction_vs_paper.png")

# %% [markdown]
# ## The committed scale against the paper's

# %%
committed = paths.load_params(path=paths.ROOT / cfg["committed_params"])
full = paths.load_params(path=paths.ROOT / cfg["full_params"])
reductions = R.reductions(committed, full)
pd.DataFrame(reductions)

# %%
extra = {}
audit = out.tables / "label_audit.md"
if audit.exists():
    extra["Label audit: the paper's one-start numerical labels against exact ones"] = audit.read_text()
path = R.write_report(out.results, reductions=reductions, extra_sections=extra)
print(path.read_text())
