"""The parts of the paper: the summaries the notebooks and the paper-scale runner share, on known
values, and the schemas the metrics are held to (the parts' runs are the notebook smoke tests)."""

import math

import numpy as np
import pytest

from wsmap.metrics import precision_recall_f, threshold_sweep
from wsmap.paper import parts
from wsmap.paper.parts import runtime_comparison, sec61_subspace, sec62_puma560, table2_optimisers, table3_embeddings
from wsmap.paper.published import SEC61, SEC62


def _session(k, f, val, precision=0.8, recall=0.9):
    return {"session": k, "precision": precision, "recall": recall, "f": f, "epochs": 10 + k, "best_epoch": 5 + k,
            "stop_reason": "max_epochs", "seconds": 2.0 * (k + 1), "best_val_loss": val}


@pytest.fixture
def sweep():
    scores = np.array([[0.9, 0.2, 0.6], [0.4, 0.7, 0.1]])
    truth = np.array([[True, False, True], [False, True, False]])
    return threshold_sweep(scores, truth, np.linspace(0.0, 1.0, 11))


def test_section_6_1_summary_of_known_sessions(sweep):
    rows = [_session(0, 0.85, 0.20), _session(1, 0.75, 0.10, precision=0.6), _session(2, 0.95, 0.30)]
    s = sec61_subspace.summarise(rows, sweep, threshold=0.5, max_epochs=12, train_samples=300)
    assert list(s) == list(sec61_subspace.Summary.__annotations__)
    assert s["f_mean"] == pytest.approx(0.85) and s["f_std"] == pytest.approx(0.1)
    assert s["f_sessions"] == [0.85, 0.75, 0.95]
    assert s["best_session"] == 1 and s["best_session_f"] == 0.75  # lowest validation loss, not highest F
    assert s["precision_mean"] == pytest.approx(2.2 / 3) and s["recall_sessions"] == [0.9] * 3
    assert s["epochs_run"] == [10, 11, 12] and s["best_epochs"] == [5, 6, 7] and s["epochs"] == 12
    assert s["seconds_per_session"] == [2.0, 4.0, 6.0] and s["seconds_per_session_mean"] == 4.0
    assert (s["best_threshold"], s["best_threshold_f"]) == (sweep.best_threshold, sweep.best_f)
    assert s["sessions"] == 3 and s["train_samples"] == 300 and s["threshold"] == 0.5 and s["paper"] == SEC61
    one = sec61_subspace.summarise(rows[:1], sweep, threshold=0.5, max_epochs=12, train_samples=300)
    assert math.isnan(one["f_std"]) and one["best_session"] == 0


def test_section_6_1_sweep_is_the_papers():
    evaluation = {"scores": np.array([[0.9, 0.2], [0.4, 0.7]]), "truth": np.array([[True, False], [False, True]])}
    sweep = sec61_subspace.sweep_of(evaluation, 5)
    np.testing.assert_array_equal(sweep.thresholds, [0.0, 0.25, 0.5, 0.75, 1.0])
    assert sweep.best_f == 1.0 and 0.4 <= sweep.best_threshold < 0.7


def test_section_6_2_summary_of_known_blocks():
    blocks = [{"f": 0.5 + 0.05 * k, "precision": 0.6, "recall": 0.7, "epochs": 3, "best_epoch": 2,
               "stop_reason": "max_fail", "seconds": 1.5} for k in range(7)]
    full = {"f": 0.8, "precision": 0.85, "recall": 0.75, "f_mean": 0.79}
    predicted = np.array([True, True, False, False])
    exact = np.array([True, False, True, False])
    s = sec62_puma560.summarise(blocks, full, (predicted, exact, precision_recall_f(predicted, exact)),
                                train_samples=400, test_samples=100, max_fail=100)
    assert list(s) == list(sec62_puma560.Summary.__annotations__)
    assert (s["f_full"], s["precision_full"], s["recall_full"], s["f_per_sample_full"]) == (0.8, 0.85, 0.75, 0.79)
    assert s["f_blocks"] == [b["f"] for b in blocks] and s["epochs_run"] == [3] * 7
    assert (s["puma560_precision"], s["puma560_recall"], s["puma560_f"]) == (0.5, 0.5, 0.5)
    assert (s["puma560_reachable_predicted"], s["puma560_reachable_exact"]) == (2, 2)
    assert s["paper"] == SEC62 and s["max_fail"] == 100


def test_cell_parts_hold_their_cells():
    cell = dict.fromkeys(table2_optimisers.CELL_KEYS, 0.5)
    fixed = dict.fromkeys(table2_optimisers.Metrics.__annotations__, 1)
    assert table2_optimisers.check_metrics({**fixed, "rprop_mse": cell})["rprop_mse"] == cell
    with pytest.raises(ValueError, match="cells not of"):
        table2_optimisers.check_metrics({**fixed, "rprop_mse": {**cell, "extra": 1}})
    cell3 = dict.fromkeys(table3_embeddings.CELL_KEYS, 0.5)
    fixed3 = dict.fromkeys(table3_embeddings.Metrics.__annotations__, 1)
    table3_embeddings.check_metrics({**fixed3, "a": {"a": cell3, "b": cell3}, "b": {"a": cell3, "b": cell3}}, ["a", "b"])
    with pytest.raises(ValueError, match="expected"):
        table3_embeddings.check_metrics({**fixed3, "a": {"a": cell3}}, ["a", "b"])
    fixed_rt = dict.fromkeys(runtime_comparison.Metrics.__annotations__, {})
    runtime_comparison.check_metrics({**fixed_rt, "network": {"27": 1e-4}, "network_std": {"27": 1e-5}})
    with pytest.raises(ValueError, match=r"unknown keys \['gpu'\]"):
        runtime_comparison.check_metrics({**fixed_rt, "gpu": {}})


def test_every_part_has_the_interface():
    for name, part in parts.registry().items():
        module = __import__(part.module, fromlist=["run"])
        assert all(callable(getattr(module, f)) for f in ("run", "save", "figures")), name
        assert isinstance(module.Metrics.__annotations__, dict), name
        assert part.outputs and all(not o.startswith("/") for o in part.outputs), name
