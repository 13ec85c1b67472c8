"""Learned maps of an arm family: the recipe that trains one, its accuracy, and accuracy against data.

The paper's networks map an arm's DH parameters to its binary workspace map. This module trains
such a map model for any dataset of the catalogue -- in particular a chain family whose classical
map is expensive (`panda7`: a 7-joint arm with joint limits and no closed form, whose numerical
map takes about a second per arm) -- with the recipe that works best here (measured in
`benchmarks/learn/bench_panda7_model.py`):

* inputs: the feature columns that vary across the family (`panda7`: its 6 scale factors; the
  grid and orientation columns are the same for every arm and carry nothing), standardised on the
  training split;
* a tanh MLP whose last layer has one logit per node of the spec's grid, trained with Adam on
  binary cross-entropy, minibatches, a cosine learning-rate schedule over a fixed number of epochs
  (reproducible from the seed on any machine, unlike a time limit), keeping the epoch with the
  lowest validation loss;
* a node is reachable where `sigmoid(logit) > 0.5`.

`fit_map_model` returns the model with its `map_spec` set (so
`model.predict_maps(arms)` gives bool maps `(B, N)` in the spec's node order and refuses arms
outside the training range) and its `TrainResult`;
`evaluate_map_model` scores it on held-out arms (the paper's pooled F-measure and per-arm F);
`learning_curve` trains on the first `n` arms for several `n` (more data against more
epochs: every point has the same recipe).

Shapes: a dataset has `n` arms of `f` stored features and `N` labelled nodes. Networks run
in float32.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch

from ..metrics import score_maps
from .network import MLPConfig, SubspaceMLP
from .training import TrainConfig, TrainResult, train_mlp_sessions

__all__ = ["MapRecipe", "varying_columns", "fit_map_model", "map_scores", "score_maps", "evaluate_map_model",
           "curve_row", "learning_curve", "speed_against_classical"]


@dataclass(frozen=True)
class MapRecipe:
    """How `fit_map_model` trains a map model.

    Attributes
    ----------
    hidden
        hidden layer widths (tanh).
    lr
        Adam's initial learning rate (cosine-annealed to 0 over `epochs`).
    epochs
        passes over the training split.
    batch_size
        arms per Adam step.
    validation_fraction
        share of the training arms held out to pick the best epoch.
    seed
        the split and the initial weights.
    device
        `"auto"`, `"cpu"`, `"cuda"` or `None` (the CPU, where models are built).
    """

    hidden: tuple[int, ...] = (256, 256)
    lr: float = 1e-3
    epochs: int = 60
    batch_size: int = 64
    validation_fraction: float = 0.05
    seed: int = 0
    device: str | None = None

    def __post_init__(self):
        hidden = tuple(self.hidden)
        if not hidden or any(isinstance(h, bool) or not isinstance(h, (int, np.integer)) or h < 1 for h in hidden):
            raise ValueError(f"MapRecipe.hidden must be a non-empty list of positive integers; got {self.hidden!r}")
        object.__setattr__(self, "hidden", tuple(int(h) for h in hidden))
        if not (isinstance(self.lr, (int, float)) and np.isfinite(self.lr) and self.lr > 0):
            raise ValueError(f"MapRecipe.lr must be a positive number; got {self.lr!r}")
        for name in ("epochs", "batch_size"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
                raise ValueError(f"MapRecipe.{name} must be a positive integer; got {v!r}")
        v = self.validation_fraction
        if not (isinstance(v, (int, float)) and 0.0 < v < 0.5):
            raise ValueError(f"MapRecipe.validation_fraction must be in (0, 0.5); got {v!r}")
        self.train_config()  # the device name and the rest, checked now

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> MapRecipe:
        """From a params section: unknown keys are a `ValueError` naming them."""
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(d) - names)
        if unknown:
            raise ValueError(f"unknown map recipe keys {unknown}; known: {sorted(names)}")
        d = dict(d)
        if "hidden" in d:
            d["hidden"] = tuple(d["hidden"])
        return cls(**d)

    def to_dict(self) -> dict[str, Any]:
        d = dataclasses.asdict(self)
        d["hidden"] = list(self.hidden)
        return d

    def train_config(self) -> TrainConfig:
        """The `TrainConfig` of this recipe (no early stop: the best validation epoch is kept)."""
        v = float(self.validation_fraction)
        return TrainConfig(optimizer="adam", optimizer_kwargs={"lr": float(self.lr)}, lr_decay="cosine",
                           batch_size=int(self.batch_size), loss="crossentropy", max_epochs=int(self.epochs),
                           max_fail=int(self.epochs), fractions=(1.0 - v, v, 0.0), seed=int(self.seed),
                           device=self.device)


def varying_columns(features) -> list[int]:
    """Indices of the feature columns `(n, f)` that are not the same for every row.

    Peak-to-peak, not the standard deviation: the std of a constant float column can come out as
    1e-17 instead of 0."""
    X = np.asarray(features, dtype=np.float64)
    if X.ndim != 2 or X.shape[0] < 2:
        raise ValueError(f"features must be a matrix of at least 2 rows; got shape {X.shape}")
    return [int(c) for c in np.flatnonzero(np.ptp(X, axis=0) > 1e-9)]


def _check_dataset(ds, what: str):
    if not (hasattr(ds, "features") and hasattr(ds, "labels") and hasattr(ds, "spec")):
        raise TypeError(f"{what} must be a wsmap dataset (wsmap.datasets.load_dataset); got {type(ds).__name__}")
    return ds


def fit_map_model(train, recipe: MapRecipe | None = None) -> tuple[SubspaceMLP, TrainResult]:
    """Train a map model on the dataset `train` (all its arms; hold arms out by passing
    `dataset.head(n)` or another file).

    Returns `(model, result)`: the model at its best validation epoch, with its `map_spec`
    set to `train.spec` (its outputs are the spec's labelled nodes in node order) and its
    training range the training split's features; `result` the
    `TrainResult` (`result.history` per epoch, `seconds`).
    """
    _check_dataset(train, "train")
    recipe = MapRecipe() if recipe is None else recipe
    if not isinstance(recipe, MapRecipe):
        raise TypeError(f"recipe must be a MapRecipe; got {type(recipe).__name__}")
    if len(train) < 20:
        raise ValueError(f"need at least 20 training arms; got {len(train)}")
    cfg_train = recipe.train_config()
    X = train.features
    columns = varying_columns(X)
    if not columns:
        raise ValueError("every feature column is the same for all training arms: nothing to learn from")
    Y = train.labels.astype(np.float32)
    cfg = MLPConfig(n_inputs=X.shape[1], n_outputs=Y.shape[1], hidden=list(recipe.hidden), input_columns=columns,
                    input_scaling="standardize", output_kind="logit", init="torch")
    (result,) = train_mlp_sessions(cfg, X, Y, cfg_train, 1)
    model = result.model
    model.set_map_spec(train.spec)
    return model, result


def map_scores(model: SubspaceMLP, features, batch_size: int = 1024) -> np.ndarray:
    """`sigmoid` scores (or raw outputs of a linear model) `(n, N)` float32 for stored feature rows."""
    with torch.no_grad():
        return model.score(features, key=0, batch_size=batch_size).cpu().numpy()


def evaluate_map_model(model: SubspaceMLP, test, threshold: float | None = None) -> dict[str, Any]:
    """`score_maps` of `model` on the held-out dataset `test` (same spec as the model's),
    at `threshold` (`None`: the model's `map_spec` threshold, 0.5)."""
    _check_dataset(test, "test")
    spec = model.map_spec
    if spec is not None:
        # the same maps: family, grid, orientation and convention (names and sample counts differ)
        keys = ("family", "scope", "lo", "hi", "step", "fixed", "convention")
        mine, theirs = spec["dataset"], test.spec.to_dict()
        diff = [k for k in keys if mine.get(k) != theirs.get(k)]
        if diff:
            raise ValueError(f"the model maps dataset {mine['name']!r}; test set {test.spec.name!r} differs in "
                             f"{', '.join(f'{k} ({theirs.get(k)!r} vs {mine.get(k)!r})' for k in diff)}")
    t = (0.5 if spec is None else float(spec["threshold"])) if threshold is None else float(threshold)
    scores = map_scores(model, test.features)
    truth = test.labels
    if scores.shape != truth.shape:
        raise ValueError(f"the model gives {scores.shape[1]} nodes; the test labels have {truth.shape[1]}")
    return score_maps(scores > t, truth)


def curve_row(train_arms: int, ev: dict, seconds: float, epochs: int) -> dict[str, Any]:
    """One row of a learning curve: a model trained on `train_arms` arms in `seconds`
    (`epochs` run), scored `ev` (`evaluate_map_model`). For the full-size model a
    caller already trained, beside `learning_curve`'s rows."""
    return dict(train_arms=int(train_arms), f=ev["f"], precision=ev["precision"], recall=ev["recall"],
                f_mean=ev["f_mean"], seconds=float(seconds), epochs=int(epochs))


def learning_curve(train, test, sizes: Sequence[int], recipe: MapRecipe | None = None) -> list[dict[str, Any]]:
    """F on `test` of models trained (same recipe) on the first `n` arms of `train` for each
    `n` in `sizes`: `[{train_arms, f, precision, recall, f_mean, seconds, epochs}]` in the
    order given. A size above `len(train)` is a `ValueError` before any training."""
    _check_dataset(train, "train")
    _check_dataset(test, "test")
    sizes = [int(n) for n in sizes]
    bad = [n for n in sizes if not 20 <= n <= len(train)]
    if bad:
        raise ValueError(f"training sizes must be in [20, {len(train)}] (the training arms available); got {bad}")
    rows = []
    for n in sizes:
        t0 = time.perf_counter()
        model, result = fit_map_model(train.head(n), recipe)
        seconds = time.perf_counter() - t0
        rows.append(curve_row(n, evaluate_map_model(model, test), seconds, result.stop_epoch))
    return rows


def speed_against_classical(model: SubspaceMLP, test, *, arms: int = 3, repeats: int = 200,
                            threads: int = 1) -> dict[str, Any]:
    """Seconds per map of the model and of the classical map that labelled `test`, side by side.

    The model: `predict_maps` of one held-out arm at a
    time (`repeats` calls after a warm-up; features, checks and thresholding included), the way
    a user asks for one arm's map. The classical map: the labels of the first `arms` held-out
    arms recomputed one arm at a time by `wsmap.datasets.labels_for` (the spec's method:
    the numerical map search for `panda7`, at the recall the labels have) and checked equal to
    the stored labels. Both on `threads` threads (torch and the compiled kernels), restored after.

    Returns `model_s` (mean), `model_min_s`, `classical_s` (mean per arm), `speedup`
    (`classical_s / model_s`), `threads`, `arms`, `nodes`.
    """
    from .. import timing
    from ..datasets import arms_from_features, labels_for
    from ..kinematics import lm_compiled

    _check_dataset(test, "test")
    if isinstance(arms, bool) or not isinstance(arms, (int, np.integer)) or not 1 <= arms <= len(test):
        raise ValueError(f"arms must be an integer in [1, {len(test)}]; got {arms!r}")
    spec = test.spec
    k = spec.n_arm_features if spec.is_chain_family else None

    def arms_of(rows):
        # what both the model and labels_for take: a chain family's scales, else the DH arms
        return rows[:, :k] if k else arms_from_features(rows)

    one = arms_of(test.features[:1])
    predict = lambda: model.predict_maps(one)  # noqa: E731
    old_torch, old_numba = torch.get_num_threads(), lm_compiled.threads()
    torch.set_num_threads(threads)
    lm_compiled.set_threads(threads)
    try:
        fast = timing.time_call(predict, repeats=repeats, warmup=3)
        labels_for(one, spec)  # compile, caches
        t0 = time.perf_counter()
        for i in range(arms):
            got = labels_for(arms_of(test.features[i:i + 1]), spec)
            if not np.array_equal(got[0], test.labels[i]):
                raise RuntimeError(f"the classical map of held-out arm {i} differs from its stored labels: the "
                                   "dataset was built by another version")
        classical = (time.perf_counter() - t0) / arms
    finally:
        torch.set_num_threads(old_torch)
        lm_compiled.set_threads(old_numba)
    return dict(model_s=fast.mean, model_min_s=fast.min, classical_s=classical, speedup=classical / fast.mean,
                threads=int(threads), arms=int(arms), nodes=int(test.labels.shape[1]))
