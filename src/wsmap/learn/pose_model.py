"""A pose-conditioned reachability network for RAM's arms: `f(morphology, pose) -> logit`.

RAM's query (`wsmap.datasets.ram`): is the end-effector pose `T` in SE(3) reachable, by a
solution free of RAM's capsule self-collision, for an arm of 5-7 revolute joints it never saw?
This module answers it with one network for every arm and any pose, trained on wsmap's exact IK
labels (`wsmap.datasets.ram.ik_labels`; no FK-sampling ceiling).

Inputs
------
* **The arm**: RAM's own modified-DH table (`sample_morphologies`: `dof + 1` rows `(alpha, a,
  d)`, rad and m, the last row the fixed end effector), padded to 7 joint rows plus the end
  effector: slots `0 .. dof-1` the joints, slot 7 the end effector, each slot `(sin alpha, cos
  alpha, a, d, present)` -- `MORPH_INPUTS` = 40 numbers (`ram_inputs`). Not
  `wsmap.kinematics.morphology.describe(arm).features()` (the tool-down model's input): that
  description refuses arms of fewer than 6 joints, and a third of RAM's arms have 5; RAM's table
  is also its arms' complete description (no joint limits, no offsets, no tool), so nothing is
  lost by taking it as it is.
* **The pose** (base frame): its position `p` (m) over `box` (1 m: every RAM arm has total
  link length 1 m), the first two columns of `R` (the continuous 6-D rotation representation of
  Zhou et al., CVPR 2019), and `sin/cos(2^k pi p / box)` for `k < frequencies`
  (`pose_inputs`).

Architecture (`PoseModelConfig`): an encoder MLP (standardised arm inputs -> latent, SiLU), a
decoder MLP on `[latent, pose features]` (SiLU), one logit; the decoder's first layer is split into
its latent and pose parts (as `MorphMapModel`), so `P` poses of one arm cost one encoder pass plus
`P` decoder passes. Float32. A pose is reachable where `sigmoid(logit) > threshold` (the model's
`threshold`, chosen on the validation arms for the best mean per-arm F1, RAM's score).

Training data (`pose_training_set`, `build_pose_shards`): RAM's arm distribution, per arm RAM's
random poses (`random_poses`: uniform in its ball, uniform orientation) plus poses concentrated
near the boundary (`boundary_poses`: RAM's geodesics from a reachable to an unreachable pose,
each pose labelled by the IK), all labelled by `ik_labels` with self-collision. The labelling is a
loop over arms, each a batch of its poses (the compiled search). Shards are `.npz` files written
atomically with a SHA-256 of their content and their spec: a run that stopped goes on at the first
missing shard. Training (`fit_pose_model`): `wsmap.learn.training.train` -- Adam on binary
cross-entropy over minibatches of arms (each with all its poses), a cosine learning-rate schedule,
the epoch of lowest validation loss kept.

Refusals: an arm whose joint count the model was not trained on is an `ExtrapolationError` (one
line), a table that is not RAM's shape or holds NaN a `ValueError`; files of another kind,
corrupt or tampered files a `ModelFileError` (`save_pose_model`, `load_pose_model`).
"""

from __future__ import annotations

import hashlib
import json
import math
import time
import zipfile
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import torch

from .._version import __version__
from ..io import atomic_path
from .conditioned import ArmConditionedField, fourier_features
from .files import ModelFileError, read_model_payload, to_plain, write_model_payload
from .training import TrainConfig, TrainResult, train
from .training_range import ExtrapolationError

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from collections.abc import Sequence

    from wsmap._typing import ArrayLike, PathLike

__all__ = ["POSE_FORMAT", "POSE_FORMAT_VERSION", "MORPH_INPUTS", "POSE_INPUTS", "PoseModelConfig", "PoseMapModel",
           "PoseShard", "ram_inputs", "pose_inputs", "pose_training_set", "build_pose_shards", "fit_pose_model",
           "predict_pose_logits", "predict_poses", "save_pose_model", "load_pose_model"]

POSE_FORMAT = "wsmap.pose_model"
POSE_FORMAT_VERSION = 1
_SLOTS = 8  # 7 joint rows and the end effector's
#: Arm inputs per arm: 8 slots of `(sin alpha, cos alpha, a, d, present)`.
MORPH_INPUTS = 5 * _SLOTS
#: Raw pose numbers per pose in a training row: the position (m) and the first two columns of R.
POSE_INPUTS = 9
_SHARD_VERSION = 1


# --------------------------------------------------------------------------------------------- inputs
def _check_tables(morph) -> np.ndarray:
    m = np.asarray(morph, dtype=np.float64)
    if m.ndim not in (2, 3) or m.shape[-1] != 3 or not 6 <= m.shape[-2] <= 8:
        raise ValueError(f"morph must be RAM's table (dof + 1, 3) or a batch (B, dof + 1, 3) of (alpha, a, d) rows "
                         f"with dof in 5..7, got shape {m.shape}")
    if not np.all(np.isfinite(m)):
        raise ValueError("morph contains NaN or infinite values")
    return m


def ram_inputs(morph: ArrayLike) -> np.ndarray:
    """The network's arm inputs of RAM tables.

    Parameters
    ----------
    morph : array_like, shape (dof + 1, 3) or (B, dof + 1, 3)
        Rows `(alpha, a, d)` (rad, m, m) of a modified-DH table, the last the end effector
        (`wsmap.datasets.sample_morphologies`), `dof` in 5..7.

    Returns
    -------
    ndarray, shape (B, MORPH_INPUTS)
        Per slot `(sin alpha, cos alpha, a, d, present)`: joint `i` in slot `i`, the end effector
        in slot 7, missing joints all zero (float64).
    """
    m = _check_tables(morph)
    m = m[None] if m.ndim == 2 else m
    n = m.shape[1] - 1
    out = np.zeros((m.shape[0], _SLOTS, 5))
    slots = list(range(n)) + [_SLOTS - 1]
    rows = np.stack([np.sin(m[..., 0]), np.cos(m[..., 0]), m[..., 1], m[..., 2], np.ones(m.shape[:2])], axis=-1)
    out[:, slots] = rows
    return out.reshape(m.shape[0], MORPH_INPUTS)


def _raw_pose(T) -> np.ndarray:
    """`(..., 9)`: position (m) and the first two columns of R of poses `(..., 4, 4)`."""
    T = np.asarray(T, dtype=np.float64)
    if T.ndim < 3 or T.shape[-2:] != (4, 4):
        raise ValueError(f"poses must have shape (P, 4, 4) or (B, P, 4, 4), got {T.shape}")
    if not np.all(np.isfinite(T)):
        raise ValueError("poses contain NaN or infinite values")
    R = T[..., :3, :3]
    return np.concatenate([T[..., :3, 3], R[..., :, 0], R[..., :, 1]], axis=-1)


def pose_inputs(T: ArrayLike) -> np.ndarray:
    """The raw pose numbers the network reads, `(..., POSE_INPUTS)` float64: position (m, base
    frame) and the first two columns of the rotation (Zhou et al.'s 6-D representation) of poses
    `(..., 4, 4)`; the Fourier features are computed inside the model (`PoseMapModel.pose_features`)."""
    return _raw_pose(T)


# --------------------------------------------------------------------------------------------- model
@dataclass(frozen=True)
class PoseModelConfig:
    """The network's shape: encoder widths, latent size, decoder widths, and the Fourier octaves
    of the position (`sin/cos(2^k pi p / box)`, `k < frequencies`)."""

    encoder: tuple[int, ...] = (256, 256)
    latent: int = 128
    decoder: tuple[int, ...] = (256, 256, 128)
    frequencies: int = 4

    def __post_init__(self) -> None:
        for name in ("encoder", "decoder"):
            v = tuple(getattr(self, name))
            if not v or any(isinstance(h, bool) or not isinstance(h, (int, np.integer)) or h < 1 for h in v):
                raise ValueError(f"PoseModelConfig.{name} must be a non-empty list of positive integers, got {v!r}")
            object.__setattr__(self, name, tuple(int(h) for h in v))
        for name, low in (("latent", 1), ("frequencies", 0)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < low:
                raise ValueError(f"PoseModelConfig.{name} must be an integer of at least {low}, got {v!r}")

    def to_dict(self) -> dict[str, Any]:
        return {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(self).items()}


class PoseMapModel(ArmConditionedField):
    """`f(arm inputs, pose) -> logit` (module notes).

    `forward(X)` takes training rows `(B, MORPH_INPUTS + P * POSE_INPUTS)` -- an arm's
    `ram_inputs` followed by its `P` poses' `pose_inputs`, flattened -- and returns the logits
    `(B, P)`: what `wsmap.learn.training.train` fits. `logits_at` takes the arm and the poses
    apart. Attributes besides the weights: `box` (m) the position scale, `dofs` the joint counts
    trained on, `threshold` the probability above which a pose is reachable.
    """

    QUERY_LAYER = "dec_pose"  # the name the model files hold

    def __init__(self, config: PoseModelConfig | None = None, *, box: float = 1.0,
                 dofs: Sequence[int] = (5, 6, 7)) -> None:
        super().__init__()
        self.config = config = config or PoseModelConfig()
        self.box = float(box)
        self.dofs = tuple(int(d) for d in dofs)
        self.threshold = 0.5
        self._build(MORPH_INPUTS, POSE_INPUTS + 6 * config.frequencies, config)

    def pose_features(self, raw: torch.Tensor) -> torch.Tensor:
        """`(..., 9 + 6 F)`: position over `box`, the 6-D rotation, sines and cosines of the
        position at `F` octaves."""
        u = raw[..., :3] / self.box
        return torch.cat([u, raw[..., 3:9]] + fourier_features(u, self.config.frequencies), dim=-1)

    def logits_at(self, A: torch.Tensor, raw: torch.Tensor, chunk: int = 1 << 14) -> torch.Tensor:
        """Logits `(B, P)` of arms `A` `(B, MORPH_INPUTS)` at raw poses `raw`: `(P, 9)` shared by
        every arm or `(B, P, 9)` one set per arm (`pose_inputs`)."""
        z = self.dec_latent(self.encode(A))[:, None, :]  # (B, 1, H): one encoder pass per arm
        out = []
        for s in range(0, raw.shape[-2], chunk):
            hp = self.query_projection(self.pose_features(raw[..., s:s + chunk, :]))  # (P, H) or (B, P, H)
            out.append(self.decoder(z + hp)[..., 0])
        return torch.cat(out, dim=-1) if out else z.new_zeros((A.shape[0], 0))

    def forward(self, X: torch.Tensor) -> torch.Tensor:
        A = X[:, :MORPH_INPUTS]
        raw = X[:, MORPH_INPUTS:].reshape(X.shape[0], -1, POSE_INPUTS)
        return self.logits_at(A, raw)


# --------------------------------------------------------------------------------------------- data
@dataclass(frozen=True)
class PoseShard:
    """One shard of training data: RAM tables `morphs` `(n, dof + 1, 3)` of one joint count, raw
    poses `poses` `(n, P, POSE_INPUTS)` (float64, `pose_inputs`), IK labels `labels` `(n, P)`
    bool, the `spec` it was built from and `cpu_seconds` (process CPU time of its labelling)."""

    morphs: np.ndarray
    poses: np.ndarray
    labels: np.ndarray
    spec: dict
    cpu_seconds: float


def pose_training_set(morphs: ArrayLike, random: int, geodesics: int, per_geodesic: int, seed: int = 0, *,
                      starts: int = 32, with_poses: bool = False) -> tuple[np.ndarray, ...]:
    """Poses and exact labels for every arm: RAM's random poses plus its boundary geodesics.

    Parameters
    ----------
    morphs : array_like, shape (n, dof + 1, 3)
        RAM tables (`sample_morphologies`).
    random : int
        Random poses per arm (`random_poses`: RAM's ball, uniform orientation; for 5-joint arms a
        quarter are FK poses of collision-free configurations, labelled reachable as RAM does).
    geodesics, per_geodesic : int
        Boundary poses per arm (`boundary_poses`): `geodesics` pairs of a reachable and an
        unreachable pose, `per_geodesic` poses along each, every one labelled by the IK.
    seed : int
        Arm `i` draws from seeds `seed * 100_003 + i`.
    starts : int
        IK starts of `ik_labels`.
    with_poses : bool
        Also return the poses themselves and which were labelled without IK (for scoring other
        labellers on exactly these poses, `wsmap.paper.parts.ram_protocol`).

    Returns
    -------
    poses : ndarray, shape (n, random + geodesics * per_geodesic, POSE_INPUTS)
        `pose_inputs` of each arm's poses (random first), float64.
    labels : ndarray of bool, same leading shape
        Reachable with a solution free of RAM's capsule self-collision.
    T : ndarray, shape (n, random + geodesics * per_geodesic, 4, 4)
        With `with_poses` only: the end-effector poses (base frame, m) that `poses` describes.
    known : ndarray of bool, shape as `labels`
        With `with_poses` only: the FK poses of collision-free configurations that RAM labels
        reachable without IK (a quarter of a 5-joint arm's random poses), OR-ed into `labels`.
    """
    from ..datasets import ram

    m = _check_tables(morphs)
    m = m[None] if m.ndim == 2 else m
    P = random + geodesics * per_geodesic
    poses = np.zeros((len(m), P, POSE_INPUTS))
    labels = np.zeros((len(m), P), dtype=bool)
    Ts = np.zeros((len(m), P, 4, 4)) if with_poses else None
    knowns = np.zeros((len(m), P), dtype=bool)
    for i, mi in enumerate(m):  # one arm at a time: each a batch of its poses in the compiled search
        s = int(seed) * 100_003 + i
        check = ram.ram_collision(mi)
        parts, labs, kn = [], [], []
        if random:
            T, known = ram.random_poses(mi, random, seed=s)
            parts.append(T)
            labs.append(ram.ik_labels(mi, T, starts=starts, seed=s, collision=check) | known)
            kn.append(known)
        if geodesics:
            known = np.zeros(geodesics * per_geodesic, dtype=bool)
            try:
                Tb, yb = ram.boundary_poses(mi, geodesics, per_geodesic, seed=s, starts=starts)
            except RuntimeError:  # no unreachable pose in the ball (or no free configuration): random ones
                Tb, known = ram.random_poses(mi, geodesics * per_geodesic, seed=s + 1)
                yb = ram.ik_labels(mi, Tb, starts=starts, seed=s, collision=check) | known
            parts.append(Tb)
            labs.append(yb)
            kn.append(known)
        T = np.concatenate(parts)
        poses[i] = _raw_pose(T)
        labels[i] = np.concatenate(labs)
        knowns[i] = np.concatenate(kn)
        if with_poses:
            Ts[i] = T
    return (poses, labels, Ts, knowns) if with_poses else (poses, labels)


def _digest(*arrays) -> str:
    h = hashlib.sha256()
    for a in arrays:
        a = np.ascontiguousarray(a)
        h.update(str((a.dtype.str, a.shape)).encode())
        h.update(a.tobytes())
    return "sha256:" + h.hexdigest()


def _load_shard(path: Path, spec: dict) -> PoseShard | None:
    """The shard at `path` if it is there, intact and of `spec`; else None (to be rebuilt)."""
    try:
        with np.load(path, allow_pickle=False) as z:
            meta = json.loads(str(z["meta"]))
            morphs, poses, labels = z["morphs"], z["poses"], z["labels"]
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile):  # missing, cut short, not ours
        return None
    if meta.get("spec") != spec or meta.get("sha256") != _digest(morphs, poses, labels):
        return None
    return PoseShard(morphs, poses, labels.astype(bool), spec, float(meta["cpu_seconds"]))


def build_pose_shards(out_dir: PathLike, dofs: Sequence[int] = (5, 6, 7), shards: int = 1, arms_per_shard: int = 100, *, random: int = 200,
                      geodesics: int = 20, per_geodesic: int = 10, first_seed: int = 0, starts: int = 32,
                      progress: bool = False) -> list[PoseShard]:
    """Build (or reuse) training shards of RAM arms and their labelled poses in `out_dir`.

    Shard `k` of joint count `d` holds `arms_per_shard` arms `sample_morphologies(arms_per_shard,
    d, seed=first_seed + k)` with the poses of `pose_training_set(..., seed=first_seed + k)`, in
    `pose_d{d}_s{seed}_{arms}.npz`. Resumable: a file that is there, intact (its SHA-256) and of
    the same spec is loaded, not rebuilt; each file is written atomically.

    Returns
    -------
    list of PoseShard
        For each joint count, its shards in order.
    """
    from ..datasets import ram

    for name, v, low in (("shards", shards, 1), ("arms_per_shard", arms_per_shard, 1), ("random", random, 0),
                         ("geodesics", geodesics, 0), ("per_geodesic", per_geodesic, 2), ("first_seed", first_seed, 0),
                         ("starts", starts, 1)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < low:
            raise ValueError(f"{name} must be an integer of at least {low}, got {v!r}")
    if random + geodesics == 0:
        raise ValueError("random and geodesics are both 0: no poses to label")
    dofs = tuple(dofs)
    if not dofs or any(d not in ram.RAM_DOFS for d in dofs):
        raise ValueError(f"dofs must be among {ram.RAM_DOFS} (RAM's arms), got {dofs!r}")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    out = []
    for d in dofs:
        for k in range(shards):
            seed = first_seed + k
            spec = {"version": _SHARD_VERSION, "dof": int(d), "arms": int(arms_per_shard), "seed": int(seed),
                    "random": int(random), "geodesics": int(geodesics), "per_geodesic": int(per_geodesic),
                    "starts": int(starts)}
            path = out_dir / f"pose_d{d}_s{seed}_{arms_per_shard}.npz"
            shard = _load_shard(path, spec)
            if shard is None:
                c0 = time.process_time()
                morphs = ram.sample_morphologies(arms_per_shard, d, seed=seed)
                poses, labels = pose_training_set(morphs, random, geodesics, per_geodesic, seed, starts=starts)
                cpu = time.process_time() - c0
                meta = {"spec": spec, "sha256": _digest(morphs, poses, labels), "cpu_seconds": cpu}
                with atomic_path(path) as tmp:
                    np.savez(tmp, morphs=morphs, poses=poses, labels=labels, meta=np.array(json.dumps(meta)))
                shard = PoseShard(morphs, poses, labels, spec, cpu)
                if progress:
                    print(f"pose shard {path.name}: {cpu:.0f} CPU s, reachable share {labels.mean():.3f}", flush=True)
            out.append(shard)
    return out


# --------------------------------------------------------------------------------------------- training
def _rows(shards) -> tuple[np.ndarray, np.ndarray, list[int]]:
    """Training rows `(n, MORPH_INPUTS + P * 9)` float32, labels `(n, P)` float32, the dofs."""
    P = {s.poses.shape[1] for s in shards}
    if len(P) != 1:
        raise ValueError(f"every shard must hold the same number of poses per arm, got {sorted(P)}")
    X = np.concatenate([np.concatenate([ram_inputs(s.morphs), s.poses.reshape(len(s.poses), -1)], axis=1)
                        for s in shards])
    Y = np.concatenate([s.labels for s in shards]).astype(np.float32)
    return X.astype(np.float32), Y, sorted({s.morphs.shape[1] - 1 for s in shards})


def fit_pose_model(shards: Sequence[PoseShard], config: PoseModelConfig | None = None, train_config: TrainConfig | None = None,
                   seed: int = 0) -> tuple[PoseMapModel, TrainResult]:
    """Train a `PoseMapModel` on `PoseShard`s (`build_pose_shards`).

    Parameters
    ----------
    shards : sequence of PoseShard
        The same number of poses per arm in each.
    config : PoseModelConfig, optional
    train_config : TrainConfig, optional
        Default: Adam (lr 1e-3), binary cross-entropy, 16 arms per step, cosine decay over 40
        epochs, 5 % of the arms for validation, no test split (the caller's held-out arms are).
    seed : int
        Initial weights (`torch.manual_seed`).

    Returns
    -------
    (PoseMapModel, TrainResult)
        The model in eval mode on the CPU; its `threshold` the probability (0.05 .. 0.95 by 0.05)
        of the best mean per-arm F1 (`ram_f1`) on the validation arms (0.5 without any).
    """
    shards = list(shards)
    if not shards:
        raise ValueError("fit_pose_model needs at least one shard")
    X, Y, dofs = _rows(shards)
    torch.manual_seed(seed)
    model = PoseMapModel(config, dofs=dofs).standardise_on(X)
    tc = train_config or TrainConfig(optimizer="adam", optimizer_kwargs={"lr": 1e-3}, loss="crossentropy",
                                     batch_size=16, lr_decay="cosine", max_epochs=40, max_fail=1000,
                                     fractions=(0.95, 0.05, 0.0), seed=seed)
    result = train(model, X, Y, tc)
    model.eval()
    model.cpu()
    model.threshold = _best_threshold(model, X[result.split.val], Y[result.split.val] > 0.5)
    model.train_config = tc
    model.shard_specs = [s.spec for s in shards]
    return model, result


def _best_threshold(model: PoseMapModel, X: np.ndarray, Y: np.ndarray) -> float:
    from ..datasets.ram import ram_f1

    if len(X) == 0:
        return 0.5
    with torch.no_grad():
        prob = torch.sigmoid(model(torch.as_tensor(X, dtype=torch.float32))).numpy()
    ts = np.round(np.arange(0.05, 0.951, 0.05), 2)
    scores = [ram_f1(prob > t, Y)[0] for t in ts]
    return float(ts[int(np.argmax(scores))])


# --------------------------------------------------------------------------------------------- prediction
def _query(model: PoseMapModel, morph, T) -> tuple[torch.Tensor, torch.Tensor]:
    m = _check_tables(morph)
    n = m.shape[-2] - 1
    if n not in model.dofs:
        raise ExtrapolationError(f"the arm has {n} joints; the pose model was trained on arms of "
                                 f"{', '.join(map(str, model.dofs))} joints only")
    raw = _raw_pose(T)
    B = 1 if m.ndim == 2 else m.shape[0]
    if raw.ndim == 3 and raw.shape[0] != B:
        raise ValueError(f"poses (B, P, 4, 4) must have one set per arm: {raw.shape[0]} sets for {B} arms")
    if raw.ndim > 3:
        raise ValueError(f"poses must have shape (P, 4, 4) or (B, P, 4, 4), got {np.shape(T)}")
    return (torch.as_tensor(ram_inputs(m), dtype=torch.float32), torch.as_tensor(raw, dtype=torch.float32))


def predict_pose_logits(model: PoseMapModel, morph: ArrayLike, T: ArrayLike) -> np.ndarray:
    """Logits of poses for RAM arms: one encoder pass per arm.

    Parameters
    ----------
    model : PoseMapModel
    morph : array_like, shape (dof + 1, 3) or (B, dof + 1, 3)
        RAM tables (rad, m) of one joint count the model was trained on.
    T : array_like, shape (P, 4, 4) or (B, P, 4, 4)
        End-effector poses (base frame, m): shared by every arm, or one set per arm.

    Returns
    -------
    ndarray, shape (P,) for one arm, else (B, P)
        float32 logits; `sigmoid` is the probability of "reachable".

    Raises
    ------
    ExtrapolationError
        A joint count the model was not trained on.
    ValueError
        Shapes that do not fit, NaN or infinite values.
    """
    A, raw = _query(model, morph, T)
    with torch.no_grad():
        out = model.logits_at(A, raw).numpy()
    return out[0] if np.ndim(morph) == 2 else out


def predict_poses(model: PoseMapModel, morph: ArrayLike, T: ArrayLike, *, threshold: float | None = None) -> np.ndarray:
    """Reachable or not, bool, shaped as `predict_pose_logits`: the probability above
    `threshold` (`None`: the model's `threshold`, in (0, 1))."""
    t = model.threshold if threshold is None else threshold
    if isinstance(t, bool) or not isinstance(t, (int, float)) or not 0.0 < t < 1.0:
        raise ValueError(f"threshold must lie in (0, 1), got {threshold!r}")
    return predict_pose_logits(model, morph, T) > math.log(t / (1.0 - t))


# --------------------------------------------------------------------------------------------- files
def save_pose_model(model: PoseMapModel, path: PathLike, *, extra: dict | None = None) -> Path:
    """Write `model` to `path` atomically (format `POSE_FORMAT`, a SHA-256 checksum over the
    content, `wsmap.learn.files.payload_checksum`); returns the path."""
    if not isinstance(model, PoseMapModel):
        raise TypeError(f"save_pose_model needs a PoseMapModel; got {type(model).__name__}")
    payload = {
        "format": POSE_FORMAT, "version": POSE_FORMAT_VERSION, "wsmap_version": __version__,
        "config": model.config.to_dict(),
        "state_dict": {k: v.detach().cpu().clone() for k, v in model.state_dict().items()},
        "box": model.box, "dofs": list(model.dofs), "threshold": float(model.threshold),
        "shard_specs": to_plain(getattr(model, "shard_specs", None), "shard_specs"),
        "train_config": to_plain(getattr(model, "train_config", None), "train_config"),
        "extra": to_plain(extra, "extra"),
    }
    return write_model_payload(path, payload)


def load_pose_model(path: PathLike) -> tuple[PoseMapModel, dict[str, Any]]:
    """Read a file of `save_pose_model` -> `(model, meta)` (eval mode, on the CPU).

    A missing, corrupt or tampered file, and a model file of another kind, are a
    `ModelFileError` `"cannot load model <path>: <problem>"`."""
    def fail(problem, cause=None):
        raise ModelFileError(f"cannot load model {path}: {problem}") from cause

    payload = read_model_payload(path, POSE_FORMAT, POSE_FORMAT_VERSION, "a pose model")
    try:
        model = PoseMapModel(PoseModelConfig(**payload["config"]), box=payload["box"], dofs=payload["dofs"])
        model.load_state_dict(payload["state_dict"])
        model.threshold = float(payload["threshold"])
    except (KeyError, TypeError, ValueError, RuntimeError) as e:
        fail(f"invalid content ({e})", e)
    model.eval()
    meta = {k: payload.get(k) for k in ("format", "version", "wsmap_version", "shard_specs", "train_config", "extra",
                                        "checksum")}
    meta["path"] = str(path)
    return model, meta
