"""Weight initialisation of the subspace networks: MATLAB's `initnw` (Nguyen–Widrow), `rands`, torch's default.

The paper's networks are MATLAB `feedforwardnet`s, whose default layer initialisation is
`initnw`: hidden (`tansig`) layers get Nguyen–Widrow weights computed from their input ranges
(`nguyen_widrow_`), the linear output layer gets `rands` (`matlab_rands_`, uniform on
`[-1, 1]`: `initnw` falls back to it for a transfer function with an unbounded active input
range such as `purelin`). `torch_default_` is PyTorch's `nn.Linear` default
(`U(-1/sqrt(fan_in), 1/sqrt(fan_in))` for weights and biases), used by `init="torch"`.

Each initialiser works in place on an `nn.Linear` or on the stacked layout of
`wsmap.learn.network.SubspaceMLP` (weights `(in, out)` or `(S, in, out)`, biases
`(out,)` or `(S, out)`), draws in float64 from an optional `torch.Generator` and returns
`(weight, bias)`.
"""

from __future__ import annotations

import math

import numpy as np
import torch
from torch import nn
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap._typing import ArrayLike

__all__ = ["nguyen_widrow_", "matlab_rands_", "torch_default_", "to_numpy", "input_range_array"]


def to_numpy(a) -> np.ndarray:
    """`a` as a numpy array: a tensor detached and copied to the CPU, anything else through
    `numpy.asarray` (same shape and dtype)."""
    return a.detach().cpu().numpy() if isinstance(a, torch.Tensor) else np.asarray(a)


def input_range_array(input_range, n_in: int) -> np.ndarray:
    """The range of each of a layer's `n_in` inputs as rows `[min, max]`.

    Parameters
    ----------
    input_range : array_like or tensor, shape (n_in, 2) or (2,), or None
        Per input, or one `[min, max]` for all; None: `[-1, 1]` for all.
    n_in : int
        Number of inputs.

    Returns
    -------
    numpy.ndarray, shape (n_in, 2), float64

    Raises
    ------
    ValueError
        Another shape, or a row with `min > max`.
    """
    if input_range is None:
        return np.tile([-1.0, 1.0], (n_in, 1))
    pr = np.asarray(to_numpy(input_range), dtype=np.float64)
    if pr.shape == (2,):
        pr = np.tile(pr, (n_in, 1))
    if pr.shape != (n_in, 2):
        raise ValueError(f"input_range must be (in, 2) = ({n_in}, 2) or (2,); got shape {pr.shape}")
    if np.any(pr[:, 0] > pr[:, 1]):
        raise ValueError("input_range rows must be [min, max] with min <= max")
    return pr


def _rands(shape, generator) -> torch.Tensor:
    """MATLAB `rands`: uniform on `[-1, 1]`, float64."""
    return torch.rand(shape, generator=generator, dtype=torch.float64) * 2 - 1


def _calcnw(s: int, pr: np.ndarray, active: tuple[float, float], generator) -> tuple[torch.Tensor, torch.Tensor]:
    """MATLAB `initnw`'s `calcnw` for `s` neurons: weights `(s, R)` and biases `(s,)`, float64.

    `pr`: `(R, 2)` input ranges; `active`: the transfer function's active input range.
    """
    R = pr.shape[0]
    if R == 0 or s == 0:
        return torch.zeros(s, R, dtype=torch.float64), torch.zeros(s, dtype=torch.float64)
    pr = pr.copy()
    pr[~np.isfinite(pr).all(axis=1)] = [0.0, 1.0]  # as MATLAB: a non-finite range counts as [0, 1]
    varying = np.flatnonzero(pr[:, 0] != pr[:, 1])  # constant inputs carry no information: weight 0
    r = varying.size
    if r == 0:
        return torch.zeros(s, R, dtype=torch.float64), torch.zeros(s, dtype=torch.float64)
    pr = torch.as_tensor(pr[varying])

    # Nguyen–Widrow for inputs and net inputs in [-1, 1]: random unit-norm rows (MATLAB randnr:
    # rows of rands normalised to length 1) scaled to beta = 0.7 s^(1/r); biases spread evenly
    # over [-beta, beta], signed like the row's first weight.
    beta = 0.7 * s ** (1.0 / r)
    direction = _rands((s, r), generator)
    direction = direction / direction.norm(dim=1, keepdim=True).clamp_min(torch.finfo(torch.float64).tiny)
    w = beta * direction
    if s > 1:
        # linspace(-1, 1, s), written so that it is exactly symmetric (and 0 in the middle)
        spread = (2 * torch.arange(s, dtype=torch.float64) - (s - 1)) / (s - 1)
        b = beta * spread * torch.sign(w[:, 0])
    else:
        b = torch.zeros(1, dtype=torch.float64)
    # Net inputs [-1, 1] -> the active range [lo, hi].
    half, mid = 0.5 * (active[1] - active[0]), 0.5 * (active[1] + active[0])
    w, b = half * w, half * b + mid
    # Inputs [pmin, pmax] -> [-1, 1]: x' = xs * x + ys, folded into w and b.
    xs = 2.0 / (pr[:, 1] - pr[:, 0])
    ys = 1.0 - pr[:, 1] * xs
    b = w @ ys + b
    w = w * xs
    full = torch.zeros(s, R, dtype=torch.float64)
    full[:, torch.as_tensor(varying)] = w
    return full, b


def _as_weight_bias(linear_or_weight, bias, fn_name: str):
    """Normalise the (layer | weight, bias) arguments: list of `(w_view (out, in), b_view (out,))`.

    `nn.Linear`: its `weight` `(out, in)` and `bias`. A tensor: the stacked layout
    `(in, out)` or `(S, in, out)`, bias `(out,)` or `(S, out)`.
    """
    if isinstance(linear_or_weight, nn.Linear):
        layer = linear_or_weight
        if bias is None:
            bias = layer.bias
        if bias is None:
            raise ValueError(f"{fn_name}: the layer has no bias (MATLAB's initnw needs one)")
        return layer.weight, bias, [(layer.weight, bias)]
    weight = linear_or_weight
    if not isinstance(weight, torch.Tensor) or weight.ndim not in (2, 3):
        raise ValueError(f"{fn_name}: need an nn.Linear or a weight tensor (in, out) / (S, in, out)")
    if bias is None:
        raise ValueError(f"{fn_name}: a weight tensor needs its bias tensor")
    out = weight.shape[-1]
    expect = (out,) if weight.ndim == 2 else (weight.shape[0], out)
    if tuple(bias.shape) != expect:
        raise ValueError(f"{fn_name}: bias shape {tuple(bias.shape)} does not fit weight {tuple(weight.shape)} "
                         f"(expected {expect})")
    if weight.ndim == 2:
        return weight, bias, [(weight.T, bias)]
    return weight, bias, [(weight[k].T, bias[k]) for k in range(weight.shape[0])]


def nguyen_widrow_(linear_or_weight: torch.nn.Module | torch.Tensor, bias: torch.Tensor | None = None,
                   input_range: ArrayLike | None = None, *, active_range: tuple[float, float] = (-2.0, 2.0),
                   generator: torch.Generator | None = None) -> tuple[torch.Tensor, torch.Tensor]:
    """Nguyen–Widrow initialisation in place, as MATLAB's `initnw` (`calcnw`) for a tanh layer.

    Parameters
    ----------
    linear_or_weight
        an `nn.Linear` (weight `(H, N)`; its own bias unless `bias` is
        given), or a weight tensor in `SubspaceMLP`'s layout, `(N, H)` or stacked
        `(S, N, H)` (each of the S slices gets its own random draw, in order).
    bias
        the bias, `(H,)` or `(S, H)`; required with a weight tensor.
    input_range
        `(N, 2)` rows `[min, max]` of each input (torch or numpy), or `(2,)`
        for all; `None`: `[-1, 1]` for every input. MATLAB uses the min/max over the
        training inputs (after input processing) for the first layer and the previous
        layer's output range ([-1, 1] for tansig) for the others.
    active_range
        the net-input interval to spread the neurons over; MATLAB's `tansig`
        active input range is `[-2, 2]` (`logsig`: `[-4, 4]`).
    generator
        random source (default: the global torch RNG).

    Notes
    -----
    What is computed, for `H` neurons and the `r` inputs whose range is not a single point
    (constant inputs get weight 0 and do not count; a non-finite range counts as `[0, 1]`):

    1. `beta = 0.7 * H**(1/r)`; each neuron's weight row is `beta * u / |u|` with `u`
       uniform on `[-1, 1]^r` (MATLAB `randnr`); biases `beta * linspace(-1, 1, H) *
       sign(w[:, 0])` (0 when `H == 1`). This places the neurons for inputs in `[-1, 1]`
       and net inputs in `[-1, 1]`.
    2. Scale to the active range `[lo, hi]`: `w *= (hi - lo)/2`, `b = b (hi - lo)/2 +
       (hi + lo)/2`. For tanh, each row then has norm `1.4 * H**(1/r)`.
    3. Map each input's `[min, max]` onto `[-1, 1]`: with `s_i = 2/(max_i - min_i)` and
       `c_i = 1 - max_i s_i`, `b += w @ c` and `w[:, i] *= s_i`. Hence on an input at the
       centre of its range the net input is `b` of step 2, and `w[:, i] * (max_i - min_i)/2`
       has the row norms of step 2.

    Computed in float64 and copied into the tensors (any dtype). Returns `(weight, bias)`.
    """
    weight, bias, slices = _as_weight_bias(linear_or_weight, bias, "nguyen_widrow_")
    n_in = slices[0][0].shape[1]
    pr = input_range_array(input_range, n_in)
    with torch.no_grad():
        for w_view, b_view in slices:
            w, b = _calcnw(w_view.shape[0], pr, active_range, generator)
            w_view.copy_(w)
            b_view.copy_(b)
    return weight, bias


def matlab_rands_(linear_or_weight: torch.nn.Module | torch.Tensor, bias: torch.Tensor | None = None, *,
                  generator: torch.Generator | None = None) -> tuple[torch.Tensor, torch.Tensor]:
    """MATLAB `rands` in place: weights and biases uniform on `[-1, 1]`.

    `initnw` uses this for layers whose transfer function has an unbounded active input range
    (the linear `purelin` output layer). Same argument layouts as `nguyen_widrow_`; per
    slice the weights `(H, N)` are drawn first (MATLAB's row order), then the biases.
    """
    weight, bias, slices = _as_weight_bias(linear_or_weight, bias, "matlab_rands_")
    with torch.no_grad():
        for w_view, b_view in slices:
            w_view.copy_(_rands(tuple(w_view.shape), generator))
            b_view.copy_(_rands(tuple(b_view.shape), generator))
    return weight, bias


def torch_default_(linear_or_weight: torch.nn.Module | torch.Tensor, bias: torch.Tensor | None = None, *,
                   generator: torch.Generator | None = None) -> tuple[torch.Tensor, torch.Tensor]:
    """PyTorch's `nn.Linear` default in place: weights and biases `U(-1/sqrt(N), 1/sqrt(N))`.

    (`kaiming_uniform_(a=sqrt(5))` on the weight gives exactly that bound.) Same layouts as
    `nguyen_widrow_`.
    """
    weight, bias, slices = _as_weight_bias(linear_or_weight, bias, "torch_default_")
    with torch.no_grad():
        for w_view, b_view in slices:
            bound = 1.0 / math.sqrt(w_view.shape[1])
            w_view.copy_(_rands(tuple(w_view.shape), generator) * bound)
            b_view.copy_(_rands(tuple(b_view.shape), generator) * bound)
    return weight, bias
