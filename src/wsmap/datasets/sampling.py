"""Random draws: the arms, the random orientations / points and the IK start configurations.

Randomness
----------
Every random quantity has its own stream, `numpy.random.SeedSequence(seed, spawn_key=(split,
quantity))` with `split` 0 for `stream="train"` and 1 for `"test"` and `quantity` 0 for the
arms, 1 for random orientations / points, 2 for IK start configurations. Hence

* a test set never shares a stream with its training set (and continuous draws never repeat);
* a dataset is a prefix of every larger dataset of the same spec (`scaled` reduces the sample
  count and keeps the first arms), and the labels of an arm never depend on the chunking.

The label audits (`wsmap.datasets.audit`) draw from splits 7, 8 and 9 of their own seed,
independent of every training and test stream.

Every family draws its arms from the arms stream as `wsmap.robots.ArmFamily.sample` does
(one `(count, n_params)` uniform array; a DH family's range is `[0, beta]`). A chain family
(`panda7`) has no random orientation and no LM start configurations (its labels are the map
search); `draw_scales` gives its scale factors alone.

Random orientation ("workspace" embedding of Table 3)
----------------------------------------------------
`fixed="random"` draws, per sample, a rotation uniformly (Haar measure) on SO(3): a unit
quaternion from four independent standard normals, normalised (Shoemake; the normal distribution
is isotropic, so the quaternion is uniform on S³ and the rotation uniform on SO(3)). It is then
written as the paper's angles `R = Rx(r1)·Ry(r2)·Rz(r3)`::

    r2 = asin(R[0, 2]),   r1 = atan2(-R[1, 2], R[2, 2]),   r3 = atan2(-R[0, 1], R[0, 0])

each wrapped into `[0, 2·pi)` (the paper's angle range; its orientation [0.312, 5.6719, 5.936]
is written that way). The labels use `rpy2r(r1, r2, r3)` rebuilt from the stored angles, so a
sample's labels follow from its features alone. For an SO3 scope `fixed="random"` draws the
point uniformly in the cube `[-2·beta, 2·beta]³` (the paper's position range).
"""

from __future__ import annotations

import numpy as np

from .spec import MAX_SAMPLES, MAX_STARTS, N_JOINTS, STREAMS, DatasetSpec, check_int, check_spec, float64_array, require_finite
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap._typing import ArrayLike, NDArray
    from wsmap.kinematics.chain import Arm

__all__ = ["draw_samples", "draw_scales", "start_configurations", "uniform_rotations", "rotation_to_rpy",
           "stream_rng", "audit_rng", "draw_arms", "draw_fixed"]

_QUANTITY = {"arms": 0, "fixed": 1, "starts": 2}
#: splits of the audit streams (the training and test streams use 0 and 1)
_AUDIT_SPLIT = {"starts_study": 7, "audit_labels": 8, "starts_recall": 9}


def stream_rng(spec: DatasetSpec, quantity: str) -> np.random.Generator:
    """A fresh generator of the stream of `quantity` in `spec`'s dataset.

    Parameters
    ----------
    spec : DatasetSpec
        Its `seed` and `stream` (`"train"` or `"test"`) pick the stream.
    quantity : str
        `"arms"`, `"fixed"` (the orientation or point per sample) or `"starts"` (the LM starts).

    Returns
    -------
    numpy.random.Generator
        Seeded by `SeedSequence(spec.seed, spawn_key=(stream, quantity))`: each quantity of each
        stream is independent of the others, and a fresh generator replays it from its start.
    """
    key = (STREAMS.index(spec.stream), _QUANTITY[quantity])
    return np.random.default_rng(np.random.SeedSequence(spec.seed, spawn_key=key))


def audit_rng(seed: int, audit: str, quantity: str) -> np.random.Generator:
    """A fresh generator of the stream of `quantity` for one of the label audits, independent of
    every dataset stream.

    Parameters
    ----------
    seed : int
        The audit's seed (>= 0).
    audit : str
        `"starts_study"`, `"audit_labels"` or `"starts_recall"` (`wsmap.datasets.audit`).
    quantity : str
        `"arms"`, `"fixed"` or `"starts"`.

    Returns
    -------
    numpy.random.Generator
        Seeded by `SeedSequence(seed, spawn_key=(audit split, quantity))`, the audit splits
        (7, 8, 9) apart from the dataset streams' (0, 1).
    """
    key = (_AUDIT_SPLIT[audit], _QUANTITY[quantity])
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=key))


def uniform_rotations(count: int, rng: np.random.Generator) -> np.ndarray:
    """`count` rotation matrices `(count, 3, 3)` uniform on SO(3) (normalised Gaussian quaternions).

    `rng` is a `numpy.random.Generator` or anything `numpy.random.default_rng` takes (a seed).
    """
    count = check_int("count", count, 0, MAX_SAMPLES)
    rng = np.random.default_rng(rng)
    q = rng.standard_normal((count, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    w, x, y, z = q.T
    return np.stack(
        [
            1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
            2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
            2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y),
        ],
        axis=-1,
    ).reshape(count, 3, 3)


def rotation_to_rpy(R: ArrayLike) -> np.ndarray:
    """Angles `(..., 3)` in `[0, 2·pi)` with `R = Rx(r1)·Ry(r2)·Rz(r3)` (`R` of shape `(..., 3, 3)`).

    `r2 = asin(R[0,2])` lies in `[-pi/2, pi/2]` before wrapping; at `cos(r2) = 0` (measure
    zero) the split between `r1` and `r3` is arbitrary.
    """
    R = float64_array(R, f"R must be rotation matrices of shape (..., 3, 3), got {type(R).__name__}")
    if R.ndim < 2 or R.shape[-2:] != (3, 3):
        raise ValueError(f"R must have shape (..., 3, 3), got {R.shape}")
    require_finite(R, "R contains NaN or infinite values")
    r2 = np.arcsin(np.clip(R[..., 0, 2], -1.0, 1.0))
    r1 = np.arctan2(-R[..., 1, 2], R[..., 2, 2])
    r3 = np.arctan2(-R[..., 0, 1], R[..., 0, 0])
    out = np.mod(np.stack([r1, r2, r3], axis=-1), 2 * np.pi)
    # mod can round a tiny negative angle up to exactly 2·pi
    return np.where(out >= 2 * np.pi, 0.0, out)


def draw_arms(spec: DatasetSpec, count: int, rng):
    """`count` arms of `spec`'s family drawn from `rng`.

    Parameters
    ----------
    spec : DatasetSpec
        Its `arm_family` draws the arms.
    count : int
        Number of arms (>= 0).
    rng : numpy.random.Generator
        The stream to draw from (`stream_rng(spec, "arms")` for a dataset).

    Returns
    -------
    DHRobot or SerialChain
        A batch `(count,)`: DH arms, or a chain family's arms.
    """
    return spec.arm_family.sample(count, seed=rng)[0]


def draw_fixed(spec: DatasetSpec, count: int, rng) -> np.ndarray:
    """The fixed orientation (R3) or point (SO3) of each of `count` samples.

    Parameters
    ----------
    spec : DatasetSpec
        Its `fixed` (a triple, shared by every sample, or `"random"`), `scope` and `beta`.
    count : int
        Number of samples (>= 0).
    rng : numpy.random.Generator
        The stream a `"random"` spec draws from (`stream_rng(spec, "fixed")` for a dataset);
        unused otherwise.

    Returns
    -------
    numpy.ndarray, shape (count, 3), float64
        R3: angles (rad) of a rotation uniform on SO(3) (`rotation_to_rpy`); SO3: a point (m)
        uniform in `[-2·beta, 2·beta)³`; or `spec.fixed` in every row.
    """
    if spec.fixed != "random":
        return np.broadcast_to(np.asarray(spec.fixed), (count, 3)).copy()
    if spec.scope == "R3":
        return rotation_to_rpy(uniform_rotations(count, rng))
    return rng.uniform(-2 * spec.beta, 2 * spec.beta, size=(count, 3))


def draw_samples(spec: DatasetSpec, count: int | None = None) -> tuple[Arm, NDArray[np.float64]]:
    """The first `count` (default `spec.samples`) arms `(count,)` and their fixed
    orientation / point `(count, 3)` from the spec's streams. The arms are a
    `DHRobot` batch, or for a chain family a
    `SerialChain` batch (`wsmap.robots.family_arm` of
    `draw_scales`)."""
    check_spec(spec)
    count = spec.samples if count is None else check_int("count", count, 1, MAX_SAMPLES)
    return draw_arms(spec, count, stream_rng(spec, "arms")), draw_fixed(spec, count, stream_rng(spec, "fixed"))


def draw_scales(spec: DatasetSpec, count: int | None = None) -> np.ndarray:
    """The scale factors `(count, n)` of the first `count` (default `spec.samples`) arms of a
    chain family's spec (the arms of `draw_samples`); `ValueError` for the DH families."""
    check_spec(spec)
    if not spec.is_chain_family:
        raise ValueError(f"spec {spec.name!r} is of the DH family {spec.family!r}: its arms have no scale factors")
    count = spec.samples if count is None else check_int("count", count, 1, MAX_SAMPLES)
    return spec.arm_family.draw(count, stream_rng(spec, "arms"))


def start_configurations(spec: DatasetSpec, count: int | None = None, starts: int | None = None) -> np.ndarray:
    """IK start configurations `(count, starts, 6)` (rad): `[:, 0]` is zero (the paper's q0),
    `[:, 1:]` uniform in `[-pi, pi)` per arm from the spec's start stream."""
    check_spec(spec)
    count = spec.samples if count is None else check_int("count", count, 0, MAX_SAMPLES)
    starts = spec.starts if starts is None else check_int("starts", starts, 1, MAX_STARTS)
    q = np.zeros((count, starts, N_JOINTS))
    if starts > 1:
        q[:, 1:] = stream_rng(spec, "starts").uniform(-np.pi, np.pi, size=(count, starts - 1, N_JOINTS))
    return q
