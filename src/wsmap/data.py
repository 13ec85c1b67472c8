"""Experience generation: the paper's datasets, deterministic, stored as one compressed file each.

A dataset is ``samples`` random arms (one row each) with

* **features** ``(samples, F)`` float64 in the paper's layout (Appendix, "experience generation")::

      [d_1..d_6, a_1..a_6, alpha_1..alpha_6,  n_x (nx values), n_y (ny), n_z (nz),  n_i (3)]

  DH columns in metres / radians; ``n_x, n_y, n_z`` the node values along each grid axis (metres
  for an "R3" scope, the angles r1, r2, r3 in radians for an "SO3" scope) -- always the *whole*
  axes of the grid, also when only a slice of its nodes is labelled (so every 21³ R3 spec has
  18 + 63 + 3 = 84 columns); ``n_i`` the fixed orientation ``(r1, r2, r3)`` in radians (R3) or
  the fixed point in metres (SO3). Columns of a fixed quantity are constant; the model sees them
  because the paper's input has them.
* **labels** ``(samples, nodes)`` bool in node order (first coordinate fastest, see
  :mod:`wsmap.workspace`): ``True`` where inverse kinematics solves the node's target pose.

A :class:`DatasetSpec` says everything that determines a dataset (it round-trips through YAML, so
``params.yaml`` can hold it); :data:`PAPER_SPECS` holds one per experiment of the paper and
:func:`test_spec` its independent 1000-sample test set. :func:`build_dataset` writes a spec's file,
:func:`load_dataset` reads it back and refuses a missing, truncated, corrupt or mismatched file.

Randomness
----------
Every random quantity has its own stream, ``numpy.random.SeedSequence(seed, spawn_key=(split,
quantity))`` with ``split`` 0 for ``stream="train"`` and 1 for ``"test"`` and ``quantity`` 0 for the
arms, 1 for random orientations / points, 2 for IK start configurations. Hence

* a test set never shares a stream with its training set (and continuous draws never repeat);
* a dataset is a prefix of every larger dataset of the same spec (``scaled`` reduces the sample
  count and keeps the first arms), and the labels of an arm never depend on the chunking.

Random orientation ("workspace" embedding of Table 3)
----------------------------------------------------
``fixed="random"`` draws, per sample, a rotation uniformly (Haar measure) on SO(3): a unit
quaternion from four independent standard normals, normalised (Shoemake; the normal distribution
is isotropic, so the quaternion is uniform on S³ and the rotation uniform on SO(3)). It is then
written as the paper's angles ``R = Rx(r1)·Ry(r2)·Rz(r3)``::

    r2 = asin(R[0, 2]),   r1 = atan2(-R[1, 2], R[2, 2]),   r3 = atan2(-R[0, 1], R[0, 0])

each wrapped into ``[0, 2·pi)`` (the paper's angle range; its orientation [0.312, 5.6719, 5.936]
is written that way). The labels use ``rpy2r(r1, r2, r3)`` rebuilt from the stored angles, so a
sample's labels follow from its features alone. For an SO3 scope ``fixed="random"`` draws the
point uniformly in the cube ``[-2·beta, 2·beta]³`` (the paper's position range).

Labels
------
``method="exact"``: the closed-form test of :mod:`wsmap.workspace` (spherical-wrist family,
unlimited joints). ``method="numerical"``: the paper's Levenberg–Marquardt (``ikine_LM``) with
``tol``, ``ilimit``, ``rlimit``, from ``starts`` start configurations; a node is reachable when ANY
start converges. Start 0 is ``q0 = 0`` (the paper's); starts 1.. are drawn per arm uniformly in
``[-pi, pi)^6`` and shared by all nodes of that arm. Later starts are run only on the nodes the
earlier ones did not solve (the union does not depend on that). See :func:`starts_study` and
:func:`starts_recall` for how the default number of starts was chosen. Two things keep the
numerical labels right and affordable without changing any of them: pairs that
:func:`possibly_reachable` proves unreachable (a sound bound on reach, height and tool tilt) are
not handed to LM, and every LM success is confirmed by forward kinematics (the LM pose error is
also zero at a half turn of the orientation, see ``_solve``).

File format
-----------
A zip archive readable by ``numpy.load`` (an ``.npz``) with three entries: ``features``
(float64), ``labels_packed`` (uint8, ``np.packbits(labels, axis=1)``: nodes big-endian within
each byte, rows padded to whole bytes) and ``header`` (UTF-8 JSON as uint8): the spec dict, the
wsmap version, shapes, and the SHA-256 of ``features.tobytes() + labels_packed.tobytes()``
(C order, little-endian). The zip is written with fixed entry timestamps (``np.savez_compressed``
stamps the current time, which would make rebuilds differ byte-wise), streamed chunk by chunk
into a temporary file beside the target, and renamed over it only when complete.
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import io
import json
import math
import sys
import time
import zipfile
import zlib
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np

from . import __version__
from . import robots
from . import workspace as ws
from .io import atomic_path
from .kinematics import DHRobot, ikine_LM, rpy2r

__all__ = [
    "FAMILIES",
    "SCOPES",
    "STREAMS",
    "DEFAULT_STARTS",
    "DatasetSpec",
    "DatasetError",
    "Dataset",
    "PAPER_SPECS",
    "TABLE3_RPY",
    "test_spec",
    "scaled",
    "grid_axes",
    "grid_nodes",
    "spec_nodes",
    "node_slice",
    "feature_names",
    "feature_slices",
    "features_for",
    "arms_from_features",
    "fixed_from_features",
    "draw_samples",
    "start_configurations",
    "uniform_rotations",
    "rotation_to_rpy",
    "labels_for",
    "possibly_reachable",
    "build_dataset",
    "load_dataset",
    "starts_study",
    "starts_recall",
    "audit_labels",
    "audit_table",
    "main",
]

FAMILIES = ("spherical_wrist", "arbitrary_6dof", "puma560")
SCOPES = ("R3", "SO3")
STREAMS = ("train", "test")
CONVENTIONS = ws.CONVENTIONS
METHODS = ws.METHODS
#: Number of IK start configurations for numerical labels (q0 = 0 plus DEFAULT_STARTS - 1 random
#: ones). Measured (seed 0, OMP_NUM_THREADS=1, 2-core machine shared with other jobs):
#: ``starts_recall(n_poses=5000, counts=(1..9, 11, 13, 17, 25, 33))`` on Table 3's arbitrary 6-DOF
#: arms (poses fkine(q), q ~ U(-pi, pi)^6, so reachable) and ``starts_study(n_arms=320, counts=
#: (1..9, 11, 13, 17))`` (Table 3 orientation, block 5: 423,360 arm-node pairs, 343 reachable):
#:
#:   starts               1      2      3      4      5      6      7      8      9     11     13     17
#:   recall           0.626  0.802  0.885  0.931  0.956  0.969  0.977  0.983  0.988  0.993  0.996  0.998
#:   gain/extra start     -  0.177  0.083  0.046  0.025  0.013  0.008  0.006  0.005  0.002  0.002  0.001
#:   grid share found 0.793  0.886  0.936  0.962  0.983  0.985  0.988  0.991  0.994  1.000  1.000  1.000
#:
#: (recall 0.9992 at 25, 0.9996 at 33). Cost is linear in starts: almost every pair LM sees is
#: unreachable and runs through every start, ~28 s per start for the 320 arms here (~0.09 s per arm
#: and start, under load), so each extra start adds 1/S to the labelling time. The knee is at 8-9:
#: the marginal start recovers 0.58 % of the reachable poses (8th), 0.48 % (9th), 0.24 % (10th and
#: 11th each); 9 keeps the labels' miss rate at ~1.2 % (8: 1.7 %, 5: 4.4 %, the paper's single
#: start: 37 %) for 12 % more time than 8, the grid study finds nothing new after 11, and 17
#: starts would cost 1.9x for +1.0 %. Kept at 9. Reproduce: the two calls above (defaults otherwise).
DEFAULT_STARTS = 9
#: Table 3's "no subspace" orientation (r1, r2, r3), radians.
TABLE3_RPY = (0.312, 5.6719, 5.936)

FORMAT = "wsmap-dataset"
FORMAT_VERSION = 1
_ZIP_TIME = (1980, 1, 1, 0, 0, 0)  # fixed entry timestamps: byte-identical rebuilds
_QUANTITY = {"arms": 0, "fixed": 1, "starts": 2}
_N_JOINTS = 6
_N_DH = 3 * _N_JOINTS


class DatasetError(ValueError):
    """A dataset file that cannot be used: truncated, corrupt, not a dataset, or for another spec."""


# --------------------------------------------------------------------------- the spec
def _number(name, value) -> float:
    """A float; strings may be arithmetic in ``pi`` (``"pi/10"``), for hand-written params.yaml."""
    if isinstance(value, str):
        from .cli import number

        try:
            return number(value)
        except Exception:
            raise ValueError(f"{name} must be a number or a pi expression, got {value!r}") from None
    if isinstance(value, bool):
        raise ValueError(f"{name} must be a number, got {value!r}")
    try:
        return float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number or a 3-tuple of numbers, got {value!r}") from None


def _triple_or_scalar(name, value):
    """A grid bound as given: a float, or a tuple of 3 floats."""
    if isinstance(value, (list, tuple, np.ndarray)):
        if len(value) != 3:
            raise ValueError(f"{name} must be a scalar or a 3-tuple, got {list(np.ravel(value))}")
        out = tuple(_number(name, v) for v in value)
    else:
        out = _number(name, value)
    if not np.all(np.isfinite(out)):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return out


def _int(name, value, minimum):
    if isinstance(value, bool) or not isinstance(value, (int, np.integer, float)) or int(value) != value:
        raise ValueError(f"{name} must be an integer, got {value!r}")
    value = int(value)
    if value < minimum:
        raise ValueError(f"{name} must be at least {minimum}, got {value}")
    return value


def _choice(name, value, choices):
    if value not in choices:
        raise ValueError(f"unknown {name} {value!r}; choose one of {', '.join(choices)}")
    return value


@dataclass(frozen=True)
class DatasetSpec:
    """Everything that determines a dataset; plain data (``to_dict`` / ``from_dict`` via YAML).

    Attributes
    ----------
    name : str
        Identifier (file names, progress bars).
    family : ``"spherical_wrist"`` | ``"arbitrary_6dof"`` | ``"puma560"``
        The arms: the paper's spherical-wrist family (d3, d4, a2, a3 ~ U(0, beta)), Table 3's
        arbitrary 6-DOF arms (every d_i, a_i, alpha_i ~ U(0, beta)), or the PUMA560 (d1 = 0) in
        every sample (useful with a random orientation).
    scope : ``"R3"`` (positions at a fixed orientation) | ``"SO3"`` (orientations at a fixed point)
    lo, hi, step : float or 3-tuple
        The grid (:func:`wsmap.workspace.grid_axes`): metres for R3, radians for SO3. ``None``
        means the paper's range, ``[-2·beta, 2·beta]`` (R3) or ``[0, 2·pi]`` (SO3). Here and in
        ``fixed``, strings are read as arithmetic in ``pi`` (``"pi/10"``) and stored as floats.
    select : None or (start, stop)
        The labelled nodes: all (``None``, ``"all"`` in YAML) or the 0-based half-open slice
        ``[start, stop)`` of the flat node order (block 5 is ``(5292, 6615)``).
    fixed : 3-tuple or ``"random"``
        The orientation (r1, r2, r3) in radians (R3) or the point in metres (SO3); ``"random"``
        draws one per sample (see the module docstring) and makes it part of the input.
    convention : ``"paper"`` (``R·transl(p)``, tests ``R·p``) | ``"standard"`` (``transl(p)·R``)
    method : ``"exact"`` (closed form; spherical-wrist arms only) | ``"numerical"`` (LM)
    tol, ilimit, rlimit, starts :
        LM settings for ``method="numerical"``: tolerance on the pose-error norm, iteration limit,
        consecutive-rejection limit, and the number of start configurations (q0 = 0 first, then
        random ones; a node is reachable when any converges). Ignored by ``"exact"``.
    samples : int
        Number of arms (rows).
    seed : int
        Root of every random stream (non-negative).
    beta : float
        Upper bound of the uniform DH draws (m, and rad for arbitrary twists); the paper's 0.5.
    stream : ``"train"`` | ``"test"``
        Which independent stream of ``seed`` the samples come from (:func:`test_spec`).
    """

    name: str
    family: str = "spherical_wrist"
    scope: str = "R3"
    lo: float | tuple | None = None
    hi: float | tuple | None = None
    step: float | tuple = 0.1
    select: tuple[int, int] | None = None
    fixed: tuple[float, float, float] | str = (0.0, 0.0, 0.0)
    convention: str = "paper"
    method: str = "exact"
    tol: float = 1e-10
    ilimit: int = 500
    rlimit: int = 100
    starts: int = DEFAULT_STARTS
    samples: int = 1000
    seed: int = 0
    beta: float = 0.5
    stream: str = "train"

    def __post_init__(self):
        set_ = lambda k, v: object.__setattr__(self, k, v)  # noqa: E731 (frozen dataclass)
        if not isinstance(self.name, str) or not self.name.strip():
            raise ValueError(f"name must be a non-empty string, got {self.name!r}")
        _choice("family", self.family, FAMILIES)
        _choice("scope", self.scope, SCOPES)
        _choice("convention", self.convention, CONVENTIONS)
        _choice("method", self.method, METHODS)
        _choice("stream", self.stream, STREAMS)
        if self.method == "exact" and self.family == "arbitrary_6dof":
            raise ValueError(
                "method 'exact' needs arms of the spherical-wrist family (closed form); "
                "family 'arbitrary_6dof' needs method 'numerical'"
            )
        beta = float(self.beta)
        if not (beta > 0 and math.isfinite(beta)):
            raise ValueError(f"beta must be positive and finite, got {self.beta!r}")
        set_("beta", beta)
        if self.lo is None:
            set_("lo", -2.0 * beta if self.scope == "R3" else 0.0)
        if self.hi is None:
            set_("hi", 2.0 * beta if self.scope == "R3" else 2.0 * math.pi)
        for k in ("lo", "hi", "step"):
            set_(k, _triple_or_scalar(k, getattr(self, k)))
        try:
            axes = ws.grid_axes(self.lo, self.hi, self.step)
        except ValueError as e:
            raise ValueError(f"empty or invalid grid (lo={self.lo}, hi={self.hi}, step={self.step}): {e}") from None
        total = int(np.prod([len(a) for a in axes]))
        sel = self.select
        if isinstance(sel, str):
            if sel != "all":
                raise ValueError(f"select must be 'all' or [start, stop], got {sel!r}")
            sel = None
        if sel is not None:
            if isinstance(sel, slice):
                sel = (sel.start, sel.stop)
            if not isinstance(sel, (list, tuple)) or len(sel) != 2:
                raise ValueError(f"select must be 'all' or [start, stop], got {sel!r}")
            start, stop = (_int(f"select {k}", v, 0) for k, v in zip(("start", "stop"), sel))
            if stop <= start:
                raise ValueError(f"empty node selection [{start}, {stop}): stop must exceed start")
            if stop > total:
                raise ValueError(f"node selection [{start}, {stop}) runs past the grid's {total} nodes")
            sel = (start, stop)
        set_("select", sel)
        if isinstance(self.fixed, str):
            if self.fixed != "random":
                raise ValueError(f"fixed must be 3 numbers or 'random', got {self.fixed!r}")
        else:
            if not isinstance(self.fixed, (list, tuple, np.ndarray)) or len(self.fixed) != 3:
                raise ValueError(f"fixed must be 3 finite numbers or 'random', got {self.fixed!r}")
            f = tuple(_number("fixed", v) for v in self.fixed)
            if not np.all(np.isfinite(f)):
                raise ValueError(f"fixed must be 3 finite numbers or 'random', got {self.fixed!r}")
            set_("fixed", f)
        set_("samples", _int("samples", self.samples, 1))
        set_("seed", _int("seed", self.seed, 0))
        set_("ilimit", _int("ilimit", self.ilimit, 1))
        set_("rlimit", _int("rlimit", self.rlimit, 0))
        set_("starts", _int("starts", self.starts, 1))
        tol = float(self.tol)
        if not (tol > 0 and math.isfinite(tol)):
            raise ValueError(f"tol must be positive and finite, got {self.tol!r}")
        set_("tol", tol)

    # ---------------------------------------------------------------- derived sizes
    @cached_property
    def grid_shape(self) -> tuple[int, int, int]:
        """Nodes along each axis ``(nx, ny, nz)`` of the whole grid."""
        return tuple(len(a) for a in grid_axes(self))

    @property
    def grid_nodes(self) -> int:
        nx, ny, nz = self.grid_shape
        return nx * ny * nz

    @property
    def n_nodes(self) -> int:
        """Labelled nodes (label columns)."""
        s = node_slice(self)
        return s.stop - s.start

    @property
    def n_features(self) -> int:
        return _N_DH + sum(self.grid_shape) + 3

    # ---------------------------------------------------------------- plain data
    def to_dict(self) -> dict:
        """Plain YAML/JSON types: floats, ints, strings, lists; ``select`` ``"all"`` or ``[start, stop]``."""
        out = {}
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if isinstance(v, tuple):
                v = list(v)
            out[f.name] = v
        if out["select"] is None:
            out["select"] = "all"
        return out

    @classmethod
    def from_dict(cls, d: dict) -> "DatasetSpec":
        """Inverse of :meth:`to_dict`; unknown keys are an error (a typo would silently use a default)."""
        if not isinstance(d, dict):
            raise ValueError(f"a dataset spec must be a mapping, got {type(d).__name__}")
        known = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(d) - known)
        if unknown:
            raise ValueError(f"unknown dataset spec field(s) {', '.join(unknown)}; known: {', '.join(sorted(known))}")
        if "name" not in d:
            raise ValueError("a dataset spec needs a name")
        return cls(**d)

    def replace(self, **changes) -> "DatasetSpec":
        return dataclasses.replace(self, **changes)



def test_spec(spec: DatasetSpec, samples: int = 1000) -> DatasetSpec:
    """The independent test set of ``spec``: same everything, ``samples`` arms from the test stream.

    The test stream is a different ``SeedSequence`` spawn key of the same seed, so its arms are
    independent of (and, being continuous draws, disjoint from) the training arms.
    """
    if spec.stream == "test":
        raise ValueError(f"spec {spec.name!r} is already a test spec")
    return dataclasses.replace(spec, name=f"{spec.name}_test", samples=samples, stream="test")


test_spec.__test__ = False  # not a pytest test, despite the name


def scaled(spec: DatasetSpec, samples: int) -> DatasetSpec:
    """``spec`` with fewer (or more) samples: the first ``samples`` arms of the same streams."""
    return dataclasses.replace(spec, samples=samples)


# --------------------------------------------------------------------------- the paper's specs
def _paper_specs() -> dict[str, DatasetSpec]:
    block5 = (ws.block_slice(4).start, ws.block_slice(4).stop)  # 0-based [5292, 6615)
    crop = (ws.CROP_3087.start, ws.CROP_3087.stop)  # 0-based [5292, 8379)
    r3 = dict(family="spherical_wrist", scope="R3", lo=-1.0, hi=1.0, fixed=(0.0, 0.0, 0.0))
    so3 = dict(family="spherical_wrist", scope="SO3", lo=0.0, hi=2 * math.pi)
    specs = [
        # section 6.1: the block-5 subspace, 1e5 arms
        DatasetSpec("sec61", **r3, step=0.1, select=block5, samples=100_000, seed=61),
        # section 6.2: the whole 21³ map (the 7 block models take their columns), 1e5 arms
        DatasetSpec("sec62", **r3, step=0.1, samples=100_000, seed=62),
        # Table 1
        DatasetSpec("table1_r3_step1", **r3, step=1.0, samples=60_000, seed=101),
        DatasetSpec("table1_r3_step05", **r3, step=0.5, samples=60_000, seed=102),
        DatasetSpec("table1_r3_block5", **r3, step=0.1, select=block5, samples=60_000, seed=103),
        DatasetSpec("table1_r3_crop3087", **r3, step=0.1, select=crop, samples=30_000, seed=104),
        DatasetSpec("table1_r3_full", **r3, step=0.1, samples=15_000, seed=105),
        DatasetSpec("table1_so3_pi3", **so3, step=math.pi / 3, fixed=(0.5, 0.5, 0.5), samples=60_000, seed=106),
        DatasetSpec("table1_so3_pi8", **so3, step=math.pi / 8, fixed=(1.0, 0.0, 0.0), samples=15_000, seed=107),
        DatasetSpec("table1_so3_pi10", **so3, step=math.pi / 10, fixed=(0.5, 0.5, 0.5), samples=15_000, seed=108),
        # Table 2: the 6.1 setup with 6e4 arms
        DatasetSpec("table2", **r3, step=0.1, select=block5, samples=60_000, seed=201),
        # Table 3: three embeddings on the same 84 inputs / 1323 outputs, so that every model can
        # be tested on every test set (the paper does that)
        DatasetSpec("table3_subspace", **r3, step=0.1, select=block5, samples=15_000, seed=301),
        DatasetSpec("table3_workspace", **{**r3, "fixed": "random"}, step=0.1, select=block5, samples=15_000, seed=302),
        DatasetSpec(
            "table3_nosubspace",
            **{**r3, "family": "arbitrary_6dof", "fixed": TABLE3_RPY},
            step=0.1,
            select=block5,
            method="numerical",
            samples=15_000,
            seed=303,
        ),
    ]
    return {s.name: s for s in specs}


#: One spec per experiment of the paper (NOTES "Datasets"); ``test_spec(s)`` gives its test set.
PAPER_SPECS: dict[str, DatasetSpec] = _paper_specs()


# --------------------------------------------------------------------------- nodes and features
def grid_axes(spec: DatasetSpec) -> list[np.ndarray]:
    """The node values along each axis of the whole grid (m for R3, rad for SO3)."""
    return ws.grid_axes(spec.lo, spec.hi, spec.step)


def grid_nodes(spec: DatasetSpec) -> np.ndarray:
    """All nodes of the grid ``(nx·ny·nz, 3)`` in node order: positions (R3) or angles (SO3)."""
    make = ws.cartesian_grid if spec.scope == "R3" else ws.angle_grid
    return make(spec.lo, spec.hi, spec.step)


def node_slice(spec: DatasetSpec) -> slice:
    """The labelled nodes as a slice of the flat node order."""
    if spec.select is None:
        return slice(0, spec.grid_nodes)
    return slice(*spec.select)


def spec_nodes(spec: DatasetSpec) -> np.ndarray:
    """The labelled nodes ``(n_nodes, 3)`` in node order (label column ``j`` is row ``j``)."""
    return grid_nodes(spec)[node_slice(spec)]


def feature_slices(spec: DatasetSpec) -> dict[str, slice]:
    """Column ranges of the feature vector: ``d``, ``a``, ``alpha``, ``nx``, ``ny``, ``nz``, ``fixed``."""
    nx, ny, nz = spec.grid_shape
    edges = np.cumsum([0, 6, 6, 6, nx, ny, nz, 3])
    keys = ("d", "a", "alpha", "nx", "ny", "nz", "fixed")
    return {k: slice(int(edges[i]), int(edges[i + 1])) for i, k in enumerate(keys)}


def feature_names(spec: DatasetSpec) -> list[str]:
    """Column names: ``d_1..d_6, a_1..a_6, alpha_1..alpha_6, n_x_1.., n_y_1.., n_z_1..`` then
    ``r_1..r_3`` (R3: the orientation angles) or ``p_1..p_3`` (SO3: the point). 1-based, like the paper."""
    nx, ny, nz = spec.grid_shape
    names = [f"{k}_{i}" for k in ("d", "a", "alpha") for i in range(1, 7)]
    for ax, n in (("x", nx), ("y", ny), ("z", nz)):
        names += [f"n_{ax}_{i}" for i in range(1, n + 1)]
    names += [f"{'r' if spec.scope == 'R3' else 'p'}_{i}" for i in (1, 2, 3)]
    return names


def _fixed_rows(spec: DatasetSpec, count: int, fixed) -> np.ndarray:
    if fixed is None:
        if spec.fixed == "random":
            raise ValueError(
                f"spec {spec.name!r} draws its {'orientation' if spec.scope == 'R3' else 'point'} per sample "
                "(fixed='random'); pass fixed=(count, 3) or (3,)"
            )
        fixed = spec.fixed
    fixed = np.asarray(fixed, dtype=np.float64)
    if fixed.shape not in ((3,), (count, 3)):
        raise ValueError(f"fixed must have shape (3,) or ({count}, 3), got {fixed.shape}")
    if not np.all(np.isfinite(fixed)):
        raise ValueError("fixed contains NaN or infinite values")
    return np.broadcast_to(fixed, (count, 3))


def _check_arms(arms) -> DHRobot:
    if not isinstance(arms, DHRobot):
        raise TypeError(f"arms must be a DHRobot, got {type(arms).__name__}")
    if arms.n != _N_JOINTS:
        raise ValueError(f"the paper's feature layout is for 6-joint arms, got {arms.n} joints")
    if len(arms.batch_shape) != 1:
        raise ValueError(f"arms must be a batch of shape (count,), got batch shape {arms.batch_shape}")
    if arms.tool is not None:
        raise ValueError("arms with a tool transform have no place in the paper's feature layout")
    return arms


def features_for(arms: DHRobot, spec: DatasetSpec, fixed=None) -> np.ndarray:
    """The feature matrix ``(count, spec.n_features)`` float64 of a batch of arms for ``spec``.

    ``arms`` is a batch ``(count,)`` of 6-joint arms (any DH values: a model trained on ``spec``
    predicts their maps). ``fixed`` is the orientation (R3, rad) or point (SO3, m), ``(3,)`` or
    ``(count, 3)``; by default the spec's (required when the spec's is ``"random"``). A model
    trained on a fixed-orientation spec has only ever seen that orientation.
    """
    arms = _check_arms(arms)
    count = arms.batch_shape[0]
    fx = _fixed_rows(spec, count, fixed)
    sl = feature_slices(spec)
    X = np.empty((count, spec.n_features), dtype=np.float64)
    X[:, sl["d"]] = arms.d
    X[:, sl["a"]] = arms.a
    X[:, sl["alpha"]] = arms.alpha
    for key, axis in zip(("nx", "ny", "nz"), grid_axes(spec)):
        X[:, sl[key]] = axis
    X[:, sl["fixed"]] = fx
    return X


def arms_from_features(X) -> DHRobot:
    """The arms ``(count,)`` whose DH columns are the first 18 feature columns."""
    X = np.asarray(X, dtype=np.float64)
    if X.ndim != 2 or X.shape[1] < _N_DH:
        raise ValueError(f"features must have shape (count, >= {_N_DH}), got {X.shape}")
    return DHRobot(X[:, 0:6], X[:, 6:12], X[:, 12:18])


def fixed_from_features(X, spec: DatasetSpec) -> np.ndarray:
    """The orientation / point columns ``(count, 3)`` of a feature matrix."""
    X = np.asarray(X, dtype=np.float64)
    if X.ndim != 2 or X.shape[1] != spec.n_features:
        raise ValueError(f"features for spec {spec.name!r} must have shape (count, {spec.n_features}), got {X.shape}")
    return X[:, feature_slices(spec)["fixed"]]


# --------------------------------------------------------------------------- random draws
def _rng(spec: DatasetSpec, quantity: str) -> np.random.Generator:
    key = (STREAMS.index(spec.stream), _QUANTITY[quantity])
    return np.random.default_rng(np.random.SeedSequence(spec.seed, spawn_key=key))


def uniform_rotations(count: int, rng) -> np.ndarray:
    """``count`` rotation matrices ``(count, 3, 3)`` uniform on SO(3) (normalised Gaussian quaternions)."""
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


def rotation_to_rpy(R) -> np.ndarray:
    """Angles ``(..., 3)`` in ``[0, 2·pi)`` with ``R = Rx(r1)·Ry(r2)·Rz(r3)`` (``R`` of shape ``(..., 3, 3)``).

    ``r2 = asin(R[0,2])`` lies in ``[-pi/2, pi/2]`` before wrapping; at ``cos(r2) = 0`` (measure
    zero) the split between ``r1`` and ``r3`` is arbitrary.
    """
    R = np.asarray(R, dtype=np.float64)
    r2 = np.arcsin(np.clip(R[..., 0, 2], -1.0, 1.0))
    r1 = np.arctan2(-R[..., 1, 2], R[..., 2, 2])
    r3 = np.arctan2(-R[..., 0, 1], R[..., 0, 0])
    out = np.mod(np.stack([r1, r2, r3], axis=-1), 2 * np.pi)
    # mod can round a tiny negative angle up to exactly 2·pi
    return np.where(out >= 2 * np.pi, 0.0, out)


def _draw_arms(spec: DatasetSpec, count: int, rng) -> DHRobot:
    if spec.family == "spherical_wrist":
        arms = robots.sample_spherical_wrist(count, seed=rng, beta=spec.beta)
    elif spec.family == "arbitrary_6dof":
        arms = robots.sample_arbitrary_6dof(count, seed=rng, beta=spec.beta)
    else:
        p = robots.puma560()
        arms = DHRobot(*(np.tile(x, (count, 1)) for x in (p.d, p.a, p.alpha)), name="puma560")
    return arms


def _draw_fixed(spec: DatasetSpec, count: int, rng) -> np.ndarray:
    if spec.fixed != "random":
        return np.broadcast_to(np.asarray(spec.fixed), (count, 3)).copy()
    if spec.scope == "R3":
        return rotation_to_rpy(uniform_rotations(count, rng))
    return rng.uniform(-2 * spec.beta, 2 * spec.beta, size=(count, 3))


def draw_samples(spec: DatasetSpec, count: int | None = None) -> tuple[DHRobot, np.ndarray]:
    """The first ``count`` (default ``spec.samples``) arms ``(count,)`` and their fixed
    orientation / point ``(count, 3)`` from the spec's streams."""
    count = spec.samples if count is None else _int("count", count, 1)
    return _draw_arms(spec, count, _rng(spec, "arms")), _draw_fixed(spec, count, _rng(spec, "fixed"))


def start_configurations(spec: DatasetSpec, count: int | None = None, starts: int | None = None) -> np.ndarray:
    """IK start configurations ``(count, starts, 6)`` (rad): ``[:, 0]`` is zero (the paper's q0),
    ``[:, 1:]`` uniform in ``[-pi, pi)`` per arm from the spec's start stream."""
    count = spec.samples if count is None else count
    starts = spec.starts if starts is None else _int("starts", starts, 1)
    q = np.zeros((count, starts, _N_JOINTS))
    if starts > 1:
        q[:, 1:] = _rng(spec, "starts").uniform(-np.pi, np.pi, size=(count, starts - 1, _N_JOINTS))
    return q


# --------------------------------------------------------------------------- labels
def _pair_poses(spec: DatasetSpec, nodes, fixed, b_idx, n_idx) -> np.ndarray:
    """Target poses ``(K, 4, 4)`` of the (arm, node) pairs ``(b_idx[k], n_idx[k])``."""
    if spec.scope == "R3":
        return ws.target_poses(nodes[n_idx], fixed[b_idx], spec.convention)
    return ws.target_poses(fixed[b_idx], nodes[n_idx], spec.convention)


def possibly_reachable(arms: DHRobot, T, margin: float = 1e-8) -> np.ndarray:
    """A sound necessary condition for the flange pose ``T`` to be reachable (any 6R arm, no limits).

    ``arms`` and ``T`` ``(..., 4, 4)`` broadcast. ``False`` means provably unreachable: every
    pose the arm can reach is at least ``margin`` (m) away in position. With standard DH the flange
    origin is ``o_6 = sum_i (d_i z_{i-1} + a_i x_i)`` with ``x_i ⊥ z_i`` and ``angle(z_i, z_{i-1}) =
    |alpha_i|``, hence, for the target orientation ``R``:

    * the wrist point ``o_5 = p - R·Rx(-alpha_6)·(a_6, 0, d_6)`` is fixed by the target and
      ``|o_5| <= sum_{i<=5} sqrt(a_i² + d_i²)``;
    * ``angle(z_i, z_0) <= Θ_i = min(pi, sum_{j<=i} |alpha_j|)``, so ``z_{i-1}·ẑ ∈ [cos Θ_{i-1}, 1]``
      and ``|x_i·ẑ| <= sin(min(pi/2, Θ_i))``, which bounds the height of ``o_5``;
    * the tool axis ``R·ẑ`` is at most ``Θ_6`` from the base ``ẑ``.

    LM reports success only within ``tol`` of the target (the position error is part of the error
    norm), so with ``margin >= tol`` skipping the pairs this rejects never changes a numerical
    label; for arms with small twists (Table 3's arbitrary family) it skips most unreachable pairs.
    """
    T = np.asarray(T, dtype=np.float64)
    d, a, al = arms.d, arms.a, arms.alpha
    R, p = T[..., :3, :3], T[..., :3, 3]
    a6, d6, c6, s6 = a[..., 5], d[..., 5], np.cos(al[..., 5]), np.sin(al[..., 5])
    # Rx(-alpha_6)·(a_6, 0, d_6) = (a_6, d_6·sin(alpha_6), d_6·cos(alpha_6))
    off = np.stack(np.broadcast_arrays(a6, d6 * s6, d6 * c6), axis=-1)
    o5 = p - (R @ off[..., None])[..., 0]
    reach = np.sqrt(a[..., :5] ** 2 + d[..., :5] ** 2).sum(axis=-1)
    cum = np.minimum(np.pi, np.cumsum(np.abs(al), axis=-1))  # Θ_1..Θ_6
    prev = np.concatenate([np.zeros_like(cum[..., :1]), cum[..., :-1]], axis=-1)  # Θ_0..Θ_5
    cz = np.cos(prev[..., :5])
    sx = np.sin(np.minimum(np.pi / 2, cum[..., :5]))
    dz = np.stack([d[..., :5] * cz, d[..., :5]], axis=0)
    zlo = (dz.min(axis=0) - np.abs(a[..., :5]) * sx).sum(axis=-1)
    zhi = (dz.max(axis=0) + np.abs(a[..., :5]) * sx).sum(axis=-1)
    tilt = np.arccos(np.clip(R[..., 2, 2], -1.0, 1.0))
    return (
        (np.linalg.norm(o5, axis=-1) <= reach + margin)
        & (o5[..., 2] >= zlo - margin)
        & (o5[..., 2] <= zhi + margin)
        & (tilt <= cum[..., 5] + 1e-12)
    )


def _solve(robot: DHRobot, T, q0, spec: DatasetSpec) -> np.ndarray:
    """LM success per target ``(K,)``, confirmed by forward kinematics.

    ``pose_error``'s rotation part ``0.5·sum(c_k x t_k)`` is ``sin(theta)·axis``: it vanishes at a
    half turn as well as at the target, so an LM "success" could in principle be the right
    position with the orientation off by pi. The check below (position and rotation matrix within
    1e-6 of the target) makes such a success a failure; in our runs it has never triggered.
    """
    res = ikine_LM(robot, T, q0=q0, tol=spec.tol, ilimit=spec.ilimit, rlimit=spec.rlimit)
    ok = res.success
    if ok.any():
        idx = np.nonzero(ok)[0]
        Tc = robot[idx].fkine(res.q[idx])
        err = np.abs(Tc[:, :3, :] - T[idx][:, :3, :]).reshape(len(idx), -1).max(axis=1)
        ok = ok.copy()
        ok[idx] = err <= 1e-6
    return ok


def _numerical_first_start(arms, spec, nodes, fixed, q0, prefilter=True) -> np.ndarray:
    """Index of the first start that solves each (arm, node) pair ``(B, N)`` int8, -1 where none does."""
    B, N = arms.batch_shape[0], len(nodes)
    first = np.full((B, N), -1, dtype=np.int8)
    b_idx, n_idx = (x.ravel() for x in np.indices((B, N)))
    if prefilter:
        # provably unreachable pairs stay -1 without running LM (labels unchanged, see possibly_reachable)
        ok = np.empty(b_idx.size, dtype=bool)
        for s in range(0, b_idx.size, 1 << 16):
            sl = slice(s, s + (1 << 16))
            sub = DHRobot(arms.d[b_idx[sl]], arms.a[b_idx[sl]], arms.alpha[b_idx[sl]])
            ok[sl] = possibly_reachable(sub, _pair_poses(spec, nodes, fixed, b_idx[sl], n_idx[sl]), max(1e-8, spec.tol))
        b_idx, n_idx = b_idx[ok], n_idx[ok]
    for k in range(q0.shape[1]):
        if not b_idx.size:
            break
        robot = DHRobot(arms.d[b_idx], arms.a[b_idx], arms.alpha[b_idx])
        T = _pair_poses(spec, nodes, fixed, b_idx, n_idx)
        ok = _solve(robot, T, q0[b_idx, k], spec)
        first[b_idx[ok], n_idx[ok]] = k
        b_idx, n_idx = b_idx[~ok], n_idx[~ok]
    return first


def labels_for(
    arms: DHRobot,
    spec: DatasetSpec,
    fixed=None,
    *,
    method: str | None = None,
    q0=None,
    nodes=None,
    prefilter: bool = True,
) -> np.ndarray:
    """Labels ``(count, n_nodes)`` bool of a batch of arms for ``spec``, in node order.

    Parameters
    ----------
    arms : DHRobot, batch ``(count,)``
    fixed : ``(3,)`` or ``(count, 3)``, optional
        Orientation (R3, rad) or point (SO3, m); default the spec's (required if ``"random"``).
    method : ``"exact"`` | ``"numerical"``, optional
        Overrides the spec's (the label audit runs the numerical path on a spherical-wrist spec).
    q0 : ``(count, S, 6)`` or ``(S, 6)``, optional
        Start configurations for the numerical path; default ``start_configurations`` of the spec
        for the first ``count`` arms (only right for the spec's own arms in order; pass them
        explicitly otherwise). ``S = 1`` with zeros is the paper's single start.
    nodes : ``(N, 3)``, optional
        Nodes to label instead of :func:`spec_nodes` (positions for R3, angles for SO3).
    prefilter : bool
        Numerical path: skip the pairs :func:`possibly_reachable` proves unreachable (same labels,
        faster). ``False`` runs LM on every pair.
    """
    arms = _check_arms(arms)
    count = arms.batch_shape[0]
    method = spec.method if method is None else _choice("method", method, METHODS)
    nodes = spec_nodes(spec) if nodes is None else np.asarray(nodes, dtype=np.float64)
    fx = _fixed_rows(spec, count, fixed)
    # one orientation for all arms (a fixed spec, or rows that happen to agree): the map functions
    random = bool(np.any(fx != fx[0]))
    if method == "numerical":
        if q0 is None:
            q0 = start_configurations(spec, count)
        q0 = np.asarray(q0, dtype=np.float64)
        if q0.ndim == 2:
            q0 = np.broadcast_to(q0, (count,) + q0.shape)
        if q0.ndim != 3 or q0.shape[0] != count or q0.shape[2] != _N_JOINTS:
            raise ValueError(f"q0 must have shape (S, 6) or ({count}, S, 6), got {q0.shape}")
        return _numerical_first_start(arms, spec, nodes, fx, q0, prefilter) >= 0
    if not random:
        if spec.scope == "R3":
            return ws.constant_orientation_map(arms, nodes, fx[0], method="exact", convention=spec.convention)
        return ws.orientation_map(arms, nodes, fx[0], method="exact", convention=spec.convention)
    # one orientation (point) per arm: the pose of node n for arm b, exact wrist-centre test,
    # a few arms at a time (the (arms, nodes, 4, 4) poses are 128 bytes per pair)
    from .kinematics import require_spherical_wrist, wrist_centre_reachable

    require_spherical_wrist(arms)
    out = np.empty((count, len(nodes)), dtype=bool)
    per = max(1, (1 << 18) // max(len(nodes), 1))
    for s in range(0, count, per):
        sl = slice(s, min(s + per, count))
        if spec.scope == "R3":
            T = ws.target_poses(nodes[None, :, :], fx[sl, None, :], spec.convention)
        else:
            T = ws.target_poses(fx[sl, None, :], nodes[None, :, :], spec.convention)
        sub = arms[sl]
        node_arms = DHRobot(sub.d[:, None, :], sub.a[:, None, :], sub.alpha[:, None, :])
        out[sl] = wrist_centre_reachable(node_arms, T[..., :3, 3])
    return out


# --------------------------------------------------------------------------- storage
def _npy_header(shape, dtype) -> bytes:
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        buf, {"descr": np.lib.format.dtype_to_descr(np.dtype(dtype)), "fortran_order": False, "shape": tuple(shape)}
    )
    return buf.getvalue()


def _zip_entry(zf: zipfile.ZipFile, name: str):
    info = zipfile.ZipInfo(name + ".npy", date_time=_ZIP_TIME)
    info.compress_type = zipfile.ZIP_DEFLATED
    info.external_attr = 0o644 << 16
    return zf.open(info, "w", force_zip64=True)


def _default_chunk(spec: DatasetSpec) -> int:
    n = spec.n_nodes
    if spec.method == "numerical":
        return max(1, (1 << 16) // n)  # LM is slow per node; small chunks keep the bar moving
    return max(1, (1 << 21) // n)


def build_dataset(spec: DatasetSpec, path, chunk: int | None = None, progress: bool = True) -> Path:
    """Generate ``spec``'s dataset into ``path`` (see the module docstring for the format).

    Arms are labelled ``chunk`` at a time (default: about 2 million node evaluations per chunk
    for exact labels), each chunk's labels bit-packed and streamed into the compressed file, so
    memory stays bounded by the features (``samples x n_features`` float64) plus one chunk.
    The same spec always gives a byte-identical file, whatever ``chunk``. Returns the path.
    """
    if not isinstance(spec, DatasetSpec):
        raise TypeError(f"spec must be a DatasetSpec, got {type(spec).__name__}")
    path = Path(path)
    chunk = _default_chunk(spec) if chunk is None else _int("chunk", chunk, 1)
    arms, fixed = draw_samples(spec)
    X = features_for(arms, spec, fixed)
    q0 = start_configurations(spec) if spec.method == "numerical" else None
    S, N = spec.samples, spec.n_nodes
    width = (N + 7) // 8
    digest = hashlib.sha256(X.tobytes())

    from tqdm.auto import tqdm

    bar = tqdm(total=S, unit="arm", desc=spec.name, disable=not progress, leave=False)
    with bar, atomic_path(path) as tmp:
        with zipfile.ZipFile(tmp, "w", compression=zipfile.ZIP_DEFLATED) as zf:
            with _zip_entry(zf, "features") as fid:
                np.lib.format.write_array(fid, X)
            with _zip_entry(zf, "labels_packed") as fid:
                fid.write(_npy_header((S, width), np.uint8))
                for s in range(0, S, chunk):
                    sl = slice(s, min(s + chunk, S))
                    L = labels_for(arms[sl], spec, fixed[sl], q0=None if q0 is None else q0[sl])
                    packed = np.packbits(L, axis=1)
                    digest.update(packed.tobytes())
                    fid.write(packed.tobytes())
                    bar.update(sl.stop - sl.start)
            header = {
                "format": FORMAT,
                "format_version": FORMAT_VERSION,
                "wsmap_version": __version__,
                "spec": spec.to_dict(),
                "features_shape": list(X.shape),
                "labels_shape": [S, N],
                "labels_packed_shape": [S, width],
                "feature_names": feature_names(spec),
                "sha256": digest.hexdigest(),
            }
            raw = json.dumps(header, sort_keys=True, separators=(",", ":")).encode("utf-8")
            with _zip_entry(zf, "header") as fid:
                np.lib.format.write_array(fid, np.frombuffer(raw, dtype=np.uint8))
    return path


@dataclass
class Dataset:
    """A loaded dataset: ``features`` ``(samples, F)`` float64, ``labels`` ``(samples, nodes)`` bool.

    ``labels`` is unpacked from ``labels_packed`` on first access (1 byte per label: 0.9 GB for
    1e5 x 9261); ``label_rows(idx)`` unpacks only some rows.
    """

    spec: DatasetSpec
    features: np.ndarray
    labels_packed: np.ndarray
    header: dict = field(repr=False)
    path: Path | None = None

    @cached_property
    def labels(self) -> np.ndarray:
        return self.label_rows(slice(None))

    def label_rows(self, idx) -> np.ndarray:
        n = self.header["labels_shape"][1]
        # unpackbits gives 0/1 bytes: viewing them as bool avoids a second 1-byte-per-label copy
        return np.unpackbits(self.labels_packed[idx], axis=-1, count=n).view(bool)

    @property
    def feature_names(self) -> list[str]:
        return feature_names(self.spec)

    @property
    def n_nodes(self) -> int:
        """Labelled nodes per sample."""
        return int(self.header["labels_shape"][1])

    def head(self, n: int | None) -> "Dataset":
        """The first ``n`` samples (all when ``n`` is ``None`` or at least ``len(self)``): what a
        reduced training run uses, the same arms a smaller build would have drawn."""
        if n is None or n >= len(self):
            return self
        n = _int("n", n, 1)
        header = {**self.header, "features_shape": [n, self.features.shape[1]],
                  "labels_shape": [n, self.n_nodes], "labels_packed_shape": [n, self.labels_packed.shape[1]]}
        return Dataset(spec=scaled(self.spec, n), features=self.features[:n],
                       labels_packed=self.labels_packed[:n], header=header, path=self.path)

    def __len__(self):
        return self.features.shape[0]


def _spec_diff(a: dict, b: dict) -> list[str]:
    keys = sorted(set(a) | set(b))
    return [f"{k}: file has {a.get(k)!r}, expected {b.get(k)!r}" for k in keys if a.get(k) != b.get(k)]


def dataset_paths(name: str, data_dir) -> tuple[Path, Path]:
    """Where the pipeline keeps dataset ``name``: ``(data_dir/NAME.npz, data_dir/NAME.test.npz)``
    (training set, independent test set)."""
    if name not in PAPER_SPECS:
        raise ValueError(f"unknown dataset {name!r}; known: {', '.join(sorted(PAPER_SPECS))}")
    data_dir = Path(data_dir)
    return data_dir / f"{name}.npz", data_dir / f"{name}.test.npz"


def build_pair(name: str, data_dir, samples: int | None = None, test_samples: int = 1000,
               progress: bool = True) -> tuple[Path, Path]:
    """Build paper dataset ``name`` (scaled to ``samples`` arms; ``None``: the paper's count) and
    its independent test set of ``test_samples`` arms into ``data_dir`` (:func:`dataset_paths`)."""
    train_path, test_path = dataset_paths(name, data_dir)
    spec = PAPER_SPECS[name]
    if samples is not None:
        spec = scaled(spec, samples)
    Path(data_dir).mkdir(parents=True, exist_ok=True)
    build_dataset(spec, train_path, progress=progress)
    build_dataset(test_spec(spec, test_samples), test_path, progress=progress)
    return train_path, test_path


def load_pair(name: str, data_dir) -> tuple[Dataset, Dataset]:
    """The training and test sets of ``name`` built by :func:`build_pair`, checked: the test set
    must be the training spec's test stream (same family, grid, orientation and labels)."""
    train_path, test_path = dataset_paths(name, data_dir)
    train, test = load_dataset(train_path), load_dataset(test_path)
    diff = _spec_diff(test.spec.to_dict(), test_spec(train.spec, len(test)).to_dict())
    if diff:
        raise DatasetError(f"{test_path} is not the test set of {train_path} ({'; '.join(diff)}); rebuild both")
    return train, test


def load_dataset(path, expect_spec: DatasetSpec | None = None) -> Dataset:
    """Read a dataset written by :func:`build_dataset`, checking it.

    Raises ``FileNotFoundError`` for a missing file and :class:`DatasetError` (a ``ValueError``)
    for a truncated or foreign file, a corrupt one (zip CRC, deflate stream or SHA-256 mismatch)
    and, when ``expect_spec`` is given, a file built for another spec; every message names the path.
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"dataset file {path} does not exist")
    try:
        with np.load(path, allow_pickle=False) as z:
            names = set(z.files)
            missing = {"features", "labels_packed", "header"} - names
            if missing:
                raise DatasetError(
                    f"dataset file {path} is not a wsmap dataset: entries {', '.join(sorted(missing))} missing"
                )
            header = json.loads(z["header"].tobytes().decode("utf-8"))
            X = z["features"]
            P = z["labels_packed"]
    except DatasetError:
        raise
    except zipfile.BadZipFile as e:
        if "crc" in str(e).lower():
            raise DatasetError(f"dataset file {path} is corrupt ({e})") from None
        raise DatasetError(f"dataset file {path} is truncated or not a dataset file ({e})") from None
    except (EOFError, OSError) as e:
        raise DatasetError(f"dataset file {path} is truncated or not a dataset file ({e})") from None
    except (zlib.error, ValueError, UnicodeDecodeError) as e:  # json errors are ValueErrors
        raise DatasetError(f"dataset file {path} is corrupt ({type(e).__name__}: {e})") from None
    if not isinstance(header, dict) or header.get("format") != FORMAT:
        raise DatasetError(f"dataset file {path} is not a wsmap dataset (header format {header.get('format')!r})")
    if list(X.shape) != header["features_shape"] or list(P.shape) != header["labels_packed_shape"]:
        raise DatasetError(
            f"dataset file {path} is corrupt (arrays of shape {list(X.shape)}, {list(P.shape)}; header says "
            f"{header['features_shape']}, {header['labels_packed_shape']})"
        )
    if X.dtype != np.float64 or P.dtype != np.uint8:
        raise DatasetError(f"dataset file {path} is corrupt (dtypes {X.dtype}, {P.dtype})")
    digest = hashlib.sha256(np.ascontiguousarray(X).tobytes())
    digest.update(np.ascontiguousarray(P).tobytes())
    if digest.hexdigest() != header["sha256"]:
        raise DatasetError(f"dataset file {path} is corrupt (SHA-256 of its arrays does not match its header)")
    try:
        spec = DatasetSpec.from_dict(header["spec"])
    except (ValueError, TypeError) as e:
        raise DatasetError(f"dataset file {path} holds an invalid spec ({e})") from None
    if expect_spec is not None:
        diff = _spec_diff(spec.to_dict(), expect_spec.to_dict())
        if diff:
            raise DatasetError(
                f"dataset file {path} was built for a different spec ({'; '.join(diff)}); rebuild it"
            )
    return Dataset(spec=spec, features=X, labels_packed=P, header=header, path=path)


# --------------------------------------------------------------------------- studies
def starts_study(
    spec: DatasetSpec | None = None,
    n_arms: int = 200,
    counts=(1, 2, 3, 5, 9, 17),
    seed: int = 0,
    chunk: int = 8,
    progress: bool = True,
) -> list[dict]:
    """How numerical labels change with the number of IK start configurations.

    Draws ``n_arms`` arms of ``spec`` (default: Table 3's arbitrary 6-DOF arms at
    [0.312, 5.6719, 5.936], block 5) from an audit stream of ``seed``, runs LM from q0 = 0 and then
    ``max(counts) - 1`` random starts (uniform in [-pi, pi)^6 per arm), each only where the earlier
    ones failed and :func:`possibly_reachable` does not rule the node out, and records which start
    first solved each node. Returns one row per entry of
    ``counts`` (total starts, q0 = 0 included): ``starts``, ``reachable`` (nodes), ``fraction``
    (reachable / all arm-node pairs), ``new`` (nodes that flipped to reachable since the previous
    row), ``new_fraction`` (of all pairs), ``share_of_final`` (reachable / reachable at the most
    starts), ``seconds`` (cumulative LM time, approximate: counted per start).
    """
    spec = PAPER_SPECS["table3_nosubspace"] if spec is None else spec
    spec = dataclasses.replace(spec, method="numerical")
    counts = sorted({_int("starts", c, 1) for c in counts})
    S = counts[-1]
    rng = lambda q: np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(7, _QUANTITY[q])))  # noqa: E731
    arms = _draw_arms(spec, n_arms, rng("arms"))
    fixed = _draw_fixed(spec, n_arms, rng("fixed"))
    q0 = np.zeros((n_arms, S, _N_JOINTS))
    q0[:, 1:] = rng("starts").uniform(-np.pi, np.pi, size=(n_arms, S - 1, _N_JOINTS))
    nodes = spec_nodes(spec)
    first = np.empty((n_arms, len(nodes)), dtype=np.int8)
    seconds = np.zeros(S)

    from tqdm.auto import tqdm

    for s in tqdm(range(0, n_arms, chunk), desc="starts study", disable=not progress, leave=False):
        sl = slice(s, min(s + chunk, n_arms))
        # one start at a time so that the time per start can be recorded
        f = np.full((sl.stop - sl.start, len(nodes)), -1, dtype=np.int8)
        sub = arms[sl]
        b_all, n_all = (x.ravel() for x in np.indices(f.shape))
        pair_arms = DHRobot(sub.d[b_all], sub.a[b_all], sub.alpha[b_all])
        possible = possibly_reachable(pair_arms, _pair_poses(spec, nodes, fixed[sl], b_all, n_all), max(1e-8, spec.tol))
        possible = possible.reshape(f.shape)
        for k in range(S):
            todo = (f < 0) & possible
            if not todo.any():
                break
            t = time.perf_counter()
            b_idx, n_idx = np.nonzero(todo)
            robot = DHRobot(sub.d[b_idx], sub.a[b_idx], sub.alpha[b_idx])
            T = _pair_poses(spec, nodes, fixed[sl], b_idx, n_idx)
            ok = _solve(robot, T, q0[sl][b_idx, k], spec)
            f[b_idx[ok], n_idx[ok]] = k
            seconds[k] += time.perf_counter() - t
        first[sl] = f
    total = first.size
    final = int(((first >= 0) & (first < S)).sum())
    rows, prev = [], 0
    for c in counts:
        reach = int(((first >= 0) & (first < c)).sum())
        rows.append(
            dict(
                starts=c,
                reachable=reach,
                fraction=reach / total,
                new=reach - prev,
                new_fraction=(reach - prev) / total,
                share_of_final=reach / final if final else float("nan"),
                seconds=float(seconds[:c].sum()),
            )
        )
        prev = reach
    return rows


def starts_recall(
    spec: DatasetSpec | None = None, n_poses: int = 2000, counts=(1, 2, 3, 5, 9, 17), seed: int = 0
) -> list[dict]:
    """Recall of multi-start LM on poses known to be reachable (forward kinematics of random q).

    ``n_poses`` arms of ``spec``'s family (default Table 3's arbitrary 6-DOF arms), one target each,
    ``fkine(q)`` with ``q ~ U(-pi, pi)^6``; LM (the spec's settings) from q0 = 0, then random
    starts as in :func:`starts_study`. One row per entry of ``counts``: ``starts``, ``found``,
    ``recall`` (found / n_poses). Complements :func:`starts_study`, whose grid nodes have no
    ground truth for arbitrary arms.
    """
    spec = PAPER_SPECS["table3_nosubspace"] if spec is None else spec
    counts = sorted({_int("starts", c, 1) for c in counts})
    S = counts[-1]
    rng = lambda q: np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(9, _QUANTITY[q])))  # noqa: E731
    arms = _draw_arms(spec, n_poses, rng("arms"))
    T = arms.fkine(rng("fixed").uniform(-np.pi, np.pi, size=(n_poses, _N_JOINTS)))
    q0 = np.zeros((n_poses, S, _N_JOINTS))
    q0[:, 1:] = rng("starts").uniform(-np.pi, np.pi, size=(n_poses, S - 1, _N_JOINTS))
    first = np.full(n_poses, -1)
    for k in range(S):
        todo = np.nonzero(first < 0)[0]
        if not todo.size:
            break
        ok = _solve(arms[todo], T[todo], q0[todo, k], spec)
        first[todo[ok]] = k
    rows = []
    for c in counts:
        found = int(((first >= 0) & (first < c)).sum())
        rows.append(dict(starts=c, found=found, recall=found / n_poses))
    return rows


def audit_labels(spec: DatasetSpec, n_arms: int = 50, seed: int = 0, *, ik: dict | None = None) -> dict:
    """Exact labels against the paper's numerical path on ``n_arms`` arms of a spherical-wrist spec.

    The numerical path is the paper's: LM with tol 1e-10, q0 = 0, one start (ilimit 500,
    rlimit 100; ``ik`` overrides). Arms (and random orientations) come from an audit stream of
    ``seed``, independent of the spec's training and test streams. Returns a dict: ``spec``,
    ``arms``, ``nodes`` (labelled nodes per arm), ``pairs`` (arms x nodes), ``exact_positives``,
    ``numerical_positives``, ``false_negatives`` (exact 1, numerical 0), ``false_positives``
    (numerical 1, exact 0), ``fn_rate`` (of exact positives), ``fp_rate`` (of exact negatives),
    ``agreement`` (fraction of equal labels), ``seconds_exact``, ``seconds_numerical`` (with the
    :func:`possibly_reachable` pre-filter, which changes no label but skips far nodes).
    """
    if spec.family == "arbitrary_6dof":
        raise ValueError(f"spec {spec.name!r} has arbitrary 6-DOF arms: no exact labels to audit against")
    n_arms = _int("n_arms", n_arms, 1)
    settings = dict(tol=1e-10, ilimit=500, rlimit=100, starts=1)
    settings.update(ik or {})
    num_spec = dataclasses.replace(spec, method="numerical", **settings)
    rng = lambda q: np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(8, _QUANTITY[q])))  # noqa: E731
    arms = _draw_arms(spec, n_arms, rng("arms"))
    fixed = _draw_fixed(spec, n_arms, rng("fixed"))
    t = time.perf_counter()
    exact = labels_for(arms, spec, fixed, method="exact")
    t_exact = time.perf_counter() - t
    t = time.perf_counter()
    q0 = np.zeros((n_arms, num_spec.starts, _N_JOINTS))
    if num_spec.starts > 1:
        q0[:, 1:] = rng("starts").uniform(-np.pi, np.pi, size=(n_arms, num_spec.starts - 1, _N_JOINTS))
    num = labels_for(arms, num_spec, fixed, method="numerical", q0=q0)
    t_num = time.perf_counter() - t
    fn = int((exact & ~num).sum())
    fp = int((num & ~exact).sum())
    pos, pairs = int(exact.sum()), exact.size
    return dict(
        spec=spec.name,
        scope=spec.scope,
        arms=n_arms,
        nodes=exact.shape[1],
        pairs=pairs,
        exact_positives=pos,
        numerical_positives=int(num.sum()),
        false_negatives=fn,
        false_positives=fp,
        fn_rate=fn / pos if pos else float("nan"),
        fp_rate=fp / (pairs - pos) if pairs > pos else float("nan"),
        agreement=float((exact == num).mean()),
        seconds_exact=t_exact,
        seconds_numerical=t_num,
    )


def audit_table(specs=None, n_arms: int = 50, seed: int = 0, progress: bool = False) -> list[dict]:
    """:func:`audit_labels` for each spec (default: every spherical-wrist spec of :data:`PAPER_SPECS`
    with distinct nodes / orientation); a list of row dicts (``pandas.DataFrame(rows)`` to tabulate)."""
    if specs is None:
        specs = [s for s in PAPER_SPECS.values() if s.method == "exact"]
        seen, unique = set(), []
        for s in specs:  # specs differing only in sample count audit the same thing
            key = (s.family, s.scope, s.lo, s.hi, s.step, s.select, s.fixed, s.convention)
            if key not in seen:
                seen.add(key)
                unique.append(s)
        specs = unique
    specs = [PAPER_SPECS[s] if isinstance(s, str) else s for s in specs]
    rows = []
    for s in specs:
        if progress:
            print(f"audit {s.name} ...", file=sys.stderr, flush=True)
        rows.append(audit_labels(s, n_arms=n_arms, seed=seed))
    return rows


# --------------------------------------------------------------------------- command line
def main(argv=None) -> int:
    """``python -m wsmap.data build NAME --out PATH [--samples N] [--test]``,
    ``python -m wsmap.data audit [NAME ...] [--arms N] [--seed S]``, ``python -m wsmap.data list``."""
    p = argparse.ArgumentParser(prog="python -m wsmap.data", description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    b = sub.add_parser("build", help="build one of the paper's datasets")
    b.add_argument("name", choices=sorted(PAPER_SPECS))
    b.add_argument("--out", required=True, help="output file (.npz)")
    b.add_argument("--samples", type=int, help="scale the sample count (first N arms of the same streams)")
    b.add_argument("--test", action="store_true", help="build the spec's independent 1000-sample test set")
    b.add_argument("--test-samples", type=int,
                   help="also build the independent test set of this many arms beside --out (NAME.test.npz)")
    b.add_argument("--quiet", action="store_true")
    a = sub.add_parser("audit", help="exact labels vs the paper's numerical path")
    a.add_argument("names", nargs="*", help="specs (default: every distinct spherical-wrist spec)")
    a.add_argument("--arms", type=int, default=50)
    a.add_argument("--seed", type=int, default=0)
    sub.add_parser("list", help="list the paper's specs")
    args = p.parse_args(argv)
    if args.cmd == "list":
        for name, s in PAPER_SPECS.items():
            print(f"{name:22s} {s.family:16s} {s.scope} nodes={s.n_nodes:5d} features={s.n_features:3d} "
                  f"samples={s.samples} fixed={s.fixed} method={s.method}")
        return 0
    if args.cmd == "build":
        spec = PAPER_SPECS[args.name]
        if args.samples is not None:
            spec = scaled(spec, args.samples)
        if args.test:
            spec = test_spec(spec)
        t = time.perf_counter()
        path = build_dataset(spec, args.out, progress=not args.quiet)
        print(f"{path}: {spec.samples} x {spec.n_nodes} nodes, {time.perf_counter() - t:.1f} s")
        if args.test_samples is not None:
            if args.test:
                p.error("--test-samples builds a test set beside the training set; do not combine it with --test")
            t = time.perf_counter()
            tspec = test_spec(spec, args.test_samples)
            out = Path(args.out)
            path = build_dataset(tspec, out.with_name(out.name.removesuffix(".npz") + ".test.npz"),
                                 progress=not args.quiet)
            print(f"{path}: {tspec.samples} x {tspec.n_nodes} nodes, {time.perf_counter() - t:.1f} s")
        return 0
    rows = audit_table(args.names or None, n_arms=args.arms, seed=args.seed, progress=True)
    print(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
