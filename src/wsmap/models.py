"""Subspace-learning networks: S fully connected tanh MLPs held as one stacked module.

The paper (section "Distinctions between Subspace Learning and Generic Feedforward Networks")
stores the parameters of all subspaces of a model as tensors whose last index is the subspace,
``W^{(j)}_{:,:,i}`` and ``B^{(j)}_{:,i}``, and builds the forward graph of subspace ``i`` at run
time. :class:`SubspaceMLP` does the same with the subspace index first:

* layer ``j``'s weights are one parameter ``(S, in_j, out_j)``, its biases ``(S, out_j)``;
* hidden layers are ``tanh``, the output layer is linear (MATLAB ``tansig`` / ``purelin``);
* ``forward(x)`` runs all S subspaces at once, ``forward(x, key=k)`` only subspace ``k`` and
  ``forward(x, key=keys)`` subspace ``keys[i]`` for sample ``i`` (no loop over samples: one
  batched pass per distinct key).

Every parameter has leading dimension S, so a :class:`SubspaceMLP` is a *stacked model* in the
sense of :mod:`wsmap.training`: ``train(model, X, Y)`` trains the S subspaces as independent
sessions (exactly independent under Rprop), and ``SubspaceMLP(config, seeds=[...])`` initialises
subspace ``s`` from ``seeds[s]`` alone, as ``train_sessions`` needs.

Features and outputs
--------------------
Inputs are feature vectors in the stored (paper) layout, ``(n, config.n_inputs)``, float64 on
disk; they are cast to the parameters' dtype (float32) inside :meth:`SubspaceMLP.forward`, which
then keeps ``config.input_columns`` (all columns when ``None``) and, with
``input_scaling="standardize"``, standardises them with the stored per-subspace mean and std
(buffers, saved with the model). The paper feeds raw inputs (``input_scaling="none"``).

Outputs are one raw value per node, ``(n, m)``. ``config.output_kind`` says how to read them:
``"linear"`` (trained with MSE/MAE, the paper's) -- the raw output is the score and a node is
reachable when it exceeds the threshold (0.5); ``"logit"`` (trained with cross-entropy on logits)
-- the score is ``sigmoid(raw)``, and ``score > t`` is ``raw > logit(t)``.
:meth:`SubspaceMLP.score` and :meth:`SubspaceMLP.predict` use that rule.

Initialisation
--------------
``config.init="nguyen-widrow"`` reproduces MATLAB's ``initnw`` (the default layer initialisation
of ``feedforwardnet``), see :func:`nguyen_widrow_`: hidden (tanh) layers get Nguyen–Widrow
weights computed from their input ranges, the linear output layer gets MATLAB's ``rands``
(uniform on ``[-1, 1]`` for weights and biases: ``initnw`` falls back to it for a transfer
function with an unbounded active input range such as ``purelin``). The first layer's input range
is ``[-1, 1]`` per input unless given; :meth:`SubspaceMLP.configure` takes it from training data,
as MATLAB's ``configure`` does (there it is the min/max of the processed inputs over the data
handed to ``train``). ``config.init="torch"`` is PyTorch's ``nn.Linear`` default
(``U(-1/sqrt(fan_in), 1/sqrt(fan_in))`` for weights and biases) in every layer.

Files
-----
:func:`save` writes one ``torch.save`` file (a dict: format tag, version, config dict, state dict,
dataset spec, training config, extras; only plain containers, numbers, strings and tensors, so
:func:`load` reads it with ``torch.load(weights_only=True)``), atomically: a temporary file beside
the target renamed over it. :func:`load` refuses a missing, truncated or corrupt file, a wrong
format tag or version, an invalid config, and a state that does not match the config, with a
``ValueError`` naming the path and the problem.

Predicting maps (the model standing in for the classical algorithm)
-------------------------------------------------------------------
A model that knows what it maps carries a *map description*, ``model.map_spec`` (``None`` when
absent; set it with :meth:`SubspaceMLP.set_map_spec`; saved and loaded with the model), a plain
dict::

    {"dataset": DatasetSpec.to_dict() of the spec it was trained on (grid, scope, fixed
                orientation or point, pose convention),
     "nodes": [start, stop],   # flat node indices of the spec's grid its outputs cover, in order
     "assemble": bool,         # True: the S subspaces are consecutive node blocks, concatenated
     "subspace": int | None,   # which subspace predicts when S > 1 and not assembled
     "threshold": float}       # score threshold (0.5, the paper's)

:meth:`SubspaceMLP.predict_maps` turns arms (:class:`wsmap.kinematics.DHRobot`) into features with
:func:`wsmap.data.features_for` and returns boolean maps in node order, the same array
:func:`wsmap.workspace.constant_orientation_map` (R3 specs) or
:func:`wsmap.workspace.orientation_map` (SO3 specs) returns for the covered nodes
(:meth:`SubspaceMLP.map_nodes`), up to the model's errors. :func:`predict_maps_from_file` does the
same from a saved model (``wsmap map --method model --model PATH``).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn

from . import __version__
from . import data as _data
from .io import atomic_path
from .kinematics import DHRobot

__all__ = [
    "ACTIVATIONS",
    "INITS",
    "INPUT_SCALINGS",
    "OUTPUT_KINDS",
    "FORMAT",
    "FORMAT_VERSION",
    "MLPConfig",
    "SubspaceMLP",
    "nguyen_widrow_",
    "matlab_rands_",
    "torch_default_",
    "check_features",
    "save",
    "load",
    "make_map_spec",
    "predict_maps_from_file",
]

#: Hidden-layer activations: name -> (function, active input range, output range). The ranges
#: are MATLAB's for ``tansig``: Nguyen–Widrow spreads each neuron's net input over the active
#: range ``[-2, 2]``; the next layer's inputs lie in the output range ``[-1, 1]``.
ACTIVATIONS: dict[str, tuple[Any, tuple[float, float], tuple[float, float]]] = {
    "tanh": (torch.tanh, (-2.0, 2.0), (-1.0, 1.0)),
}
INITS = ("nguyen-widrow", "torch")
INPUT_SCALINGS = ("none", "standardize")
OUTPUT_KINDS = ("linear", "logit")

FORMAT = "wsmap.subspace_mlp"
FORMAT_VERSION = 1


# --------------------------------------------------------------------------------------------
# Configuration
# --------------------------------------------------------------------------------------------


@dataclass
class MLPConfig:
    """Architecture and input/output conventions of a :class:`SubspaceMLP`.

    Attributes:
        n_inputs: features per sample in the stored layout the model is fed (84 for the 21³
            grid: ``[d_1..d_6, a_1..a_6, alpha_1..alpha_6, nx, ny, nz, fixed(3)]``).
        n_outputs: outputs (nodes) per subspace, ``m``.
        hidden: hidden layer widths (the paper: ``[125, 100, 100, 125]``).
        activation: hidden activation, ``"tanh"`` (MATLAB ``tansig``).
        init: ``"nguyen-widrow"`` (MATLAB ``initnw``) or ``"torch"`` (``nn.Linear`` default).
        input_columns: indices into the stored features that feed the first layer, in that
            order; ``None``: all ``n_inputs``.
        input_scaling: ``"none"`` (the paper: raw inputs) or ``"standardize"`` (per-subspace mean
            and std, from training data, stored as buffers).
        n_subspaces: S, parameter sets held by the model.
        output_kind: ``"linear"`` (MSE/MAE-trained: threshold the raw output) or ``"logit"``
            (cross-entropy-trained: threshold ``sigmoid(raw)``).
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
        """Width of the first layer's input: ``len(input_columns)`` or ``n_inputs``."""
        return self.n_inputs if self.input_columns is None else len(self.input_columns)

    @property
    def layer_sizes(self) -> list[int]:
        """``[n_network_inputs, *hidden, n_outputs]``."""
        return [self.n_network_inputs, *self.hidden, self.n_outputs]

    def to_dict(self) -> dict[str, Any]:
        """Plain dict (JSON/YAML and ``weights_only`` friendly)."""
        d = dataclasses.asdict(self)
        d["hidden"] = list(self.hidden)
        d["input_columns"] = None if self.input_columns is None else list(self.input_columns)
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> MLPConfig:
        """Inverse of :meth:`to_dict`; unknown or missing keys raise ``ValueError``."""
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


# --------------------------------------------------------------------------------------------
# Initialisation
# --------------------------------------------------------------------------------------------


def _to_numpy(a) -> np.ndarray:
    return a.detach().cpu().numpy() if isinstance(a, torch.Tensor) else np.asarray(a)


def _input_range_array(input_range, n_in: int) -> np.ndarray:
    """``input_range`` as float64 ``(n_in, 2)`` rows ``[min, max]``; ``None`` -> ``[-1, 1]``."""
    if input_range is None:
        return np.tile([-1.0, 1.0], (n_in, 1))
    pr = np.asarray(_to_numpy(input_range), dtype=np.float64)
    if pr.shape == (2,):
        pr = np.tile(pr, (n_in, 1))
    if pr.shape != (n_in, 2):
        raise ValueError(f"input_range must be (in, 2) = ({n_in}, 2) or (2,); got shape {pr.shape}")
    if np.any(pr[:, 0] > pr[:, 1]):
        raise ValueError("input_range rows must be [min, max] with min <= max")
    return pr


def _rands(shape, generator) -> torch.Tensor:
    """MATLAB ``rands``: uniform on ``[-1, 1]``, float64."""
    return torch.rand(shape, generator=generator, dtype=torch.float64) * 2 - 1


def _calcnw(s: int, pr: np.ndarray, active: tuple[float, float], generator) -> tuple[torch.Tensor, torch.Tensor]:
    """MATLAB ``initnw``'s ``calcnw`` for ``s`` neurons: weights ``(s, R)`` and biases ``(s,)``, float64.

    ``pr``: ``(R, 2)`` input ranges; ``active``: the transfer function's active input range.
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
    """Normalise the (layer | weight, bias) arguments: list of ``(w_view (out, in), b_view (out,))``.

    ``nn.Linear``: its ``weight`` ``(out, in)`` and ``bias``. A tensor: the stacked layout
    ``(in, out)`` or ``(S, in, out)``, bias ``(out,)`` or ``(S, out)``.
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


def nguyen_widrow_(linear_or_weight, bias: torch.Tensor | None = None, input_range=None, *,
                   active_range: tuple[float, float] = (-2.0, 2.0),
                   generator: torch.Generator | None = None) -> tuple[torch.Tensor, torch.Tensor]:
    """Nguyen–Widrow initialisation in place, as MATLAB's ``initnw`` (``calcnw``) for a tanh layer.

    Args:
        linear_or_weight: an ``nn.Linear`` (weight ``(H, N)``; its own bias unless ``bias`` is
            given), or a weight tensor in :class:`SubspaceMLP`'s layout, ``(N, H)`` or stacked
            ``(S, N, H)`` (each of the S slices gets its own random draw, in order).
        bias: the bias, ``(H,)`` or ``(S, H)``; required with a weight tensor.
        input_range: ``(N, 2)`` rows ``[min, max]`` of each input (torch or numpy), or ``(2,)``
            for all; ``None``: ``[-1, 1]`` for every input. MATLAB uses the min/max over the
            training inputs (after input processing) for the first layer and the previous
            layer's output range ([-1, 1] for tansig) for the others.
        active_range: the net-input interval to spread the neurons over; MATLAB's ``tansig``
            active input range is ``[-2, 2]`` (``logsig``: ``[-4, 4]``).
        generator: random source (default: the global torch RNG).

    What is computed, for ``H`` neurons and the ``r`` inputs whose range is not a single point
    (constant inputs get weight 0 and do not count; a non-finite range counts as ``[0, 1]``):

    1. ``beta = 0.7 * H**(1/r)``; each neuron's weight row is ``beta * u / |u|`` with ``u``
       uniform on ``[-1, 1]^r`` (MATLAB ``randnr``); biases ``beta * linspace(-1, 1, H) *
       sign(w[:, 0])`` (0 when ``H == 1``). This places the neurons for inputs in ``[-1, 1]``
       and net inputs in ``[-1, 1]``.
    2. Scale to the active range ``[lo, hi]``: ``w *= (hi - lo)/2``, ``b = b (hi - lo)/2 +
       (hi + lo)/2``. For tanh, each row then has norm ``1.4 * H**(1/r)``.
    3. Map each input's ``[min, max]`` onto ``[-1, 1]``: with ``s_i = 2/(max_i - min_i)`` and
       ``c_i = 1 - max_i s_i``, ``b += w @ c`` and ``w[:, i] *= s_i``. Hence on an input at the
       centre of its range the net input is ``b`` of step 2, and ``w[:, i] * (max_i - min_i)/2``
       has the row norms of step 2.

    Computed in float64 and copied into the tensors (any dtype). Returns ``(weight, bias)``.
    """
    weight, bias, slices = _as_weight_bias(linear_or_weight, bias, "nguyen_widrow_")
    n_in = slices[0][0].shape[1]
    pr = _input_range_array(input_range, n_in)
    with torch.no_grad():
        for w_view, b_view in slices:
            w, b = _calcnw(w_view.shape[0], pr, active_range, generator)
            w_view.copy_(w)
            b_view.copy_(b)
    return weight, bias


def matlab_rands_(linear_or_weight, bias: torch.Tensor | None = None, *,
                  generator: torch.Generator | None = None) -> tuple[torch.Tensor, torch.Tensor]:
    """MATLAB ``rands`` in place: weights and biases uniform on ``[-1, 1]``.

    ``initnw`` uses this for layers whose transfer function has an unbounded active input range
    (the linear ``purelin`` output layer). Same argument layouts as :func:`nguyen_widrow_`; per
    slice the weights ``(H, N)`` are drawn first (MATLAB's row order), then the biases.
    """
    weight, bias, slices = _as_weight_bias(linear_or_weight, bias, "matlab_rands_")
    with torch.no_grad():
        for w_view, b_view in slices:
            w_view.copy_(_rands(tuple(w_view.shape), generator))
            b_view.copy_(_rands(tuple(b_view.shape), generator))
    return weight, bias


def torch_default_(linear_or_weight, bias: torch.Tensor | None = None, *,
                   generator: torch.Generator | None = None) -> tuple[torch.Tensor, torch.Tensor]:
    """PyTorch's ``nn.Linear`` default in place: weights and biases ``U(-1/sqrt(N), 1/sqrt(N))``.

    (``kaiming_uniform_(a=sqrt(5))`` on the weight gives exactly that bound.) Same layouts as
    :func:`nguyen_widrow_`.
    """
    weight, bias, slices = _as_weight_bias(linear_or_weight, bias, "torch_default_")
    with torch.no_grad():
        for w_view, b_view in slices:
            bound = 1.0 / math.sqrt(w_view.shape[1])
            w_view.copy_(_rands(tuple(w_view.shape), generator) * bound)
            b_view.copy_(_rands(tuple(b_view.shape), generator) * bound)
    return weight, bias


# --------------------------------------------------------------------------------------------
# The model
# --------------------------------------------------------------------------------------------


def _n_features(features) -> int:
    shape = features.shape if hasattr(features, "shape") else np.shape(features)
    if len(shape) == 0:
        raise ValueError("features must be an array (n, f); got a scalar")
    return int(shape[-1])


def check_features(model: SubspaceMLP | MLPConfig, features) -> None:
    """Raise ``ValueError("model expects 84 features, got 83")`` unless the last axis of
    ``features`` has ``config.n_inputs`` entries (the stored feature layout)."""
    config = model if isinstance(model, MLPConfig) else model.config
    f = _n_features(features)
    if f != config.n_inputs:
        raise ValueError(f"model expects {config.n_inputs} features, got {f}")


@dataclass(frozen=True)
class _MapPlan:
    """A validated ``map_spec``: the parsed dataset spec and how to run the model."""

    spec: Any  # wsmap.data.DatasetSpec
    nodes: slice  # flat indices of the spec's grid covered by the outputs
    assemble: bool
    key: int | None
    threshold: float
    # One feature row of the spec with zero DH columns (fixed specs only): predict_maps fills in
    # the 18 DH columns instead of calling features_for, whose grid construction dominates the
    # time of a one-arm map (~0.1 ms of it).
    template: np.ndarray | None = None


def make_map_spec(dataset, *, nodes=None, assemble: bool = False, subspace: int | None = None,
                  threshold: float = 0.5) -> dict[str, Any]:
    """A ``map_spec`` dict (module docstring), before checking it against a model.

    Args:
        dataset: the :class:`wsmap.data.DatasetSpec` the model was trained on, or its ``to_dict()``.
        nodes: ``(start, stop)`` or a slice of the spec grid's flat node order covered by the
            model's outputs (0-based, stop exclusive; within the spec's labelled nodes). ``None``:
            the spec's labelled nodes (:func:`wsmap.data.node_slice`); with ``assemble`` and a
            node count different from the model's, ``start`` is kept and ``stop`` follows from
            the model (see :meth:`SubspaceMLP.set_map_spec`).
        assemble: the S subspaces are consecutive node blocks of ``m`` nodes each, concatenated
            in node order (section 6.2: 7 blocks of 1323 → the 9261-node map).
        subspace: for a stacked model used without ``assemble``, the subspace that predicts.
        threshold: score threshold (``score > threshold`` is reachable; the paper's 0.5).
    """
    spec = dataset if isinstance(dataset, _data.DatasetSpec) else _data.DatasetSpec.from_dict(dataset)
    if isinstance(nodes, slice):
        nodes = (nodes.start, nodes.stop)
    return {"dataset": spec.to_dict(), "nodes": None if nodes is None else [nodes[0], nodes[1]],
            "assemble": bool(assemble), "subspace": subspace, "threshold": threshold}


def _map_plan(config: MLPConfig, map_spec) -> tuple[dict[str, Any], _MapPlan]:
    """Validate ``map_spec`` against a model's config -> (normalised dict, plan)."""
    if not isinstance(map_spec, dict):
        raise ValueError(f"map_spec must be a dict; got {type(map_spec).__name__}")
    known = {"dataset", "nodes", "assemble", "subspace", "threshold"}
    unknown = sorted(set(map_spec) - known)
    if unknown:
        raise ValueError(f"unknown map_spec keys {unknown}; known: {sorted(known)}")
    if "dataset" not in map_spec:
        raise ValueError("map_spec needs 'dataset' (the DatasetSpec dict the model was trained on)")
    try:
        spec = _data.DatasetSpec.from_dict(dict(map_spec["dataset"]))
    except (TypeError, ValueError) as e:
        raise ValueError(f"map_spec dataset is not a valid dataset spec: {e}") from None
    assemble = map_spec.get("assemble", False)
    if not isinstance(assemble, (bool, np.bool_)):
        raise ValueError(f"map_spec assemble must be true or false; got {assemble!r}")
    assemble = bool(assemble)
    S, m = config.n_subspaces, config.n_outputs
    width = S * m if assemble else m
    key = map_spec.get("subspace")
    if assemble:
        if key is not None:
            raise ValueError("map_spec: an assembled model uses every subspace; give no subspace")
    elif key is None:
        if S > 1:
            raise ValueError(f"map_spec: the model has {S} subspaces: set assemble=True (consecutive node "
                             "blocks) or pick one with subspace=k")
        key = 0
    else:
        if isinstance(key, bool) or not isinstance(key, (int, np.integer)) or not 0 <= key < S:
            raise ValueError(f"map_spec subspace must be an integer in 0..{S - 1}; got {key!r}")
        key = int(key)
    labelled = _data.node_slice(spec)
    nodes = map_spec.get("nodes")
    if nodes is None:
        start = labelled.start
        stop = start + width if assemble else labelled.stop
    else:
        if isinstance(nodes, slice):
            nodes = (nodes.start, nodes.stop)
        if (not isinstance(nodes, (list, tuple)) or len(nodes) != 2
                or any(isinstance(v, bool) or not isinstance(v, (int, np.integer)) for v in nodes)):
            raise ValueError(f"map_spec nodes must be [start, stop] (integers) or None; got {nodes!r}")
        start, stop = int(nodes[0]), int(nodes[1])
    if not labelled.start <= start < stop <= labelled.stop:
        raise ValueError(f"map_spec nodes [{start}, {stop}) are not within the nodes [{labelled.start}, "
                         f"{labelled.stop}) that dataset {spec.name!r} labels")
    if stop - start != width:
        what = f"{S} subspaces x {m} outputs" if assemble else f"{m} outputs"
        raise ValueError(f"map_spec covers {stop - start} nodes [{start}, {stop}) but the model gives {width} "
                         f"({what})")
    threshold = map_spec.get("threshold", 0.5)
    threshold = 0.5 if threshold is None else threshold
    if isinstance(threshold, bool) or not isinstance(threshold, (int, float, np.floating, np.integer)) \
            or not math.isfinite(threshold):
        raise ValueError(f"map_spec threshold must be a finite number; got {threshold!r}")
    normalised = {"dataset": spec.to_dict(), "nodes": [start, stop], "assemble": assemble,
                  "subspace": None if assemble else key, "threshold": float(threshold)}
    template = None
    if spec.fixed != "random":
        zero = np.zeros((1, 6))
        template = _data.features_for(DHRobot(zero, zero, zero), spec)[0]
        template.setflags(write=False)
    return normalised, _MapPlan(spec, slice(start, stop), assemble, None if assemble else key, float(threshold),
                                template)


def _check_map_arms(arms, spec) -> DHRobot:
    """``arms`` as a 1-D batch ``(B,)`` of 6-joint arms with finite DH values, no limits, no tool."""
    if not isinstance(arms, DHRobot):
        raise TypeError(f"arms must be a wsmap.kinematics.DHRobot (one arm or a batch); got {type(arms).__name__}")
    if arms.n != 6:
        raise ValueError(f"the model maps 6-joint arms (the feature layout of dataset {spec.name!r}); "
                         f"got arms with {arms.n} joints")
    # DHRobot refuses non-finite values when built, but its arrays are plain attributes.
    for label in ("d", "a", "alpha"):
        values = np.asarray(getattr(arms, label))
        if not np.all(np.isfinite(values)):
            bad = np.flatnonzero(~np.isfinite(values.reshape(-1, arms.n)).all(axis=1))
            raise ValueError(f"DH column {label} contains NaN or infinite values (arms {bad[:5].tolist()})")
    if arms.qlim is not None:
        raise ValueError("the model was trained on arms without joint limits and cannot honour qlim; "
                         "drop the limits or use the classical map (method exact/numerical)")
    if arms.tool is not None:
        raise ValueError("arms with a tool transform have no place in the model's feature layout")
    if arms.d.ndim == 2:
        return arms
    n = arms.n
    return DHRobot(arms.d.reshape(-1, n), arms.a.reshape(-1, n), arms.alpha.reshape(-1, n))


class SubspaceMLP(nn.Module):
    """S tanh MLPs with identical architecture, stacked: ``weights[j]`` is ``(S, in_j, out_j)``,
    ``biases[j]`` ``(S, out_j)``; buffers ``input_mean``/``input_std`` ``(S, n_network_inputs)``.

    Args:
        config: :class:`MLPConfig`.
        input_range: first-layer input ranges for Nguyen–Widrow (see :meth:`reset_parameters`).
        seeds: one seed per subspace; subspace ``s`` is then initialised from
            ``torch.Generator().manual_seed(seeds[s])`` alone, so a stack built with ``seeds``
            equals the single models built with ``[seeds[s]]`` (and ``from_models`` of them).
            ``None``: the global torch RNG, subspace 0 first.

    Shapes: ``n`` samples, ``f = config.n_inputs`` stored features, ``m = config.n_outputs``.
    """

    def __init__(self, config: MLPConfig, *, input_range=None, seeds: Sequence[int] | None = None,
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
        self._map_plan: _MapPlan | None = None
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

    def reset_parameters(self, input_range=None, seeds: Sequence[int] | None = None) -> None:
        """Initialise every subspace per ``config.init`` (module docstring).

        ``input_range``: ``(n_network_inputs, 2)`` rows ``[min, max]`` of the first layer's
        inputs as it sees them (after column selection and scaling), or ``(n_inputs, 2)`` in the
        stored layout (the selected rows are used), or ``(2,)`` for all; ``None``: ``[-1, 1]``.
        Hidden layers after the first see tanh outputs, range ``[-1, 1]``. Draw order: subspace
        by subspace, layer by layer, weights then biases.
        """
        cfg = self.config
        gens = self._generators(seeds)
        n_net = cfg.n_network_inputs
        if input_range is not None and cfg.input_columns is not None:
            arr = _to_numpy(input_range)
            if arr.shape == (cfg.n_inputs, 2) and cfg.n_inputs != n_net:
                input_range = arr[cfg.input_columns]
        first_range = _input_range_array(input_range, n_net)
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
        t = torch.as_tensor(_to_numpy(values), dtype=torch.float64)
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

    def set_input_stats(self, mean, std) -> None:
        """Store the standardisation ``z = (x - mean) / std`` of the first layer's inputs.

        ``mean``, ``std``: ``(f,)`` (all subspaces) or ``(S, f)``, with ``f`` either the stored
        feature count (the ``input_columns`` are taken) or the network input count. ``std`` must
        be positive and finite. Only with ``config.input_scaling == "standardize"``.
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
        """Mean and population std (ddof 0) per column of ``x`` ``(n, f)``, float64.

        A constant column (max == min) gets its value as mean and std 1, so it standardises to
        exactly 0 (a computed std of a constant column is rounding noise, and dividing by it
        would amplify noise).
        """
        x = np.asarray(_to_numpy(x), dtype=np.float64)
        if x.ndim != 2 or x.shape[0] == 0:
            raise ValueError(f"need (n, f) data with n >= 1; got shape {x.shape}")
        const = x.max(axis=0) == x.min(axis=0)
        mean = np.where(const, x[0], x.mean(axis=0))
        std = np.where(const, 1.0, x.std(axis=0))
        std = np.where(std > 0, std, 1.0)
        return mean, std

    def network_inputs(self, x, key: int | None = None) -> torch.Tensor:
        """The first layer's inputs: ``x`` (stored layout) after column selection and scaling.

        ``key=None``: ``(S, n, f_net)`` (``(n, f_net)`` copies per subspace stats); an int key:
        ``(n, f_net)`` for that subspace.
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

    def configure(self, x, *, seeds: Sequence[int] | None = None) -> SubspaceMLP:
        """Set up from training features ``x`` ``(n, n_inputs)``, as MATLAB's ``configure`` +
        ``init``: with ``"standardize"`` set the input stats from ``x`` (:meth:`input_stats_from`,
        same for all subspaces), then re-initialise with the first layer's input range taken as
        the per-column min/max of the network inputs over ``x`` (constant columns get zero
        Nguyen–Widrow weights and do not count in ``H**(1/r)``). Pass the training split (MATLAB
        configures on everything given to ``train``; for the paper's raw inputs the min/max
        barely differ). ``seeds`` as in the constructor (the draws restart from them, so
        ``SubspaceMLP(c, seeds=sd).configure(x, seeds=sd)`` is reproducible). Returns ``self``.
        """
        arr = np.asarray(_to_numpy(x), dtype=np.float64)
        if arr.ndim != 2 or arr.shape[0] == 0:
            raise ValueError(f"configure needs (n, f) features with n >= 1; got shape {arr.shape}")
        check_features(self, arr)
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
        """x ``(n, f_net)`` or ``(S, n, f_net)`` -> ``(S, n, m)``."""
        h = self._scale(x, None)
        act = ACTIVATIONS[self.config.activation][0]
        last = self.n_layers - 1
        for j, (W, b) in enumerate(zip(self.weights, self.biases)):
            h = torch.baddbmm(b.unsqueeze(1), h, W)
            if j < last:
                h = act(h)
        return h

    def _run_one(self, x: torch.Tensor, k: int) -> torch.Tensor:
        """x ``(n, f_net)`` through subspace ``k`` -> ``(n, m)``."""
        h = self._scale(x, k)
        act = ACTIVATIONS[self.config.activation][0]
        last = self.n_layers - 1
        for j, (W, b) in enumerate(zip(self.weights, self.biases)):
            h = torch.addmm(b[k], h, W[k])
            if j < last:
                h = act(h)
        return h

    def forward(self, x, key=None) -> torch.Tensor:
        """Raw outputs.

        Args:
            x: features in the stored layout (torch or numpy; cast to the parameters' dtype):
                ``(n, f)`` shared by all subspaces, or ``(S, n, f)`` one batch per subspace
                (only with ``key=None``).
            key: ``None``: all subspaces -> ``(S, n, m)`` (also for S = 1). An int ``k``:
                subspace ``k`` only -> ``(n, m)``. Per-sample keys ``(n,)`` (integer tensor,
                array or list): sample ``i`` through subspace ``key[i]`` -> ``(n, m)``, one
                batched pass per distinct key.

        Raises:
            ValueError: wrong feature count, wrong shape, unknown key.
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

    def assemble(self, x) -> torch.Tensor:
        """All S subspaces on the same ``x`` ``(n, f)``, concatenated along the node axis:
        ``(n, S*m)``, subspace 0's ``m`` nodes first (section 6.2: 7 block models of 1323 nodes
        give the 9261-node map in node order)."""
        x = self._as_tensor(x)
        if x.ndim != 2:
            raise ValueError(f"assemble needs features (n, f) shared by all subspaces; got shape {tuple(x.shape)}")
        out = self._run_all(x)
        S, n, m = out.shape
        return out.permute(1, 0, 2).reshape(n, S * m)

    # ---------------------------------------------------------------- prediction

    def _batched(self, fn, x, batch_size):
        if batch_size is None:
            return fn(x)
        if batch_size < 1:
            raise ValueError("batch_size must be >= 1")
        n = x.shape[-2]
        outs = [fn(x[..., i:i + batch_size, :]) for i in range(0, n, batch_size)]
        return torch.cat(outs, dim=-2) if outs else fn(x)

    def score(self, x, key=None, *, assemble: bool = False, batch_size: int | None = None) -> torch.Tensor:
        """The thresholded quantity, without gradients: the raw output (``output_kind
        "linear"``) or ``sigmoid(raw)`` (``"logit"``). Shapes as :meth:`forward`, or as
        :meth:`assemble` with ``assemble=True``. ``batch_size``: samples per pass (memory)."""
        if assemble and key is not None:
            raise ValueError("assemble runs all subspaces: give no key")
        x = x if isinstance(x, torch.Tensor) else torch.as_tensor(np.asarray(x))
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

    def predict(self, x, threshold: float = 0.5, key=None, *, assemble: bool = False,
                batch_size: int | None = None) -> torch.Tensor:
        """Binary map(s): ``score > threshold`` (bool tensor; shapes as :meth:`score`).

        ``output_kind "linear"``: raw output > threshold (the paper: 0.5). ``"logit"``:
        ``sigmoid(raw) > threshold``, i.e. ``raw > logit(threshold)``. Use ``.numpy()`` for numpy.
        """
        return self.score(x, key, assemble=assemble, batch_size=batch_size) > threshold

    # ---------------------------------------------------------------- maps of arms

    @property
    def map_spec(self) -> dict[str, Any] | None:
        """What the outputs map (module docstring), a plain dict (a copy), or ``None``.

        Assigning a dict validates it against the model (``ValueError`` if it does not fit) and
        stores its normalised form (``nodes`` filled in, ``threshold`` a float); ``None`` clears it.
        """
        return None if self._map_spec is None else {**self._map_spec, "dataset": dict(self._map_spec["dataset"]),
                                                    "nodes": list(self._map_spec["nodes"])}

    @map_spec.setter
    def map_spec(self, value) -> None:
        if value is None:
            self._map_spec, self._map_plan = None, None
        else:
            self._map_spec, self._map_plan = _map_plan(self.config, value)

    def set_map_spec(self, dataset, *, nodes=None, assemble: bool = False, subspace: int | None = None,
                     threshold: float = 0.5) -> SubspaceMLP:
        """Say what the model maps (arguments as :func:`make_map_spec`); returns ``self``.

        Examples: a model trained on all nodes of ``spec``: ``set_map_spec(spec)``; one block
        model trained on columns ``[5292, 6615)`` of the 21³ ``sec62`` labels:
        ``set_map_spec(sec62, nodes=(5292, 6615))``; the 7 stacked block models:
        ``set_map_spec(sec62, assemble=True)``.
        """
        self.map_spec = make_map_spec(dataset, nodes=nodes, assemble=assemble, subspace=subspace,
                                      threshold=threshold)
        return self

    def _require_plan(self) -> _MapPlan:
        if self._map_plan is None:
            raise ValueError("the model has no map_spec (what grid and nodes its outputs are): call "
                             "model.set_map_spec(dataset_spec, ...) before predicting maps")
        return self._map_plan

    def map_nodes(self) -> np.ndarray:
        """The nodes the maps cover ``(N, 3)`` in output order: positions in metres (R3 specs) or
        angles in radians (SO3 specs); ``N = stop - start`` of ``map_spec["nodes"]``."""
        plan = self._require_plan()
        return _data.grid_nodes(plan.spec)[plan.nodes]

    def map_features(self, arms, fixed=None) -> np.ndarray:
        """Features ``(B, n_inputs)`` float64 of ``arms`` (a :class:`~wsmap.kinematics.DHRobot`, one
        arm or a batch of any shape, flattened to ``B`` arms) for the map's dataset spec, with the
        checks of :meth:`predict_maps`."""
        plan = self._require_plan()
        spec = plan.spec
        flat = _check_map_arms(arms, spec)
        if fixed is not None and spec.fixed != "random":
            f = np.asarray(fixed, dtype=np.float64)
            if f.shape not in ((3,), (flat.batch_shape[0], 3)):
                raise ValueError(f"fixed must have shape (3,) or ({flat.batch_shape[0]}, 3), got {f.shape}")
            if not np.allclose(f, spec.fixed, rtol=0, atol=1e-9):
                what = "orientation (rad)" if spec.scope == "R3" else "point (m)"
                raise ValueError(f"the model was trained at the fixed {what} {list(spec.fixed)} only "
                                 f"(dataset {spec.name!r}); got {np.round(f, 6).tolist()}")
        if fixed is None and plan.template is not None:
            # features_for's layout, from the cached row: [d(6), a(6), alpha(6), grid axes, fixed(3)]
            X = np.empty((flat.batch_shape[0], plan.template.size))
            X[:] = plan.template
            X[:, 0:6], X[:, 6:12], X[:, 12:18] = flat.d, flat.a, flat.alpha
        else:
            X = _data.features_for(flat, spec, fixed)
        check_features(self, X)
        return X

    def predict_maps(self, arms, fixed=None, threshold: float | None = None,
                     batch_size: int | None = None) -> np.ndarray:
        """Binary workspace maps of ``arms`` predicted by the network, in node order.

        Args:
            arms: a :class:`~wsmap.kinematics.DHRobot` with 6 joints: one arm (batch ``()``) or a
                batch of any shape ``(...)``; finite DH values, no joint limits, no tool.
            fixed: the orientation (R3 specs; angles in rad) or point (SO3 specs; m), ``(3,)`` or
                ``(B, 3)``. ``None``: the spec's. Required for a spec with ``fixed="random"``;
                for a fixed spec it must equal the spec's (the model has seen no other).
            threshold: score threshold; ``None``: ``map_spec["threshold"]``.
            batch_size: arms per forward pass (memory); ``None``: all at once.

        Returns:
            bool ``(..., N)`` with ``N`` the covered nodes (:meth:`map_nodes`): for a model covering
            its whole R3 grid the array ``wsmap.workspace.constant_orientation_map(arms,
            grid_nodes, fixed, convention=...)`` would be (``orientation_map`` for SO3), a
            single arm giving ``(N,)``. Equal to ``predict(features, threshold, key=subspace,
            assemble=...)`` on :meth:`map_features`.

        Raises:
            ValueError: no ``map_spec``; arms with other than 6 joints, non-finite DH values,
                joint limits or a tool; a ``fixed`` the model was not trained at.
            TypeError: ``arms`` is not a ``DHRobot``.
        """
        plan = self._require_plan()
        X = self.map_features(arms, fixed)
        t = plan.threshold if threshold is None else float(threshold)
        out = self.predict(X, t, key=plan.key, assemble=plan.assemble, batch_size=batch_size)
        return out.cpu().numpy().reshape(tuple(arms.batch_shape) + (out.shape[-1],))

    # ---------------------------------------------------------------- stacking

    @classmethod
    def from_models(cls, models: Sequence[SubspaceMLP]) -> SubspaceMLP:
        """Stack separately trained models into one: their subspaces in order (a model with
        ``S_i > 1`` contributes all of its). Configs must agree except ``n_subspaces``; dtype
        and device follow the first model. Parameters and input stats are copied."""
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
        return out

    def subspace(self, k: int) -> SubspaceMLP:
        """A copy of subspace ``k`` as a single-subspace model (S = 1)."""
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
        return out


# --------------------------------------------------------------------------------------------
# Files
# --------------------------------------------------------------------------------------------


def _plain(value, where: str):
    """``value`` as ``weights_only``-loadable content: dicts (str keys), lists, str, int, float,
    bool, None, tensors. Tuples -> lists, numpy -> Python/lists, paths -> str, dataclasses and
    objects with ``to_dict()`` -> dicts; anything else raises ``TypeError``."""
    if isinstance(value, np.generic):  # before the builtins: np.float64 is a float subclass
        value = value.item()
    if value is None:
        return None
    # Exact builtin types: subclasses (numpy scalars, enums) would need unsafe globals to load.
    for kind in (bool, int, float, str):
        if isinstance(value, kind):
            return kind(value)
    if isinstance(value, torch.Tensor):
        return value.detach().cpu().clone()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, dict):
        out = {}
        for k, v in value.items():
            if not isinstance(k, str):
                raise TypeError(f"cannot save {where}: key {k!r} is not a string")
            out[k] = _plain(v, f"{where}[{k!r}]")
        return out
    if isinstance(value, (list, tuple)):
        return [_plain(v, f"{where}[{i}]") for i, v in enumerate(value)]
    if hasattr(value, "to_dict") and callable(value.to_dict):
        return _plain(value.to_dict(), where)
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return _plain(dataclasses.asdict(value), where)
    raise TypeError(f"cannot save {where}: {type(value).__name__} is not a plain value")


def save(model: SubspaceMLP, path, *, dataset_spec: dict | None = None, train_config: dict | None = None,
         extra: dict | None = None) -> Path:
    """Write ``model`` and its provenance to ``path`` atomically; returns the path.

    The file is ``torch.save`` of ``{"format": FORMAT, "version": FORMAT_VERSION, "wsmap_version",
    "config": config.to_dict(), "state_dict": {name: CPU tensor}, "dataset_spec", "train_config",
    "extra", "map_spec"}`` (``map_spec``: the model's, ``None`` when it has none).
    ``dataset_spec``/``train_config``/``extra`` may be dicts, dataclasses or objects with
    ``to_dict()`` (e.g. ``DatasetSpec``, ``TrainConfig``); they are stored as plain values.
    """
    if not isinstance(model, SubspaceMLP):
        raise TypeError(f"save needs a SubspaceMLP; got {type(model).__name__}")
    payload = {
        "format": FORMAT,
        "version": FORMAT_VERSION,
        "wsmap_version": __version__,
        "config": model.config.to_dict(),
        "state_dict": {k: v.detach().cpu().clone() for k, v in model.state_dict().items()},
        "dataset_spec": _plain(dataset_spec, "dataset_spec"),
        "train_config": _plain(train_config, "train_config"),
        "extra": _plain(extra, "extra"),
        "map_spec": _plain(model.map_spec, "map_spec"),
    }
    path = Path(path)
    with atomic_path(path) as tmp:
        torch.save(payload, tmp)
    return path


def load(path, *, map_location: str | torch.device = "cpu") -> tuple[SubspaceMLP, dict[str, Any]]:
    """Read a file written by :func:`save` -> ``(model, meta)``.

    ``meta``: ``path`` (str), ``format``, ``version``, ``wsmap_version``, ``dataset_spec``,
    ``train_config``, ``extra``, ``map_spec`` (as saved; ``None`` where not given). The model is in
    eval mode and has its ``map_spec`` back (``None`` for files without one).

    Raises:
        ValueError: ``"cannot load model <path>: <problem>"`` for a missing file, a file that
            ``torch.load(weights_only=True)`` cannot read (truncated, corrupt, not a torch file),
            a wrong format tag or a newer version, an invalid config, or a state that does not
            match the config (missing/unexpected entries, wrong shapes).
    """
    path = Path(path)

    def fail(problem: str, cause: BaseException | None = None):
        raise ValueError(f"cannot load model {path}: {problem}") from cause

    if not path.is_file():
        fail("no such file")
    try:
        payload = torch.load(path, map_location=map_location, weights_only=True)
    except Exception as e:  # truncated zip, random bytes, pickle with non-plain content
        fail("not a readable torch file (truncated or corrupt)", e)
    if not isinstance(payload, dict) or "format" not in payload:
        fail("not a wsmap model file (no format tag)")
    if payload["format"] != FORMAT:
        fail(f"format tag {payload['format']!r} is not {FORMAT!r}")
    version = payload.get("version")
    if isinstance(version, bool) or not isinstance(version, int) or not 1 <= version <= FORMAT_VERSION:
        fail(f"format version {version!r} is not supported (this wsmap reads 1..{FORMAT_VERSION})")
    missing = [k for k in ("config", "state_dict") if not isinstance(payload.get(k), dict)]
    if missing:
        fail(f"missing {missing}")
    try:
        config = MLPConfig.from_dict(payload["config"])
    except (TypeError, ValueError) as e:
        fail(f"invalid config: {e}", e)
    model = SubspaceMLP(config, _init=False)
    expected = model.state_dict()
    state = payload["state_dict"]
    problems = []
    if sorted(set(expected) - set(state)):
        problems.append(f"missing {sorted(set(expected) - set(state))}")
    if sorted(set(state) - set(expected)):
        problems.append(f"unexpected {sorted(set(state) - set(expected))}")
    for k in sorted(set(expected) & set(state)):
        v = state[k]
        if not isinstance(v, torch.Tensor):
            problems.append(f"{k} is not a tensor")
        elif tuple(v.shape) != tuple(expected[k].shape):
            problems.append(f"{k} has shape {tuple(v.shape)}, config needs {tuple(expected[k].shape)}")
    if problems:
        fail("state does not match config: " + "; ".join(problems))
    if payload.get("map_spec") is not None:
        try:
            model.map_spec = payload["map_spec"]
        except (TypeError, ValueError) as e:
            fail(f"invalid map_spec: {e}", e)
    dtypes = {v.dtype for v in state.values()}
    if len(dtypes) == 1:
        model.to(dtype=dtypes.pop())  # keep what was saved (float32 for the networks)
    model.load_state_dict(state)
    model.to(map_location)
    model.eval()
    meta = {"path": str(path), "format": payload["format"], "version": version,
            "wsmap_version": payload.get("wsmap_version"), "dataset_spec": payload.get("dataset_spec"),
            "train_config": payload.get("train_config"), "extra": payload.get("extra"),
            "map_spec": model.map_spec}
    return model, meta


def _grid_mismatch(spec, grid: dict) -> list[str]:
    """How a command's grid (``scope``, ``lo``, ``hi``, ``step`` as in :func:`wsmap.cli.compute_map`)
    differs from the dataset spec's; empty when they agree (1e-9 tolerance)."""
    problems = []
    if grid.get("scope", spec.scope) != spec.scope:
        problems.append(f"scope {grid['scope']} (model: {spec.scope})")
    for k in ("lo", "hi", "step"):
        if k in grid and grid[k] is not None:
            want = np.broadcast_to(np.asarray(getattr(spec, k), dtype=np.float64), 3)
            got = np.broadcast_to(np.asarray(grid[k], dtype=np.float64), 3)
            if not np.allclose(got, want, rtol=0, atol=1e-9):
                problems.append(f"{k} {np.round(got, 6).tolist()} (model: {np.round(want, 6).tolist()})")
    return problems


def predict_maps_from_file(path, arms, fixed=None, *, threshold: float | None = None,
                           batch_size: int | None = None, grid: dict | None = None,
                           convention: str | None = None, whole_grid: bool = False,
                           map_location: str | torch.device = "cpu") -> np.ndarray:
    """:meth:`SubspaceMLP.predict_maps` of the model saved at ``path`` (:func:`load`).

    Args:
        path: a model file written by :func:`save` from a model with a ``map_spec``.
        arms, fixed, threshold, batch_size: as :meth:`SubspaceMLP.predict_maps`.
        grid: optional dict with ``scope`` (``"R3"``/``"SO3"``), ``lo``, ``hi``, ``step`` (scalars
            or 3 values; metres or radians) that the caller expects the map on; it must be the
            model's grid, else ``ValueError`` names every difference.
        convention: optional pose convention (``"paper"``/``"standard"``) the caller expects; must
            be the model's.
        whole_grid: require the model to cover every node of its grid (a flat map of the whole
            grid, as ``wsmap map`` writes), not a node slice of it.

    Returns:
        bool ``(..., N)`` maps in node order (see :meth:`SubspaceMLP.predict_maps`).

    Raises:
        ValueError: unreadable file (from :func:`load`), a model without ``map_spec``, a grid,
            convention or coverage that does not match, bad arms.
    """
    model, meta = load(path, map_location=map_location)
    if model.map_spec is None:
        raise ValueError(f"model {path} has no map_spec (what grid and nodes it maps): set one with "
                         "model.set_map_spec(dataset_spec, ...) before saving it")
    plan = model._map_plan
    spec = plan.spec
    problems = _grid_mismatch(spec, grid) if grid is not None else []
    if convention is not None and convention != spec.convention:
        problems.append(f"convention {convention} (model: {spec.convention})")
    if problems:
        nx, ny, nz = spec.grid_shape
        raise ValueError(f"model {path} maps a different grid: {'; '.join(problems)}. The model was trained "
                         f"on dataset {spec.name!r}, {spec.scope} grid of {nx}x{ny}x{nz} nodes")
    if whole_grid and (plan.nodes.start, plan.nodes.stop) != (0, spec.grid_nodes):
        raise ValueError(f"model {path} covers nodes [{plan.nodes.start}, {plan.nodes.stop}) of its grid's "
                         f"{spec.grid_nodes} only; a whole-grid map needs a model of every node (e.g. the 7 "
                         "block models assembled)")
    return model.predict_maps(arms, fixed, threshold=threshold, batch_size=batch_size)
