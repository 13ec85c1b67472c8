"""wsmap.timing: time_call, Timing, the paper network per grid, the run-time comparison."""

import math

import numpy as np
import pytest
import torch

from wsmap import timing
from wsmap.paper import runtime


def _fake_clock(ticks):
    it = iter(ticks)
    return lambda: next(it)


def test_time_call_counts_warmup_and_repeats():
    calls = []
    # the clock is read twice per timed call: (0, 1), (1, 3), (3, 6) -> 1, 2, 3 s
    t = timing.time_call(lambda: calls.append(1), repeats=3, warmup=2, clock=_fake_clock([0, 1, 1, 3, 3, 6]))
    assert len(calls) == 5
    assert t.values == (1.0, 2.0, 3.0)
    assert t.mean == pytest.approx(2.0)
    assert t.std == pytest.approx(1.0)  # sample std (ddof 1)
    assert t.n == 3 and t.min == 1.0


def test_time_call_real_clock_is_positive():
    t = timing.time_call(lambda: sum(range(1000)), repeats=4, warmup=0)
    assert t.n == 4 and all(v > 0 for v in t.values) and t.std >= 0


@pytest.mark.parametrize("repeats, warmup", [(0, 0), (-1, 0), (2, -1), (1.5, 0), (True, 0)])
def test_time_call_rejects_bad_counts(repeats, warmup):
    with pytest.raises(ValueError):
        timing.time_call(lambda: None, repeats=repeats, warmup=warmup)


def test_timing_single_value_and_scaling():
    t = timing.Timing.from_values([2.0])
    assert t.std == 0.0 and t.mean == 2.0
    s = timing.Timing.from_values([1.0, 3.0]).scaled(10)
    assert s.values == (10.0, 30.0) and s.mean == pytest.approx(20.0) and s.std == pytest.approx(math.sqrt(200))
    with pytest.raises(ValueError):
        timing.Timing.from_values([])


@pytest.mark.parametrize("step, nodes, features", [(1.0, 27, 30), (0.5, 125, 36), (0.1, 9261, 84)])
def test_grid_spec_and_paper_network(step, nodes, features):
    spec = runtime.grid_spec(step)
    assert spec.n_nodes == nodes and spec.n_features == features
    model, how = runtime.paper_network(features, nodes)
    assert model.config.hidden == [125, 100, 100, 125]
    if nodes == 9261:
        assert how == {"assemble": True} and model.n_subspaces == 7 and model.config.n_outputs == 1323
    else:
        assert how == {"key": 0} and model.n_subspaces == 1 and model.config.n_outputs == nodes
    out = model.predict(np.zeros((1, features)), **how)
    assert tuple(out.shape) == (1, nodes) and out.dtype == torch.bool


def test_runtime_comparison_small_grid():
    torch.set_num_threads(1)
    df = runtime.runtime_comparison((1.0,), repeats=2, warmup=1, classical_repeats=2, classical_warmup=0,
                                   per_node_sample=3)
    assert list(df["method"]) == list(runtime.METHODS)
    assert (df["nodes"] == 27).all() and (df["mean_s"] > 0).all() and (df["std_s"] >= 0).all()
    per_node = df.set_index("method").loc["classical_per_node_numerical"]
    assert per_node["timed_nodes"] == 3 and per_node["extrapolated"]
    assert per_node["paper_s"] == 19.5 and per_node["agreement_with_exact"] == 1.0
    net = df.set_index("method").loc["network"]
    assert net["paper_s"] == pytest.approx(0.0313) and math.isnan(net["agreement_with_exact"])
    assert df.set_index("method").loc["classical_batched_numerical", "agreement_with_exact"] == 1.0
    m = runtime.metrics_from_table(df)
    assert set(m["network"]) == {"27"} and m["classical_exact"]["27"] > 0
    assert m["speedup"]["network_vs_classical_per_node_numerical"]["27"] > 0


def test_runtime_comparison_whole_small_grid_is_not_extrapolated():
    df = runtime.runtime_comparison((1.0,), methods=["classical_per_node_numerical"], classical_repeats=1,
                                   classical_warmup=0, per_node_sample=100)
    row = df.iloc[0]
    assert row["timed_nodes"] == 27 and not row["extrapolated"]


def test_runtime_comparison_rejects_unknown_method():
    with pytest.raises(ValueError, match="unknown methods"):
        runtime.runtime_comparison((1.0,), methods=["magic"])
