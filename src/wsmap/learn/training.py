"""Training with MATLAB-style early stopping: full batch (the paper's) or minibatches (Adam).

The paper trains each network with MATLAB's `train`: the samples are split 70/15/15 at random
(`dividerand`), every epoch is one full-batch step of the training function on the training
split, and training stops at the first of: the epoch limit, the time limit, the performance goal,
a gradient norm below `min_grad`, or `max_fail` consecutive validation failures; the network
returned is the one of the best validation epoch. `train` does the same with a torch model
and an optimiser from `wsmap.learn.optim`; `train_sessions` repeats it for independent
sessions (the paper: 10 sessions, different seeds, hence different initial weights and splits).

Epoch numbering follows MATLAB: epoch `e` is the state after `e` optimiser steps, so the history
of a run that hits `max_epochs` has `max_epochs + 1` rows (epoch 0 is the initial network).

Stacked sessions
----------------
A *stacked* model holds `S` independent parameter sets and returns `(S, n, m)` outputs, for
inputs `(n, f)` (shared) or `(S, n, f)` (one batch per session); every parameter has leading
dimension `S`. `train` detects it from the output's rank and minimises the *sum over
sessions* of each session's loss. The gradient of that sum with respect to session `s`'s
parameters is exactly the gradient of session `s`'s own loss, so an *elementwise* optimiser
(Rprop: `wsmap.learn.optim.ELEMENTWISE`) moves every session as it would move alone (up to
float32 rounding of the batched products: ~1e-7 in the tests), and early stopping, best-epoch
bookkeeping and restoring are kept per session (a stopped session is masked out of the sum, which
freezes it under Rprop). For the other optimisers (SCG, CGB, OSS: line searches, step sizes and
conjugate directions are computed from global dot products; GDX: one learning rate driven by the
total loss) a stacked run is *not* equivalent to separate runs, so `train_sessions` runs
those sessions one after another. On a CPU stacking does not pay (see `train_sessions`).

Minibatch training (the improved model)
---------------------------------------
The paper's trainers are full batch. For bigger networks and datasets `TrainConfig` also
takes `optimizer="adam"` (`torch.optim.Adam`, `optimizer_kwargs` such as `lr`) with
`batch_size` (`None`: full batch, one step per epoch). With a `batch_size` an epoch is one
pass over the training split in minibatches of that many samples (the last one smaller), in an
order drawn afresh each epoch from `torch.Generator().manual_seed(config.seed)`, so a run is
reproducible from its seed. Validation, early stopping and best-epoch restoring happen once per
epoch, exactly as in full-batch training. What differs in the record: no full-batch gradient is
ever computed, so `History.grad_norm` is NaN and `min_grad` never stops a minibatch run, and
`History.loss` of epoch `e >= 1` is the mean of the minibatch losses of pass `e` (weighted by
batch size; the parameters move during the pass), epoch 0's the full training loss of the initial
network. Boolean targets stay boolean on the device and are cast per batch (a 20 000 × 9261 label
matrix is 185 MB as bool, 741 MB as float32). `lr_decay="cosine"` anneals Adam's learning rate
from its initial value to 0 over `max_epochs` (per step), `"cosine-time"` over
`time_limit_s` (then a run depends on the machine's speed and is not bit-reproducible).

Devices
-------
`TrainConfig(device=...)` (`"auto"`, `"cpu"`, `"cuda"`; `wsmap.learn.device`) moves
the model to that device when `train` starts, and the training data follow the model's
parameters, so a whole run (a stacked run of several sessions included) happens there; `"cuda"`
without a GPU fails before any work. The model is built and initialised on the CPU (CPU random
generators), so CPU and GPU runs start from the same weights and splits and agree to float32
rounding. The returned model stays on the device; histories and losses are plain floats either way.

The improved model's recipe (20 000 spherical-wrist arms; inputs the 4 free DH parameters
standardised; [256, 256, 256] tanh → 9261 logits; cross-entropy; Adam lr 1e-3; batch 256)::

    config = MLPConfig(n_inputs=84, n_outputs=9261, hidden=[256, 256, 256], init="torch",
                       input_columns=[2, 3, 7, 8], input_scaling="standardize", output_kind="logit")
    model = SubspaceMLP(config).configure(X[split.train])
    train(model, X, Y, TrainConfig(optimizer="adam", optimizer_kwargs={"lr": 1e-3}, batch_size=256,
                                   loss="crossentropy", max_epochs=10_000, max_fail=20,
                                   time_limit_s=300, fractions=(0.95, 0.05, 0.0)), split=split)
"""

from __future__ import annotations

import dataclasses
import math
import numbers
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn
from torch.nn.utils import parameters_to_vector

from .device import check_device_name, resolve_device
from .optim import ALIASES, ELEMENTWISE, OPTIMIZERS, canonical_name, make_optimizer
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    import pandas as pd

    from wsmap._typing import ArrayLike
    from wsmap.learn.network import SubspaceMLP

__all__ = [
    "LOSSES",
    "Loss",
    "make_loss",
    "Split",
    "split_indices",
    "TrainConfig",
    "History",
    "TrainResult",
    "train",
    "train_sessions",
    "train_mlp_sessions",
    "STOP_REASONS",
    "MINIBATCH_OPTIMIZERS",
    "LR_DECAYS",
    "optimizer_name",
    "validation_stop",
]

# --------------------------------------------------------------------------------------------
# Losses
# --------------------------------------------------------------------------------------------


class Loss:
    """A loss `loss(output, target)` averaged over the last two dimensions.

    `output`: `(n, m)` → a scalar; `(S, n, m)` (stacked sessions) → `(S,)`, one mean per
    session. `target` is `(n, m)` or `(S, n, m)` and broadcasts against `output`.
    """

    def __init__(self, name: str, reduced: Callable[[torch.Tensor, torch.Tensor], torch.Tensor]):
        self.name = name
        self._reduced = reduced

    def __call__(self, output: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
        return self._reduced(output, target.expand_as(output))

    def __repr__(self) -> str:
        return f"Loss({self.name!r})"


class _MeanSquaredError(torch.autograd.Function):
    """Mean of `(output − target)²` over the last two dimensions, with a lean backward.

    The paper's outputs are large (a 10-session stack of 7000 samples × 1323 nodes holds 93 M
    values). Autograd's `(out − t).square().mean()` allocates four such tensors (difference,
    square, the broadcast mean gradient, the product) and its backward runs three passes over
    them; this keeps the difference for a one-pass backward `2·diff/K`, which roughly halves the
    time of a stacked step on the CPU.
    """

    @staticmethod
    def forward(ctx, output, target):
        diff = output - target
        count = diff.shape[-2] * diff.shape[-1]
        # square().mean() allocates a temporary, but sums accurately (cascade summation): a
        # float32 BLAS dot or vector_norm over 9 M values is off by 1e-4..1e-2, too much for the
        # loss differences SCG and the line searches compare.
        per = diff.square().mean(dim=(-2, -1))
        ctx.save_for_backward(diff)  # an intermediate: fine without double backward
        ctx.count = count
        return per

    @staticmethod
    def backward(ctx, grad):
        scale = (grad * (2.0 / ctx.count)).reshape(*grad.shape, 1, 1)
        (diff,) = ctx.saved_tensors
        return diff * scale, None


def _mse(out, t):
    if out.requires_grad and not t.requires_grad:
        return _MeanSquaredError.apply(out, t)
    return (out - t).square().mean(dim=(-2, -1))


def _mae(out, t):
    return (out - t).abs().mean(dim=(-2, -1))


def _bce_logits(out, t):
    return F.binary_cross_entropy_with_logits(out, t, reduction="none").mean(dim=(-2, -1))


LOSSES = {"mse": _mse, "crossentropy": _bce_logits, "mae": _mae}


def make_loss(name: str, pos_weight: float | None = None) -> Loss:
    """The loss called `name`: `"mse"`, `"crossentropy"` or `"mae"`.

    * `mse`: mean squared error over every sample and output (MATLAB `mse`; the paper's loss).
    * `mae`: mean absolute error (MATLAB `mae`).
    * `crossentropy`: binary cross entropy *on logits*: the network's linear output `z` is read
      as a logit, `p = sigmoid(z)`, loss `−t·log p − (1 − t)·log(1 − p)`, averaged. MATLAB's
      `crossentropy` applied to a linear output layer takes logs of raw outputs; the logit form is
      the well-defined equivalent for 0/1 labels. A model trained with it predicts 1 where
      `z > 0` (`p > 0.5`), not where `z > 0.5`: apply `torch.sigmoid` before the paper's
      0.5 threshold.

    `pos_weight` (`crossentropy` only): the weight of a positive target's term,
    `−w·t·log p − (1 − t)·log(1 − p)` (torch's `pos_weight`), for maps whose reachable nodes
    are a few per cent of the grid; `None` is 1.

    Unknown names, and `pos_weight` that is not a positive number or is given to another loss,
    raise `ValueError`.
    """
    key = str(name).strip().lower()
    if key not in LOSSES:
        raise ValueError(f"unknown loss {name!r}; known: {', '.join(sorted(LOSSES))}")
    if pos_weight is None:
        return Loss(key, LOSSES[key])
    if isinstance(pos_weight, bool) or not isinstance(pos_weight, (int, float, np.integer, np.floating)) \
            or not np.isfinite(pos_weight) or pos_weight <= 0:
        raise ValueError(f"pos_weight must be a positive number or None, got {pos_weight!r}")
    if key != "crossentropy":
        raise ValueError(f"pos_weight weighs the positive targets of crossentropy, not of loss {key!r}")
    w = float(pos_weight)

    def weighted(out, t):
        weight = torch.as_tensor(w, dtype=out.dtype, device=out.device)
        return F.binary_cross_entropy_with_logits(out, t, pos_weight=weight, reduction="none").mean(dim=(-2, -1))

    return Loss(key, weighted)


# --------------------------------------------------------------------------------------------
# Data split
# --------------------------------------------------------------------------------------------


class Split(NamedTuple):
    """Sorted, disjoint sample indices (int64 arrays) of the training, validation and test sets."""

    train: np.ndarray
    val: np.ndarray
    test: np.ndarray


def split_indices(n: int, fractions: Sequence[float] = (0.7, 0.15, 0.15), seed: int | None = 0) -> Split:
    """Random train/validation/test split of `n` samples, as MATLAB's `dividerand`.

    `round(fractions[1]·n)` validation and `round(fractions[2]·n)` test samples, the rest for
    training, drawn by a random permutation from `numpy.random.default_rng(seed)`. The three
    index arrays are sorted, disjoint and together cover `range(n)`.
    """
    fr = np.asarray(fractions, dtype=float)
    if fr.shape != (3,) or np.any(fr < 0) or not np.isclose(fr.sum(), 1.0) or fr[0] <= 0:
        raise ValueError(f"fractions must be 3 non-negative numbers summing to 1, train > 0; got {fractions!r}")
    n = int(n)
    n_val, n_test = int(round(fr[1] * n)), int(round(fr[2] * n))
    n_train = n - n_val - n_test
    if n_train < 1:
        raise ValueError(f"no training samples left from n = {n} with fractions {tuple(fractions)}")
    perm = np.random.default_rng(seed).permutation(n)
    return Split(np.sort(perm[:n_train]), np.sort(perm[n_train:n_train + n_val]), np.sort(perm[n_train + n_val:]))


# --------------------------------------------------------------------------------------------
# Configuration and results
# --------------------------------------------------------------------------------------------

#: Optimisers built here rather than in `wsmap.learn.optim` (which holds the paper's full-batch
#: trainers): name -> `torch.optim` class. Only these take minibatches (`batch_size`) and
#: `lr_decay`; full batch they take one step per epoch like the others.
MINIBATCH_OPTIMIZERS: dict[str, type[torch.optim.Optimizer]] = {"adam": torch.optim.Adam}
#: Learning-rate schedules for `MINIBATCH_OPTIMIZERS` (`TrainConfig.lr_decay`).
LR_DECAYS = ("cosine", "cosine-time")


def optimizer_name(name: str) -> str:
    """Canonical optimiser name: `"adam"`, or `wsmap.learn.optim.canonical_name` (`"trainrp"`
    → `"rprop"`, ...). Unknown names raise `ValueError` listing every known one."""
    key = str(name).strip().lower()
    if key in MINIBATCH_OPTIMIZERS:
        return key
    try:
        return canonical_name(key)
    except ValueError:
        known = sorted([*OPTIMIZERS, *MINIBATCH_OPTIMIZERS])
        raise ValueError(f"unknown optimizer {name!r}; known: {', '.join(known)} "
                         f"(MATLAB aliases: {', '.join(sorted(ALIASES))})") from None


def _build_optimizer(name: str, params, kwargs: dict) -> torch.optim.Optimizer:
    key = optimizer_name(name)
    if key in MINIBATCH_OPTIMIZERS:
        return MINIBATCH_OPTIMIZERS[key](params, **kwargs)
    return make_optimizer(key, params, **kwargs)


#: Why a run (or a session) stopped, in the order `train` tests them each epoch.
STOP_REASONS = ("nonfinite", "goal", "max_epochs", "time_limit", "min_grad", "max_fail", "min_step")


def _validation_update(crit: np.ndarray, best_crit: np.ndarray, fails: np.ndarray, active: np.ndarray,
                       first: bool, has_val: bool) -> np.ndarray:
    """One epoch of MATLAB's validation check, in place, for `S` sessions at once.

    `crit` `(S,)`: this epoch's validation loss (the training loss without a validation
    split); `best_crit`, `fails`: the sessions' best so far and consecutive failures, updated
    for the `active` sessions. A strictly lower value is an improvement (failures back to 0), a
    strictly higher one a failure, an equal one neither; `first` (epoch 0) always improves.
    Returns the `(S,)` mask of the sessions that improved. Shared by `train` and
    `validation_stop`, so that a replayed history stops where training would have.
    """
    improved = active & ((crit < best_crit) | first)
    worse = active & has_val & (crit > best_crit) & ~improved
    fails[improved] = 0
    fails[worse] += 1
    best_crit[improved] = crit[improved]
    return improved


def validation_stop(val_loss: Sequence[float], max_fail: int) -> dict[str, Any]:
    """Where MATLAB's validation stopping rule with `max_fail` would have ended a recorded run.

    Replays `train`'s rule (`_validation_update`) over a history's per-epoch
    validation losses, e.g. a run trained with a larger `max_fail`: since every epoch up to the
    stop is the same whatever `max_fail` is, the replay is what a run with this `max_fail`
    would have recorded, without training it again.

    Parameters
    ----------
    val_loss
        `(E + 1,)` validation loss at epochs 0..E (`History.val_loss` of one
        session; NaN entries after a session stopped end the replay there).
    max_fail
        consecutive failures that stop (MATLAB's default 6); `>= 1`.

    Returns
    -------
    dict[str, Any]
        `stop_epoch` (the epoch the rule stops at; the last recorded epoch when it never
        fires), `stopped` (whether the rule fired), `best_epoch` and `best_val_loss` (the
        epoch whose parameters the run keeps and its validation loss).

    Raises
    ------
    ValueError
        `max_fail < 1`, an empty or non-1-D `val_loss`, or NaN at epoch 0.
    """
    if isinstance(max_fail, bool) or not isinstance(max_fail, numbers.Integral) or max_fail < 1:
        raise ValueError(f"max_fail must be an integer >= 1, got {max_fail!r}")
    v = np.asarray(val_loss, dtype=float)
    if v.ndim != 1 or v.size == 0:
        raise ValueError(f"val_loss must be a non-empty 1-D sequence, got shape {v.shape}")
    if not np.isfinite(v[0]):
        raise ValueError("val_loss[0] is not finite: the history has no validation loss")
    best, fails, active = np.full(1, np.inf), np.zeros(1, dtype=int), np.ones(1, dtype=bool)
    best_epoch, last, stopped = 0, 0, False
    for epoch, x in enumerate(v):
        if not np.isfinite(x):
            break
        last = epoch
        if _validation_update(np.array([x]), best, fails, active, epoch == 0, True)[0]:
            best_epoch = epoch
        if fails[0] >= max_fail:
            stopped = True
            break
    return {"stop_epoch": last, "stopped": stopped, "best_epoch": best_epoch, "best_val_loss": float(best[0])}


@dataclass
class TrainConfig:
    """What `train` needs besides the model and data.

    Attributes
    ----------
    optimizer
        name for `wsmap.learn.optim.make_optimizer` (`rprop`, `scg`, `cgb`,
        `oss`, `gdx` or a MATLAB name), or `adam` (`MINIBATCH_OPTIMIZERS`);
        `optimizer_kwargs` override its defaults (e.g. `{"lr": 1e-3}` for Adam).
    loss
        `mse`, `crossentropy` or `mae` (`make_loss`).
    pos_weight
        `crossentropy` only: the weight of positive targets (`make_loss`);
        `None` (default) is 1, and is left out of `to_dict` so that settings hashed
        before this option existed keep their hash.
    max_epochs
        optimiser steps at most (MATLAB `epochs`; the paper's section 6.1: 1000).
    max_fail
        consecutive validation failures that stop training (MATLAB `max_fail`,
        default 6; the paper's section 6.2 used 100).
    min_grad
        stop when the L2 norm of the loss gradient is at most this.
    goal
        stop when the training loss is at most this (MATLAB `goal`, default 0).
    time_limit_s
        stop after this many seconds (`None`: no limit), per `train` call.
    seed
        split seed (session `s` of a stacked run uses `seed + s`); `train_sessions`
        also seeds the initial weights with it.
    fractions
        train/validation/test fractions for `split_indices`.
    track_test
        also record the test-split loss every epoch (costs one more forward pass).
    batch_size
        samples per step; `None` (default): full batch, one step per epoch. Only
        with `adam`; an epoch is then one shuffled pass (module docstring). A value above
        the training split's size means full batch.
    lr_decay
        `None` (constant learning rate), `"cosine"` (`lr·(1 + cos(pi·t))/2` with
        `t` the fraction of `max_epochs` done, updated every step) or `"cosine-time"`
        (`t` the fraction of `time_limit_s` elapsed). Only with `adam`.
    device
        where `train` runs: `"auto"` (the GPU when `torch.cuda.is_available()`,
        else the CPU), `"cpu"`, `"cuda"` / `"cuda:N"` (an error without a GPU), or
        `None` (default): wherever the model's parameters already are (the networks are
        built on the CPU). `train` moves the model there first (`wsmap.learn.device`);
        the name is checked here, the GPU's presence when `train` starts.
    """

    optimizer: str = "rprop"
    optimizer_kwargs: dict[str, Any] = field(default_factory=dict)
    loss: str = "mse"
    max_epochs: int = 1000
    max_fail: int = 6
    min_grad: float = 1e-7
    goal: float = 0.0
    time_limit_s: float | None = None
    seed: int = 0
    fractions: tuple[float, float, float] = (0.7, 0.15, 0.15)
    track_test: bool = False
    batch_size: int | None = None
    lr_decay: str | None = None
    device: str | None = None
    pos_weight: float | None = None

    def __post_init__(self):
        key = optimizer_name(self.optimizer)  # fail early on a bad name
        if self.device is not None:
            self.device = check_device_name(self.device, "TrainConfig.device")
        make_loss(self.loss, self.pos_weight)
        if self.pos_weight is not None:
            self.pos_weight = float(self.pos_weight)
        self.fractions = tuple(float(f) for f in self.fractions)
        if self.max_epochs < 0 or self.max_fail < 1:
            raise ValueError("need max_epochs >= 0 and max_fail >= 1")
        minibatch_capable = key in MINIBATCH_OPTIMIZERS
        if self.batch_size is not None:
            b = self.batch_size
            if isinstance(b, bool) or not isinstance(b, (int, np.integer)) or b < 1:
                raise ValueError(f"batch_size must be a positive integer or None (full batch); got {b!r}")
            self.batch_size = int(b)
            if not minibatch_capable:
                # Rprop's sign rule and the line searches of SCG/CGB/OSS assume the same objective
                # at every step; on minibatches they chase noise.
                raise ValueError(f"optimizer {self.optimizer!r} is a full-batch trainer; batch_size needs one of "
                                 f"{sorted(MINIBATCH_OPTIMIZERS)} (or batch_size=None)")
        if self.lr_decay is not None:
            if self.lr_decay not in LR_DECAYS:
                raise ValueError(f"lr_decay must be None or one of {list(LR_DECAYS)}; got {self.lr_decay!r}")
            if not minibatch_capable:
                raise ValueError(f"lr_decay needs one of {sorted(MINIBATCH_OPTIMIZERS)}; optimizer "
                                 f"{self.optimizer!r} adapts its own steps")
            if self.lr_decay == "cosine-time" and self.time_limit_s is None:
                raise ValueError("lr_decay 'cosine-time' anneals over time_limit_s; set time_limit_s")

    def to_dict(self) -> dict[str, Any]:
        """Plain dict (JSON/YAML friendly: tuples become lists)."""
        d = dataclasses.asdict(self)
        if d["pos_weight"] is None:
            del d["pos_weight"]
        d["fractions"] = list(self.fractions)
        d["optimizer_kwargs"] = {k: list(v) if isinstance(v, tuple) else v for k, v in self.optimizer_kwargs.items()}
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> TrainConfig:
        """Inverse of `to_dict`; unknown keys raise `ValueError`."""
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = set(d) - names
        if unknown:
            raise ValueError(f"unknown TrainConfig keys {sorted(unknown)}; known: {sorted(names)}")
        d = dict(d)
        if "optimizer_kwargs" in d:
            d["optimizer_kwargs"] = dict(d["optimizer_kwargs"] or {})
        return cls(**d)

    def replace(self, **changes) -> TrainConfig:
        return dataclasses.replace(self, **changes)


@dataclass
class History:
    """Per-epoch record. For a stacked run each value is a list of `S` (one per session; NaN
    once a session has stopped).

    Attributes
    ----------
    epoch
        0, 1, …; `loss`: training loss (minibatch runs: the mean minibatch loss of the
        epoch's pass); `grad_norm`: L2 norm of the training-loss gradient (the session's own
        parameters; NaN in minibatch runs); `val_loss`: validation loss (NaN without a
        validation split); `test_loss`: test loss (only with `track_test`; else empty);
        `time`: seconds since the start of `train`.
    """

    epoch: list[int] = field(default_factory=list)
    loss: list = field(default_factory=list)
    grad_norm: list = field(default_factory=list)
    val_loss: list = field(default_factory=list)
    test_loss: list = field(default_factory=list)
    time: list[float] = field(default_factory=list)

    _VALUES = ("loss", "grad_norm", "val_loss", "test_loss")

    def __len__(self) -> int:
        return len(self.epoch)

    def session(self, s: int, length: int | None = None) -> History:
        """The history of session `s` of a stacked run, first `length` epochs."""
        n = len(self.epoch) if length is None else length
        return History(epoch=self.epoch[:n], time=self.time[:n],
                       **{k: [row[s] for row in getattr(self, k)[:n]] for k in self._VALUES})

    def to_dict(self) -> dict[str, list]:
        return {k: list(getattr(self, k)) for k in ("epoch", *self._VALUES, "time")}

    def to_frame(self) -> pd.DataFrame:
        """A pandas DataFrame, one row per epoch (per epoch and session for a stacked run)."""
        import pandas as pd

        cols = [k for k in self._VALUES if len(getattr(self, k))]
        if self.loss and isinstance(self.loss[0], list):
            rows = []
            for i, e in enumerate(self.epoch):
                for s in range(len(self.loss[i])):
                    rows.append({"epoch": e, "session": s, **{k: getattr(self, k)[i][s] for k in cols},
                                 "time": self.time[i]})
            return pd.DataFrame(rows)
        return pd.DataFrame({"epoch": self.epoch, **{k: getattr(self, k) for k in cols}, "time": self.time})


@dataclass
class TrainResult:
    """What `train` returns.

    For a single model the fields are scalars; for a stacked model `best_epoch`,
    `best_val_loss`, `stop_reason`, `stop_epoch` and `split` are lists (one per session)
    and `sessions` gives one single-session view per session.

    Attributes
    ----------
    model
        the trained model, parameters restored to the best epoch (of every session).
    history
        `History`.
    best_epoch
        epoch whose parameters were restored (best validation loss; best training loss
        without a validation split).
    best_val_loss
        validation loss at `best_epoch` (NaN without validation).
    stop_reason
        one of `STOP_REASONS`.
    stop_epoch
        last epoch evaluated.
    split
        the `Split` used.
    config
        the `TrainConfig`.
    n_sessions
        `S` for a stacked model, `None` otherwise.
    session
        for a view from `sessions`, which slice of the stacked `model` it is.
    """

    model: nn.Module
    history: History
    best_epoch: Any
    best_val_loss: Any
    stop_reason: Any
    stop_epoch: Any
    split: Any
    config: TrainConfig
    n_sessions: int | None = None
    session: int | None = None

    def sessions(self) -> list[TrainResult]:
        """One result per session (a list of one for a single model)."""
        if self.n_sessions is None:
            return [self]
        return [TrainResult(model=self.model, history=self.history.session(s, self.stop_epoch[s] + 1),
                            best_epoch=self.best_epoch[s], best_val_loss=self.best_val_loss[s],
                            stop_reason=self.stop_reason[s], stop_epoch=self.stop_epoch[s],
                            split=self.split[s], config=self.config.replace(seed=self.config.seed + s),
                            n_sessions=None, session=s)
                for s in range(self.n_sessions)]


# --------------------------------------------------------------------------------------------
# The objective: full-batch loss and gradient, cached by parameter values
# --------------------------------------------------------------------------------------------


class _Objective:
    """Closure for the optimisers: zero grads, full-batch loss, backward; returns the total loss.

    Results are cached by parameter values (a few recent points), because the training loop
    evaluates the current point for its record and the optimiser's step re-evaluates it (and
    line searches/trial steps often end on the point the next epoch starts from). A cache hit
    writes the stored gradient back into `.grad`.
    """

    _CACHE = 4

    def __init__(self, model, params, x_train, y_train, loss_fn, n_sessions):
        self.model, self.params = model, params
        self.x, self.y, self.loss_fn = x_train, y_train, loss_fn
        self.S = n_sessions  # None: single model
        self.mask = None if n_sessions is None else torch.ones(n_sessions, dtype=y_train.dtype,
                                                               device=y_train.device)
        self._cache: list[tuple] = []

    def set_active(self, active: np.ndarray) -> None:
        self.mask = torch.as_tensor(active, dtype=self.y.dtype, device=self.y.device)
        self._cache.clear()

    def evaluate(self) -> tuple[torch.Tensor, np.ndarray, np.ndarray]:
        """(total loss, per-session losses, per-session gradient norms) at the current parameters."""
        with torch.no_grad():
            x = parameters_to_vector(self.params)
        for i, entry in enumerate(self._cache):
            if torch.equal(entry[0], x):
                self._cache.insert(0, self._cache.pop(i))
                self._restore_grad(entry[4])
                return entry[1], entry[2], entry[3]
        for p in self.params:
            p.grad = None
        with torch.enable_grad():
            per = self.loss_fn(self.model(self.x), self.y)
            total = per.sum() if self.S is None else (per * self.mask).sum()
            total.backward()
        grads = [torch.zeros_like(p) if p.grad is None else p.grad for p in self.params]
        for p, g in zip(self.params, grads):
            p.grad = g
        if self.S is None:
            gnorm = torch.sqrt(sum(g.square().sum() for g in grads)).reshape(1)
        else:
            # Each parameter's leading dimension is the session: per-session norms.
            gnorm = torch.sqrt(sum(g.reshape(self.S, -1).square().sum(1) for g in grads))
        entry = (x.clone(), total.detach(), per.detach().double().cpu().numpy().reshape(-1),
                 gnorm.detach().double().cpu().numpy(), torch.cat([g.reshape(-1) for g in grads]).clone())
        self._cache.insert(0, entry)
        del self._cache[self._CACHE:]
        return entry[1], entry[2], entry[3]

    def _restore_grad(self, flat: torch.Tensor) -> None:
        offset = 0
        for p in self.params:
            n = p.numel()
            p.grad = flat[offset:offset + n].view_as(p).clone()
            offset += n

    def __call__(self) -> torch.Tensor:
        return self.evaluate()[0]


# --------------------------------------------------------------------------------------------
# Training
# --------------------------------------------------------------------------------------------


def _take(a, idx, dtype, device, per_session: bool = False) -> torch.Tensor:
    """Rows `idx` of `a` as a tensor of `dtype` on `device`.

    `a` `(n, …)`: `idx` `(k,)` gives `(k, …)`, `(S, k)` gives `(S, k, …)`.
    `per_session` (`a` is `(S, n, …)`): `(S, k, …)`, session `s` from `a[s]`.
    Indexes before converting, so a big numpy `Y` is never copied whole.
    """
    torch_in = isinstance(a, torch.Tensor)
    if torch_in:
        idx = torch.as_tensor(idx, dtype=torch.long, device=a.device)
    if per_session:
        rows = (torch.arange(a.shape[0], device=a.device) if torch_in else np.arange(a.shape[0]))[:, None]
        out = a[:, idx] if idx.ndim == 1 else a[rows, idx]
    else:
        out = a[idx]
    return torch.as_tensor(out).to(dtype=dtype, device=device)


def _check_finite(name: str, a, chunk: int = 4096) -> None:
    """`ValueError` naming the first rows of `a` (numpy or torch; samples along axis -2 for 3-D
    targets, else axis 0) with NaN or infinite values; bool and integer arrays pass. Row chunks
    keep the temporary mask small for big label matrices."""
    torch_in = isinstance(a, torch.Tensor)
    if torch_in and not (a.is_floating_point() or a.is_complex()):
        return
    if not torch_in and a.dtype.kind not in "fc":
        return
    rows_axis = a.ndim - 2
    n = a.shape[rows_axis]
    for i in range(0, n, chunk):
        part = a[..., i:i + chunk, :] if rows_axis else a[i:i + chunk]
        ok = torch.isfinite(part) if torch_in else np.isfinite(part)
        if not bool(ok.all()):
            ok = ok.cpu().numpy() if torch_in else ok
            row_ok = ok.all(axis=-1)  # (k,), or (S, k) for per-session targets
            bad = np.flatnonzero(~(row_ok.all(axis=0) if row_ok.ndim == 2 else row_ok))
            raise ValueError(f"{name} contains NaN or infinite values (rows {(bad[:5] + i).tolist()}); "
                             "training on them would stop at once with loss NaN")


def _checked_arrays(X, Y) -> tuple[np.ndarray | torch.Tensor, np.ndarray | torch.Tensor]:
    """`X` and `Y` as arrays (torch tensors stay tensors), checked: `(n, f)` inputs,
    `(n, m)` or `(S, n, m)` targets with the same `n >= 1`, every value finite."""
    if not isinstance(X, torch.Tensor):
        X = np.asarray(X)
    if not isinstance(Y, torch.Tensor):
        Y = np.asarray(Y)
    if X.ndim != 2 or Y.ndim not in (2, 3) or X.shape[0] != Y.shape[-2]:
        raise ValueError(f"X must be (n, f) and Y (n, m) or (S, n, m) with the same n; "
                         f"got {tuple(X.shape)}, {tuple(Y.shape)}")
    if X.shape[0] == 0:
        raise ValueError("no samples: X and Y have 0 rows")
    _check_finite("X", X)
    _check_finite("Y", Y)
    return X, Y


def _session_count(model: nn.Module, params: list[torch.Tensor], X, Y) -> int | None:
    """`S` for a stacked model (read from the rank of its output on one sample), `None` for a
    single one; `ValueError` when the parameters or the targets do not fit that."""
    with torch.no_grad():
        probe = model(_take(X, np.arange(1), params[0].dtype, params[0].device))
    per_session_y = Y.ndim == 3
    if probe.ndim == 3:
        S = probe.shape[0]
        if per_session_y and Y.shape[0] != S:
            raise ValueError(f"stacked model with S = {S}: targets (S, n, m) have S = {Y.shape[0]}")
        bad = [tuple(p.shape) for p in params if p.ndim == 0 or p.shape[0] != S]
        if bad:
            raise ValueError(f"stacked model with S = {S}: every parameter needs leading dimension S; got {bad}")
        return S
    if probe.ndim == 2:
        if per_session_y:
            raise ValueError("targets (S, n, m) need a stacked model")
        return None
    raise ValueError(f"model output must be (n, m) or (S, n, m); got {tuple(probe.shape)}")


def _resolve_splits(split: Split | Sequence[Split] | None, n: int, S: int | None, config: TrainConfig) -> list[Split]:
    """The splits `train` uses: one, or one per session of a stacked model (`split=None`:
    drawn by `split_indices` with seed `config.seed + s`), as int64 index arrays."""
    if split is None:
        splits = ([split_indices(n, config.fractions, config.seed)] if S is None else
                  [split_indices(n, config.fractions, config.seed + s) for s in range(S)])
    elif isinstance(split, Split) or (len(split) == 3 and not isinstance(split[0], (Split, tuple))):
        splits = [Split(*(np.asarray(i, dtype=np.int64) for i in split))]
    else:
        splits = [Split(*(np.asarray(i, dtype=np.int64) for i in sp)) for sp in split]
    if S is None and len(splits) != 1:
        raise ValueError("one split for a single model")
    if S is not None and len(splits) not in (1, S):
        raise ValueError(f"stacked model with S = {S}: give one split or {S}")
    for part in range(3):
        if len({len(sp[part]) for sp in splits}) != 1:
            raise ValueError("per-session splits must have equal sizes")
    return splits


@dataclass
class _TrainData:
    """The samples of the splits, gathered once onto the training device.

    `x_*` are `(k, f)` (one split) or `(S, k, f)` (one split per session), `y_*` `(k, m)` or
    `(S, k, m)`; `x_te`, `y_te` are `None` unless the test loss is tracked.
    """

    x_tr: torch.Tensor
    y_tr: torch.Tensor
    x_va: torch.Tensor
    y_va: torch.Tensor
    x_te: torch.Tensor | None
    y_te: torch.Tensor | None
    has_val: bool
    track_test: bool

    @classmethod
    def gather(cls, X, Y, splits: list[Split], config: TrainConfig, dtype: torch.dtype,
               device: torch.device) -> _TrainData:
        """Rows of `X` and `Y` per split, as `dtype` on `device` (bool targets of a minibatch run
        stay bool: they are cast batch by batch, 4x less memory)."""
        bool_y = (Y.dtype == torch.bool) if isinstance(Y, torch.Tensor) else (Y.dtype == np.bool_)
        y_dtype = torch.bool if (config.batch_size is not None and bool_y) else dtype

        def part(i):
            if len(splits) == 1:
                idx = splits[0][i]
            else:
                idx = np.stack([sp[i] for sp in splits])  # (S, k): one batch per session
            return _take(X, idx, dtype, device), _take(Y, idx, y_dtype, device, Y.ndim == 3)

        (x_tr, y_tr), (x_va, y_va) = part(0), part(1)
        track_test = config.track_test and len(splits[0].test) > 0
        x_te, y_te = part(2) if track_test else (None, None)  # the test split is big: gather only if used
        return cls(x_tr, y_tr, x_va, y_va, x_te, y_te, has_val=len(splits[0].val) > 0, track_test=track_test)


class _SplitLoss:
    """Per-session loss `(S,)` (float64 numpy; `(1,)` for a single model) of `model` on a split,
    without gradients; in chunks of `chunk` samples when given (a full `(n, 9261)` forward
    pass of 20 000 arms would hold ~0.7 GB per activation of the output layer)."""

    def __init__(self, model: nn.Module, loss_fn: Loss, dtype: torch.dtype, chunk: int | None):
        self.model, self.loss_fn, self.dtype, self.chunk = model, loss_fn, dtype, chunk

    def __call__(self, x: torch.Tensor, y: torch.Tensor) -> np.ndarray:
        n_x = x.shape[-2]
        with torch.no_grad():
            if self.chunk is None or n_x <= self.chunk:
                return self.loss_fn(self.model(x), y.to(self.dtype)).double().cpu().numpy().reshape(-1)
            total = 0.0
            for i in range(0, n_x, self.chunk):
                xb, yb = x[..., i:i + self.chunk, :], y[..., i:i + self.chunk, :]
                total = total + self.loss_fn(self.model(xb), yb.to(self.dtype)).double() * xb.shape[-2]
            return (total / n_x).cpu().numpy().reshape(-1)


class _LearningRateSchedule:
    """`TrainConfig.lr_decay` on an optimiser: counts the steps taken and, before each, sets every
    group's learning rate to its initial one times the cosine factor (a no-op without decay)."""

    def __init__(self, optimizer: torch.optim.Optimizer, config: TrainConfig, total_steps: int):
        self.optimizer, self.config, self.total_steps = optimizer, config, total_steps
        self.base_lrs = [g.get("lr") for g in optimizer.param_groups]
        self.steps_done = 0

    def apply(self, elapsed: float) -> None:
        """Set the learning rates for the next step, `elapsed` seconds into the run."""
        decay, limit = self.config.lr_decay, self.config.time_limit_s
        if decay is None:
            return
        if decay == "cosine":
            t = self.steps_done / self.total_steps
        else:
            t = elapsed / limit if limit > 0 else 1.0
        factor = 0.5 * (1.0 + math.cos(math.pi * min(1.0, t)))
        for g, lr in zip(self.optimizer.param_groups, self.base_lrs):
            g["lr"] = lr * factor


class _FullBatchEpochs:
    """Full-batch training: an epoch is one optimiser step on the whole training split."""

    def __init__(self, optimizer: torch.optim.Optimizer, objective: _Objective, schedule: _LearningRateSchedule):
        self.optimizer, self.objective, self.schedule = optimizer, objective, schedule

    def training_loss(self) -> tuple[np.ndarray, np.ndarray]:
        """Per-session training loss and gradient norm `(S,)` at the current parameters."""
        _, loss_s, gnorm_s = self.objective.evaluate()
        return loss_s, gnorm_s

    def drop_stopped(self, active: np.ndarray) -> None:
        self.objective.set_active(active)

    def step(self, t0: float) -> None:
        """One optimiser step (`t0`: the run's start, for a time-based learning-rate decay)."""
        self.schedule.apply(time.perf_counter() - t0)
        self.optimizer.step(self.objective)
        self.schedule.steps_done += 1


class _MinibatchEpochs:
    """Minibatch training: an epoch is one pass over the training split in batches of `batch`
    samples, in an order drawn from `torch.Generator().manual_seed(seed)`; stopped sessions of
    a stacked model leave the summed loss through the session mask."""

    def __init__(self, model: nn.Module, optimizer: torch.optim.Optimizer, data: _TrainData, loss_fn: Loss,
                 split_loss: _SplitLoss, schedule: _LearningRateSchedule, S: int | None, batch: int, seed: int):
        self.model, self.optimizer, self.data, self.loss_fn = model, optimizer, data, loss_fn
        self.split_loss, self.schedule, self.S, self.batch = split_loss, schedule, S, batch
        self.n_s = 1 if S is None else S
        self.dtype, self.device = split_loss.dtype, data.x_tr.device
        self.mask = torch.ones(self.n_s, dtype=self.dtype, device=self.device)
        self.shuffle = torch.Generator().manual_seed(int(seed))
        self.pass_loss: np.ndarray | None = None

    def training_loss(self) -> tuple[np.ndarray, np.ndarray]:
        """Per-session training loss `(S,)`: the full loss before the first pass, then the
        last pass's mean minibatch loss; the gradient norm is NaN (none is computed)."""
        if self.pass_loss is None:
            loss_s = self.split_loss(self.data.x_tr, self.data.y_tr)
        else:
            loss_s = self.pass_loss
        return loss_s, np.full(self.n_s, float("nan"))

    def drop_stopped(self, active: np.ndarray) -> None:
        # Under Adam the stopped sessions' momentum still moves them; their best parameters are kept apart.
        self.mask = torch.as_tensor(active, dtype=self.dtype, device=self.device)

    def step(self, t0: float) -> None:
        """One shuffled pass (`t0`: the run's start, for a time-based learning-rate decay); keeps
        its per-session mean minibatch loss (float64, weighted by batch size)."""
        x_tr, y_tr = self.data.x_tr, self.data.y_tr
        n_train = x_tr.shape[-2]
        perm = torch.randperm(n_train, generator=self.shuffle).to(self.device)
        sums = torch.zeros(self.n_s, dtype=torch.float64, device=self.device)
        for i in range(0, n_train, self.batch):
            idx = perm[i:i + self.batch]
            xb, yb = x_tr.index_select(-2, idx), y_tr.index_select(-2, idx).to(self.dtype)
            self.schedule.apply(time.perf_counter() - t0)
            self.optimizer.zero_grad(set_to_none=True)
            per = self.loss_fn(self.model(xb), yb)
            total = per.sum() if self.S is None else (per * self.mask).sum()
            total.backward()
            self.optimizer.step()
            self.schedule.steps_done += 1
            sums += per.detach().double().reshape(-1) * idx.numel()
        self.pass_loss = (sums / n_train).cpu().numpy()


def _stop_reason(config: TrainConfig, epoch: int, loss: float, grad_norm: float, fails: int, elapsed: float,
                 has_val: bool, stalled: bool) -> str | None:
    """The first of `STOP_REASONS` that holds for one session after `epoch`, else `None`."""
    if not math.isfinite(loss):
        return "nonfinite"
    if loss <= config.goal:
        return "goal"
    if epoch == config.max_epochs:
        return "max_epochs"
    if config.time_limit_s is not None and elapsed >= config.time_limit_s:
        return "time_limit"
    if grad_norm <= config.min_grad:
        return "min_grad"
    if has_val and fails >= config.max_fail:
        return "max_fail"
    if stalled:
        return "min_step"
    return None


class _EarlyStopping:
    """Per-session bookkeeping of a run: which sessions still train, MATLAB's validation count,
    the best epoch with a copy of its parameters, and why and when each session stopped."""

    def __init__(self, params: list[torch.Tensor], S: int | None, config: TrainConfig, has_val: bool):
        self.params, self.S, self.config, self.has_val = params, S, config, has_val
        n_s = 1 if S is None else S
        self.active = np.ones(n_s, dtype=bool)
        self.best_crit = np.full(n_s, np.inf)
        self.best_val = np.full(n_s, np.nan)
        self.best_epoch = np.zeros(n_s, dtype=int)
        self.fails = np.zeros(n_s, dtype=int)
        self.stop_reason: list[str | None] = [None] * n_s
        self.stop_epoch = np.zeros(n_s, dtype=int)
        # Best parameters: a copy per tensor; a session's slice is refreshed when it improves.
        self.best = [p.detach().clone() for p in params]

    def masked(self, v: np.ndarray) -> float | list[float]:
        """A history entry: `v` `(S,)` with NaN for the stopped sessions (a float for a single model)."""
        v = np.where(self.active, v, np.nan)
        return float(v[0]) if self.S is None else [float(a) for a in v]

    def update_best(self, epoch: int, loss_s: np.ndarray, val_s: np.ndarray) -> None:
        """Count `epoch`'s validation failures (the training loss without a validation split) and
        keep the parameters of the sessions that improved."""
        crit = val_s if self.has_val else loss_s
        improved = _validation_update(crit, self.best_crit, self.fails, self.active, epoch == 0, self.has_val)
        self.best_val[improved] = val_s[improved]
        self.best_epoch[improved] = epoch
        if not improved.any():
            return
        with torch.no_grad():
            for b, p in zip(self.best, self.params):
                if self.S is None:
                    b.copy_(p)
                else:
                    sel = torch.as_tensor(np.flatnonzero(improved), device=p.device)
                    b[sel] = p[sel]

    def stop(self, epoch: int, loss_s: np.ndarray, gnorm_s: np.ndarray, elapsed: float, stalled: bool) -> bool:
        """Stop the active sessions for which a `STOP_REASONS` holds; returns whether any did."""
        newly = np.zeros(len(self.active), dtype=bool)
        for s in np.flatnonzero(self.active):
            reason = _stop_reason(self.config, epoch, loss_s[s], gnorm_s[s], self.fails[s], elapsed,
                                  self.has_val, stalled)
            if reason is not None:
                self.stop_reason[s], self.stop_epoch[s], newly[s] = reason, epoch, True
        self.active &= ~newly
        return bool(newly.any())

    def restore_best(self) -> None:
        """Every session's parameters back to its best epoch's."""
        with torch.no_grad():
            for b, p in zip(self.best, self.params):
                p.copy_(b)

    def result(self, model: nn.Module, history: History, splits: list[Split], config: TrainConfig) -> TrainResult:
        """The `TrainResult` of the run: scalars for a single model, lists for a stacked one."""
        S = self.S
        if S is None:
            return TrainResult(model=model, history=history, best_epoch=int(self.best_epoch[0]),
                               best_val_loss=float(self.best_val[0]), stop_reason=self.stop_reason[0],
                               stop_epoch=int(self.stop_epoch[0]), split=splits[0], config=config)
        return TrainResult(model=model, history=history, best_epoch=[int(e) for e in self.best_epoch],
                           best_val_loss=[float(v) for v in self.best_val], stop_reason=list(self.stop_reason),
                           stop_epoch=[int(e) for e in self.stop_epoch],
                           split=splits * S if len(splits) == 1 else splits, config=config, n_sessions=S)


def _record_epoch(history: History, stopping: _EarlyStopping, epoch: int, losses: dict[str, np.ndarray | None],
                  elapsed: float) -> None:
    """Append one epoch to `history` (`losses`: `loss`, `grad_norm`, `val_loss`, `test_loss`,
    each `(S,)` or `None` when not tracked)."""
    history.epoch.append(epoch)
    for key, value in losses.items():
        if value is not None:
            getattr(history, key).append(stopping.masked(value))
    history.time.append(elapsed)


def _run_epochs(config: TrainConfig, epochs: _FullBatchEpochs | _MinibatchEpochs, optimizer: torch.optim.Optimizer,
                data: _TrainData, split_loss: _SplitLoss, stopping: _EarlyStopping) -> History:
    """The epoch loop of `train`: evaluate and record, update the best epoch, stop or step."""
    n_s = len(stopping.active)
    history = History()
    stalled = False
    t0 = time.perf_counter()
    for epoch in range(config.max_epochs + 1):
        loss_s, gnorm_s = epochs.training_loss()
        val_s = split_loss(data.x_va, data.y_va) if data.has_val else np.full(n_s, float("nan"))
        test_s = split_loss(data.x_te, data.y_te) if data.track_test else None
        elapsed = time.perf_counter() - t0
        _record_epoch(history, stopping, epoch,
                      {"loss": loss_s, "grad_norm": gnorm_s, "val_loss": val_s, "test_loss": test_s}, elapsed)
        stopping.update_best(epoch, loss_s, val_s)
        if stopping.stop(epoch, loss_s, gnorm_s, elapsed, stalled):
            if not stopping.active.any():
                break
            # Drop stopped sessions from the objective: under Rprop their zero gradients freeze them.
            epochs.drop_stopped(stopping.active)
            if hasattr(optimizer, "objective_changed"):
                optimizer.objective_changed()
        epochs.step(t0)
        stalled = bool(getattr(optimizer, "stalled", False))
    return history


def train(model: nn.Module, X: ArrayLike | torch.Tensor, Y: ArrayLike | torch.Tensor, config: TrainConfig | None = None,
          split: Split | Sequence[Split] | None = None) -> TrainResult:
    """Train `model` on `(X, Y)` with early stopping, full batch or in minibatches
    (`config.batch_size`); see the module docstring.

    Parameters
    ----------
    model
        maps float `(n, f)` inputs to raw `(n, m)` outputs, or a stacked model
        (`(S, n, m)` outputs for `(n, f)` or `(S, n, f)` inputs, every parameter with
        leading dimension `S`). Used as is: no dropout/batch-norm is expected.
    X
        `(n, f)` inputs; Y: `(n, m)` targets, or for a stacked model `(S, n, m)`: one
        target set per session (e.g. the paper's 7 output blocks trained as one stack). Numpy
        or torch; cast to the model's dtype and device (float32 for the networks).
    config
        `TrainConfig` (default: the paper's Rprop + MSE, 1000 epochs, max_fail 6).
    split
        a `Split`, or for a stacked model one split per session (equal sizes).
        `None`: `split_indices(n, config.fractions, config.seed)`; for a stacked model
        session `s` uses seed `config.seed + s` (as `train_sessions` does).

    Notes
    -----
    Each epoch `e` (parameters after `e` steps): evaluate training loss and gradient,
    validation loss, record them; update the best epoch (a strictly lower validation loss resets
    the failure count, a strictly higher one adds a failure, an equal one does neither, as
    MATLAB); stop on the first of `STOP_REASONS` (`min_step`: a line search of CGB/OSS
    found no decrease); else take one optimiser step (full batch) or one shuffled pass of
    minibatch steps (`batch_size`). At the end every session's parameters are restored to its
    best epoch.

    Returns
    -------
    TrainResult
        The model restored to its best epoch, its history and why it stopped.

    Raises
    ------
    ValueError
        shapes that do not fit, no samples, NaN or infinite values in `X` or `Y`,
        bad splits, a model without trainable parameters.
    """
    config = TrainConfig() if config is None else config
    if config.device is not None:
        # before any work: a missing GPU is an error naming the setting, not a fall-back
        model.to(resolve_device(config.device, "TrainConfig.device"))
    params = [p for p in model.parameters() if p.requires_grad]
    if not params:
        raise ValueError("model has no trainable parameters")
    dtype, device = params[0].dtype, params[0].device
    X, Y = _checked_arrays(X, Y)
    S = _session_count(model, params, X, Y)
    splits = _resolve_splits(split, X.shape[0], S, config)
    data = _TrainData.gather(X, Y, splits, config, dtype, device)
    loss_fn = make_loss(config.loss, config.pos_weight)
    minibatch = config.batch_size is not None
    objective = None if minibatch else _Objective(model, params, data.x_tr, data.y_tr, loss_fn, S)
    optimizer = _build_optimizer(config.optimizer, params, dict(config.optimizer_kwargs))
    n_train = data.x_tr.shape[-2]
    batch = min(config.batch_size, n_train) if minibatch else n_train
    steps_per_epoch = -(-n_train // batch) if minibatch else 1
    split_loss = _SplitLoss(model, loss_fn, dtype, max(batch, 4096) if minibatch else None)
    schedule = _LearningRateSchedule(optimizer, config, max(1, config.max_epochs * steps_per_epoch))
    if minibatch:
        epochs = _MinibatchEpochs(model, optimizer, data, loss_fn, split_loss, schedule, S, batch, config.seed)
    else:
        epochs = _FullBatchEpochs(optimizer, objective, schedule)
    stopping = _EarlyStopping(params, S, config, data.has_val)
    history = _run_epochs(config, epochs, optimizer, data, split_loss, stopping)
    stopping.restore_best()
    return stopping.result(model, history, splits, config)


def train_sessions(model_factory: Callable[[list[int]], nn.Module], X: ArrayLike | torch.Tensor,
                   Y: ArrayLike | torch.Tensor, config: TrainConfig | None = None, sessions: int = 10, *,
                   stacked: bool = False) -> list[TrainResult]:
    """Independent training sessions (the paper: 10), session `s` with seed `config.seed + s`.

    The seed of a session fixes its initial weights (the global torch RNG is seeded with it before
    `model_factory` is called) and its split (`split_indices(n, config.fractions, seed)`).

    Parameters
    ----------
    model_factory
        `model_factory(seeds) -> model`. Sequential runs call it once per session
        with `[seed]`; a stacked run calls it once with all seeds and needs back a stacked
        model with `S = len(seeds)` whose session `s` is initialised as
        `model_factory([seeds[s]])` would be (so stacked and sequential runs agree).
    stacked
        train all sessions at once in one stacked model; only for elementwise optimisers
        (`wsmap.learn.optim.ELEMENTWISE`, i.e. Rprop): with SCG/CGB/OSS/GDX a stacked run
        couples the sessions (see the module docstring), so `True` raises `ValueError`.
        Default `False` (one session after another): on a 2-core CPU, 10 stacked sessions of
        the paper's [84 → 125, 100, 100, 125 → 1323] network on 7000 samples took 3.3–4.0 s
        per epoch against 2.4–2.8 s for 10 sequential epochs (the per-session matrix products
        already keep the cores busy; the stacked run only adds memory traffic). Stacking pays
        where one session leaves the device idle (a GPU: `config.device`, the stacked model
        runs there as a whole).

    Returns
    -------
    list[TrainResult]
        One `TrainResult` per session. In a stacked run they share the stacked `model`
        (each result's `session` says which slice is its own).
    """
    config = TrainConfig() if config is None else config
    elementwise = optimizer_name(config.optimizer) in ELEMENTWISE
    if stacked and not elementwise:
        raise ValueError(f"optimizer {config.optimizer!r} is not elementwise: stacked sessions would not be "
                         "independent; run them sequentially (stacked=False)")
    n = len(X)
    seeds = [config.seed + s for s in range(sessions)]
    if stacked:
        torch.manual_seed(seeds[0])
        model = model_factory(seeds)
        splits = [split_indices(n, config.fractions, sd) for sd in seeds]
        return train(model, X, Y, config, split=splits).sessions()
    results = []
    for sd in seeds:
        torch.manual_seed(sd)
        model = model_factory([sd])
        cfg = config.replace(seed=sd)
        res = train(model, X, Y, cfg, split=split_indices(n, config.fractions, sd))
        if res.n_sessions is not None:  # a stacked model with S = 1
            res = res.sessions()[0]
        results.append(res)
    return results


def train_mlp_sessions(mlp: SubspaceMLP, X: ArrayLike | torch.Tensor, Y: ArrayLike | torch.Tensor,
                       config: TrainConfig | None = None, sessions: int = 1, *, stacked: bool = False
                      ) -> list[TrainResult]:
    """`train_sessions` of `SubspaceMLP` models with
    architecture `mlp` (an `MLPConfig`; `n_subspaces` is ignored),
    each session's network configured on that session's training split
    (`SubspaceMLP.configure`: Nguyen–Widrow ranges and input standardisation), as MATLAB
    configures a network on the data handed to `train`; the validation and test parts stay
    unseen. A stacked run (`stacked=True`) stacks the sessions' networks as configured one by
    one, so it starts where the sequential run does. `X` `(n, f)`, `Y` `(n, m)` float32
    targets."""
    from .network import SubspaceMLP

    config = TrainConfig() if config is None else config
    X = np.asarray(X)
    one = mlp.replace(n_subspaces=1)

    def factory(seeds):
        models = [SubspaceMLP(one, seeds=[sd]).configure(X[split_indices(len(X), config.fractions, sd).train],
                                                         seeds=[sd]) for sd in seeds]
        return models[0] if len(models) == 1 else SubspaceMLP.from_models(models)

    return train_sessions(factory, X, Y, config, sessions, stacked=stacked)
