"""The subspace-learning network: S fully connected tanh MLPs held as one stacked module.

The paper (section "Distinctions between Subspace Learning and Generic Feedforward Networks")
stores the parameters of all subspaces of a model as tensors whose last index is the subspace,
`W^{(j)}_{:,:,i}` and `B^{(j)}_{:,i}`, and builds the forward graph of subspace `i` at run
time. `SubspaceMLP` does the same with the subspace index first:

* layer `j`'s weights are one parameter `(S, in_j, out_j)`, its biases `(S, out_j)`;
* hidden layers are `tanh`, the output layer is linear (MATLAB `tansig` / `purelin`);
* `forward(x)` runs all S subspaces at once, `forward(x, key=k)` only subspace `k` and
  `forward(x, key=keys)` subspace `keys[i]` for sample `i` (no loop over samples: one
  batched pass per distinct key).

Every parameter has leading dimension S, so a `SubspaceMLP` is a *stacked model* in the
sense of `wsmap.learn.training`: `train(model, X, Y)` trains the S subspaces as independent
sessions (exactly independent under Rprop), and `SubspaceMLP(config, seeds=[...])` initialises
subspace `s` from `seeds[s]` alone, as `train_sessions` needs.

Features and outputs
--------------------
Inputs are feature vectors in the stored (paper) layout, `(n, config.n_inputs)`, float64 on
disk; they are cast to the parameters' dtype (float32) inside `SubspaceMLP.forward`, which
then keeps `config.input_columns` (all columns when `None`) and, with
`input_scaling="standardize"`, standardises them with the stored per-subspace mean and std
(buffers, saved with the model). The paper feeds raw inputs (`input_scaling="none"`).

Outputs are one raw value per node, `(n, m)`. `config.output_kind` says how to read them:
`"linear"` (trained with MSE/MAE, the paper's) -- the raw output is the score and a node is
reachable when it exceeds the threshold (0.5); `"logit"` (trained with cross-entropy on logits)
-- the score is `sigmoid(raw)`, and `score > t` is `raw > logit(t)`.
`SubspaceMLP.score` and `SubspaceMLP.predict` use that rule; thresholds lie in (0, 1).

Initialisation
--------------
`config.init="nguyen-widrow"` reproduces MATLAB's `initnw` (`wsmap.learn.init`): hidden
(tanh) layers get Nguyen–Widrow weights computed from their input ranges, the linear output layer
MATLAB's `rands`. The first layer's input range is `[-1, 1]` per input unless given;
`SubspaceMLP.configure` takes it from training data, as MATLAB's `configure` does.
`config.init="torch"` is PyTorch's `nn.Linear` default in every layer.

What the model was trained on, and what it maps
-----------------------------------------------
`SubspaceMLP.configure` also records the range of every stored feature over the training
data (`SubspaceMLP.training_range`, a `TrainingRange`);
`SubspaceMLP.set_map_spec` says which grid and nodes the outputs are
(`wsmap.learn.mapspec`). With both, `SubspaceMLP.predict_maps` turns arms
(`wsmap.kinematics.DHRobot`) into boolean maps in node order, refusing arms outside the
training range unless `allow_extrapolation=True`. Files: `wsmap.learn.files`.
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import torch
from torch import nn

from ..datasets.features import feature_names, grid_nodes
from .init import input_range_array, matlab_rands_, nguyen_widrow_, to_numpy, torch_default_
from .mapspec import (
    MapPlan,
    check_batch_size,
    check_threshold,
    make_map_spec,
    map_batch_shape,
    map_features,
    map_plan,
)
from .training_range import TrainingRange, check_no_range
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap._typing import ArrayLike
    from wsmap.datasets.store import Dataset
    from wsmap.kinematics.chain import Arm

__all__ = [
    "ACTIVATIONS",
    "INITS",
    "INPUT_SCALINGS",
    "OUTPUT_KINDS",
    "MLPConfig",
    "SubspaceMLP",
    "check_features",
    "training_range_of",
    "unit_saturation",
]

#: Hidden-layer activations: name -> (function, active input range, output range). The ranges
#: are MATLAB's for `tansig`: Nguyen–Widrow spreads each neuron's net input over the active
#: range `[-2, 2]`; the next layer's inputs lie in the output range `[-1, 1]`.
ACTIVATIONS: dict[str, tuple[Any, tuple[float, float], tuple[float, float]]] = {
    "tanh": (torch.tanh, (-2.0, 2.0), (-1.0, 1.0)),
}
INITS = ("nguyen-widrow", "torch")
INPUT_SCALINGS = ("none", "standardize")
OUTPUT_KINDS = ("linear", "logit")


# --------------------------------------------------------------------------------------------
# Configuration
# --------------------------------------------------------------------------------------------


@dataclass
class MLPConfig:
    """Architecture and input/output conventions of a `SubspaceMLP`.

    Attributes
    ----------
    n_inputs
        features per sample in the stored layout the model is fed (84 for the 21³
        grid: `[d_1..d_6, a_1..a_6, alpha_1..alpha_6, nx, ny, nz, fixed(3)]`).
    n_outputs
        outputs (nodes) per subspace, `m`.
    hidden
        hidden layer widths (the paper: `[125, 100, 100, 125]`).
    activation
        hidden activation, `"tanh"` (MATLAB `tansig`).
    init
        `"nguyen-widrow"` (MATLAB `initnw`) or `"torch"` (`nn.Linear` default).
    input_columns
        indices into the stored features that feed the first layer, in that
        order; `None`: all `n_inputs`.
    input_scaling
        `"none"` (the paper: raw inputs) or `"standardize"` (per-subspace mean
        and std, from training data, stored as buffers).
    n_subspaces
        S, parameter sets held by the model.
    output_kind
        `"linear"` (MSE/MAE-trained: threshold the raw output) or `"logit"`
        (cross-entropy-trained: threshold `sigmoid(raw)`).
    """

    n_inputs: int
    n_outputs: int
    hidden: list[int] = field(default_factory=lambda: [125, 100, 100, 125])
    activation: str = "tanh"
    init: str = "nguyen-widrow"
    input_columns: list[int] | None = None
    input_scaling: str = "none"
    n_subspaces: int = 1
    output_kind: str = "linear"

    def __post_init__(self):
        def positive_int(name, v):
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
                raise ValueError(f"MLPConfig.{name} must be a positive integer; got {v!r}")
            return int(v)

        self.n_inputs = positive_int("n_inputs", self.n_inputs)
        self.n_outputs = positive_int("n_outputs", self.n_outputs)
        self.n_subspaces = positive_int("n_subspaces", self.n_subspaces)
        self.hidden = [positive_int("hidden", h) for h in self.hidden]
        for name, value, choices in (("activation", self.activation, tuple(ACTIVATIONS)),
                                     ("init", self.init, INITS),
                                     ("input_scaling", self.input_scaling, INPUT_SCALINGS),
                                     ("output_kind", self.output_kind, OUTPUT_KINDS)):
            if value not in choices:
                raise ValueError(f"MLPConfig.{name} must be one of {list(choices)}; got {value!r}")
        if self.input_columns is not None:
            cols = list(self.input_columns)
            if not cols:
                raise ValueError("MLPConfig.input_columns must not be empty (None: all features)")
            bad = [c for c in cols if isinstance(c, bool) or not isinstance(c, (int, np.integer))
                   or not 0 <= c < self.n_inputs]
            if bad:
                raise ValueError(f"MLPConfig.input_columns must be integers in [0, {self.n_inputs}); got {bad}")
            if len(set(int(c) for c in cols)) != len(cols):
                raise ValueError("MLPConfig.input_columns has repeated columns")
            self.input_columns = [int(c) for c in cols]

    @property
    def n_network_inputs(self) -> int:
        """Width of the first layer's input: `len(input_columns)` or `n_inputs`."""
        return self.n_inputs if self.input_columns is None else len(self.input_columns)

    @property
    def layer_sizes(self) -> list[int]:
        """`[n_network_inputs, *hidden, n_outputs]`."""
        return [self.n_network_inputs, *self.hidden, self.n_outputs]

    def to_dict(self) -> dict[str, Any]:
        """Plain dict (JSON/YAML and `weights_only` friendly)."""
        d = dataclasses.asdict(self)
        d["hidden"] = list(self.hidden)
        d["input_columns"] = None if self.input_columns is None else list(self.input_columns)
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> MLPConfig:
        """Inverse of `to_dict`; unknown or missing keys raise `ValueError`."""
        if not isinstance(d, dict):
            raise ValueError(f"MLPConfig.from_dict needs a dict; got {type(d).__name__}")
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = set(d) - names
        if unknown:
            raise ValueError(f"unknown MLPConfig keys {sorted(unknown)}; known: {sorted(names)}")
        missing = {"n_inputs", "n_outputs"} - set(d)
        if missing:
            raise ValueError(f"MLPConfig needs {sorted(missing)}")
        return cls(**d)

    def replace(self, **changes) -> MLPConfig:
        return dataclasses.replace(self, **changes)


def _n_features(features) -> int:
    shape = features.shape if hasattr(features, "shape") else np.shape(features)
    if len(shape) == 0:
        raise ValueError("features must be an array (n, f); got a scalar")
    return int(shape[-1])


def check_features(model: SubspaceMLP | MLPConfig, features: ArrayLike) -> None:
    """Raise `ValueError("model expects 84 features, got 83")` unless the last axis of
    `features` has `config.n_inputs` entries (the stored feature layout)."""
    config = model if isinstance(model, MLPConfig) else model.config
    f = _n_features(features)
    if f != config.n_inputs:
        raise ValueError(f"model expects {config.n_inputs} features, got {f}")


class SubspaceMLP(nn.Module):
    """S tanh MLPs with identical architecture, stacked: `weights[j]` is `(S, in_j, out_j)`,
    `biases[j]` `(S, out_j)`; buffers `input_mean`/`input_std` `(S, n_network_inputs)`.

    Parameters
    ----------
    config
        `MLPConfig`.
    input_range
        first-layer input ranges for Nguyen–Widrow (see `reset_parameters`).
    seeds
        one seed per subspace; subspace `s` is then initialised from
        `torch.Generator().manual_seed(seeds[s])` alone, so a stack built with `seeds`
        equals the single models built with `[seeds[s]]` (and `from_models` of them).
        `None`: the global torch RNG, subspace 0 first.

    Notes
    -----
    Shapes: `n` samples, `f = config.n_inputs` stored features, `m = config.n_outputs`.
    """

    def __init__(self, config: MLPConfig, *, input_range: ArrayLike | None = None, seeds: Sequence[int] | None = None,
                 _init: bool = True):
        super().__init__()
        if not isinstance(config, MLPConfig):
            raise TypeError(f"config must be an MLPConfig; got {type(config).__name__}")
        self.config = config
        S, sizes = config.n_subspaces, config.layer_sizes
        self.weights = nn.ParameterList(
            [nn.Parameter(torch.zeros(S, i, o, dtype=torch.float32)) for i, o in zip(sizes[:-1], sizes[1:])])
        self.biases = nn.ParameterList([nn.Parameter(torch.zeros(S, o, dtype=torch.float32)) for o in sizes[1:]])
        self.register_buffer("input_mean", torch.zeros(S, sizes[0], dtype=torch.float32))
        self.register_buffer("input_std", torch.ones(S, sizes[0], dtype=torch.float32))
        cols = config.input_columns
        # Derived from the config, so not part of the saved state; a buffer only to follow .to().
        self.register_buffer("_columns", None if cols is None else torch.tensor(cols, dtype=torch.long),
                             persistent=False)
        self._map_spec: dict[str, Any] | None = None
        self._map_plan: MapPlan | None = None
        self._training_range: TrainingRange | None = None
        if _init:
            self.reset_parameters(input_range=input_range, seeds=seeds)

    # ---------------------------------------------------------------- properties

    @property
    def n_subspaces(self) -> int:
        return self.config.n_subspaces

    @property
    def n_layers(self) -> int:
        return len(self.weights)

    def extra_repr(self) -> str:
        c = self.config
        return (f"S={c.n_subspaces}, sizes={c.layer_sizes}, activation={c.activation}, init={c.init}, "
                f"n_inputs={c.n_inputs}, input_scaling={c.input_scaling}, output_kind={c.output_kind}")

    # ---------------------------------------------------------------- initialisation

    def _generators(self, seeds) -> list[torch.Generator | None]:
        S = self.n_subspaces
        if seeds is None:
            return [None] * S
        seeds = [int(s) for s in seeds]
        if len(seeds) != S:
            raise ValueError(f"need one seed per subspace: {S} subspaces, got {len(seeds)} seeds")
        return [torch.Generator().manual_seed(s) for s in seeds]

    def reset_parameters(self, input_range: ArrayLike | None = None, seeds: Sequence[int] | None = None) -> None:
        """Initialise every subspace per `config.init` (module docstring).

        `input_range`: `(n_network_inputs, 2)` rows `[min, max]` of the first layer's
        inputs as it sees them (after column selection and scaling), or `(n_inputs, 2)` in the
        stored layout (the selected rows are used), or `(2,)` for all; `None`: `[-1, 1]`.
        Hidden layers after the first see tanh outputs, range `[-1, 1]`. Draw order: subspace
        by subspace, layer by layer, weights then biases.
        """
        cfg = self.config
        gens = self._generators(seeds)
        n_net = cfg.n_network_inputs
        if input_range is not None and cfg.input_columns is not None:
            arr = to_numpy(input_range)
            if arr.shape == (cfg.n_inputs, 2) and cfg.n_inputs != n_net:
                input_range = arr[cfg.input_columns]
        first_range = input_range_array(input_range, n_net)
        _, active, out_range = ACTIVATIONS[cfg.activation]
        last = self.n_layers - 1
        with torch.no_grad():
            for s, gen in enumerate(gens):
                for j, (W, b) in enumerate(zip(self.weights, self.biases)):
                    if cfg.init == "torch":
                        torch_default_(W[s], b[s], generator=gen)
                    elif j == last:
                        matlab_rands_(W[s], b[s], generator=gen)
                    else:
                        pr = first_range if j == 0 else np.tile(out_range, (W.shape[1], 1))
                        nguyen_widrow_(W[s], b[s], pr, active_range=active, generator=gen)

    # ---------------------------------------------------------------- input handling

    def _as_tensor(self, x) -> torch.Tensor:
        if not isinstance(x, torch.Tensor):
            x = torch.as_tensor(np.asarray(x))
        if x.ndim not in (2, 3):
            raise ValueError(f"features must be (n, f) or (S, n, f); got shape {tuple(x.shape)}")
        check_features(self, x)
        ref = self.weights[0]
        x = x.to(device=ref.device, dtype=ref.dtype)
        if self._columns is not None:
            x = x.index_select(-1, self._columns)
        return x

    def _select_stats(self, values, name: str) -> torch.Tensor:
        cfg, S = self.config, self.n_subspaces
        t = torch.as_tensor(to_numpy(values), dtype=torch.float64)
        if t.ndim == 1:
            t = t.expand(S, -1)
        if t.ndim != 2 or t.shape[0] != S:
            raise ValueError(f"{name} must be (f,) or (S, f) with S = {S}; got shape {tuple(t.shape)}")
        f = t.shape[1]
        if cfg.input_columns is not None and f == cfg.n_inputs and f != cfg.n_network_inputs:
            t = t[:, cfg.input_columns]
        elif f != cfg.n_network_inputs:
            raise ValueError(f"{name} needs {cfg.n_network_inputs} (network inputs) or {cfg.n_inputs} "
                             f"(stored features) columns; got {f}")
        return t

    def set_input_stats(self, mean: ArrayLike, std: ArrayLike) -> None:
        """Store the standardisation `z = (x - mean) / std` of the first layer's inputs.

        `mean`, `std`: `(f,)` (all subspaces) or `(S, f)`, with `f` either the stored
        feature count (the `input_columns` are taken) or the network input count. `std` must
        be positive and finite. Only with `config.input_scaling == "standardize"`.
        """
        if self.config.input_scaling != "standardize":
            raise ValueError(f"input_scaling is {self.config.input_scaling!r}: the model does not use input stats")
        mean, std = self._select_stats(mean, "mean"), self._select_stats(std, "std")
        if not torch.isfinite(mean).all():
            raise ValueError("input mean must be finite")
        if not (torch.isfinite(std).all() and (std > 0).all()):
            raise ValueError("input std must be positive and finite")
        with torch.no_grad():
            self.input_mean.copy_(mean)
            self.input_std.copy_(std)

    @staticmethod
    def input_stats_from(x) -> tuple[np.ndarray, np.ndarray]:
        """Mean and population std (ddof 0) per column of `x` `(n, f)`, float64.

        A constant column (max == min) gets its value as mean and std 1, so it standardises to
        exactly 0 (a computed std of a constant column is rounding noise, and dividing by it
        would amplify noise).
        """
        x = np.asarray(to_numpy(x), dtype=np.float64)
        if x.ndim != 2 or x.shape[0] == 0:
            raise ValueError(f"need (n, f) data with n >= 1; got shape {x.shape}")
        const = x.max(axis=0) == x.min(axis=0)
        mean = np.where(const, x[0], x.mean(axis=0))
        std = np.where(const, 1.0, x.std(axis=0))
        std = np.where(std > 0, std, 1.0)
        return mean, std

    def network_inputs(self, x: torch.Tensor, key: int | None = None) -> torch.Tensor:
        """The first layer's inputs: `x` (stored layout) after column selection and scaling.

        `key=None`: `(S, n, f_net)` (`(n, f_net)` copies per subspace stats); an int key:
        `(n, f_net)` for that subspace.
        """
        x = self._as_tensor(x)
        if key is None:
            return self._scale(x, None)
        return self._scale(x, self._check_key(key))

    def _scale(self, x: torch.Tensor, k: int | None) -> torch.Tensor:
        if self.config.input_scaling == "none":
            return x if (k is not None or x.ndim == 3) else x.expand(self.n_subspaces, *x.shape)
        if k is None:
            return (x - self.input_mean.unsqueeze(1)) / self.input_std.unsqueeze(1)
        return (x - self.input_mean[k]) / self.input_std[k]

    def configure(self, x: torch.Tensor, *, seeds: Sequence[int] | None = None) -> SubspaceMLP:
        """Set up from training features `x` `(n, n_inputs)`, as MATLAB's `configure` +
        `init`: with `"standardize"` set the input stats from `x` (`input_stats_from`,
        same for all subspaces), then re-initialise with the first layer's input range taken as
        the per-column min/max of the network inputs over `x` (constant columns get zero
        Nguyen–Widrow weights and do not count in `H**(1/r)`). Pass the training split (MATLAB
        configures on everything given to `train`; for the paper's raw inputs the min/max
        barely differ). `seeds` as in the constructor (the draws restart from them, so
        `SubspaceMLP(c, seeds=sd).configure(x, seeds=sd)` is reproducible).

        It also records `training_range`, the min/max of every stored feature over `x`
        (the arms the model is trained on), which `predict_maps` checks arms against and
        `wsmap.learn.files.save` writes into the model file. Returns `self`.
        """
        arr = np.asarray(to_numpy(x), dtype=np.float64)
        if arr.ndim != 2 or arr.shape[0] == 0:
            raise ValueError(f"configure needs (n, f) features with n >= 1; got shape {arr.shape}")
        check_features(self, arr)
        training_range = TrainingRange.from_features(arr)  # refuses NaN / inf features
        cfg = self.config
        if cfg.input_columns is not None:
            arr = arr[:, cfg.input_columns]
        if cfg.input_scaling == "standardize":
            mean, std = self.input_stats_from(arr)
            self.set_input_stats(mean, std)
            # The stats as stored (float32), so the range matches what the layer will see.
            mean = self.input_mean[0].double().cpu().numpy()
            std = self.input_std[0].double().cpu().numpy()
            arr = (arr - mean) / std
        self.reset_parameters(input_range=np.stack([arr.min(axis=0), arr.max(axis=0)], axis=1), seeds=seeds)
        self._training_range = training_range
        return self

    # ---------------------------------------------------------------- forward

    def _check_key(self, key) -> int:
        S = self.n_subspaces
        if isinstance(key, torch.Tensor):
            key = key.item()
        if isinstance(key, bool) or not isinstance(key, (int, np.integer)) or not 0 <= key < S:
            raise ValueError(f"unknown subspace key {key!r}: the model has {S} subspace(s), keys 0..{S - 1}")
        return int(key)

    def _run_all(self, x: torch.Tensor) -> torch.Tensor:
        """x `(n, f_net)` or `(S, n, f_net)` -> `(S, n, m)`."""
        h = self._scale(x, None)
        act = ACTIVATIONS[self.config.activation][0]
        last = self.n_layers - 1
        for j, (W, b) in enumerate(zip(self.weights, self.biases)):
            h = torch.baddbmm(b.unsqueeze(1), h, W)
            if j < last:
                h = act(h)
        return h

    def _run_one(self, x: torch.Tensor, k: int, hidden: list | None = None) -> torch.Tensor:
        """x `(n, f_net)` through subspace `k` -> `(n, m)`; each hidden layer's outputs
        `(n, h_j)` are appended to `hidden` when given."""
        h = self._scale(x, k)
        act = ACTIVATIONS[self.config.activation][0]
        last = self.n_layers - 1
        for j, (W, b) in enumerate(zip(self.weights, self.biases)):
            h = torch.addmm(b[k], h, W[k])
            if j < last:
                h = act(h)
                if hidden is not None:
                    hidden.append(h)
        return h

    def hidden_outputs(self, x: torch.Tensor, key: int = 0) -> list[torch.Tensor]:
        """The outputs of every hidden layer of subspace `key` for features `x` (stored
        layout, `(n, f)`): a list of `(n, h_j)` tensors, no gradient."""
        x = self._as_tensor(x)
        if x.ndim != 2:
            raise ValueError(f"hidden_outputs needs (n, f) features; got shape {tuple(x.shape)}")
        hidden: list[torch.Tensor] = []
        with torch.no_grad():
            self._run_one(x, self._check_key(key), hidden)
        return hidden

    def forward(self, x: torch.Tensor, key: str | None = None) -> torch.Tensor:
        """Raw outputs.

        Parameters
        ----------
        x
            features in the stored layout (torch or numpy; cast to the parameters' dtype):
            `(n, f)` shared by all subspaces, or `(S, n, f)` one batch per subspace
            (only with `key=None`).
        key
            `None`: all subspaces -> `(S, n, m)` (also for S = 1). An int `k`:
            subspace `k` only -> `(n, m)`. Per-sample keys `(n,)` (integer tensor,
            array or list): sample `i` through subspace `key[i]` -> `(n, m)`, one
            batched pass per distinct key.

        Raises
        ------
        ValueError
            wrong feature count, wrong shape, unknown key.
        """
        x = self._as_tensor(x)
        if key is None:
            if x.ndim == 3 and x.shape[0] != self.n_subspaces:
                raise ValueError(f"(S, n, f) input needs S = {self.n_subspaces}; got {x.shape[0]}")
            return self._run_all(x)
        if x.ndim != 2:
            raise ValueError(f"with a key, features must be (n, f); got shape {tuple(x.shape)}")
        if isinstance(key, (int, np.integer)) or (isinstance(key, torch.Tensor) and key.ndim == 0):
            return self._run_one(x, self._check_key(key))
        keys = key if isinstance(key, torch.Tensor) else torch.as_tensor(np.asarray(key))
        if keys.ndim != 1 or keys.shape[0] != x.shape[0]:
            raise ValueError(f"per-sample keys must be ({x.shape[0]},); got shape {tuple(keys.shape)}")
        if keys.dtype.is_floating_point or keys.dtype.is_complex or keys.dtype == torch.bool:
            raise ValueError(f"subspace keys must be integers; got dtype {keys.dtype}")
        keys = keys.to(device=x.device, dtype=torch.long)
        if x.shape[0] == 0:
            return x.new_zeros(0, self.config.n_outputs)
        bad = keys[(keys < 0) | (keys >= self.n_subspaces)]
        if bad.numel():
            self._check_key(int(bad[0]))
        uniq, inverse = torch.unique(keys, return_inverse=True)
        parts, order = [], []
        for j, k in enumerate(uniq.tolist()):
            idx = torch.nonzero(inverse == j).squeeze(1)
            parts.append(self._run_one(x[idx], k))
            order.append(idx)
        # Concatenate the groups and undo the grouping permutation (autograd-friendly).
        return torch.cat(parts)[torch.argsort(torch.cat(order))]

    def assemble(self, x: torch.Tensor) -> torch.Tensor:
        """All S subspaces on the same `x` `(n, f)`, concatenated along the node axis:
        `(n, S*m)`, subspace 0's `m` nodes first (section 6.2: 7 block models of 1323 nodes
        give the 9261-node map in node order)."""
        x = self._as_tensor(x)
        if x.ndim != 2:
            raise ValueError(f"assemble needs features (n, f) shared by all subspaces; got shape {tuple(x.shape)}")
        out = self._run_all(x)
        S, n, m = out.shape
        return out.permute(1, 0, 2).reshape(n, S * m)

    # ---------------------------------------------------------------- prediction

    def _batched(self, fn, x, batch_size):
        batch_size = check_batch_size(batch_size)
        if batch_size is None:
            return fn(x)
        n = x.shape[-2]
        outs = [fn(x[..., i:i + batch_size, :]) for i in range(0, n, batch_size)]
        return torch.cat(outs, dim=-2) if outs else fn(x)

    def score(self, x: torch.Tensor, key: str | None = None, *, assemble: bool = False, batch_size: int | None = None
             ) -> torch.Tensor:
        """The thresholded quantity, without gradients: the raw output (`output_kind
        "linear"`) or `sigmoid(raw)` (`"logit"`). Shapes as `forward`, or as
        `assemble` with `assemble=True`. `batch_size`: samples per pass (memory).
        Features with NaN or infinite values raise `ValueError` (they would give NaN scores,
        which no threshold counts as reachable: a silently empty map)."""
        if assemble and key is not None:
            raise ValueError("assemble runs all subspaces: give no key")
        batch_size = check_batch_size(batch_size)
        x = x if isinstance(x, torch.Tensor) else torch.as_tensor(np.asarray(x))
        if (x.is_floating_point() or x.is_complex()) and not bool(torch.isfinite(x).all()):
            rows = torch.nonzero(~torch.isfinite(x).reshape(-1, x.shape[-1]).all(dim=-1)).reshape(-1)
            raise ValueError(f"features contain NaN or infinite values (rows {rows[:5].tolist()})")
        if batch_size is not None and key is not None and not isinstance(key, (int, np.integer)):
            # Per-sample keys have to be chunked with the samples.
            keys = key if isinstance(key, torch.Tensor) else torch.as_tensor(np.asarray(key))
            if keys.ndim == 1:
                return torch.cat([self.score(x[i:i + batch_size], keys[i:i + batch_size])
                                  for i in range(0, x.shape[0], batch_size)] or [self.score(x, keys)])
        with torch.no_grad():
            def run(chunk):
                out = self.assemble(chunk) if assemble else self.forward(chunk, key)
                return torch.sigmoid(out) if self.config.output_kind == "logit" else out

            return self._batched(run, x, batch_size)

    def predict(self, x: torch.Tensor, threshold: float = 0.5, key: str | None = None, *, assemble: bool = False,
                batch_size: int | None = None) -> torch.Tensor:
        """Binary map(s): `score > threshold` (bool tensor; shapes as `score`).

        `output_kind "linear"`: raw output > threshold (the paper: 0.5). `"logit"`:
        `sigmoid(raw) > threshold`, i.e. `raw > logit(threshold)`. Use `.numpy()` for numpy.
        `threshold` must lie in (0, 1) (`ValueError` otherwise).
        """
        threshold = check_threshold(threshold)
        return self.score(x, key, assemble=assemble, batch_size=batch_size) > threshold

    # ---------------------------------------------------------------- maps of arms

    @property
    def map_spec(self) -> dict[str, Any] | None:
        """What the outputs map (module docstring), a plain dict (a copy), or `None`.

        Assigning a dict validates it against the model (`ValueError` if it does not fit) and
        stores its normalised form (`nodes` filled in, `threshold` a float); `None` clears it.
        """
        return None if self._map_spec is None else {**self._map_spec, "dataset": dict(self._map_spec["dataset"]),
                                                    "nodes": list(self._map_spec["nodes"])}

    @map_spec.setter
    def map_spec(self, value) -> None:
        if value is None:
            self._map_spec, self._map_plan = None, None
        else:
            self._map_spec, self._map_plan = map_plan(self.config, value)

    def set_map_spec(self, dataset: Dataset, *, nodes: ArrayLike | None = None, assemble: bool = False,
                     subspace: int | None = None, threshold: float = 0.5) -> SubspaceMLP:
        """Say what the model maps (arguments as `make_map_spec`); returns `self`.

        Examples: a model trained on all nodes of `spec`: `set_map_spec(spec)`; one block
        model trained on columns `[5292, 6615)` of the 21³ `sec62` labels:
        `set_map_spec(sec62, nodes=(5292, 6615))`; the 7 stacked block models:
        `set_map_spec(sec62, assemble=True)`.
        """
        self.map_spec = make_map_spec(dataset, nodes=nodes, assemble=assemble, subspace=subspace,
                                      threshold=threshold)
        return self

    def _require_plan(self) -> MapPlan:
        if self._map_plan is None:
            raise ValueError("the model has no map_spec (what grid and nodes its outputs are): call "
                             "model.set_map_spec(dataset_spec, ...) before predicting maps")
        return self._map_plan

    def map_nodes(self) -> np.ndarray:
        """The nodes the maps cover `(N, 3)` in output order: positions in metres (R3 specs) or
        angles in radians (SO3 specs); `N = stop - start` of `map_spec["nodes"]`."""
        plan = self._require_plan()
        return grid_nodes(plan.spec)[plan.nodes]

    def map_features(self, arms: Arm | ArrayLike, fixed: ArrayLike | None = None) -> np.ndarray:
        """Features `(B, n_inputs)` float64 of `arms` (a `DHRobot`, one
        arm or a batch of any shape, flattened to `B` arms) for the map's dataset spec, with the
        checks of `predict_maps` except the training range
        (`wsmap.learn.mapspec.map_features`)."""
        X = map_features(self._require_plan(), arms, fixed)
        check_features(self, X)
        return X

    # ---------------------------------------------------------------- the training range

    @property
    def training_range(self) -> TrainingRange | None:
        """The range of every stored feature over the training data
        (`TrainingRange`), or `None` when unknown.

        Set by `configure` and by `wsmap.learn.files.load`; assign a
        `TrainingRange` (or `None`), or use `set_training_range`. Kept by
        `subspace`; `from_models` keeps the intersection of the models' ranges.
        """
        return self._training_range

    @training_range.setter
    def training_range(self, value) -> None:
        if value is not None:
            if not isinstance(value, TrainingRange):
                raise TypeError(f"training_range must be a TrainingRange or None; got {type(value).__name__} "
                                "(use set_training_range(features) for data)")
            if value.n_features != self.config.n_inputs:
                raise ValueError(f"training range has {value.n_features} features, the model expects "
                                 f"{self.config.n_inputs}")
        self._training_range = value

    def set_training_range(self, data: ArrayLike | Dataset | Any) -> SubspaceMLP:
        """Record the training range from `data`: training features `(n, n_inputs)` (numpy or
        torch), an object with such `.features` (a `wsmap.datasets.Dataset`), or a
        `TrainingRange`. Returns `self`."""
        self.training_range = training_range_of(data)
        return self

    def check_training_range(self, features: ArrayLike, *, allow_extrapolation: bool = False) -> None:
        """Refuse feature rows `(n, n_inputs)` outside `training_range`
        (`ExtrapolationError`, a `ValueError` naming the
        parameter, the value and the trained range), or warn
        (`ExtrapolationWarning`) with `allow_extrapolation`.
        A model without a training range refuses unless `allow_extrapolation`."""
        rng = self._training_range
        if rng is None:
            check_no_range(allow_extrapolation)
            return
        if not rng.outside(features).any():  # the common case, without building names
            return
        names = None
        if rng.names is None and self._map_plan is not None:
            names = feature_names(self._map_plan.spec)
        what = "the model"
        if self._map_plan is not None:
            what = f"the model (trained on dataset {self._map_plan.spec.name!r})"
        rng.check(features, names=names, allow_extrapolation=allow_extrapolation, what=what)

    def predict_maps(self, arms: Arm | ArrayLike, fixed: ArrayLike | None = None, threshold: float | None = None,
                     batch_size: int | None = None, *, allow_extrapolation: bool = False) -> np.ndarray:
        """Binary workspace maps of `arms` predicted by the network, in node order.

        Parameters
        ----------
        arms
            a `DHRobot` with 6 joints: one arm (batch `()`) or a
            batch of any shape `(...)`; finite DH values, no joint limits, no tool.
        fixed
            the orientation (R3 specs; angles in rad) or point (SO3 specs; m), `(3,)` or
            `(B, 3)`. `None`: the spec's. Required for a spec with `fixed="random"`;
            for a fixed spec it must equal the spec's (the model has seen no other).
        threshold
            score threshold in (0, 1); `None`: `map_spec["threshold"]`.
        batch_size
            arms per forward pass (memory); `None`: all at once.
        allow_extrapolation
            predict for arms outside `training_range` (or with a model
            that records none) with an `ExtrapolationWarning`
            instead of refusing them.

        Returns
        -------
        np.ndarray
            bool `(..., N)` with `N` the covered nodes (`map_nodes`): for a model covering
            its whole R3 grid the array `wsmap.workspace.constant_orientation_map(arms,
            grid_nodes, fixed, convention=...)` would be (`orientation_map` for SO3), a
            single arm giving `(N,)`. Equal to `predict(features, threshold, key=subspace,
            assemble=...)` on `map_features`.

        Raises
        ------
        ExtrapolationError
            (a `ValueError`) arms outside the training range, or no training
            range, without `allow_extrapolation`.
        ValueError
            no `map_spec`; arms with other than 6 joints, non-finite DH values,
            joint limits or a tool; a `fixed` the model was not trained at; a threshold
            outside (0, 1); a bad `batch_size`.
        TypeError
            `arms` is not a `DHRobot`.
        """
        plan = self._require_plan()
        t = plan.threshold if threshold is None else check_threshold(threshold)
        batch_size = check_batch_size(batch_size)
        X = self.map_features(arms, fixed)
        self.check_training_range(X, allow_extrapolation=allow_extrapolation)
        out = self.predict(X, t, key=plan.key, assemble=plan.assemble, batch_size=batch_size)
        return out.cpu().numpy().reshape(map_batch_shape(arms, self._require_plan().spec) + (out.shape[-1],))

    # ---------------------------------------------------------------- stacking

    @classmethod
    def from_models(cls, models: Sequence[SubspaceMLP]) -> SubspaceMLP:
        """Stack separately trained models into one: their subspaces in order (a model with
        `S_i > 1` contributes all of its). Configs must agree except `n_subspaces`; dtype
        and device follow the first model. Parameters and input stats are copied; the training
        range is the intersection of the models' ranges (`None` if one has none, or if they do
        not overlap). The `map_spec` is not carried over (the stack maps something else)."""
        models = list(models)
        if not models:
            raise ValueError("from_models needs at least one model")
        base = models[0].config.to_dict()
        base.pop("n_subspaces")
        for i, mdl in enumerate(models):
            if not isinstance(mdl, SubspaceMLP):
                raise TypeError(f"model {i} is a {type(mdl).__name__}, not a SubspaceMLP")
            d = mdl.config.to_dict()
            d.pop("n_subspaces")
            diff = sorted(k for k in base if base[k] != d[k])
            if diff:
                raise ValueError(f"model {i} differs from model 0 in {diff}; only n_subspaces may differ")
        config = models[0].config.replace(n_subspaces=sum(m.n_subspaces for m in models))
        out = cls(config, _init=False)
        ref = models[0].weights[0]
        out.to(device=ref.device, dtype=ref.dtype)
        with torch.no_grad():
            for j in range(out.n_layers):
                out.weights[j].copy_(torch.cat([m.weights[j].detach() for m in models]))
                out.biases[j].copy_(torch.cat([m.biases[j].detach() for m in models]))
            out.input_mean.copy_(torch.cat([m.input_mean for m in models]))
            out.input_std.copy_(torch.cat([m.input_std for m in models]))
        ranges = [m.training_range for m in models]
        if all(r is not None for r in ranges):
            common = ranges[0]
            for r in ranges[1:]:
                common = common.intersect(r) if common is not None else None
            if common is None:
                warnings.warn("from_models: the models' training ranges do not overlap; the stack records no "
                              "training range", UserWarning, stacklevel=2)
            out._training_range = common
        return out

    def subspace(self, k: int) -> SubspaceMLP:
        """A copy of subspace `k` as a single-subspace model (S = 1), with the training range."""
        k = self._check_key(k)
        out = type(self)(self.config.replace(n_subspaces=1), _init=False)
        ref = self.weights[0]
        out.to(device=ref.device, dtype=ref.dtype)
        with torch.no_grad():
            for j in range(self.n_layers):
                out.weights[j].copy_(self.weights[j][k:k + 1])
                out.biases[j].copy_(self.biases[j][k:k + 1])
            out.input_mean.copy_(self.input_mean[k:k + 1])
            out.input_std.copy_(self.input_std[k:k + 1])
        out._training_range = self._training_range
        return out


def unit_saturation(model: SubspaceMLP, x: ArrayLike | torch.Tensor, key: int = 0, *, level: float = 0.99,
                    share: float = 0.95) -> list[dict[str, Any]]:
    """How saturated the tanh units of subspace `key` are on features `x` `(n, f)`.

    A unit's output is *saturated* on a sample when `|h| > level`; a unit is *constant* when it
    sits saturated at one sign (`h > level`, or `h < -level`) on at least `share` of the
    samples: it then passes almost nothing about the input to the next layer, and its gradient
    (`1 - h²` < `1 - level²`) almost vanishes there. Returns one dict per hidden layer
    (1-based `layer`): `units`, `saturated` (the share of unit–sample pairs saturated),
    `constant` (the share of units constant) and `active_units` (the units not constant).
    """
    if model.config.activation != "tanh":
        raise ValueError(f"unit_saturation reads tanh units; the model's activation is {model.config.activation!r}")
    if not (0.0 < level < 1.0 and 0.0 < share <= 1.0):
        raise ValueError(f"level must lie in (0, 1) and share in (0, 1]; got level={level!r}, share={share!r}")
    rows = []
    for j, h in enumerate(model.hidden_outputs(x, key), start=1):
        constant = ((h > level).float().mean(0) >= share) | ((h < -level).float().mean(0) >= share)
        rows.append({"layer": j, "units": int(h.shape[1]), "saturated": float((h.abs() > level).float().mean()),
                     "constant": float(constant.float().mean()), "active_units": int((~constant).sum())})
    return rows


def training_range_of(data) -> TrainingRange:
    """A `TrainingRange` from training features `(n, f)`, an
    object with `.features` (a dataset), or a `TrainingRange` (returned as is)."""
    if isinstance(data, TrainingRange):
        return data
    if data is None:
        raise ValueError("training data is None; give training features (n, f), a dataset or a TrainingRange")
    features = getattr(data, "features", data)
    names = None
    spec = getattr(data, "spec", None)
    if spec is not None:
        try:
            names = feature_names(spec)
        except (TypeError, ValueError, AttributeError):
            names = None
    rng = TrainingRange.from_features(to_numpy(features) if isinstance(features, torch.Tensor) else features)
    return rng.with_names(names) if names is not None and len(names) == rng.n_features else rng
