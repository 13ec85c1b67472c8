"""Tests of wsmap.metrics: confusion counts, P/R/F (micro and per sample), sweeps, histogram."""

import math

import numpy as np
import pytest
import torch

from wsmap.learn.training import History
from wsmap.metrics import (
    Confusion,
    best_threshold,
    confusion,
    error_histogram,
    outcomes,
    per_sample_error,
    precision_recall_f,
    session_curves,
    session_mean_std,
    threshold_sweep,
)

B = np.array  # short for hand-made bool maps


def bools(*rows):
    return np.array(rows, dtype=bool)


def test_confusion_counts():
    pred = bools([1, 1, 0, 0, 1], [0, 0, 0, 1, 1])
    truth = bools([1, 0, 1, 0, 1], [0, 1, 0, 1, 1])
    assert confusion(pred, truth) == Confusion(tp=4, fp=1, fn=2, tn=3)
    per = confusion(pred, truth, axis=1)
    assert per.tp.tolist() == [2, 2] and per.fp.tolist() == [1, 0] and per.fn.tolist() == [1, 1]
    assert per.tn.tolist() == [1, 2]
    # torch tensors and 0/1 integers are accepted
    assert confusion(torch.tensor(pred), truth.astype(np.int8)) == Confusion(4, 1, 2, 3)


def test_confusion_errors():
    with pytest.raises(ValueError) as e:
        confusion(np.zeros((3, 4), bool), np.zeros((3, 5), bool))
    assert str(e.value) == "pred shape (3, 4) does not match truth shape (3, 5)"
    with pytest.raises(ValueError, match="threshold scores first"):
        confusion(np.array([0.2, 0.7]), np.array([True, False]))


def test_hand_made_prf():
    # tp 2, fp 1, fn 1 -> P = R = F = 2/3
    r = precision_recall_f(B([1, 1, 0, 0, 1], bool), B([1, 0, 1, 0, 1], bool))
    assert (r.precision, r.recall, r.f) == pytest.approx((2 / 3, 2 / 3, 2 / 3))
    assert (r.tp, r.fp, r.fn, r.tn) == (2, 1, 1, 1)
    # tp 3, fp 1, fn 3 -> P 0.75, R 0.5, F 0.6
    pred = B([1, 1, 1, 1, 0, 0, 0, 0], bool)
    truth = B([1, 1, 1, 0, 1, 1, 1, 0], bool)
    r = precision_recall_f(pred, truth)
    assert (r.precision, r.recall, r.f) == pytest.approx((0.75, 0.5, 0.6))
    assert r.undefined_precision == r.undefined_recall == r.undefined_f == 0
    assert math.isnan(r.f_std)
    d = r.to_dict()
    assert d["f"] == pytest.approx(0.6) and "per_sample" not in d


def test_undefined_cases():
    # no predicted positives, some true positives: P undefined, R = 0
    r = precision_recall_f(B([0, 0, 0], bool), B([1, 0, 1], bool))
    assert math.isnan(r.precision) and r.recall == 0 and math.isnan(r.f)
    assert (r.undefined_precision, r.undefined_recall, r.undefined_f) == (1, 0, 1)
    r0 = precision_recall_f(B([0, 0, 0], bool), B([1, 0, 1], bool), zero_division=0)
    assert (r0.precision, r0.recall, r0.f) == (0.0, 0.0, 0.0)
    r1 = precision_recall_f(B([0, 0, 0], bool), B([1, 0, 1], bool), zero_division=1)
    assert (r1.precision, r1.recall, r1.f) == (1.0, 0.0, 0.0)
    # nothing predicted, nothing true: both undefined
    r = precision_recall_f(np.zeros(4, bool), np.zeros(4, bool))
    assert math.isnan(r.precision) and math.isnan(r.recall) and math.isnan(r.f)
    r1 = precision_recall_f(np.zeros(4, bool), np.zeros(4, bool), zero_division=1)
    assert (r1.precision, r1.recall, r1.f) == (1.0, 1.0, 1.0)
    # positives predicted and present but none right: P = R = 0, F = 0 (defined)
    r = precision_recall_f(B([1, 0], bool), B([0, 1], bool))
    assert (r.precision, r.recall, r.f) == (0.0, 0.0, 0.0)
    with pytest.raises(ValueError, match="zero_division"):
        precision_recall_f(B([1], bool), B([1], bool), zero_division=0.5)
    with pytest.raises(ValueError, match="average"):
        precision_recall_f(B([1], bool), B([1], bool), average="macro")


def test_micro_vs_samples():
    truth = bools([1] * 8 + [0] * 2,
                  [1] + [0] * 9,
                  [0] * 10)
    pred = bools([1] * 8 + [0] * 2,   # perfect: P = R = F = 1
                 [0, 1] + [0] * 8,    # one miss, one false alarm: P = R = F = 0
                 [0] * 10)            # all negative, predicted so: P, R, F undefined
    micro = precision_recall_f(pred, truth)
    assert (micro.tp, micro.fp, micro.fn) == (8, 1, 1)
    assert (micro.precision, micro.recall, micro.f) == pytest.approx((8 / 9, 8 / 9, 8 / 9))

    s = precision_recall_f(pred, truth, average="samples")
    assert (s.precision, s.recall, s.f) == pytest.approx((0.5, 0.5, 0.5))
    assert s.f_std == pytest.approx(math.sqrt(0.5))  # ddof 1 over the 2 defined samples
    assert (s.undefined_precision, s.undefined_recall, s.undefined_f) == (1, 1, 1)
    assert s.n_samples == 3 and (s.tp, s.fp, s.fn, s.tn) == (8, 1, 1, 20)
    np.testing.assert_array_equal(s.per_sample["f"], [1.0, 0.0, np.nan])
    s0 = precision_recall_f(pred, truth, average="samples", zero_division=0, ddof=0)
    assert s0.f == pytest.approx(1 / 3) and s0.undefined_f == 0
    assert s0.f_std == pytest.approx(np.std([1.0, 0.0, 0.0]))
    with pytest.raises(ValueError, match="needs \\(samples, nodes\\)"):
        precision_recall_f(pred[0], truth[0], average="samples")


def test_threshold_sweep_matches_brute_force_and_is_monotonic():
    rng = np.random.default_rng(0)
    truth = rng.random((30, 40)) < 0.4
    scores = np.where(truth, rng.normal(0.7, 0.3, truth.shape), rng.normal(0.3, 0.3, truth.shape))
    scores[0, :3] = [0.5, 0.25, 1.0]  # values exactly on thresholds: strict ">"
    th = np.linspace(0, 1, 21)
    sw = threshold_sweep(scores, truth, th)
    for i, t in enumerate(th):
        r = precision_recall_f(scores > t, truth)
        assert (sw.tp[i], sw.fp[i], sw.fn[i], sw.tn[i]) == (r.tp, r.fp, r.fn, r.tn)
        assert sw.f[i] == pytest.approx(r.f, nan_ok=True)
    assert np.all(np.diff(sw.recall) <= 0)  # raising the threshold never finds more positives
    assert np.all(np.diff(sw.tp + sw.fp) <= 0)
    assert np.all(sw.tp + sw.fn == truth.sum())
    i = int(np.argmax(sw.f))
    assert sw.best_threshold == th[i] and sw.best_f == sw.f[i]
    assert best_threshold(scores, truth, th) == (sw.best_threshold, sw.best_f)
    assert 0.3 < sw.best_threshold < 0.7
    # default thresholds: 0..1 in steps of 0.01
    assert threshold_sweep(scores, truth).thresholds.shape == (101,)
    with pytest.raises(ValueError, match="does not match truth shape"):
        threshold_sweep(scores[:, :5], truth)


def test_sweep_edge_cases():
    truth = np.array([True, False, True])
    sw = threshold_sweep(np.array([0.2, 0.4, np.nan]), truth, [0.0, 0.3, 2.0])
    assert sw.tp.tolist() == [1, 0, 0] and sw.fp.tolist() == [1, 1, 0]  # NaN never positive
    assert math.isnan(sw.precision[2]) and math.isnan(sw.f[2])
    # float32 scores are compared in float32, as torch's predictions are
    s32 = np.array([np.float32(0.1)], dtype=np.float32)
    sw = threshold_sweep(s32, np.array([True]), [0.1])
    assert sw.tp[0] == int((torch.tensor(s32) > 0.1).item()) == 0
    all_nan = threshold_sweep(np.zeros(3), np.zeros(3, bool), [0.5])
    assert math.isnan(all_nan.best_threshold) and all_nan.best_index == -1


def test_error_histogram():
    truth = np.array([[True, True, False, False]])
    scores = np.array([[0.75, 1.25, 0.5, -0.25]])
    h = error_histogram(scores, truth, bins=4, range=(-1.0, 1.0))
    # errors = truth - score = [0.25, -0.25, -0.5, 0.25]
    assert h.counts.tolist() == [0, 2, 2, 0]
    assert h.counts_reachable.tolist() == [0, 1, 1, 0]
    assert h.counts_unreachable.tolist() == [0, 1, 1, 0]
    assert h.n == 4 and h.mean == pytest.approx(-0.0625)
    np.testing.assert_allclose(h.centers, [-0.75, -0.25, 0.25, 0.75])
    h2 = error_histogram(torch.tensor([[0.5, np.inf]]), np.array([[True, False]]))
    assert h2.n == 1 and h2.n_nonfinite == 1 and h2.counts.sum() == 1 and len(h2.edges) == 21


# --------------------------------------------------------------------------------------------
# per-node outcomes, per-sample errors, curves over training sessions
# --------------------------------------------------------------------------------------------


def _hist(values, key="grad_norm"):
    h = History()
    for i, v in enumerate(values):
        h.epoch.append(i)
        h.time.append(0.1 * i)
        for k in ("loss", "grad_norm", "val_loss"):
            h.__getattribute__(k).append(v if k == key else 1.0 / (i + 1))
    return h


def test_session_curves_pads_stopped_sessions_with_nan():
    c = session_curves([_hist([3.0, 2.0, 1.0]), _hist([4.0, 5.0])], "grad_norm")
    assert c.shape == (2, 3)
    np.testing.assert_array_equal(c[0], [3, 2, 1])
    np.testing.assert_array_equal(c[1, :2], [4, 5])
    assert math.isnan(c[1, 2])
    with pytest.raises(ValueError):
        session_curves([], "loss")


def test_mean_band_statistics_ignore_stopped_sessions():
    mean, std, count = session_mean_std(np.array([[1.0, 2.0, 3.0], [3.0, 4.0, np.nan]]))
    np.testing.assert_allclose(mean, [2, 3, 3])
    np.testing.assert_allclose(std, [1, 1, 0])
    np.testing.assert_array_equal(count, [2, 2, 1])


def test_per_sample_error_counts_wrong_nodes():
    scores = np.array([[0.9, 0.1, 0.6, 0.5], [0.0, 0.0, 0.0, 0.0]], dtype=np.float32)
    truth = np.array([[1, 0, 0, 1], [0, 0, 0, 0]], dtype=bool)
    # 0.5 is not > 0.5: node 3 of sample 0 is a false negative, node 2 a false positive
    np.testing.assert_allclose(per_sample_error(scores, truth), [0.5, 0.0])
    np.testing.assert_allclose(per_sample_error(scores, truth, threshold=0.7), [0.25, 0.0])
    with pytest.raises(ValueError):
        per_sample_error(scores[:, :2], truth)


def test_outcomes_codes():
    pred = np.array([True, True, False, False])
    truth = np.array([True, False, True, False])
    np.testing.assert_array_equal(outcomes(pred, truth), [1, 2, 3, 0])
    with pytest.raises(ValueError):
        outcomes(pred, truth[:3])
