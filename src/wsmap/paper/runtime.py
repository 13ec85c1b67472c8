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
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
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


@dataclass
class _Grid:
    """One grid of the comparison: its step (m), nodes `(N, 3)`, exact map `(N,)` and the
    paper's classical and network times for its node count (NaN where the paper has none)."""

    step: float
    nodes: np.ndarray
    exact: np.ndarray
    paper_classical: float
    paper_network: float

    @property
    def n(self) -> int:
        return len(self.nodes)


@dataclass
class _Comparison:
    """The settings of one `runtime_comparison` (see there), the arm, the node-sample
    generator (one for all grids, drawn in grid order) and the rows measured so far."""

    robot: Any
    lo: float
    hi: float
    rpy: tuple[float, float, float]
    ik: dict
    repeats: int
    warmup: int
    classical_repeats: int
    classical_warmup: int
    per_node_sample: int
    seed: int
    methods: list[str]
    say: Callable[[str], None]
    net_device: Any
    rng: np.random.Generator
    rows: list[dict] = field(default_factory=list)

    def grid(self, step: float) -> _Grid:
        from .. import workspace

        nodes = workspace.cartesian_grid(self.lo, self.hi, step)
        exact = workspace.constant_orientation_map(self.robot, nodes, self.rpy, method="exact", convention="paper")
        paper_classical, paper_network_s = RUNTIME_SECONDS.get(len(nodes), (math.nan, math.nan))
        return _Grid(step, nodes, exact, paper_classical, paper_network_s)

    def add(self, g: _Grid, method: str, timing: Timing, timed_nodes: int, extrapolated: bool = False,
            agreement: float = math.nan) -> None:
        network = method.startswith("network")
        paper = g.paper_network if network else g.paper_classical
        self.rows.append(dict(
            nodes=g.n, step=float(g.step), method=method, label=METHODS[method],
            mean_s=timing.mean, std_s=timing.std, min_s=timing.min, repeats=timing.n,
            timed_nodes=int(timed_nodes), extrapolated=bool(extrapolated),
            device=str(self.net_device) if network else "cpu",
            agreement_with_exact=agreement, paper_s=paper,
            speedup_vs_paper=paper / timing.mean if timing.mean > 0 else math.nan,
        ))

    def per_node(self, g: _Grid) -> None:
        """The paper's way: one LM call per node of a fresh random sample per repeat, the time
        extrapolated to the grid."""
        from .. import workspace
        from ..kinematics import ikine_LM

        T = workspace.target_poses(g.nodes, self.rpy, "paper")
        n = min(int(self.per_node_sample), g.n)
        samples = [np.sort(self.rng.choice(g.n, size=n, replace=False)) if n < g.n else np.arange(g.n)
                   for _ in range(self.classical_repeats)]
        it = iter(samples)
        solved: dict[int, bool] = {}

        def per_node():
            for i in next(it):
                solved[int(i)] = bool(ikine_LM(self.robot, T[i], **self.ik).success)

        for _ in range(self.classical_warmup):  # one node per warm-up call: the loop is the same code
            ikine_LM(self.robot, T[0], **self.ik)
        self.say(f"{g.n} nodes: per-node LM on {n} nodes x {self.classical_repeats} repeats")
        t = time_call(per_node, self.classical_repeats, 0).scaled(g.n / n)
        idx = np.fromiter(solved, dtype=int)
        self.add(g, "classical_per_node_numerical", t, n, extrapolated=n < g.n,
                 agreement=_agreement([solved[i] for i in idx], g.exact[idx]))

    def batched(self, g: _Grid) -> None:
        """The same LM on every node at once."""
        from .. import workspace

        out = {}

        def batched():
            # the paper's one-start LM, not the library's multi-start search
            out["map"] = workspace.constant_orientation_map(self.robot, g.nodes, self.rpy, method="numerical",
                                                            convention="paper", ik={**self.ik, "solver": "paper"})

        self.say(f"{g.n} nodes: batched LM x {self.classical_repeats} repeats")
        t = time_call(batched, self.classical_repeats, self.classical_warmup)
        self.add(g, "classical_batched_numerical", t, g.n, agreement=_agreement(out["map"], g.exact))

    def exact(self, g: _Grid) -> None:
        """The closed-form map, batched."""
        from .. import workspace

        self.say(f"{g.n} nodes: exact x {self.repeats} repeats")
        t = time_call(lambda: workspace.constant_orientation_map(self.robot, g.nodes, self.rpy, method="exact",
                                                                 convention="paper"), self.repeats, self.warmup)
        self.add(g, "classical_exact", t, g.n, agreement=1.0)

    def network(self, g: _Grid) -> None:
        """The network's `predict`, and features + `predict`, on the arm's feature row."""
        import torch

        from ..datasets import features_for
        from ..kinematics import DHRobot

        spec = grid_spec(g.step, self.lo, self.hi, self.rpy)
        arm = DHRobot(self.robot.d[None], self.robot.a[None], self.robot.alpha[None])
        X = features_for(arm, spec)
        model, how = paper_network(spec.n_features, g.n, seed=self.seed, device=self.net_device)
        shape = model.predict(X, **how).shape
        if tuple(shape) != (1, g.n):
            raise AssertionError(f"network output {tuple(shape)} for a {g.n}-node grid")
        with torch.inference_mode():
            # .cpu(): the map on the host (a no-op on the CPU; on a GPU it waits for the kernels)
            if "network" in self.methods:
                self.say(f"{g.n} nodes: network predict on {self.net_device} x {self.repeats} repeats")
                t = time_call(lambda: model.predict(X, **how).cpu(), self.repeats, self.warmup)
                self.add(g, "network", t, g.n)
            if "network_end_to_end" in self.methods:
                self.say(f"{g.n} nodes: features + network predict on {self.net_device} x {self.repeats} repeats")
                t = time_call(lambda: model.predict(features_for(arm, spec), **how).cpu(), self.repeats, self.warmup)
                self.add(g, "network_end_to_end", t, g.n)

    def measure(self, step: float) -> None:
        """Every chosen method on the grid of `step`, in `METHODS`' order."""
        g = self.grid(step)
        if "classical_per_node_numerical" in self.methods:
            self.per_node(g)
        if "classical_batched_numerical" in self.methods:
            self.batched(g)
        if "classical_exact" in self.methods:
            self.exact(g)
        if "network" in self.methods or "network_end_to_end" in self.methods:
            self.network(g)


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

    Parameters
    ----------
    steps : sequence of float
        Grid steps (m; the paper's 1, 0.5, 0.1 give 27, 125 and 9261 nodes on [-1, 1]³).
    lo, hi, rpy : float, float, tuple of float
        The grid's bounds (m) and fixed orientation (rad, paper convention).
    repeats, warmup : int
        Timed and untimed calls of the fast methods (exact, network).
    classical_repeats, classical_warmup : int
        The same for the numerical methods (per-node and batched LM), which take seconds per
        call (a per-node warm-up call solves one node).
    per_node_sample : int
        Nodes solved one at a time per repeat of the per-node method (a fresh random sample each
        repeat, extrapolated to the grid); grids with at most this many nodes are solved whole.
    ik : dict, optional
        LM settings (default the paper's: tol 1e-10, ilimit 500, rlimit 100, q0 = 0).
    robot : DHRobot, optional
        The arm (default `wsmap.robots.puma560`).
    seed : int
        Node samples and network initialisation.
    methods : sequence of str, optional
        Subset of `METHODS` (default all).
    progress : callable, optional
        Called with a line of text before each measurement.
    device : str or torch.device
        Where the network runs: `"cpu"` (default), `"cuda"` or `"auto"`
        (`wsmap.learn.device.resolve_device`; `"cuda"` without a GPU is a `ValueError`
        before any measurement). A timed network call includes copying its map back to the
        host (`.cpu()`), so a GPU's asynchronous work is finished inside the timing. The
        classical methods always run on the CPU.

    Returns
    -------
    pandas.DataFrame
        One row per (grid, method): `nodes`, `step`, `method`, `label`, `mean_s`,
        `std_s`, `min_s`, `repeats`, `timed_nodes` (nodes solved per timed call),
        `extrapolated`, `device` (where the method ran), `agreement_with_exact` (fraction
        of the timed nodes whose label equals the exact map's; NaN for the network), `paper_s`
        (the paper's classical time for the classical rows, its network time for the network
        rows), `speedup_vs_paper` (`paper_s / mean_s`).
    """
    from .. import robots
    from ..learn.device import resolve_device

    methods = _checked_methods(methods)
    net_device = resolve_device(device, "runtime_comparison device")
    if isinstance(per_node_sample, bool) or int(per_node_sample) != per_node_sample or per_node_sample < 1:
        raise ValueError(f"per_node_sample must be a positive integer, got {per_node_sample!r}")
    run = _Comparison(robot=robots.puma560() if robot is None else robot, lo=lo, hi=hi,
                      rpy=tuple(float(r) for r in rpy), ik={"tol": 1e-10, "ilimit": 500, "rlimit": 100, **(ik or {})},
                      repeats=repeats, warmup=warmup, classical_repeats=classical_repeats,
                      classical_warmup=classical_warmup, per_node_sample=per_node_sample, seed=seed, methods=methods,
                      say=progress or (lambda s: None), net_device=net_device, rng=np.random.default_rng(seed))
    for step in steps:
        run.measure(step)
    return _table(run.rows)


def _checked_methods(methods: Sequence[str] | None) -> list[str]:
    """`methods` as a list (`None`: all of `METHODS`); an unknown one is a `ValueError`."""
    methods = list(METHODS) if methods is None else list(methods)
    unknown = [m for m in methods if m not in METHODS]
    if unknown:
        raise ValueError(f"unknown methods {unknown}; choose from {list(METHODS)}")
    return methods


def _table(rows: list[dict]):
    """The rows as a `pandas.DataFrame`, by node count and then in `METHODS`' order."""
    import pandas as pd

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
