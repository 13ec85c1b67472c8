"""Arm-conditioned fields: the network shape the morphology and pose models share.

A field `f(arm, query) -> logit` whose arm enters once per arm and whose query (a point, or a pose)
enters once per query:

* an **encoder** MLP (SiLU) from the arm's inputs, standardised by the training set's mean and
  standard deviation (buffers `feature_mean`, `feature_std`; a constant column keeps unit scale),
  to a latent vector;
* a **decoder** MLP (SiLU) whose first layer is split in two: `dec_latent` (the latent's part,
  computed once per arm) plus the query's part (a bias-free linear layer named by the subclass,
  `QUERY_LAYER`, computed once per query), then one logit.

So a map of `P` queries of `B` arms costs `B` encoder passes and `P` (or `B·P`) query projections.
Positions enter with Fourier features (`fourier_features`): sines and cosines at octaves of π, so
that a small network can draw a sharp workspace boundary. Float32, as every network of the package.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import torch
from torch import nn

__all__ = ["fourier_features", "ArmConditionedField"]


def fourier_features(u: torch.Tensor, octaves: int) -> list[torch.Tensor]:
    """`[sin(π u), cos(π u), sin(2π u), cos(2π u), ...]`: `2 · octaves` tensors shaped as `u`.

    `u` is a position already divided by the model's box (so `[-1, 1]` inside it); octave `k`
    has angular frequency `2^k · π`."""
    parts = []
    for k in range(octaves):
        w = (2.0 ** k) * math.pi * u
        parts += [torch.sin(w), torch.cos(w)]
    return parts


class ArmConditionedField(nn.Module):
    """The encoder, split first decoder layer and standardisation of an arm-conditioned field.

    Subclasses call `_build(n_arm, n_query, config)` in their `__init__` (`config` has `encoder`,
    `latent` and `decoder` widths) and set `QUERY_LAYER`, the attribute name of the query's
    projection (the name is part of the saved state dict, so it stays what the model files hold).
    The modules are created in one fixed order (encoder, `dec_latent`, the query layer, decoder),
    so a seeded model initialises to the same weights whatever subclass builds it.
    """

    #: the attribute name of the query projection (`nn.Linear(n_query, decoder[0], bias=False)`)
    QUERY_LAYER = "dec_query"

    def _build(self, n_arm: int, n_query: int, config: Any) -> None:
        self.n_arm_inputs = int(n_arm)
        layers, width = [], n_arm
        for h in config.encoder:
            layers += [nn.Linear(width, h), nn.SiLU()]
            width = h
        layers.append(nn.Linear(width, config.latent))
        self.encoder = nn.Sequential(*layers)
        first = config.decoder[0]
        self.dec_latent = nn.Linear(config.latent, first)
        setattr(self, self.QUERY_LAYER, nn.Linear(n_query, first, bias=False))
        rest, width = [], first
        for h in config.decoder[1:]:
            rest += [nn.SiLU(), nn.Linear(width, h)]
            width = h
        rest += [nn.SiLU(), nn.Linear(width, 1)]
        self.decoder = nn.Sequential(*rest)
        self.register_buffer("feature_mean", torch.zeros(n_arm))
        self.register_buffer("feature_std", torch.ones(n_arm))

    def query_projection(self, features: torch.Tensor) -> torch.Tensor:
        """The decoder's first layer applied to query features `(..., n_query)` -> `(..., H)`."""
        return getattr(self, self.QUERY_LAYER)(features)

    def standardise_on(self, X: Any) -> ArmConditionedField:
        """Set the arm inputs' standardisation from training rows `(n, >= n_arm)` (the first
        `n_arm` columns; float64 statistics; a column with standard deviation <= 1e-8, or a
        single row, keeps unit scale). Returns the model."""
        X = torch.as_tensor(np.asarray(X)[:, :self.n_arm_inputs], dtype=torch.float64)
        std = X.std(dim=0) if len(X) > 1 else torch.ones(self.n_arm_inputs, dtype=torch.float64)
        self.feature_mean.copy_(X.mean(dim=0).to(self.feature_mean.dtype))
        self.feature_std.copy_(torch.where(std > 1e-8, std, torch.ones_like(std)).to(self.feature_std.dtype))
        return self

    def encode(self, A: torch.Tensor) -> torch.Tensor:
        """Latent vectors `(B, latent)` of arm inputs `(B, n_arm)`."""
        return self.encoder((A - self.feature_mean) / self.feature_std)
