"""The paper's experiments as functions: fit subspace models on a dataset, score them on a test set.

Notebooks call these so that every number they show comes from tested code:

* `fit` trains `sessions` independent models (the paper repeats 10) of one architecture on
  one dataset, optionally on a slice of its nodes (one output subspace);
* `fit_blocks` trains one model per output block and stacks them into one
  `SubspaceMLP` whose subspaces assemble the whole map (section 6.2);
* `evaluate` gives the pooled (micro) and per-sample precision, recall and F-measure of a
  model on a test set, the paper's numbers.

Devices: `train_config.device` (`TrainConfig`) says where the
sessions train; the returned models stay there, and `evaluate` scores them where they are
(the scores come back as numpy arrays).

Shapes: a dataset has `n` samples (arms) of `f` stored features and `N` nodes; a node slice
picks `m` of them. Networks run in float32; labels are bool on disk and float32 targets here.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import torch

from ..metrics import score_maps
from ..datasets import Dataset
from ..learn import MLPConfig, SubspaceMLP
from ..learn.device import resolve_device
from ..learn.training import TrainConfig, TrainResult, train_mlp_sessions
from .specs import load_pair

__all__ = ["model_config", "fit", "fit_blocks", "stack_sessions", "evaluate", "node_slice", "training_data",
           "paper_train_config", "timed", "log_training"]


def node_slice(nodes, n_nodes: int) -> slice:
    """`nodes` as a slice of a dataset's `n_nodes` node columns: `None` (all), a slice, or a
    `(start, stop)` pair (0-based, stop exclusive). Raises `ValueError` outside the range."""
    if nodes is None:
        return slice(0, n_nodes)
    if not isinstance(nodes, slice):
        if len(nodes) != 2:
            raise ValueError(f"nodes must be None, a slice or (start, stop); got {nodes!r}")
        nodes = slice(int(nodes[0]), int(nodes[1]))
    start, stop, step = nodes.indices(n_nodes)
    if step != 1 or not 0 <= start < stop <= n_nodes or (nodes.stop is not None and nodes.stop > n_nodes):
        raise ValueError(f"node slice {nodes} is not a non-empty contiguous range within the {n_nodes} nodes")
    return slice(start, stop)


def training_data(cfg, data_dir):
    """What §6.1 and §6.2 train and test on, from their params section `cfg`: `(device, threads,
    train_all, train, test)`, the device `cfg["device"]` resolved before any work (cuda without a
    GPU fails here), torch's thread count, the dataset pair `cfg["dataset"]` in `data_dir` and
    `train` its first `cfg["train_samples"]` training arms."""
    device = resolve_device(cfg["device"], f"{cfg.source} device")
    threads = torch.get_num_threads()
    train_all, test = load_pair(cfg["dataset"], data_dir)
    return device, threads, train_all, train_all.head(cfg["train_samples"]), test


def paper_train_config(cfg, device) -> TrainConfig:
    """The paper's training (Rprop on the MSE, §6) with `cfg`'s `max_epochs`, `max_fail` and
    `seed`, on `device`."""
    return TrainConfig(optimizer="rprop", loss="mse", max_epochs=cfg["max_epochs"], max_fail=cfg["max_fail"],
                       seed=cfg["seed"], device=device)


def timed(train: Callable[[], Any]) -> tuple[Any, float]:
    """`(train(), wall-clock seconds it took)`: the training time a part reports over all sessions."""
    t0 = time.perf_counter()
    value = train()
    return value, time.perf_counter() - t0


def log_training(results: Sequence[TrainResult], labels: Sequence[str], total_seconds: float, what: str,
                 log: Callable[[str], Any]) -> list[float]:
    """Log one line per training run (its label, epochs, why it stopped, best epoch, validation MSE,
    seconds) and one for all `what` together; returns the seconds each run took (the last time of
    its history)."""
    seconds = [float(r.history.time[-1]) for r in results]
    for label, r, s in zip(labels, results, seconds):
        log(f"{label}: {r.stop_epoch} epochs ({r.stop_reason}), best epoch {r.best_epoch}, "
            f"val MSE {r.best_val_loss:.5f}, {s:.1f} s")
    log(f"all {what}: {total_seconds:.1f} s")
    return seconds


def model_config(ds: Dataset, nodes=None, hidden: Sequence[int] = (125, 100, 100, 125), **kwargs) -> MLPConfig:
    """The `MLPConfig` for `ds` (its feature count in, the node slice's size out);
    `kwargs` set the other fields (`input_columns`, `input_scaling`, `output_kind`, ...)."""
    sl = node_slice(nodes, ds.header["labels_shape"][1])
    return MLPConfig(n_inputs=ds.features.shape[1], n_outputs=sl.stop - sl.start, hidden=list(hidden), **kwargs)


def _targets(ds: Dataset, sl: slice) -> np.ndarray:
    return ds.labels[:, sl].astype(np.float32)


def fit(ds: Dataset, train_config: TrainConfig, *, nodes=None, sessions: int = 1,
        hidden: Sequence[int] = (125, 100, 100, 125), stacked: bool = False, **mlp) -> list[TrainResult]:
    """Train `sessions` independent models on `ds` (session `s`: seed `train_config.seed + s`
    for its split and initial weights, as `wsmap.learn.training.train_mlp_sessions`).

    Parameters
    ----------
    ds
        training dataset (the 70/15/15 split is drawn inside).
    train_config
        optimiser, loss, epochs, early stopping.
    nodes
        node slice to learn (`None`: all nodes of `ds`; `(start, stop)` 0-based).
    hidden, mlp
        architecture (`model_config`); the first layer is configured
        (Nguyen–Widrow ranges, input standardisation) on the session's training split.
    stacked
        train the sessions as one stacked model (Rprop only; see `train_sessions`).

    Returns
    -------
    list[TrainResult]
        One `TrainResult` per session; `result.model` is restored to its best epoch.
    """
    sl = node_slice(nodes, ds.header["labels_shape"][1])
    return train_mlp_sessions(model_config(ds, sl, hidden, **mlp), ds.features, _targets(ds, sl), train_config,
                              sessions, stacked=stacked)


def stack_sessions(results: Sequence[TrainResult]) -> SubspaceMLP:
    """The models of several results (one subspace each) stacked into one model, in order."""
    models = []
    for r in results:
        m = r.model
        models.append(m.subspace(r.session) if r.session is not None else m)
    return SubspaceMLP.from_models(models)


def fit_blocks(ds: Dataset, train_config: TrainConfig, blocks: Sequence, *,
               hidden: Sequence[int] = (125, 100, 100, 125), **mlp) -> tuple[SubspaceMLP, list[TrainResult]]:
    """One model per node block (section 6.2: 7 consecutive blocks of 1323 nodes), trained one
    after another with the same config and seed, stacked into one `SubspaceMLP` whose
    subspace `k` predicts block `k`; `model.assemble(x)` concatenates them in node order.

    `blocks` are `(start, stop)` pairs or slices of equal size. Returns `(model, results)`.
    """
    n_nodes = ds.header["labels_shape"][1]
    slices = [node_slice(b, n_nodes) for b in blocks]
    if len({s.stop - s.start for s in slices}) != 1:
        raise ValueError("blocks must all have the same number of nodes (one architecture per subspace)")
    results = [fit(ds, train_config, nodes=s, sessions=1, hidden=hidden, **mlp)[0] for s in slices]
    return stack_sessions(results), results


def evaluate(model: SubspaceMLP, test: Dataset, *, nodes=None, key: int | None = None,
             assemble: bool = False, threshold: float = 0.5, batch_size: int = 2048) -> dict[str, Any]:
    """Precision, recall and F-measure of `model` on `test` (`wsmap.metrics.score_maps`):
    pooled over every sample and node (`precision`, `recall`, `f`: the paper's), per sample
    (`f_mean`, `f_std`, over samples whose F is defined; `f_undefined`: samples with no
    positive in truth or prediction), and the confusion counts.

    `nodes` (the truth's node slice) must match the model's outputs: one subspace (`key`) or
    all of them concatenated (`assemble=True`). Also returns `scores` (float32, `(n, m)`)
    and `truth` (bool) for histograms and threshold sweeps.
    """
    n_nodes = test.header["labels_shape"][1]
    sl = node_slice(nodes, n_nodes)
    if model.n_subspaces > 1 and key is None and not assemble:
        raise ValueError(f"the model has {model.n_subspaces} subspaces: give key=k or assemble=True")
    key = 0 if (key is None and not assemble) else key
    scores = model.score(test.features, key=key, assemble=assemble, batch_size=batch_size).cpu().numpy()
    truth = test.labels[:, sl]
    if scores.shape != truth.shape:
        raise ValueError(f"model outputs {scores.shape[1]} nodes but the truth slice {sl} has {truth.shape[1]}")
    return dict(score_maps(scores > threshold, truth), threshold=float(threshold), scores=scores, truth=truth)
