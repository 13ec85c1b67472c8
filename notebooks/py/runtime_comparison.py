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
# * **SL network** -- `model.predict` on the PUMA560's feature row (`wsmap.data.features_for`),
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
output_root = None

# %%
import os
import platform

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import torch

from wsmap import paths
from wsmap.io import atomic_path, write_json
from wsmap.learn.device import device_facts, resolve_device
from wsmap.paper import runtime as RT
from wsmap.paper.published import RUNTIME_SECONDS
from wsmap.viz import save_figure

out = paths.Outputs(output_root).make()
cfg = paths.notebook_params("runtime_comparison", params_file)
device = resolve_device(cfg["device"], f"{cfg.source} device")  # before any work: cuda without a GPU fails here
torch.set_num_threads(int(cfg["torch_threads"]))
machine = {
    "cpus": os.cpu_count(),
    "load_average_before": list(os.getloadavg()),
    "torch_threads": torch.get_num_threads(),
    "network_device": device_facts(device),
    "python": platform.python_version(),
    "torch": torch.__version__,
    "numpy": np.__version__,
}
cfg, machine

# %% [markdown]
# ## Measure

# %%
df = RT.runtime_comparison(
    cfg["steps"], lo=cfg["lo"], hi=cfg["hi"], rpy=cfg["rpy"],
    repeats=int(cfg["repeats"]), warmup=int(cfg["warmup"]),
    classical_repeats=int(cfg["classical_repeats"]), classical_warmup=int(cfg["classical_warmup"]),
    per_node_sample=int(cfg["per_node_sample"]), seed=int(cfg["seed"]), progress=print, device=device,
)
machine["load_average_after"] = list(os.getloadavg())
df[["nodes", "label", "mean_s", "std_s", "repeats", "timed_nodes", "extrapolated", "agreement_with_exact",
    "paper_s", "speedup_vs_paper"]]

# %% [markdown]
# ## Table: ours beside the paper's

# %%
table = df[["nodes", "step", "method", "label", "mean_s", "std_s", "min_s", "repeats", "timed_nodes",
            "extrapolated", "agreement_with_exact", "paper_s", "speedup_vs_paper"]].copy()
with atomic_path(out.tables / "runtime_comparison.csv") as tmp:
    table.to_csv(tmp, index=False)
md = table.drop(columns=["method", "step"]).to_markdown(index=False, floatfmt=".4g")
note = ("\n\nMean ± sigma (sample std) over `repeats` calls; per-node rows with extrapolated = True solved "
        "`timed_nodes` random nodes per repeat, scaled to the grid. Network: untrained paper network "
        "(inference time does not depend on the weights). paper_s: the paper's classical time for the classical "
        "rows, its network time for the network rows (MATLAB R2017b, Xeon E3-1505M).\n")
with atomic_path(out.tables / "runtime_comparison.md") as tmp:
    tmp.write_text(md + note)
print(md)

# %% [markdown]
# ## Figure (log scale, error bars ± sigma)

# %%
grids = sorted(df["nodes"].unique())
bars = [  # (label, values per grid, sigma per grid, colour, hatch)
    ("paper: classical (MATLAB, per node)", [RUNTIME_SECONDS[n][0] for n in grids], None, "#bbbbbb", "//"),
]
colours = {"classical_per_node_numerical": "#d62728", "classical_batched_numerical": "#ff7f0e",
           "classical_exact": "#2ca02c", "network": "#1f4e79"}
by = df.set_index(["method", "nodes"])
for m, c in colours.items():
    if m == "network":
        bars.append(("paper: SL network", [RUNTIME_SECONDS[n][1] for n in grids], None, "#9ecae1", "//"))
    extrapolated = [str(n) for n in grids if by.loc[(m, n), "extrapolated"]]
    lab = RT.METHODS[m] + (f" (extrapolated on {', '.join(extrapolated)})" if extrapolated else "")
    bars.append(("ours: " + lab, [by.loc[(m, n), "mean_s"] for n in grids], [by.loc[(m, n), "std_s"] for n in grids],
                 c, None))
fig, ax = plt.subplots(figsize=(10, 6))
width = 0.8 / len(bars)
x = np.arange(len(grids))
for i, (lab, vals, err, colour, hatch) in enumerate(bars):
    if err is not None:  # log scale: a lower bar of sigma >= mean is clipped at 10 % of the mean
        vals, err = np.asarray(vals), np.asarray(err)
        err = np.stack([np.minimum(err, 0.9 * vals), err])
    ax.bar(x + (i - (len(bars) - 1) / 2) * width, vals, width, yerr=err, capsize=3, label=lab, color=colour,
           hatch=hatch, edgecolor="black", linewidth=0.5)
ax.set_yscale("log")
ax.set_xticks(x)
ax.set_xticklabels([f"{n} nodes" for n in grids])
ax.set_ylabel("run time (s), mean ± σ, log scale\n(lower bar clipped where σ ≥ mean)")
ax.set_title("PUMA560 workspace map: run time of the SL network and the classical algorithm")
ax.grid(True, axis="y", which="both", alpha=0.3)
ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.08), ncol=2)
fig.tight_layout()
save_figure(fig, out.figures / "runtime_comparison.png")

# %%
metrics = {
    **RT.metrics_from_table(df),
    "paper": {"classical": {str(n): c for n, (c, _) in RUNTIME_SECONDS.items()},
              "network": {str(n): w for n, (_, w) in RUNTIME_SECONDS.items()}},
    "per_node_extrapolated": {str(r.nodes): bool(r.extrapolated) for r in df.itertuples()
                              if r.method == "classical_per_node_numerical"},
    "settings": {k: cfg[k] for k in ("steps", "lo", "hi", "rpy", "repeats", "warmup", "classical_repeats",
                                     "classical_warmup", "per_node_sample", "seed", "device")},
    "machine": machine,
}
write_json(metrics, out.results / "runtime_comparison.json")
# a smoke run checks what it produced, not just that it ran
assert (df["mean_s"] > 0).all()
for n in grids:
    assert by.loc[("classical_exact", n), "mean_s"] < by.loc[("classical_batched_numerical", n), "mean_s"]
assert (out.figures / "runtime_comparison.png").stat().st_size > 5_000
{k: metrics[k] for k in ("classical_per_node_numerical", "classical_batched_numerical", "classical_exact", "network")}
