"""Run-time measurement: the classical algorithm against the subspace-learning network.

The paper's figure "Run time (± sigma) of SL model compared to the classical algorithm" times the
PUMA560's constant-orientation map on the 27-, 125- and 9261-node grids ([-1, 1]³ m at steps 1,
0.5 and 0.1, R = I). `runtime_comparison` measures, per grid:

`classical_per_node_numerical`
    The paper's way: one `wsmap.kinematics.ik.lm.ikine_LM` call per node (the Appendix's LM, tol
    1e-10, q0 = 0), in a Python loop. On the large grids only a random sample of nodes is solved
    per repeat (a fresh sample each repeat) and the time is **extrapolated** to all nodes
    (`seconds x nodes / sampled`); grids no larger than the sample are solved whole.
`classical_batched_numerical`
    The same LM on all nodes at once (`wsmap.workspace.constant_orientation_map`,
    `method="numerical"`).
`classical_exact`
    The closed-form wrist-centre test (`method="exact"`), batched.
`network`
    `model.predict` of a freshly initialised paper network on the PUMA560's feature row
    (`wsmap.datasets.features_for`): hidden layers [125, 100, 100, 125] (tanh); 27 or 125
    outputs for the small grids, and for 9261 nodes the section-6.2 assembly of 7 block subspaces
    of 1323 outputs (`predict(..., assemble=True)`). Inference time does not depend on the
    values of the weights, so an untrained network times the same as a trained one.
`network_end_to_end`
    `wsmap.datasets.features_for` + `predict`: from the arm's DH table to the map.

Times are wall-clock (`time.perf_counter`), mean ± sigma (sample standard deviation) over
`repeats` calls after `warmup` untimed ones.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..timing import Timing, time_call
from ..workspace import BLOCK_NODES
from .published import RUNTIME_SECONDS

__all__ = [
    "METHODS",
    "grid_spec",
    "paper_network",
    "runtime_comparison",
    "metrics_from_table",
]

#: method key -> human label, in table order.
METHODS: dict[str, str] = {
    "classical_per_node_numerical": "classical, numerical, one node at a time (paper's way)",
    "classical_batched_numerical": "classical, numerical, batched",
    "classical_exact": "classical, exact (closed form), batched",
    "network": "SL network, predict",
    "network_end_to_end": "SL network, features + predict",
}
_CLASSICAL = ("classical_per_node_numerical", "classical_batched_numerical", "classical_exact")

#: Nodes per block subspace of the 21³ map (section 6.2: 7 blocks of 3 z-layers).


def grid_spec(step: float, lo: float = -1.0, hi: float = 1.0, rpy=(0.0, 0.0, 0.0)):
    """The R3 `wsmap.datasets.DatasetSpec` of a grid (all nodes, spherical-wrist layout) whose
    feature layout the network of that grid is fed."""
    from ..datasets import DatasetSpec

    return DatasetSpec(f"runtime_step{step:g}", scope="R3", lo=lo, hi=hi, step=step, fixed=tuple(rpy),
                       convention="paper")


def paper_network(n_features: int, n_nodes: int, seed: int = 0, device=None):
    """A freshly initialised paper network for a grid: hidden [125, 100, 100, 125] tanh.

    Grids of more than `BLOCK_NODES` nodes that split into whole blocks (9261 = 7 x 1323)
    get one subspace per block, to be assembled (section 6.2); smaller grids one network with
    `n_nodes` outputs. Returns `(model, kwargs)`: the keyword arguments of `model.predict`
    that give one `(n, n_nodes)` map per feature row (`assemble=True` or `key=0`).
    `device`: `None` (the CPU, where it is built) or a `device` setting / `torch.device`
    (`wsmap.learn.device.resolve_device`) the model is moved to.
    """
    import torch

    from ..learn import MLPConfig, SubspaceMLP
    from ..learn.device import resolve_device

    if n_nodes > BLOCK_NODES and n_nodes % BLOCK_NODES == 0:
        S, m = n_nodes // BLOCK_NODES, BLOCK_NODES
    else:
        S, m = 1, n_nodes
    cfg = MLPConfig(n_inputs=n_features, n_outputs=m, hidden=[125, 100, 100, 125], n_subspaces=S)
    model = SubspaceMLP(cfg, seeds=[seed + s for s in range(S)])
    if device is not None:
        model.to(device if isinstance(device, torch.device) else resolve_device(device))
    model.eval()
    return model, ({"assemble": True} if S > 1 else {"key": 0})


def _agreement(pred, exact) -> float:
    return float(np.mean(np.asarray(pred, bool) == np.asarray(exact, bool)))


def runtime_comparison(
    steps: Sequence[float] = (1.0, 0.5, 0.1),
    *,
    lo: float = -1.0,
    hi: float = 1.0,
    rpy=(0.0, 0.0, 0.0),
    repeats: int = 20,
    warmup: int = 2,
    classical_repeats: int = 3,
    classical_warmup: int = 1,
    per_node_sample: int = 100,
    ik: dict | None = None,
    robot=None,
    seed: int = 0,
    methods: Sequence[str] | None = None,
    progress: Callable[[str], None] | None = None,
    device="cpu",
):
    """Run time of the classical map and of the network on each grid; a `pandas.DataFrame`.

    Args:
        steps: grid steps (the paper's 1, 0.5, 0.1 give 27, 125 and 9261 nodes on [-1, 1]³).
        lo, hi, rpy: the grid's bounds (m) and fixed orientation (rad, paper convention).
        repeats, warmup: timed and untimed calls of the fast methods (exact, network).
        classical_repeats, classical_warmup: the same for the numerical methods (per-node and
            batched LM), which take seconds per call (a per-node warm-up call solves one node).
        per_node_sample: nodes solved one at a time per repeat of the per-node method (a fresh
            random sample each repeat, extrapolated to the grid); grids with at most this many
            nodes are solved whole.
        ik: LM settings (default the paper's: tol 1e-10, ilimit 500, rlimit 100, q0 = 0).
        robot: the arm (default `wsmap.robots.puma560`).
        seed: node samples and network initialisation.
        methods: subset of `METHODS` (default all).
        progress: called with a line of text before each measurement.
        device: where the network runs: `"cpu"` (default), `"cuda"` or `"auto"`
            (`wsmap.learn.device.resolve_device`; `"cuda"` without a GPU is a `ValueError`
            before any measurement). A timed network call includes copying its map back to the
            host (`.cpu()`), so a GPU's asynchronous work is finished inside the timing. The
            classical methods always run on the CPU.

    Returns:
        One row per (grid, method): `nodes`, `step`, `method`, `label`, `mean_s`,
        `std_s`, `min_s`, `repeats`, `timed_nodes` (nodes solved per timed call),
        `extrapolated`, `device` (where the method ran), `agreement_with_exact` (fraction
        of the timed nodes whose label equals the exact map's; NaN for the network), `paper_s`
        (the paper's classical time for the classical rows, its network time for the network
        rows), `speedup_vs_paper` (`paper_s / mean_s`).
    """
    import pandas as pd
    import torch

    from .. import robots
    from .. import workspace
    from ..datasets import features_for
    from ..kinematics import DHRobot, ikine_LM
    from ..learn.device import resolve_device

    methods = list(METHODS) if methods is None else list(methods)
    unknown = [m for m in methods if m not in METHODS]
    if unknown:
        raise ValueError(f"unknown methods {unknown}; choose from {list(METHODS)}")
    net_device = resolve_device(device, "runtime_comparison device")
    if isinstance(per_node_sample, bool) or int(per_node_sample) != per_node_sample or per_node_sample < 1:
        raise ValueError(f"per_node_sample must be a positive integer, got {per_node_sample!r}")
    ik = {"tol": 1e-10, "ilimit": 500, "rlimit": 100, **(ik or {})}
    robot = robots.puma560() if robot is None else robot
    rpy = tuple(float(r) for r in rpy)
    say = progress or (lambda s: None)
    rng = np.random.default_rng(seed)
    rows = []
    for step in steps:
        nodes = workspace.cartesian_grid(lo, hi, step)
        N = len(nodes)
        exact = workspace.constant_orientation_map(robot, nodes, rpy, method="exact", convention="paper")
        paper_classical, paper_network_s = RUNTIME_SECONDS.get(N, (math.nan, math.nan))

        def add(method, timing, timed_nodes, extrapolated=False, agreement=math.nan):
            paper = paper_network_s if method.startswith("network") else paper_classical
            rows.append(dict(
                nodes=N, step=float(step), method=method, label=METHODS[method],
                mean_s=timing.mean, std_s=timing.std, min_s=timing.min, repeats=timing.n,
                timed_nodes=int(timed_nodes), extrapolated=bool(extrapolated),
                device=str(net_device) if method.startswith("network") else "cpu",
                agreement_with_exact=agreement, paper_s=paper,
                speedup_vs_paper=paper / timing.mean if timing.mean > 0 else math.nan,
            ))

        if "classical_per_node_numerical" in methods:
            T = workspace.target_poses(nodes, rpy, "paper")
            n = min(int(per_node_sample), N)
            samples = [np.sort(rng.choice(N, size=n, replace=False)) if n < N else np.arange(N)
                       for _ in range(classical_repeats)]
            it = iter(samples)
            solved: dict[int, bool] = {}

            def per_node():
                for i in next(it):
                    solved[int(i)] = bool(ikine_LM(robot, T[i], **ik).success)

            for _ in range(classical_warmup):  # one node per warm-up call: the loop is the same code
                ikine_LM(robot, T[0], **ik)
            say(f"{N} nodes: per-node LM on {n} nodes x {classical_repeats} repeats")
            t = time_call(per_node, classical_repeats, 0).scaled(N / n)
            idx = np.fromiter(solved, dtype=int)
            add("classical_per_node_numerical", t, n, extrapolated=n < N,
                agreement=_agreement([solved[i] for i in idx], exact[idx]))

        if "classical_batched_numerical" in methods:
            out = {}

            def batched():
                # the paper's one-start LM, not the library's multi-start search
                out["map"] = workspace.constant_orientation_map(robot, nodes, rpy, method="numerical",
                                                         convention="paper", ik={**ik, "solver": "paper"})

            say(f"{N} nodes: batched LM x {classical_repeats} repeats")
            t = time_call(batched, classical_repeats, classical_warmup)
            add("classical_batched_numerical", t, N, agreement=_agreement(out["map"], exact))

        if "classical_exact" in methods:
            say(f"{N} nodes: exact x {repeats} repeats")
            t = time_call(lambda: workspace.constant_orientation_map(robot, nodes, rpy, method="exact",
                                                                     convention="paper"), repeats, warmup)
            add("classical_exact", t, N, agreement=1.0)

        if "network" in methods or "network_end_to_end" in methods:
            spec = grid_spec(step, lo, hi, rpy)
            arm = DHRobot(robot.d[None], robot.a[None], robot.alpha[None])
            X = features_for(arm, spec)
            model, how = paper_network(spec.n_features, N, seed=seed, device=net_device)
            shape = model.predict(X, **how).shape
            if tuple(shape) != (1, N):
                raise AssertionError(f"network output {tuple(shape)} for a {N}-node grid")
            with torch.inference_mode():
                # .cpu(): the map on the host (a no-op on the CPU; on a GPU it waits for the kernels)
                if "network" in methods:
                    say(f"{N} nodes: network predict on {net_device} x {repeats} repeats")
                    t = time_call(lambda: model.predict(X, **how).cpu(), repeats, warmup)
                    add("network", t, N)
                if "network_end_to_end" in methods:
                    say(f"{N} nodes: features + network predict on {net_device} x {repeats} repeats")
                    t = time_call(lambda: model.predict(features_for(arm, spec), **how).cpu(), repeats, warmup)
                    add("network_end_to_end", t, N)
    df = pd.DataFrame(rows)
    order = {m: i for i, m in enumerate(METHODS)}
    if len(df):
        df = df.sort_values(["nodes", "method"], key=lambda c: c.map(order) if c.name == "method" else c,
                            kind="stable").reset_index(drop=True)
    return df


def metrics_from_table(df) -> dict[str, Any]:
    """The run-time table as nested metrics: `{method: {"27": mean_s, ...}, method + "_std":
    {...}}` (the keys `wsmap.paper.report` reads), plus `speedup` of the network over each
    classical method per grid (classical mean / network mean)."""
    out: dict[str, Any] = {}
    for r in df.itertuples(index=False):
        out.setdefault(r.method, {})[str(r.nodes)] = float(r.mean_s)
        out.setdefault(f"{r.method}_std", {})[str(r.nodes)] = float(r.std_s)
    speed: dict[str, dict[str, float]] = {}
    for m in _CLASSICAL:
        for n, v in out.get(m, {}).items():
            net = out.get("network", {}).get(n)
            if net:
                speed.setdefault(f"network_vs_{m}", {})[n] = v / net
    out["speedup"] = speed
    return out
