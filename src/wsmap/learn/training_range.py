"""What a model was trained on: the range of every input feature, and the check that refuses arms outside it.

A network trained on a family of arms (the paper's: the spherical-wrist arms with `d3, d4, a2, a3
~ U(0, 0.5)` m, every other DH parameter fixed) says nothing reliable about an arm outside that
family; it still returns a map, which looks as plausible as any other. `TrainingRange`
records, per stored feature (`d_1..d_6, a_1..a_6, alpha_1..alpha_6`, the grid axes, the fixed
orientation or point), the minimum and maximum over the training arms; a feature whose minimum
equals its maximum is *fixed* in the family (e.g. `d_1 = 0` and every twist of the PUMA-like
family). The record travels with the model (`wsmap.learn.network.SubspaceMLP.training_range`,
set by `configure` from the training features) and is saved
in the model file (`wsmap.learn.files`).

`TrainingRange.check` is what `predict_maps` runs on the features of the arms it is asked
to map: a value more than the tolerance `RANGE_ATOL + RANGE_RTOL·(max − min)` outside
`[min, max]` raises `ExtrapolationError` (a `ValueError`) naming the parameter, the
arm's value and the trained range; `allow_extrapolation=True` lets it through with an
`ExtrapolationWarning` instead. The relative tolerance (2 % of the trained width) absorbs the
gap between the sample minimum/maximum and the family's bounds (about `width/n` for `n`
uniform training arms, so arms drawn from the same family pass); the absolute one (1e-6 m or rad)
absorbs rounding of a fixed parameter (`pi/2` typed as a float expression).
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..io import check_record
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap._typing import ArrayLike

__all__ = [
    "RANGE_RTOL",
    "RANGE_ATOL",
    "TrainingRange",
    "ExtrapolationError",
    "ExtrapolationWarning",
]

#: Tolerance of `TrainingRange.check`, relative to the trained width `max - min` ...
RANGE_RTOL = 0.02
#: ... plus this absolute part (metres or radians), which is all a fixed feature gets.
RANGE_ATOL = 1e-6


class ExtrapolationError(ValueError):
    """Arms outside the range a model was trained on (or a model that does not record one)."""


class ExtrapolationWarning(UserWarning):
    """A model was asked, with `allow_extrapolation=True`, for maps of arms outside its training range."""


def _fmt(v: float) -> str:
    return f"{v:.6g}"


class TrainingRange:
    """Per-feature `[low, high]` of a model's training inputs (float64 `(n_features,)` each).

    Parameters
    ----------
    low, high
        the minimum and maximum of each stored feature over the training arms.
    names
        optional feature names (`wsmap.datasets.feature_names(spec)`: `d_1`, ..., `r_3`).
    samples
        how many training rows the range was taken from (`None`: unknown).

    Notes
    -----
    Immutable; compare with `==`. `to_dict` / `from_dict` give the plain form stored
    in model files, which also lists the fixed features (`low == high`) and their values.
    """

    __slots__ = ("_low", "_high", "_names", "_samples")

    def __init__(self, low: ArrayLike, high: ArrayLike, names: Sequence[str] | None = None, samples: int | None = None):
        try:
            low, high = np.array(low, dtype=np.float64), np.array(high, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError("a training range needs low and high as arrays of numbers") from None
        if low.ndim != 1 or low.shape != high.shape or low.size == 0:
            raise ValueError("a training range needs low and high as two non-empty 1-D arrays of equal length")
        if not (np.isfinite(low).all() and np.isfinite(high).all()):
            raise ValueError("a training range must be finite (the training features contained NaN or inf)")
        bad = np.flatnonzero(low > high)
        if bad.size:
            raise ValueError(f"a training range needs low <= high; feature(s) {bad[:5].tolist()} have low > high")
        if names is not None:
            names = tuple(names)
            if len(names) != low.size or not all(isinstance(n, str) and n for n in names):
                raise ValueError(f"training range names must be {low.size} non-empty strings; got {len(names)}")
        if samples is not None:
            if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or samples < 1:
                raise ValueError(f"training range samples must be a positive integer or None; got {samples!r}")
            samples = int(samples)
        low.setflags(write=False)
        high.setflags(write=False)
        self._low, self._high, self._names, self._samples = low, high, names, samples

    # ------------------------------------------------------------------ construction

    @classmethod
    def from_features(cls, features, names: Sequence[str] | None = None) -> TrainingRange:
        """The min/max per column of training features `(n, f)` (numpy or torch), `n >= 1`, finite."""
        if hasattr(features, "detach"):
            features = features.detach().cpu().numpy()
        try:
            x = np.asarray(features, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError(f"training data must be features (n, f) (numbers), a dataset with .features or a "
                             f"TrainingRange; got {type(features).__name__}") from None
        if x.ndim != 2 or x.shape[0] == 0 or x.shape[1] == 0:
            raise ValueError(f"a training range needs features (n, f) with n >= 1; got shape {x.shape}")
        finite = np.isfinite(x)
        if not finite.all():
            rows = np.flatnonzero(~finite.all(axis=1))
            cols = np.flatnonzero(~finite.all(axis=0))
            raise ValueError(f"training features contain NaN or infinite values (rows {rows[:5].tolist()}, "
                             f"columns {cols[:5].tolist()})")
        return cls(x.min(axis=0), x.max(axis=0), names, x.shape[0])

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> TrainingRange:
        """Inverse of `to_dict` (`fixed` is checked against `low`/`high`)."""
        check_record(d, {"low", "high", "names", "samples", "fixed"}, "a training range", "training range")
        if "low" not in d or "high" not in d:
            raise ValueError("a training range needs 'low' and 'high'")
        for k in ("low", "high"):
            v = d[k]
            if not isinstance(v, (list, tuple)) or not all(
                    isinstance(x, (int, float)) and not isinstance(x, bool) for x in v):
                raise ValueError(f"training range {k} must be a list of numbers")
        out = cls(d["low"], d["high"], d.get("names"), d.get("samples"))
        if "fixed" in d and d["fixed"] is not None and d["fixed"] != out.to_dict()["fixed"]:
            raise ValueError("training range 'fixed' does not match its low/high")
        return out

    def with_names(self, names: Sequence[str] | None) -> TrainingRange:
        return TrainingRange(self._low, self._high, names, self._samples)

    # ------------------------------------------------------------------ views

    @property
    def low(self) -> np.ndarray:
        return self._low

    @property
    def high(self) -> np.ndarray:
        return self._high

    @property
    def names(self) -> tuple[str, ...] | None:
        return self._names

    @property
    def samples(self) -> int | None:
        return self._samples

    @property
    def n_features(self) -> int:
        return int(self._low.size)

    def name(self, j: int) -> str:
        return self._names[j] if self._names is not None else f"feature {j}"

    @property
    def fixed(self) -> dict[str, float]:
        """Features that have one value in the whole training set: `{name: value}`."""
        return {self.name(int(j)): float(self._low[j]) for j in np.flatnonzero(self._low == self._high)}

    def tolerance(self) -> np.ndarray:
        """Per-feature tolerance of `check`: `RANGE_ATOL + RANGE_RTOL * (high - low)`."""
        return RANGE_ATOL + RANGE_RTOL * (self._high - self._low)

    def to_dict(self) -> dict[str, Any]:
        """Plain form: `low`, `high` (lists of floats), `names` (or `None`), `samples`,
        `fixed` (`{name: value}` of the features with `low == high`)."""
        return {"names": None if self._names is None else list(self._names), "low": self._low.tolist(),
                "high": self._high.tolist(), "samples": self._samples, "fixed": self.fixed}

    def __eq__(self, other) -> bool:
        if not isinstance(other, TrainingRange):
            return NotImplemented
        return (np.array_equal(self._low, other._low) and np.array_equal(self._high, other._high)
                and self._names == other._names and self._samples == other._samples)

    __hash__ = None

    def __repr__(self) -> str:
        return (f"TrainingRange({self.n_features} features, {len(self.fixed)} fixed, "
                f"samples={self._samples})")

    # ------------------------------------------------------------------ combining

    def intersect(self, other: TrainingRange) -> TrainingRange | None:
        """Where both ranges hold (the domain of a stack of models); `None` when empty in a feature."""
        if self.n_features != other.n_features:
            raise ValueError(f"training ranges of {self.n_features} and {other.n_features} features do not combine")
        low, high = np.maximum(self._low, other._low), np.minimum(self._high, other._high)
        if np.any(low > high):
            return None
        names = self._names if self._names == other._names else None
        samples = min(self._samples, other._samples) if self._samples and other._samples else None
        return TrainingRange(low, high, names, samples)

    # ------------------------------------------------------------------ the check

    def outside(self, features: ArrayLike) -> np.ndarray:
        """Bool `(n, f)`: where `features` lie outside the range by more than the tolerance
        (non-finite values count as outside)."""
        x = np.asarray(features, dtype=np.float64)
        if x.ndim != 2 or x.shape[1] != self.n_features:
            raise ValueError(f"features must be (n, {self.n_features}) to check against the training range; "
                             f"got shape {x.shape}")
        tol = self.tolerance()
        return ~((x >= self._low - tol) & (x <= self._high + tol))

    def describe_violations(self, features: ArrayLike, names: Sequence[str] | None = None, limit: int = 4
                           ) -> str | None:
        """A sentence naming up to `limit` features (first offending arm of each) outside the range,
        or `None` when every value is inside."""
        x = np.asarray(features, dtype=np.float64)
        bad = self.outside(x)
        if not bad.any():
            return None
        names = tuple(names) if names is not None else None
        label = (lambda j: names[j]) if names is not None and len(names) == self.n_features else self.name
        cols = np.flatnonzero(bad.any(axis=0))
        parts = []
        for j in cols[:limit]:
            i = int(np.flatnonzero(bad[:, j])[0])
            v, lo, hi = float(x[i, j]), float(self._low[j]), float(self._high[j])
            who = f"arm {i}: " if x.shape[0] > 1 else ""
            if lo == hi:
                parts.append(f"{who}{label(j)} = {_fmt(v)}, but {label(j)} is fixed at {_fmt(lo)} in the training arms")
            else:
                parts.append(f"{who}{label(j)} = {_fmt(v)} is outside the trained range [{_fmt(lo)}, {_fmt(hi)}]")
        more = f" (and {cols.size - limit} more parameters)" if cols.size > limit else ""
        n_arms = int(bad.any(axis=1).sum())
        arms = f"{n_arms} of {x.shape[0]} arms are" if x.shape[0] > 1 else "the arm is"
        return f"{arms} outside its training range: " + "; ".join(parts) + more

    def check(self, features: ArrayLike, *, names: Sequence[str] | None = None, allow_extrapolation: bool = False,
              what: str = "the model") -> None:
        """Raise `ExtrapolationError` if any row of `features` `(n, f)` lies outside the
        range (beyond `tolerance`); with `allow_extrapolation` warn
        (`ExtrapolationWarning`) instead."""
        problem = self.describe_violations(features, names)
        if problem is None:
            return
        if allow_extrapolation:
            warnings.warn(f"{what}: {problem}. Predicting anyway (allow_extrapolation=True): these maps are "
                          "extrapolations and may be wrong anywhere.", ExtrapolationWarning, stacklevel=4)
            return
        raise ExtrapolationError(f"{what} refuses: {problem}. (Values within {RANGE_RTOL:.0%} of a "
                                 f"trained width, or {RANGE_ATOL:g} of a fixed value, count as inside.) Its maps "
                                 "there would be extrapolations: use the classical map (method exact/numerical), "
                                 "or pass allow_extrapolation=True (--allow-extrapolation) to predict anyway.")


def check_no_range(allow_extrapolation: bool, what: str = "the model") -> None:
    """The rule for a model without a recorded training range: refuse unless `allow_extrapolation`."""
    message = (f"{what} records no training range (it was neither configured on training features nor saved "
               "with training_data), so it cannot tell whether an arm belongs to the family it was trained on")
    if not allow_extrapolation:
        raise ExtrapolationError(message + ". Set one with model.set_training_range(training_features) and "
                                 "re-save it, or pass allow_extrapolation=True to predict anyway.")
    warnings.warn(message + "; predicting anyway (allow_extrapolation=True).", ExtrapolationWarning, stacklevel=4)

