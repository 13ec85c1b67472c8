"""A learned manipulability map for the paper's spherical-wrist family (issue 14: the paper's future work).

What is learned
---------------
Inputs: the family's four free DH parameters in the order `wsmap.robots.sample_spherical_wrist`
draws them, `PARAM_NAMES` `= (d3, d4, a2, a3)`, metres (every other DH value is fixed:
`d1 = 0`, the twists of `wsmap.kinematics.SPHERICAL_WRIST_ALPHA`, no joint limits, no tool).

Outputs: the manipulability map of the map-kinds issue (`wsmap.workspace.manipulability_map`):
at each node the largest Yoshikawa manipulability `√det(J Jᵀ)` over the 8 closed-form IK
branches, 0 where the pose is unreachable. `J` is the 6 x 6 geometric Jacobian in the base frame
(rows `[v; ω]`: m/rad and rad/rad), so the value is `|det J|` in **m³** (per rad³ of joint
motion); over the family it lies in `[0, ~0.3]` m³. Targets are exact
(`wsmap.workspace.manipulability_maps`, float64, stored as float32).

The grid and the pose are the paper's R3 section 6.1 spec (`sec61`): nodes on `[-1, 1]³` m at
0.1 m (21³ = 9261, first coordinate fastest, `wsmap.workspace.cartesian_grid`), flange
positions in the base frame, fixed orientation `rpy = (0, 0, 0)` under the paper's convention
(`Rx·Ry·Rz·transl(p)`, which is `transl(p)` at that orientation, so the `standard` convention
gives the same map). All 9261 nodes are mapped, as `sec62` does, not `sec61`'s block-5 selection.

The model
---------
A `ManipulabilityModel`: a `SubspaceMLP` (one subspace, 4
standardised inputs, tanh hidden layers, 9261 linear outputs, float32) and the target transform
it was trained on: `"linear"` (the map itself) or `"sqrt"` (its square root, which spreads the
small values near the workspace boundary), divided by one global scale (the training targets'
standard deviation, so the MSE loss stays a multiple of the squared error in the map's own units
for `"linear"`). Predictions are transformed back and clipped at 0 (manipulability is never
negative; the network's small negative outputs outside the workspace are noise). Training: Adam
in minibatches, MSE, early stopping on a validation split (`wsmap.learn.train`).

Inputs outside the family are refused the way the map models refuse them
(`wsmap.learn.training_range`): parameters outside the range the model was trained on raise
`ExtrapolationError` (a `ValueError`) unless
`allow_extrapolation=True`; arms that are not of the family (other twists, `d1 ≠ 0`, joint
limits, a tool) and arrays of the wrong shape raise `ValueError`.

Measured (`benchmarks/learn/bench_manipulability_model.py --epochs 60`, one thread): 4000 training
arms, the default config (60 epochs), 500 held-out arms: R² 0.9947 pooled over arms x nodes, MAE
0.00064 m³; on the reachable nodes R² 0.9925, MAE 0.0026 m³; largest error 0.080 m³ (the earlier
time-limited default, 150 s or 63 epochs: R² 0.9948). A map costs
0.13 ms per arm predicted in bulk (0.3 ms for one arm) against 1.8-2.6 ms exact
(`wsmap.workspace.manipulability_maps`). `docs/learned-maps.md` (section "Manipulability, learned") has the runs.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch

from ..kinematics import DHRobot, is_spherical_wrist
from ..robots import SPHERICAL_WRIST
from .files import ModelFileError, load, save
from .network import MLPConfig, SubspaceMLP
from .training import TrainConfig, TrainResult, split_indices, train
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap._typing import ArrayLike, PathLike
    from wsmap.kinematics.chain import Arm

__all__ = [
    "PARAM_NAMES",
    "FAMILY_RANGE",
    "MANIPULABILITY_TARGETS",
    "MANIPULABILITY_KIND",
    "ManipulabilityModel",
    "ManipulabilityTrainConfig",
    "manipulability_grid",
    "manipulability_params",
    "manipulability_targets",
    "manipulability_dataset",
    "train_manipulability_model",
    "predict_manipulability",
    "regression_metrics",
    "save_manipulability_model",
    "load_manipulability_model",
]

#: The family's free parameters, in the input order (metres): `wsmap.robots.SPHERICAL_WRIST`'s.
PARAM_NAMES = SPHERICAL_WRIST.params
#: Their range in the paper's family: each ~ U(0, 0.5) m (`sample_spherical_wrist`'s `beta`).
FAMILY_RANGE = (SPHERICAL_WRIST.low, SPHERICAL_WRIST.high)
#: Target transforms: what the network's outputs are, up to the stored scale.
MANIPULABILITY_TARGETS = ("linear", "sqrt")
#: The `extra["kind"]` tag of a saved manipulability model.
MANIPULABILITY_KIND = "wsmap.manipulability"
#: The dataset spec whose grid, orientation and pose convention the maps use ...
GRID_SPEC = "sec61"
#: ... and those settings, as `wsmap.paper.specs.paper_spec("sec61")` has them (a test checks;
#: learn does not import the paper's package): `[lo, hi]³` m at `step`, `rpy` rad.
_GRID = {"lo": -1.0, "hi": 1.0, "step": 0.1, "rpy": (0.0, 0.0, 0.0), "convention": "paper"}


def manipulability_grid() -> dict[str, Any]:
    """The grid and pose of the maps: `nodes` `(9261, 3)` (m, base frame, node order), `rpy`
    (rad), `convention`, `lo`, `hi`, `step` (m) and `spec` (the paper's spec they are
    taken from)."""
    from ..workspace import cartesian_grid

    return {"nodes": cartesian_grid(_GRID["lo"], _GRID["hi"], _GRID["step"]), **_GRID, "spec": GRID_SPEC}


# --------------------------------------------------------------------------------------------
# Inputs
# --------------------------------------------------------------------------------------------


def _arm_params(arms: DHRobot) -> np.ndarray:
    if arms.n != 6 or not bool(np.all(is_spherical_wrist(arms))):
        raise ValueError("arms must be of the spherical-wrist family (d = [d1, 0, d3, d4, 0, 0], "
                         "a = [0, a2, a3, 0, 0, 0], alpha = [pi/2, 0, -pi/2, pi/2, -pi/2, 0], no tool)")
    if arms.qlim is not None:
        raise ValueError("arms must have no joint limits: the family's maps (and the paper's) ignore them")
    if np.any(np.abs(arms.d[..., 0]) > 1e-9):
        raise ValueError("arms must have d1 = 0: the family's base height is fixed at 0 and is not an input")
    return SPHERICAL_WRIST.params_of(arms)


def manipulability_params(arms_or_params: Arm | ArrayLike) -> tuple[np.ndarray, bool]:
    """`(params (B, 4) float64, single)`: the four free parameters `(d3, d4, a2, a3)` (m) of
    arms (a spherical-wrist `DHRobot`, one arm or a batch of any shape,
    flattened) or of a parameter array `(4,)` / `(B, 4)`; `single` says the input was one arm.

    Raises
    ------
    ValueError
        an array of another shape or with NaN/inf; arms outside the family.
    TypeError
        neither a `DHRobot` nor an array of numbers.
    """
    if isinstance(arms_or_params, DHRobot):
        p = _arm_params(arms_or_params)
        single = arms_or_params.batch_shape == ()
        return p.reshape(-1, 4), single
    if isinstance(arms_or_params, torch.Tensor):
        arms_or_params = arms_or_params.detach().cpu().numpy()
    try:
        p = np.asarray(arms_or_params, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError("expected a DHRobot of the spherical-wrist family or parameters (B, 4) (d3, d4, a2, a3); "
                        f"got {type(arms_or_params).__name__}") from None
    if not (p.shape == (4,) or (p.ndim == 2 and p.shape[1] == 4 and p.shape[0] >= 1)):
        raise ValueError(f"parameters must be (4,) or (B, 4) with B >= 1, columns (d3, d4, a2, a3) in m; "
                         f"got shape {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ValueError("parameters contain NaN or infinite values")
    return p.reshape(-1, 4), p.ndim == 1


def _arms_of(params: np.ndarray) -> DHRobot:
    from ..robots import spherical_wrist

    return spherical_wrist(a2=params[:, 2], a3=params[:, 3], d3=params[:, 0], d4=params[:, 1])


def manipulability_targets(arms_or_params: Arm | ArrayLike) -> np.ndarray:
    """Exact manipulability maps (m³) on the `sec61` grid: float64 `(B, 9261)` (`(9261,)` for
    one arm or a `(4,)` parameter vector); inputs as `manipulability_params` (any values:
    the closed form holds outside the sampled range too)."""
    from ..workspace import manipulability_maps

    params, single = manipulability_params(arms_or_params)
    g = manipulability_grid()
    out = manipulability_maps(_arms_of(params), g["nodes"], g["rpy"], convention=g["convention"])
    return out[0] if single else out


def manipulability_dataset(count: int, seed: int | None = None, *, beta: float = FAMILY_RANGE[1]
                          ) -> tuple[np.ndarray, np.ndarray]:
    """`count` arms of the family (`wsmap.robots.sample_spherical_wrist` with `seed` and
    `beta`) -> `(params, targets)`: float64 `(count, 4)` `(d3, d4, a2, a3)` in m and float32
    `(count, 9261)` exact manipulability maps in m³ (`manipulability_targets`).

    About 3.5 ms per arm on one thread; 37 KB of targets per arm.
    """
    from ..robots import sample_spherical_wrist

    arms = sample_spherical_wrist(count, seed=seed, beta=beta)
    params = _arm_params(arms)
    return params, manipulability_targets(params).astype(np.float32)


# --------------------------------------------------------------------------------------------
# The model
# --------------------------------------------------------------------------------------------


def _check_target(target: str) -> str:
    if target not in MANIPULABILITY_TARGETS:
        raise ValueError(f"target must be one of {list(MANIPULABILITY_TARGETS)}; got {target!r}")
    return target


@dataclass
class ManipulabilityModel:
    """A network predicting manipulability maps from `(d3, d4, a2, a3)`.

    Attributes
    ----------
    network
        a `SubspaceMLP` with `n_inputs = 4`, one subspace,
        `n_outputs = 9261`, linear outputs; its training range is the parameters' range.
    target
        `"linear"` or `"sqrt"`: the network's output times `scale` is the map (m³)
        or its square root (m^1.5).
    scale
        positive float, the global output scale.
    grid
        the spec whose grid and pose the outputs are (`"sec61"`).
    """

    network: SubspaceMLP
    target: str
    scale: float
    grid: str = GRID_SPEC

    def __post_init__(self):
        if not isinstance(self.network, SubspaceMLP):
            raise TypeError(f"network must be a SubspaceMLP; got {type(self.network).__name__}")
        c = self.network.config
        if c.n_inputs != 4 or c.n_subspaces != 1 or c.output_kind != "linear":
            raise ValueError("a manipulability network has 4 inputs (d3, d4, a2, a3), one subspace and linear "
                             f"outputs; got n_inputs={c.n_inputs}, n_subspaces={c.n_subspaces}, "
                             f"output_kind={c.output_kind!r}")
        _check_target(self.target)
        if not (isinstance(self.scale, (int, float)) and math.isfinite(self.scale) and self.scale > 0):
            raise ValueError(f"scale must be a positive finite number; got {self.scale!r}")
        self.scale = float(self.scale)
        if self.grid != GRID_SPEC:
            raise ValueError(f"manipulability models map the {GRID_SPEC!r} grid; got {self.grid!r}")

    def encode(self, maps: ArrayLike) -> np.ndarray:
        """Maps (m³) -> network targets (float32)."""
        # float32 throughout: a training set of 4000 maps is 148 MB as float32, twice that as float64
        m = np.asarray(maps, dtype=np.float32)
        y = np.sqrt(np.maximum(m, np.float32(0.0))) if self.target == "sqrt" else m
        return (y / np.float32(self.scale)).astype(np.float32, copy=False)

    def decode(self, outputs: torch.Tensor) -> np.ndarray:
        """Network outputs -> maps (m³), clipped at 0; float32."""
        y = np.maximum(np.asarray(outputs, dtype=np.float32) * np.float32(self.scale), 0.0)
        return y * y if self.target == "sqrt" else y

    def extra(self) -> dict[str, Any]:
        """What a model file keeps besides the network (`save(..., extra=...)`)."""
        return {"kind": MANIPULABILITY_KIND, "target": self.target, "scale": self.scale, "grid": self.grid,
                "inputs": list(PARAM_NAMES), "input_unit": "m", "output_unit": "m^3"}


@dataclass
class ManipulabilityTrainConfig:
    """How `train_manipulability_model` trains.

    Attributes
    ----------
    hidden
        tanh hidden layer widths.
    target
        `"linear"` or `"sqrt"` (`ManipulabilityModel`).
    lr
        Adam's initial learning rate; `batch_size`: arms per step.
    max_epochs
        passes over the training arms at most; `max_fail`: validation failures in a
        row that stop training (the best validation epoch is kept).
    time_limit_s
        stop after this many seconds (`None`: none).
    lr_decay
        `None`, `"cosine"` (over `max_epochs`, reproducible) or `"cosine-time"`
        (over `time_limit_s`; depends on the machine's speed).
    val_fraction
        arms held out of the training parameters for early stopping.
    seed
        the split and the initial weights.

    Notes
    -----
    The default is an epoch budget (60 epochs, cosine decay over them, no time limit), so the same
    arms and seed give the same model on any machine; a time limit (`time_limit_s` with
    `"cosine-time"`) trades that for a bounded wall time.
    """

    hidden: tuple[int, ...] = (256, 256, 256)
    target: str = "linear"
    lr: float = 1e-3
    batch_size: int = 64
    max_epochs: int = 60
    max_fail: int = 30
    time_limit_s: float | None = None
    lr_decay: str | None = "cosine"
    val_fraction: float = 0.05
    seed: int = 0

    def __post_init__(self):
        _check_target(self.target)
        self.hidden = tuple(int(h) for h in self.hidden)
        if not 0.0 < self.val_fraction < 1.0:
            raise ValueError(f"val_fraction must lie in (0, 1); got {self.val_fraction!r}")
        self.train_config()  # the remaining checks are TrainConfig's

    def train_config(self) -> TrainConfig:
        return TrainConfig(optimizer="adam", optimizer_kwargs={"lr": float(self.lr)}, loss="mse",
                           batch_size=self.batch_size, max_epochs=self.max_epochs, max_fail=self.max_fail,
                           time_limit_s=self.time_limit_s, lr_decay=self.lr_decay, seed=self.seed,
                           fractions=(1.0 - self.val_fraction, self.val_fraction, 0.0))

    def to_dict(self) -> dict[str, Any]:
        d = dataclasses.asdict(self)
        d["hidden"] = list(self.hidden)
        return d


def _check_pair(params, targets) -> tuple[np.ndarray, np.ndarray]:
    p, single = manipulability_params(params)
    if single:
        raise ValueError("training needs parameters (B, 4), not one arm")
    y = np.asarray(targets)
    if y.shape != (p.shape[0], 9261):
        raise ValueError(f"targets must be (B, 9261) = ({p.shape[0]}, 9261) for {p.shape[0]} arms; got shape {y.shape}")
    if not np.all(np.isfinite(y)) or np.any(y < 0):
        raise ValueError("targets must be finite and non-negative (manipulability maps in m^3)")
    return p, y


def train_manipulability_model(params: ArrayLike, targets: ArrayLike, config: ManipulabilityTrainConfig | None = None
                               ) -> tuple[ManipulabilityModel, TrainResult]:
    """Train a `ManipulabilityModel` on `params` `(B, 4)` (m) and exact `targets`
    `(B, 9261)` (m³, `manipulability_dataset`) -> `(model, train_result)`.

    With the default [256, 256, 256] network one thread runs 18-25 epochs of 4000 arms a minute
    (measured on a shared 2-core machine), so the default 60 epochs take 2.5-3.5 minutes; the
    model returned is the best validation epoch's, in eval mode.

    Raises
    ------
    ValueError
        shapes that do not fit, NaN/inf or negative targets, a bad config.
    """
    config = ManipulabilityTrainConfig() if config is None else config
    if not isinstance(config, ManipulabilityTrainConfig):
        raise TypeError(f"config must be a ManipulabilityTrainConfig; got {type(config).__name__}")
    p, y = _check_pair(params, targets)
    tc = config.train_config()
    split = split_indices(p.shape[0], tc.fractions, tc.seed)
    if split.train.size == 0 or split.val.size == 0:
        raise ValueError(f"{p.shape[0]} arms leave no training or no validation arms at val_fraction "
                         f"{config.val_fraction}")
    net_config = MLPConfig(n_inputs=4, n_outputs=9261, hidden=list(config.hidden), init="torch",
                           input_scaling="standardize", output_kind="linear")
    network = SubspaceMLP(net_config, seeds=[config.seed]).configure(p[split.train], seeds=[config.seed])
    network.training_range = network.training_range.with_names(PARAM_NAMES)
    raw = np.sqrt(np.maximum(y[split.train], 0.0)) if config.target == "sqrt" else y[split.train]
    scale = float(np.std(raw, dtype=np.float64)) or 1.0
    model = ManipulabilityModel(network, config.target, scale)
    result = train(network, p, model.encode(y), tc, split=split)
    network.eval()
    return model, result


def predict_manipulability(model: ManipulabilityModel, arms_or_params: Arm | ArrayLike, *,
                           allow_extrapolation: bool = False, batch_size: int | None = 4096) -> np.ndarray:
    """Predicted manipulability maps (m³) on the `sec61` grid: float32 `(B, 9261)`, or
    `(9261,)` for one arm or one `(4,)` parameter vector; nodes in the grid's order, 0 or more.

    Parameters
    ----------
    model
        a `ManipulabilityModel`.
    arms_or_params
        a spherical-wrist `DHRobot` (`d1 = 0`, no joint
        limits, no tool; one arm or a batch, flattened) or parameters `(B, 4)` / `(4,)`,
        columns `(d3, d4, a2, a3)` in m.
    allow_extrapolation
        predict for parameters outside the model's training range with an
        `ExtrapolationWarning` instead of refusing them.
    batch_size
        arms per forward pass (memory: 37 KB of float32 output per arm).

    Raises
    ------
    ExtrapolationError
        (a `ValueError`) parameters outside the training range.
    ValueError
        wrong shapes, NaN/inf, arms outside the family.
    """
    if not isinstance(model, ManipulabilityModel):
        raise TypeError(f"model must be a ManipulabilityModel; got {type(model).__name__}")
    p, single = manipulability_params(arms_or_params)
    model.network.check_training_range(p, allow_extrapolation=allow_extrapolation)
    out = model.network.score(p, key=0, batch_size=batch_size).cpu().numpy()
    maps = model.decode(out)
    return maps[0] if single else maps


def regression_metrics(pred: ArrayLike, true: ArrayLike) -> dict[str, float | int]:
    """Errors of predicted maps against exact ones (same shape, e.g. `(B, 9261)`, m³).

    Returns a dict: `r2` = 1 − SSE/SST pooled over every value (SST about the pooled mean; NaN
    when the exact values are all equal), `mae` (mean absolute error, m³), `r2_reachable` and
    `mae_reachable` over the values where the exact map is positive (reachable and not singular;
    NaN when there are none), `max_abs_error` (m³), `n_values`, `n_reachable`.

    Raises
    ------
    ValueError
        shapes that differ, empty arrays, NaN or infinite values.
    """
    p = np.asarray(pred, dtype=np.float64)
    t = np.asarray(true, dtype=np.float64)
    if p.shape != t.shape:
        raise ValueError(f"pred and true must have the same shape; got {p.shape} and {t.shape}")
    if p.size == 0:
        raise ValueError("pred and true are empty")
    if not (np.all(np.isfinite(p)) and np.all(np.isfinite(t))):
        raise ValueError("pred and true must be finite")

    def r2(a, b):
        sst = float(np.sum((b - b.mean()) ** 2))
        return float("nan") if sst == 0.0 else 1.0 - float(np.sum((a - b) ** 2)) / sst

    err = np.abs(p - t)
    reach = t > 0
    return {
        "r2": r2(p, t),
        "mae": float(err.mean()),
        "r2_reachable": r2(p[reach], t[reach]) if reach.any() else float("nan"),
        "mae_reachable": float(err[reach].mean()) if reach.any() else float("nan"),
        "max_abs_error": float(err.max()),
        "n_values": int(t.size),
        "n_reachable": int(reach.sum()),
    }


# --------------------------------------------------------------------------------------------
# Files
# --------------------------------------------------------------------------------------------


def save_manipulability_model(model: ManipulabilityModel, path: PathLike, *, train_config: TrainConfig | None = None
                             ) -> PathLike:
    """Write `model` to `path` with `wsmap.learn.save` (checksummed; the target transform,
    scale and grid in `extra`, the parameters' training range with names); returns the path."""
    if not isinstance(model, ManipulabilityModel):
        raise TypeError(f"model must be a ManipulabilityModel; got {type(model).__name__}")
    return save(model.network, path, train_config=train_config, extra=model.extra())


def load_manipulability_model(path: PathLike, *, map_location: str = "cpu"
                             ) -> tuple[ManipulabilityModel, dict[str, Any]]:
    """Read a file of `save_manipulability_model` -> `(model, meta)` (`meta` as
    `wsmap.learn.load`). A model file of another kind raises
    `ModelFileError`."""
    network, meta = load(path, map_location=map_location)
    extra = meta.get("extra") or {}
    if extra.get("kind") != MANIPULABILITY_KIND:
        raise ModelFileError(f"cannot load model {path}: not a manipulability model (extra kind "
                             f"{extra.get('kind')!r}, expected {MANIPULABILITY_KIND!r})")
    try:
        model = ManipulabilityModel(network, extra.get("target"), extra.get("scale"), extra.get("grid"))
    except (TypeError, ValueError) as e:
        raise ModelFileError(f"cannot load model {path}: invalid manipulability model ({e})") from e
    if network.training_range is not None and network.training_range.names is None:
        network.training_range = network.training_range.with_names(PARAM_NAMES)
    return model, meta

