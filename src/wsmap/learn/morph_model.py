"""One map model for every arm: an implicit network `f(morphology, point) -> logit`.

The arm enters as its morphology features (`wsmap.kinematics.morphology.Morphology.features`:
73 numbers, every arm padded to 7 joints), the point as its position in metres (base frame) with
a few Fourier features; the orientation (tool-down, `R = Rx(pi)`, `"standard"` convention
`T = transl(p)·R`, as the `morph6` / `morph7` datasets) is fixed per model. A point is
reachable where `sigmoid(logit) > 0.5`. Because the network is queried at points, a model maps
any grid inside the box it was trained on (`[-1.5, 1.5]³` m), whatever its step.

Architecture (`MorphModelConfig`): an encoder MLP (standardised features -> latent vector,
SiLU), a decoder MLP on `[latent, point features]` (SiLU), one logit. The decoder's first layer
is split into its latent and point parts, so a map of `P` points of one arm costs one encoder
pass plus `P` decoder passes.

Training (`fit_morph_model`): the project's `wsmap.learn.training.train` -- Adam on
binary cross-entropy over minibatches of arms (each arm with all its labelled nodes), a cosine
learning-rate schedule, the epoch of lowest validation loss kept. Float32.

What a model refuses (`ExtrapolationError`, or a warning with
`allow_extrapolation=True`): an arm outside the range of the families it was trained on
(`wsmap.robots.morph.MorphFamily.problems`: lengths, joint ranges, tool, or a joint count
it has not seen), and points outside its box. A robot that has no morphology (a prismatic joint,
more than 7 joints) is a `MorphologyError`; an orientation
or convention other than the model's a `ValueError`.

Files (`save_morph_model`, `load_morph_model`): the format of `wsmap.learn.files`
(a `torch.save` dict of plain content and a SHA-256 checksum over it) with the format tag
`FORMAT`; a file of another kind (a family map model) is a
`ModelFileError` naming what it is. `nearest_arm_maps` is the
baseline a model must beat: the map of the nearest training arm in
`morphology_distance`.
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch

from .._version import __version__
from ..kinematics.morphology import N_FEATURES, SNAP, describe, morphology_distance
from ..robots import FAMILIES
from ..robots.morph import MorphFamily, morph_params, morphology_of
from .conditioned import ArmConditionedField, fourier_features
from .files import ModelFileError, read_model_payload, to_plain, write_model_payload
from .predictor import register_model_format
from .training import TrainConfig, TrainResult, train
from .training_range import ExtrapolationError, ExtrapolationWarning

__all__ = ["FORMAT", "FORMAT_VERSION", "MorphModelConfig", "MorphMapModel", "morph_features", "fit_morph_model",
           "predict_morph_map", "predict_morph_grid", "prepare_query", "save_morph_model", "load_morph_model", "nearest_arm_maps", "fk_labels", "TOOL_DOWN", "morph_spec",
           "build_morph_shards", "family_of"]

FORMAT = "wsmap.morph_model"
FORMAT_VERSION = 1
#: The orientation of the morph datasets and models: tool down, `R = Rx(pi)` (rad).
TOOL_DOWN = (math.pi, 0.0, 0.0)


@dataclass(frozen=True)
class MorphModelConfig:
    """The network's shape: encoder widths, latent size, decoder widths, Fourier frequencies of the
    point (`sin/cos(2^k·pi·p/box)`, `k < frequencies`)."""

    encoder: tuple[int, ...] = (256, 256)
    latent: int = 128
    decoder: tuple[int, ...] = (128, 128)
    frequencies: int = 4

    def __post_init__(self):
        for name in ("encoder", "decoder"):
            v = tuple(getattr(self, name))
            if not v or any(isinstance(h, bool) or not isinstance(h, (int, np.integer)) or h < 1 for h in v):
                raise ValueError(f"MorphModelConfig.{name} must be a non-empty list of positive integers, got {v!r}")
            object.__setattr__(self, name, tuple(int(h) for h in v))
        for name in ("latent", "frequencies"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < (1 if name == "latent" else 0):
                raise ValueError(f"MorphModelConfig.{name} must be a {'positive' if name == 'latent' else 'non-negative'} "
                                 f"integer, got {v!r}")

    def to_dict(self) -> dict[str, Any]:
        return {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(self).items()}


class MorphMapModel(ArmConditionedField):
    """`f(features, point) -> logit` (module notes).

    `forward(X)` takes raw morphology features `(B, N_FEATURES)` and returns the logits
    `(B, N)` at the model's training nodes (`nodes`, `(N, 3)` m): what
    `train` fits. `logits_at` queries any points.

    Attributes (besides the weights): `box` the half-width (m) of the cube it was trained in;
    `rpy`, `convention` the fixed orientation and the pose convention of its labels;
    `families` the names of the arm families it was trained on.
    """

    QUERY_LAYER = "dec_point"  # the name the model files hold

    def __init__(self, config: MorphModelConfig | None = None, nodes=None, *, box: float = 1.5,
                 rpy=TOOL_DOWN, convention: str = "standard", families=("morph6", "morph7")):
        super().__init__()
        self.config = config = config or MorphModelConfig()
        self.box = float(box)
        self.rpy = tuple(float(x) for x in rpy)
        self.convention = str(convention)
        self.families = tuple(families)
        #: the probability above which a node is reachable (`fit_morph_model` picks it on the
        #: validation arms)
        self.threshold = 0.5
        self._build(N_FEATURES, 3 + 6 * config.frequencies, config)
        nodes = np.zeros((0, 3)) if nodes is None else np.asarray(nodes, dtype=np.float64)
        self.register_buffer("nodes", torch.as_tensor(nodes, dtype=torch.float32))

    def point_features(self, points: torch.Tensor) -> torch.Tensor:
        """`(P, 3 + 6 F)`: the point over the box, and its sines and cosines at F octaves."""
        u = points / self.box
        return torch.cat([u] + fourier_features(u, self.config.frequencies), dim=-1)

    def logits_at(self, X: torch.Tensor, points: torch.Tensor, chunk: int = 1 << 15) -> torch.Tensor:
        """Logits `(B, P)` of arms `X` `(B, N_FEATURES)` at points `(P, 3)` (m)."""
        z = self.dec_latent(self.encode(X))  # (B, H)
        out = []
        for s in range(0, points.shape[0], chunk):
            hp = self.query_projection(self.point_features(points[s:s + chunk]))  # (P, H)
            out.append(self.decoder(z[:, None, :] + hp[None, :, :])[..., 0])
        return torch.cat(out, dim=1) if out else z.new_zeros((X.shape[0], 0))

    def forward(self, X: torch.Tensor) -> torch.Tensor:
        return self.logits_at(X, self.nodes)


# --------------------------------------------------------------------------------------------- inputs
def family_of(n: int, families) -> MorphFamily | None:
    """The first of `families` that is a morph family of `n`-joint arms.

    Parameters
    ----------
    n : int
        Joint count of the arm.
    families : iterable of str
        Names in `wsmap.robots.FAMILIES` (a model's `families`); other families and unknown
        names are skipped.

    Returns
    -------
    MorphFamily or None
        None when none of them has `n` joints.
    """
    for name in families:
        f = FAMILIES.get(name)
        if isinstance(f, MorphFamily) and f.n_joints == n:
            return f
    return None


def morph_features(arms) -> np.ndarray:
    """Morphology features `(B, N_FEATURES)` of a list of arms (each a chain, a DH robot or the
    parameters of a morph family)."""
    rows = []
    for arm in arms:
        if isinstance(arm, np.ndarray):
            rows.append(morphology_of(arm).features())
        else:
            rows.append(describe(arm).features())
    return np.stack(rows) if rows else np.zeros((0, N_FEATURES))


def _check_arm(model: MorphMapModel, robot, allow_extrapolation: bool) -> np.ndarray:
    """The features `(N_FEATURES,)` of `robot`, refused (or warned about) outside the training range."""
    m = describe(robot)  # MorphologyError: prismatic, < 6 or > 7 joints, a batch
    label = m.name or "the arm"
    problems = []
    family = family_of(m.n, model.families)
    if family is None:
        problems.append(f"it has {m.n} joints; the model was trained on {', '.join(model.families)} only")
    elif np.abs(m.mount - np.eye(4)).max() > SNAP:  # a file's rounded numbers tilt it by ~1e-5
        problems.append("its first joint axis is not the base z axis")
    else:
        problems += family.problems(morph_params(m))
    if problems:
        what = f"{label} is outside the model's training range ({', '.join(model.families)}): {problems[0]}"
        if not allow_extrapolation:
            raise ExtrapolationError(f"{what}; pass allow_extrapolation=True (--allow-extrapolation) to predict anyway")
        warnings.warn(f"{what}; predicted anyway (allow_extrapolation=True)", ExtrapolationWarning, stacklevel=3)
    return m.features()


def prepare_query(model: MorphMapModel, robot, nodes, rpy, convention, threshold, allow_extrapolation):
    """The checks every prediction makes before any work (the orientation, convention, nodes, the
    arm's range, the box, the threshold): `(features (N_FEATURES,), nodes (N, 3) float64, logit
    threshold)`; the errors are `predict_morph_map`'s."""
    if rpy is not None and not np.allclose(np.asarray(rpy, dtype=np.float64), model.rpy, atol=1e-9):
        raise ValueError(f"the morphology model maps orientation rpy = {list(model.rpy)} (tool down), not "
                         f"{[float(x) for x in np.ravel(np.asarray(rpy, dtype=float))]}")
    if convention is not None and convention != model.convention:
        raise ValueError(f"the morphology model's labels use convention {model.convention!r}, not {convention!r}")
    nodes = np.asarray(nodes, dtype=np.float64)
    if nodes.ndim != 2 or nodes.shape[1] != 3 or not np.all(np.isfinite(nodes)):
        raise ValueError(f"nodes must be finite positions of shape (N, 3), got shape {nodes.shape}")
    x = _check_arm(model, robot, allow_extrapolation)
    outside = np.abs(nodes).max(axis=1) > model.box + 1e-9
    if outside.any():
        what = (f"{int(outside.sum())} of the {len(nodes)} nodes lie outside the model's box "
                f"[-{model.box}, {model.box}]³ m")
        if not allow_extrapolation:
            raise ExtrapolationError(f"{what}; pass allow_extrapolation=True (--allow-extrapolation) to predict anyway")
        warnings.warn(f"{what}; predicted anyway (allow_extrapolation=True)", ExtrapolationWarning, stacklevel=3)
    threshold = model.threshold if threshold is None else float(threshold)
    if not 0.0 < threshold < 1.0:
        raise ValueError(f"threshold must lie in (0, 1), got {threshold!r}")
    return x, nodes, math.log(threshold / (1.0 - threshold))


def predict_morph_map(model: MorphMapModel, robot, nodes, *, rpy=None, convention: str | None = None,
                      threshold: float | None = None, allow_extrapolation: bool = False) -> np.ndarray:
    """The predicted map bool `(N,)` of one arm at `nodes` `(N, 3)` (m, base frame): nodes
    whose probability exceeds `threshold` (`None`: the model's, `MorphMapModel.threshold`),
    the network evaluated at every node (`predict_morph_grid` maps a grid faster).

    `rpy` and `convention` (`None`: the model's) must be the model's; nodes outside its
    box and arms outside its training range are an `ExtrapolationError` unless
    `allow_extrapolation` (then an `ExtrapolationWarning`)."""
    x, nodes, logit_threshold = prepare_query(model, robot, nodes, rpy, convention, threshold, allow_extrapolation)
    with torch.no_grad():
        X = torch.as_tensor(x[None], dtype=torch.float32)
        logits = model.logits_at(X, torch.as_tensor(nodes, dtype=torch.float32))[0]
    return (logits > logit_threshold).numpy()


#: `predict_morph_grid`'s defaults: every `COARSE`-th node along each axis first, and a
#: coarse cell is refined when a corner's logit is within `MARGIN` of the threshold's
#: (`benchmarks/learn/bench_morph_map_speed.py`: with margin 6 the maps of 206 arms were already
#: identical to the dense ones; 8 keeps room)
COARSE, MARGIN = 3, 8.0
#: where the coarse pass leaves more than this share of the nodes to evaluate, every node is
#: evaluated (the dense map; gathering and scattering most of a grid cost more than they save:
#: the stage's small model on the UR5e took 36 ms coarse to fine against 28 ms dense)
DENSE_ABOVE = 0.5


def predict_morph_grid(model: MorphMapModel, robot, lo, hi, step, *, rpy=None, convention: str | None = None,
                       threshold: float | None = None, allow_extrapolation: bool = False, coarse: int = COARSE,
                       margin: float = MARGIN) -> np.ndarray:
    """The predicted map bool `(N,)` of one arm on the grid `cartesian_grid(lo, hi, step)`
    (m, base frame, x fastest), coarse to fine: what `predict_morph_map` gives at those nodes,
    evaluating the network at a fraction of them.

    The network is evaluated first at every `coarse`-th node along each axis (and the last), then
    at the nodes of each coarse cell with a corner whose logit is at least the threshold's minus
    `margin`; every other node is unreachable. Reachable sets fill a few per cent of the box, so
    most of the network's work goes (it is evaluated at about 16 % of the nodes of a 0.1 m grid for
    typical arms). This is a bet on the network's smoothness, not a proof: a positive node inside a
    coarse cell whose eight corners all lie more than `margin` logits below the threshold would be
    missed (none was in the benchmark). `coarse` = 1 (or `margin` = inf) evaluates every node,
    and so does a map whose near cells hold more than `DENSE_ABOVE` of the nodes.
    The other arguments and errors are `predict_morph_map`'s."""
    from ..workspace.grids import cartesian_grid, grid_counts

    if isinstance(coarse, bool) or not isinstance(coarse, (int, np.integer)) or coarse < 1:
        raise ValueError(f"coarse must be a positive integer, got {coarse!r}")
    if not margin >= 0:
        raise ValueError(f"margin must be a non-negative number of logits, got {margin!r}")
    counts = [int(c) for c in grid_counts(lo, hi, step)]  # (nx, ny, nz); the nodes x fastest
    x, nodes, logit_threshold = prepare_query(model, robot, cartesian_grid(lo, hi, step), rpy, convention, threshold,
                                         allow_extrapolation)
    with torch.no_grad():
        z = model.dec_latent(model.encode(torch.as_tensor(x[None], dtype=torch.float32)))[0]

        def logits(points: np.ndarray) -> np.ndarray:
            hp = model.dec_point(model.point_features(torch.as_tensor(points, dtype=torch.float32)))
            return model.decoder(hp + z)[:, 0].numpy()

        if coarse == 1 or not math.isfinite(margin) or min(counts) < 2:
            return logits(nodes) > logit_threshold
        # per axis: the coarse indices (every coarse-th, and the last), and each node's coarse cell
        picks = [np.unique(np.r_[np.arange(0, c, coarse), c - 1]) for c in counts]
        cells = [np.clip(np.searchsorted(pk, np.arange(c), side="right") - 1, 0, len(pk) - 2)
                 for pk, c in zip(picks, counts)]
        vol = nodes.reshape(counts[2], counts[1], counts[0], 3)
        coarse_nodes = vol[np.ix_(picks[2], picks[1], picks[0])].reshape(-1, 3)
        near = (logits(coarse_nodes) >= logit_threshold - margin).reshape(len(picks[2]), len(picks[1]), len(picks[0]))
        cell = np.zeros(tuple(len(pk) - 1 for pk in picks[::-1]), dtype=bool)  # (z, y, x) cells
        for dz in (0, 1):
            for dy in (0, 1):
                for dx in (0, 1):
                    cell |= near[dz:dz + cell.shape[0], dy:dy + cell.shape[1], dx:dx + cell.shape[2]]
        todo = cell[np.ix_(cells[2], cells[1], cells[0])].ravel()
        if todo.mean() > DENSE_ABOVE:  # gathering most of the nodes costs more than it saves
            return logits(nodes) > logit_threshold
        out = np.zeros(len(nodes), dtype=bool)
        if todo.any():
            out[todo] = logits(nodes[todo]) > logit_threshold
    return out


# --------------------------------------------------------------------------------------------- experience
def morph_spec(n_joints: int, samples: int, seed: int = 0, step: float = 0.1, box: float = 1.5):
    """The dataset spec of `samples` arms of `morph<n_joints>`: the tool-down map
    (`TOOL_DOWN`, `"standard"` convention) on `[-box, box]³` at `step` (m), labelled by
    the numerical map search; `seed` picks the streams (one seed per shard)."""
    from ..datasets import DatasetSpec

    if n_joints not in (6, 7):
        raise ValueError(f"the morph families have 6 or 7 joints, got {n_joints!r}")
    return DatasetSpec(f"morph{n_joints}_s{seed}", family=f"morph{n_joints}", method="numerical", fixed=TOOL_DOWN,
                       convention="standard", lo=-box, hi=box, step=step, samples=samples, seed=seed)


def build_morph_shards(out_dir, n_joints: int, shards: int, arms_per_shard: int, *, step: float = 0.1,
                       box: float = 1.5, first_seed: int = 0, test_samples: int | None = None, progress: bool = False,
                       workers: int | None = None, scheduler=None) -> tuple[list, list[float]]:
    """Build (or reuse) `shards` dataset files of `arms_per_shard` arms each, shard `k` the
    spec `morph_spec` with seed `first_seed + k` (independent streams), in `out_dir`.

    Resumable: a shard whose file is there and holds exactly its spec is loaded, not rebuilt, so a
    run that stopped goes on at the first missing shard (each file is written atomically by
    `wsmap.datasets.build_dataset_files`, in chunks, on Dask with `workers` / `scheduler`).
    `test_samples`: shard 0 also gets its independent test set (`NAME.test.npz`).

    Returns `(datasets, seconds)`: the loaded `Dataset` of every shard in
    order (with shard 0's test set last when asked for) and the build time of each shard (0.0 for
    a shard that was there)."""
    from ..datasets import DatasetError, build_dataset_files, load_dataset, test_path_for, test_spec

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    loaded, seconds = [], []
    test = None
    for k in range(shards):
        spec = morph_spec(n_joints, arms_per_shard, first_seed + k, step, box)
        path = out_dir / f"{spec.name}_{arms_per_shard}_{step:g}.npz"
        want_test = test_samples is not None and k == 0
        tspec = test_spec(spec, test_samples) if want_test else None
        try:
            ds = load_dataset(path, expect_spec=spec)
            ts = load_dataset(test_path_for(path), expect_spec=tspec) if want_test else None
            seconds.append(0.0)
        except (FileNotFoundError, DatasetError):
            t0 = time.perf_counter()
            build_dataset_files(spec, path, test_samples=test_samples if want_test else None, progress=progress,
                                workers=workers, scheduler=scheduler)
            seconds.append(time.perf_counter() - t0)
            ds = load_dataset(path, expect_spec=spec)
            ts = load_dataset(test_path_for(path), expect_spec=tspec) if want_test else None
        loaded.append(ds)
        test = ts if want_test else test
    if test is not None:
        loaded.append(test)
    return loaded, seconds


# --------------------------------------------------------------------------------------------- training
def fit_morph_model(datasets, config: MorphModelConfig | None = None, train_config: TrainConfig | None = None,
                    seed: int = 0, labels=None) -> tuple[MorphMapModel, TrainResult]:
    """Train a `MorphMapModel` on datasets of the morph families (`wsmap.datasets.Dataset`
    of one grid, R3, fixed orientation); returns the model (eval mode, on the CPU whatever
    `train_config.device` trained it on) and the training result.

    `train_config` defaults to Adam (lr 1e-3), binary cross-entropy, 8 arms per step, cosine
    decay over 30 epochs, 5 % of the arms for validation, no test split (the caller's held-out
    arms are the test). The model's threshold is then the probability (0.05 to 0.95 by 0.05) of the
    best pooled F on the validation arms (0.5 without any): reachable nodes are a few per cent of
    the box, and the cross-entropy optimum leans to "unreachable".

    `labels`: one bool array `(samples, nodes)` per dataset to train on instead of its own
    labels, for the same arms (the forward-kinematics-only baseline, `fk_labels`)."""
    datasets = list(datasets)
    if not datasets:
        raise ValueError("fit_morph_model needs at least one dataset")
    if labels is not None:
        labels = list(labels)
        if len(labels) != len(datasets):
            raise ValueError(f"labels: one array per dataset, got {len(labels)} for {len(datasets)} datasets")
        for ds, y in zip(datasets, labels):
            if np.shape(y) != (len(ds.features), ds.spec.n_nodes):
                raise ValueError(f"labels for dataset {ds.spec.name!r} must have shape "
                                 f"{(len(ds.features), ds.spec.n_nodes)}, got {np.shape(y)}")
    from ..datasets import spec_nodes

    first = datasets[0].spec
    X, Y = [], []
    for i, ds in enumerate(datasets):
        s = ds.spec
        if not isinstance(FAMILIES.get(s.family), MorphFamily):
            raise ValueError(f"dataset {s.name!r} is of family {s.family!r}, not a morph family (morph6, morph7)")
        for k in ("scope", "lo", "hi", "step", "select", "fixed", "convention"):
            if getattr(s, k) != getattr(first, k):
                raise ValueError(f"datasets {first.name!r} and {s.name!r} differ in {k}: one model maps one grid")
        k = s.n_arm_features
        X.append(morph_features(list(ds.features[:, :k])))
        Y.append(ds.labels if labels is None else np.asarray(labels[i], dtype=bool))
    X, Y = np.concatenate(X), np.concatenate(Y).astype(np.float32)
    torch.manual_seed(seed)
    hi = first.hi if isinstance(first.hi, float) else max(first.hi)
    model = MorphMapModel(config, spec_nodes(first), box=float(hi), rpy=first.fixed, convention=first.convention,
                          families=tuple(sorted({ds.spec.family for ds in datasets})))
    model.standardise_on(X)
    tc = train_config or TrainConfig(optimizer="adam", optimizer_kwargs={"lr": 1e-3}, loss="crossentropy",
                                     batch_size=8, lr_decay="cosine", max_epochs=30, max_fail=1000,
                                     fractions=(0.95, 0.05, 0.0), seed=seed)
    result = train(model, X.astype(np.float32), Y, tc)
    model.eval()
    model.threshold = _best_threshold(model, X[result.split.val], Y[result.split.val])
    # trained where `tc.device` says; maps are predicted from CPU tensors, and a saved model loads there
    model.cpu()
    model.train_config = tc
    model.dataset_specs = [ds.spec.to_dict() for ds in datasets]
    return model, result


def _best_threshold(model: MorphMapModel, X: np.ndarray, Y: np.ndarray, chunk: int = 1024) -> float:
    if len(X) == 0:
        return 0.5
    # on the device the model was trained on, `chunk` arms at a time (thousands of validation arms
    # times the grid's nodes would not fit in one forward pass)
    device = next(model.parameters()).device
    with torch.no_grad():
        prob = np.concatenate([torch.sigmoid(model(torch.as_tensor(X[i:i + chunk], dtype=torch.float32,
                                                                   device=device))).cpu().numpy()
                               for i in range(0, len(X), chunk)])
    truth = Y > 0.5
    best, best_f = 0.5, -1.0
    for t in np.round(np.arange(0.05, 0.951, 0.05), 2):
        pred = prob > t
        tp = np.sum(pred & truth)
        f = 2 * tp / max(1, pred.sum() + truth.sum())
        if f > best_f:
            best, best_f = float(t), f
    return best


# --------------------------------------------------------------------------------------------- baselines
def fk_labels(dataset, *, samples: int = 200_000, angle_tol: float = 0.4, seed: int = 0) -> np.ndarray:
    """The labels `(arms, nodes)` bool of every arm of a morph-family `dataset` on its grid from
    forward kinematics alone (`wsmap.workspace.fk_sampled_maps`: `samples` configurations per
    arm, rotations within `angle_tol` rad of the dataset's orientation): the experience of a
    RAM-like model, trained with `fit_morph_model(..., labels=...)` and scored against the
    dataset's own (map-search) labels. Arm `i` draws from seed `(seed, i)`: a row does not
    depend on the other arms."""
    from ..workspace import fk_sampled_maps

    s = dataset.spec
    fam = FAMILIES.get(s.family)
    if not isinstance(fam, MorphFamily):
        raise ValueError(f"dataset {s.name!r} is of family {s.family!r}, not a morph family (morph6, morph7)")
    params = np.asarray(dataset.features[:, :s.n_arm_features], dtype=np.float64)
    out = np.zeros((len(params), s.n_nodes), dtype=bool)
    for i in range(len(params)):
        arm = fam.arms(params[i], allow_extrapolation=True)
        out[i] = fk_sampled_maps(arm, s.lo, s.hi, s.step, s.fixed, convention=s.convention, samples=samples,
                                 angle_tol=angle_tol, seed=int(np.random.SeedSequence([int(seed), i]).generate_state(1)[0]))
    return out


def nearest_arm_maps(train_features, train_labels, query_features, *,
                     max_numbers: int = 1 << 24) -> tuple[np.ndarray, np.ndarray]:
    """The nearest-neighbour baseline: for each query arm `(Q, N_FEATURES)` the labels `(Q, N)`
    of the training arm nearest in `morphology_distance`, and
    that distance `(Q,)` (m). `max_numbers` bounds the memory: queries go in chunks whose
    `(chunk, arms, N_FEATURES)` differences hold about that many float64s (at least one query)."""
    F = np.asarray(train_features, dtype=np.float64)
    Q = np.asarray(query_features, dtype=np.float64)
    # queries in chunks: the (chunk, arms, features) difference stays near `max_numbers` float64s
    # (128 MB by default) however many training arms there are (100,000 arms x 200 queries: 12 GB)
    chunk = max(1, int(max_numbers) // max(1, F.shape[0] * F.shape[-1]))
    idx = np.empty(len(Q), dtype=np.int64)
    dist = np.empty(len(Q))
    for s in range(0, len(Q), chunk):
        d = morphology_distance(Q[s:s + chunk, None, :], F[None, :, :])
        idx[s:s + chunk] = d.argmin(axis=1)
        dist[s:s + chunk] = d[np.arange(len(d)), idx[s:s + chunk]]
    return np.asarray(train_labels)[idx], dist


# --------------------------------------------------------------------------------------------- files
def save_morph_model(model: MorphMapModel, path, *, extra: dict | None = None) -> Path:
    """Write `model` to `path` atomically (format `FORMAT`, with a checksum); returns the path."""
    if not isinstance(model, MorphMapModel):
        raise TypeError(f"save_morph_model needs a MorphMapModel; got {type(model).__name__}")
    payload = {
        "format": FORMAT, "version": FORMAT_VERSION, "wsmap_version": __version__,
        "config": model.config.to_dict(),
        "state_dict": {k: v.detach().cpu().clone() for k, v in model.state_dict().items()},
        "box": model.box, "threshold": model.threshold, "rpy": list(model.rpy), "convention": model.convention, "families": list(model.families),
        "dataset_specs": to_plain(getattr(model, "dataset_specs", None), "dataset_specs"),
        "train_config": to_plain(getattr(model, "train_config", None), "train_config"),
        "extra": to_plain(extra, "extra"),
    }
    return write_model_payload(path, payload)


def load_morph_model(path) -> tuple[MorphMapModel, dict[str, Any]]:
    """Read a file of `save_morph_model` -> `(model, meta)` (eval mode, on the CPU).

    A missing, corrupt or tampered file, and a model file of another kind, are a
    `ModelFileError` `"cannot load model <path>: <problem>"`."""
    def fail(problem, cause=None):
        raise ModelFileError(f"cannot load model {path}: {problem}") from cause

    payload = read_model_payload(path, FORMAT, FORMAT_VERSION, "a morphology model")
    try:
        config = MorphModelConfig(**payload["config"])
        state = payload["state_dict"]
        model = MorphMapModel(config, np.zeros(tuple(state["nodes"].shape)), box=payload["box"], rpy=payload["rpy"],
                              convention=payload["convention"], families=payload["families"])
        model.load_state_dict(state)
        model.threshold = float(payload["threshold"])
    except (KeyError, TypeError, ValueError, RuntimeError) as e:
        fail(f"invalid content ({e})", e)
    model.eval()
    meta = {k: payload.get(k) for k in ("format", "version", "wsmap_version", "dataset_specs", "train_config", "extra",
                                        "checksum")}
    meta["path"] = str(path)
    return model, meta


def _whole_grid_map(path, robot, fixed, *, grid: dict, convention: str, allow_extrapolation: bool) -> np.ndarray:
    """`method="model"` of `wsmap.workspace.grid_map` for a morphology model file: the map
    `(N,)` of one arm on `grid` (R3 only; any step inside the model's box)."""
    if grid["scope"] != "R3":
        raise ValueError(f"a morphology model maps positions (scope R3), not {grid['scope']}")
    model, _ = load_morph_model(path)
    return predict_morph_grid(model, robot, grid["lo"], grid["hi"], grid["step"], rpy=fixed, convention=convention,
                              allow_extrapolation=allow_extrapolation)


register_model_format(FORMAT, _whole_grid_map)
