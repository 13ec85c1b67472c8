"""Scores of binary workspace maps: confusion counts, precision / recall / F-measure, per-node
outcomes and per-sample errors, threshold sweeps, the prediction-error histogram, and the statistics
of training curves over sessions (what the figures of `wsmap.viz` draw).

Conventions
-----------
* Maps are bool arrays `(samples, nodes)` (any shape for pooled counts), numpy or torch;
  integer/float arrays holding only 0 and 1 are accepted as bool. `pred` and `truth` must
  have the same shape.
* Positive = reachable (1). `P = tp / (tp + fp)`, `R = tp / (tp + fn)`,
  `F = 2 P R / (P + R)`.
* `average="micro"` pools the counts over every sample and node (the paper's F-measure, on a
  1000-sample test set); `average="samples"` computes P, R, F per sample (row) and reports
  their mean and standard deviation over the samples where they are defined.
* Undefined cases: precision with no predicted positive (`tp + fp == 0`) and recall with no
  true positive (`tp + fn == 0`) are 0/0; they become `zero_division` -- `"nan"` (default;
  the paper printed NaN), `0` or `1`. F is NaN when P or R is NaN, 0 when `P + R == 0`
  (both defined and zero: no true positive at all, the limit of `2tp / (2tp + fp + fn)`),
  else `2PR / (P + R)`. With `zero_division=1` an all-negative sample predicted all negative
  scores P = R = F = 1.
* Scores (raw network outputs, or sigmoid of logits) are thresholded as the models do: a node is
  predicted reachable when `score > threshold` (strict; NaN scores are never positive). For
  float32 scores the thresholds are rounded to float32 first, so the comparison is exactly
  `torch`'s `score > threshold` on the float32 tensor.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any, NamedTuple

import numpy as np

__all__ = [
    "Confusion",
    "PRF",
    "Sweep",
    "ErrorHistogram",
    "confusion",
    "precision_recall_f",
    "threshold_sweep",
    "best_threshold",
    "error_histogram",
    "score_maps",
    "OUTCOME_NAMES",
    "outcomes",
    "per_sample_error",
    "session_curves",
    "session_mean_std",
]


# --------------------------------------------------------------------------------------------
# Input handling
# --------------------------------------------------------------------------------------------


def _to_numpy(a) -> np.ndarray:
    if hasattr(a, "detach") and hasattr(a, "cpu"):  # torch tensor, without importing torch
        a = a.detach().cpu().numpy()
    return np.asarray(a)


def _as_bool(a, name: str) -> np.ndarray:
    a = _to_numpy(a)
    if a.dtype == np.bool_:
        return a
    if a.dtype.kind in "iuf":
        ok = (a == 0) | (a == 1)
        if not ok.all():
            raise ValueError(f"{name} must be boolean (or 0/1); got values other than 0 and 1 "
                             "(threshold scores first)")
        return a.astype(bool)
    raise ValueError(f"{name} must be boolean (or 0/1); got dtype {a.dtype}")


def _pair(pred, truth, names=("pred", "truth")) -> tuple[np.ndarray, np.ndarray]:
    p, t = _as_bool(pred, names[0]), _as_bool(truth, names[1])
    if p.shape != t.shape:
        raise ValueError(f"{names[0]} shape {p.shape} does not match {names[1]} shape {t.shape}")
    return p, t


def _zero_division_value(zero_division) -> float:
    if isinstance(zero_division, str):
        if zero_division.lower() == "nan":
            return math.nan
    elif not isinstance(zero_division, bool) and zero_division in (0, 1):
        return float(zero_division)
    raise ValueError(f"zero_division must be 'nan', 0 or 1; got {zero_division!r}")


def _ratio(num, den, fill: float):
    num = np.asarray(num, dtype=np.float64)
    den = np.asarray(den, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.where(den > 0, num / np.where(den > 0, den, 1.0), fill)
    return out


def _f_from(p, r):
    p = np.asarray(p, dtype=np.float64)
    r = np.asarray(r, dtype=np.float64)
    s = p + r
    with np.errstate(divide="ignore", invalid="ignore"):
        f = np.where(s > 0, 2 * p * r / np.where(s > 0, s, 1.0), 0.0)
    return np.where(np.isnan(p) | np.isnan(r), np.nan, f)


# --------------------------------------------------------------------------------------------
# Confusion counts and P / R / F
# --------------------------------------------------------------------------------------------


class Confusion(NamedTuple):
    """Counts of true/false positives/negatives: ints (pooled) or int64 arrays (per row)."""

    tp: Any
    fp: Any
    fn: Any
    tn: Any


def confusion(pred, truth, axis: int | tuple[int, ...] | None = None) -> Confusion:
    """`(tp, fp, fn, tn)` of bool maps `pred` vs `truth` (same shape).

    `axis=None`: pooled over every element (Python ints). Otherwise counted along `axis`
    (e.g. `axis=1` on `(samples, nodes)` gives per-sample int64 arrays).

    Raises
    ------
    ValueError
        shapes differ (both are named), or values are not boolean / 0-1.
    """
    p, t = _pair(pred, truth)
    counts = [np.count_nonzero(m, axis=axis) for m in (p & t, p & ~t, ~p & t, ~p & ~t)]
    if axis is None:
        return Confusion(*(int(c) for c in counts))
    return Confusion(*(np.asarray(c, dtype=np.int64) for c in counts))


@dataclass
class PRF:
    """Precision, recall and F-measure.

    `average="micro"`: `precision`, `recall`, `f` from the pooled `tp, fp, fn, tn`;
    the `*_std` are NaN and `undefined_*` are 0 or 1 (whether the pooled value is 0/0).

    `average="samples"`: `precision`, `recall`, `f` are means over the samples where the
    value is defined (not NaN; with `zero_division` 0 or 1 every sample is), `*_std` their
    standard deviations (`ddof`), `undefined_*` how many samples had NaN, `n_samples` the
    sample count; `per_sample` holds the `(samples,)` arrays `precision`, `recall`,
    `f`. The pooled `tp, fp, fn, tn` are filled in both cases.
    """

    precision: float
    recall: float
    f: float
    average: str
    tp: int
    fp: int
    fn: int
    tn: int
    n_samples: int
    precision_std: float = math.nan
    recall_std: float = math.nan
    f_std: float = math.nan
    undefined_precision: int = 0
    undefined_recall: int = 0
    undefined_f: int = 0
    per_sample: dict[str, np.ndarray] | None = field(default=None, repr=False)

    def to_dict(self) -> dict[str, Any]:
        """Plain dict (JSON friendly; `per_sample` left out, NaN stays `float('nan')`)."""
        d = asdict(self)
        d.pop("per_sample")
        return d


def precision_recall_f(pred, truth, average: str = "micro", *, zero_division="nan", ddof: int = 1) -> PRF:
    """Precision, recall and F-measure of bool maps `pred` vs `truth`.

    Parameters
    ----------
    pred, truth
        bool `(samples, nodes)` (any shape for `"micro"`; for `"samples"`
        the first axis is the sample and the others are pooled per sample).
    average
        `"micro"` (pool every sample and node: the paper's) or `"samples"`
        (per sample, then mean and std).
    zero_division
        value of an undefined precision/recall: `"nan"` (default), `0` or
        `1` (module docstring for F).
    ddof
        delta degrees of freedom of the `"samples"` standard deviations (default 1,
        MATLAB's `std`); with fewer than `ddof + 1` defined samples the std is NaN.

    Returns
    -------
    PRF
        Precision, recall and F-measure, averaged as `average` says.
    """
    fill = _zero_division_value(zero_division)
    p, t = _pair(pred, truth)
    if average == "micro":
        c = confusion(p, t)
        prec = float(_ratio(c.tp, c.tp + c.fp, fill))
        rec = float(_ratio(c.tp, c.tp + c.fn, fill))
        f = float(_f_from(prec, rec))
        n = int(p.shape[0]) if p.ndim else 1
        return PRF(prec, rec, f, "micro", *c, n_samples=n,
                   undefined_precision=int(math.isnan(prec)), undefined_recall=int(math.isnan(rec)),
                   undefined_f=int(math.isnan(f)))
    if average != "samples":
        raise ValueError(f"average must be 'micro' or 'samples'; got {average!r}")
    if p.ndim < 2:
        raise ValueError(f"average='samples' needs (samples, nodes) maps; got shape {p.shape}")
    axes = tuple(range(1, p.ndim))
    c = confusion(p, t, axis=axes)
    prec = _ratio(c.tp, c.tp + c.fp, fill)
    rec = _ratio(c.tp, c.tp + c.fn, fill)
    f = _f_from(prec, rec)

    def mean_std(v):
        ok = v[~np.isnan(v)]
        mean = float(ok.mean()) if ok.size else math.nan
        std = float(ok.std(ddof=ddof)) if ok.size > ddof else math.nan
        return mean, std, int(v.size - ok.size)

    (pm, ps, pu), (rm, rs, ru), (fm, fs, fu) = mean_std(prec), mean_std(rec), mean_std(f)
    pooled = Confusion(*(int(x.sum()) for x in c))
    return PRF(pm, rm, fm, "samples", *pooled, n_samples=int(p.shape[0]),
               precision_std=ps, recall_std=rs, f_std=fs,
               undefined_precision=pu, undefined_recall=ru, undefined_f=fu,
               per_sample={"precision": prec, "recall": rec, "f": f})


# --------------------------------------------------------------------------------------------
# Threshold sweep
# --------------------------------------------------------------------------------------------


def score_maps(pred, truth) -> dict[str, Any]:
    """Precision, recall and F of predicted maps against labels, both bool `(n, N)`: pooled over
    every arm and node (`precision`, `recall`, `f`: the paper's F-measure) and per arm
    (`f_mean`, `f_std` over arms whose F is defined; `f_undefined` the others;
    `f_per_sample`), with the confusion counts (`tp`, `fp`, `fn`) and the share of nodes
    that differ (`node_error`)."""
    micro = precision_recall_f(pred, truth, "micro")
    per = precision_recall_f(pred, truth, "samples")
    c = confusion(pred, truth)
    pred = np.asarray(pred)
    return dict(precision=micro.precision, recall=micro.recall, f=micro.f, f_mean=per.f, f_std=per.f_std,
                f_undefined=per.undefined_f, f_per_sample=per.per_sample["f"], tp=int(c.tp), fp=int(c.fp),
                fn=int(c.fn), node_error=float((c.fp + c.fn) / pred.size), samples=int(pred.shape[0]),
                nodes=int(pred.shape[1]))


def _scores(scores, name="scores") -> np.ndarray:
    s = _to_numpy(scores)
    if s.dtype.kind not in "iuf" and s.dtype != np.bool_:
        raise ValueError(f"{name} must be numeric; got dtype {s.dtype}")
    return s


def _thresholds_like(thresholds, s: np.ndarray) -> np.ndarray:
    th = np.asarray(thresholds, dtype=np.float64).ravel()
    if s.dtype == np.float32 or s.dtype == np.float16:
        th = th.astype(s.dtype).astype(np.float64)  # compare as the model does, in the scores' precision
    return th


@dataclass
class Sweep:
    """Pooled (micro) P/R/F per threshold, prediction `score > threshold`.

    Arrays `(T,)`: `thresholds` (as given, float64), `precision`, `recall`, `f`, and
    the counts `tp`, `fp`, `fn`, `tn`. `best_threshold`/`best_f`/`best_index`: the
    threshold with the highest F (NaN F ignored; ties: the first in the given order); NaN/-1
    when every F is NaN.
    """

    thresholds: np.ndarray
    precision: np.ndarray
    recall: np.ndarray
    f: np.ndarray
    tp: np.ndarray
    fp: np.ndarray
    fn: np.ndarray
    tn: np.ndarray

    @property
    def best_index(self) -> int:
        if np.all(np.isnan(self.f)):
            return -1
        return int(np.nanargmax(self.f))

    @property
    def best_threshold(self) -> float:
        i = self.best_index
        return math.nan if i < 0 else float(self.thresholds[i])

    @property
    def best_f(self) -> float:
        i = self.best_index
        return math.nan if i < 0 else float(self.f[i])

    def to_dict(self) -> dict[str, Any]:
        d = {k: getattr(self, k).tolist() for k in ("thresholds", "precision", "recall", "f", "tp", "fp", "fn", "tn")}
        d.update(best_threshold=self.best_threshold, best_f=self.best_f)
        return d


def threshold_sweep(scores, truth, thresholds=None, *, zero_division="nan") -> Sweep:
    """Micro P/R/F of `score > t` for every threshold `t`, vectorised.

    Parameters
    ----------
    scores
        `(samples, nodes)` (any shape) raw outputs or probabilities.
    truth
        bool, same shape.
    thresholds
        1-D thresholds; default `linspace(0, 1, 101)` (the authors swept 0..1).
    zero_division
        as in `precision_recall_f`.

    Notes
    -----
    One sort of the scores per class and a binary search per threshold:
    `O(N log N + T log N)` for `N` scores and `T` thresholds.
    """
    fill = _zero_division_value(zero_division)
    s = _scores(scores)
    t = _as_bool(truth, "truth")
    if s.shape != t.shape:
        raise ValueError(f"scores shape {s.shape} does not match truth shape {t.shape}")
    th = _thresholds_like(np.linspace(0.0, 1.0, 101) if thresholds is None else thresholds, s)
    given = np.asarray(np.linspace(0.0, 1.0, 101) if thresholds is None else thresholds, dtype=np.float64).ravel()
    s = s.astype(np.float64, copy=False).ravel()
    t = t.ravel()
    s = np.where(np.isnan(s), -np.inf, s)  # NaN is never "> t", like the models' predictions
    pos, neg = np.sort(s[t]), np.sort(s[~t])
    tp = pos.size - np.searchsorted(pos, th, side="right")
    fp = neg.size - np.searchsorted(neg, th, side="right")
    # A NaN threshold predicts nothing (every comparison is False).
    tp = np.where(np.isnan(th), 0, tp).astype(np.int64)
    fp = np.where(np.isnan(th), 0, fp).astype(np.int64)
    fn = pos.size - tp
    tn = neg.size - fp
    prec = _ratio(tp, tp + fp, fill)
    rec = _ratio(tp, tp + fn, fill)
    return Sweep(given, prec, rec, _f_from(prec, rec), tp, fp, fn, tn)


def best_threshold(scores, truth, thresholds=None, *, zero_division="nan") -> tuple[float, float]:
    """`(threshold, F)` maximising the micro F of `score > threshold` (see `Sweep`)."""
    sw = threshold_sweep(scores, truth, thresholds, zero_division=zero_division)
    return sw.best_threshold, sw.best_f


# --------------------------------------------------------------------------------------------
# Error histogram
# --------------------------------------------------------------------------------------------


@dataclass
class ErrorHistogram:
    """Histogram of `error = truth - score` (MATLAB `ploterrhist`'s "Errors = Targets -
    Outputs").

    `edges` `(bins + 1,)`, `counts` `(bins,)` over all errors; `counts_reachable` /
    `counts_unreachable` split them by the true label (they sum to `counts`). `n`, `mean`,
    `std` (ddof 0) of the errors; `n_nonfinite` errors left out (NaN/inf scores).
    """

    edges: np.ndarray
    counts: np.ndarray
    counts_reachable: np.ndarray
    counts_unreachable: np.ndarray
    n: int
    mean: float
    std: float
    n_nonfinite: int = 0

    @property
    def centers(self) -> np.ndarray:
        return 0.5 * (self.edges[:-1] + self.edges[1:])

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        for k in ("edges", "counts", "counts_reachable", "counts_unreachable"):
            d[k] = d[k].tolist()
        return d


def error_histogram(scores, truth, bins=20, range: tuple[float, float] | None = None) -> ErrorHistogram:
    """Histogram of prediction errors `truth - score` (truth as 0/1) for the paper's
    "Histogram of prediction errors" figure.

    Parameters
    ----------
    scores
        raw outputs (or probabilities), any shape; truth: bool, same shape.
    bins
        number of bins (default 20, as MATLAB's `ploterrhist`) or explicit edges.
    range
        `(lo, hi)` of the bins; default the finite errors' min and max.
    """
    s = _scores(scores)
    t = _as_bool(truth, "truth")
    if s.shape != t.shape:
        raise ValueError(f"scores shape {s.shape} does not match truth shape {t.shape}")
    err = t.ravel().astype(np.float64) - s.astype(np.float64, copy=False).ravel()
    label = t.ravel()
    finite = np.isfinite(err)
    n_bad = int(err.size - np.count_nonzero(finite))
    if n_bad:
        err, label = err[finite], label[finite]
    if err.size == 0 and range is None and np.ndim(bins) == 0:
        range = (-1.0, 1.0)  # np.histogram needs a range for no data
    counts, edges = np.histogram(err, bins=bins, range=range)
    reach, _ = np.histogram(err[label], bins=edges)
    unreach, _ = np.histogram(err[~label], bins=edges)
    return ErrorHistogram(edges, counts, reach, unreach, int(err.size),
                          float(err.mean()) if err.size else math.nan,
                          float(err.std()) if err.size else math.nan, n_bad)


# --------------------------------------------------------------------------------------------
# Per-node outcomes and per-sample errors
# --------------------------------------------------------------------------------------------

#: `outcomes` codes 0..3 and their names.
OUTCOME_NAMES = ("true negative", "true positive", "false positive", "false negative")


def outcomes(pred, truth) -> np.ndarray:
    """Per-element outcome codes (uint8) of a prediction against the truth (same shape, read as
    bool): 0 true negative, 1 true positive, 2 false positive, 3 false negative (`OUTCOME_NAMES`)."""
    p, t = _to_numpy(pred), _to_numpy(truth)
    if p.shape != t.shape:
        raise ValueError(f"prediction shape {p.shape} does not match truth shape {t.shape}")
    p, t = p.astype(bool), t.astype(bool)
    out = np.zeros(p.shape, dtype=np.uint8)
    out[p & t] = 1
    out[p & ~t] = 2
    out[~p & t] = 3
    return out


def per_sample_error(scores, truth, threshold: float = 0.5) -> np.ndarray:
    """Fraction of each sample's nodes predicted wrongly (`score > threshold` against the
    truth), `(samples,)` float64: the error of each prediction on a test set. `scores` and
    `truth` are `(samples, nodes)`."""
    s = _to_numpy(scores)
    t = np.asarray(_to_numpy(truth), dtype=bool)
    if s.shape != t.shape or s.ndim != 2:
        raise ValueError(f"scores and truth must both be (samples, nodes); got {s.shape} and {t.shape}")
    pred = s > np.asarray(threshold, dtype=s.dtype if s.dtype.kind == "f" else np.float64)
    return np.mean(pred != t, axis=1, dtype=np.float64)


# --------------------------------------------------------------------------------------------
# Curves over training sessions
# --------------------------------------------------------------------------------------------


def session_curves(histories, key: str) -> np.ndarray:
    """`(sessions, epochs)` float64 matrix of `history.<key>` (`loss`, `grad_norm`,
    `val_loss`, `test_loss`, `time`) of single-session histories
    (`wsmap.learn.training.History`), padded with NaN after a session that stopped early
    (epochs = the longest history)."""
    rows = [np.asarray(getattr(h, key), dtype=np.float64).reshape(-1) for h in histories]
    if not rows:
        raise ValueError("session_curves needs at least one history")
    if any(r.ndim != 1 for r in rows):
        raise ValueError(f"history.{key} must be one value per epoch (single-session histories)")
    n = max(len(r) for r in rows)
    out = np.full((len(rows), n), np.nan)
    for i, r in enumerate(rows):
        out[i, : len(r)] = r
    return out


def session_mean_std(curves) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per epoch (column) of `curves` `(sessions, epochs)` (NaN: the session had stopped): the
    mean, the population standard deviation (0 with one session) and the number of sessions
    present, each `(epochs,)`; NaN mean and deviation where no session is present."""
    curves = np.atleast_2d(np.asarray(curves, dtype=np.float64))
    count = np.sum(np.isfinite(curves), axis=0)
    safe = np.where(np.isfinite(curves), curves, 0.0)
    mean = np.where(count > 0, safe.sum(0) / np.maximum(count, 1), np.nan)
    dev = np.where(np.isfinite(curves), curves - mean, 0.0)
    std = np.where(count > 0, np.sqrt((dev**2).sum(0) / np.maximum(count, 1)), np.nan)
    return mean, std, count
