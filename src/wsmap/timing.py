"""Wall-clock timing of repeated calls (the run-time comparison and the benchmarks use it)."""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["Timing", "time_call"]


@dataclass(frozen=True)
class Timing:
    """Wall-clock seconds of repeated calls: `mean`, `std` (sample std, ddof 1; 0 for one
    value) and the individual `values`."""

    mean: float
    std: float
    values: tuple[float, ...]

    @classmethod
    def from_values(cls, values: Sequence[float]) -> "Timing":
        v = np.asarray(values, dtype=np.float64)
        if v.ndim != 1 or v.size == 0:
            raise ValueError("a Timing needs at least one value")
        std = float(v.std(ddof=1)) if v.size > 1 else 0.0
        return cls(float(v.mean()), std, tuple(float(x) for x in v))

    @property
    def n(self) -> int:
        return len(self.values)

    @property
    def min(self) -> float:
        return min(self.values)

    def scaled(self, factor: float) -> "Timing":
        """Every value multiplied by `factor` (extrapolation from a sample)."""
        return Timing.from_values([x * factor for x in self.values])


def time_call(fn: Callable[[], Any], repeats: int = 10, warmup: int = 1,
              clock: Callable[[], float] = time.perf_counter) -> Timing:
    """Time `repeats` calls of `fn()` after `warmup` untimed calls; a `Timing`."""
    if isinstance(repeats, bool) or int(repeats) != repeats or repeats < 1:
        raise ValueError(f"repeats must be a positive integer, got {repeats!r}")
    if isinstance(warmup, bool) or int(warmup) != warmup or warmup < 0:
        raise ValueError(f"warmup must be a non-negative integer, got {warmup!r}")
    for _ in range(int(warmup)):
        fn()
    values = []
    for _ in range(int(repeats)):
        t0 = clock()
        fn()
        values.append(clock() - t0)
    return Timing.from_values(values)
