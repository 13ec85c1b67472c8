"""What every arm class shares: a batch of arms that has a length, is indexed like an array, and
checks joint coordinates the same way."""

from __future__ import annotations

import numpy as np

from .transforms import as_real_array, check_finite

__all__ = ["ArmBatch"]


class ArmBatch:
    """Mixin for robot classes with `n` joints and a `batch_shape` (`()` for one arm).

    Subclasses define `_select(idx)`, the arms `idx` of the batch (numpy indexing).
    """

    n: int

    @property
    def batch_shape(self) -> tuple[int, ...]:  # pragma: no cover - every subclass defines it
        raise NotImplementedError

    def __len__(self):
        if not self.batch_shape:
            raise TypeError("a single arm has no length; batch_shape is ()")
        return self.batch_shape[0]

    def __getitem__(self, idx):
        """Select arms of a batch (numpy indexing on the batch dimensions)."""
        if not self.batch_shape:
            raise TypeError("a single arm cannot be indexed")
        return self._select(idx)

    def _check_q(self, q) -> np.ndarray:
        """`q` as float64 `(..., n)`; a wrong last dimension, NaN, inf or complex is a `ValueError`."""
        q = as_real_array("joint coordinates", q)
        if q.ndim == 0 or q.shape[-1] != self.n:
            raise ValueError(f"joint coordinates must have a last dimension of {self.n}, got shape {q.shape}")
        check_finite("joint coordinates", q)
        return q
