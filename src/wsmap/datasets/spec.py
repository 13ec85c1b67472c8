"""The dataset spec: everything that determines a dataset, as plain data.

A `DatasetSpec` names the arms (`family`, `beta`), the grid and the labelled nodes
(`scope`, `lo`, `hi`, `step`, `select`), the fixed orientation or point (`fixed`), how
labels are computed (`method`, `convention` and the LM settings), and the random streams
(`seed`, `stream`, `samples`), and, for a chain family, whether the labels are collision-free
(`collision`, `wsmap.datasets.collision`). It round-trips through YAML / JSON (`DatasetSpec.to_dict`,
`DatasetSpec.from_dict`), so `params.yaml` and every dataset file can hold it.

Every field is checked when a spec is made: a bad value is a `ValueError` naming the field,
before any work. Numbers must be real numbers (a string is accepted only when it is a plain
numeral, because YAML reads `1e-10` as a string); expressions such as `"pi/10"` are refused:
write the value.

`test_spec` gives a spec's independent test set and `scaled` changes its sample count
(the first arms of the same streams).
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .. import robots
from .. import workspace as ws
from .collision import LabelCollision, label_collision

__all__ = [
    "FAMILIES",
    "CHAIN_FAMILIES",
    "CHAIN_FAMILY_GRID",
    "SCOPES",
    "STREAMS",
    "CONVENTIONS",
    "METHODS",
    "DEFAULT_STARTS",
    "MAX_GRID_NODES",
    "MAX_SAMPLES",
    "MAX_STARTS",
    "MAX_LM_ITERATIONS",
    "MAX_TOL",
    "N_JOINTS",
    "N_DH",
    "DatasetSpec",
    "test_spec",
    "scaled",
    "check_spec",
    "check_int",
    "check_choice",
]

#: Families of a dataset's arms: the names of `wsmap.robots.FAMILIES` (the paper's three DH
#: families, `DHRobot` arms, and the real-arm families).
FAMILIES = tuple(robots.FAMILIES)
#: Families whose arms are `SerialChain` batches built from scale
#: factors (`wsmap.robots.ScaledFamily`): their features are the scales, their labels the
#: numerical map search (`wsmap.datasets.labels`).
CHAIN_FAMILIES = tuple(name for name, family in robots.FAMILIES.items() if family.chain)
#: The default R3 grid bounds of a chain family (metres), `lo = -hi`: `[-1.2, 1.2]³` holds the
#: Panda's reach (0.855 m) and nearly all of the scaled arms' tool-down workspace.
CHAIN_FAMILY_GRID = 1.2
SCOPES = ("R3", "SO3")
STREAMS = ("train", "test")
CONVENTIONS = ws.CONVENTIONS
#: How labels are computed (a dataset says which; "auto" is the maps' choice, not a label method).
METHODS = ("exact", "numerical")
#: Number of IK start configurations for numerical labels (q0 = 0 plus DEFAULT_STARTS - 1 random
#: ones). Measured (seed 0, OMP_NUM_THREADS=1, 2-core machine shared with other jobs):
#: `starts_recall(spec, n_poses=5000, counts=(1..9, 11, 13, 17, 25, 33))` on Table 3's arbitrary
#: 6-DOF arms (poses fkine(q), q ~ U(-pi, pi)^6, so reachable) and `starts_study(spec, n_arms=320,
#: counts=(1..9, 11, 13, 17))` (Table 3 orientation, block 5: 423,360 arm-node pairs, 343
#: reachable), `spec = wsmap.paper.specs.PAPER_SPECS["table3_nosubspace"]`:
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

# Upper bounds: values beyond them are typos, not experiments (and would fail much later, deep
# inside numpy, or run for days).
#: Nodes of a spec's whole grid: 2**24 (256³; 0.4 GB of node coordinates). The paper's largest is 21³.
MAX_GRID_NODES = 2**24
#: Arms of one dataset: 10⁹ (the paper's largest is 10⁵; 10⁹ rows of 84 features are 670 GB).
MAX_SAMPLES = 10**9
#: IK start configurations: 1000 (the start study stops at 33; each start costs a full LM pass).
MAX_STARTS = 1000
#: LM iteration and consecutive-rejection limits: 10⁶ (the paper's are 500 and 100).
MAX_LM_ITERATIONS = 10**6
#: LM tolerance: at most 1e-6, the tolerance of the forward-kinematics check that confirms every LM
#: success (`wsmap.datasets.labels`); a looser LM tolerance would make converged poses fail it.
MAX_TOL = 1e-6

#: Joints of every arm, and DH columns of the feature vector (d, a, alpha per joint).
N_JOINTS = 6
N_DH = 3 * N_JOINTS


# --------------------------------------------------------------------------- field checks
def _real(name, value) -> float:
    """A finite float. Accepted: ints, floats, numpy reals, and strings that are plain numerals."""
    if isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} must be a number, got {value!r}")
    if isinstance(value, str):
        try:
            out = float(value)
        except ValueError:
            raise ValueError(
                f"{name} must be a number, got the string {value!r} (expressions such as 'pi/10' are "
                "not evaluated: write the value, e.g. 0.3141592653589793)"
            ) from None
    elif isinstance(value, numbers.Real):
        out = float(value)
    else:
        raise ValueError(f"{name} must be a number, got {value!r} ({type(value).__name__})")
    if not math.isfinite(out):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return out


def _real_or_triple(name, value):
    """A grid bound: a float, or a tuple of 3 floats."""
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value.item()
    if isinstance(value, (list, tuple, np.ndarray)):
        if (value.shape if isinstance(value, np.ndarray) else (len(value),)) != (3,):
            raise ValueError(f"{name} must be a number or 3 numbers, got {value!r}")
        return tuple(_real(f"{name}[{i}]", v) for i, v in enumerate(value))
    return _real(name, value)


def check_int(name, value, minimum, maximum=None) -> int:
    """`value` as an int in `[minimum, maximum]`, or a one-line `ValueError` naming `name`.

    Parameters
    ----------
    name : str
        What the value is, as the error message names it (`"samples"`, `"counts entry"`).
    value : int or float
        An integer, or an integral float (`1e3`); a bool is refused.
    minimum : int
        The smallest value accepted.
    maximum : int, optional
        The largest value accepted (None: no bound).

    Returns
    -------
    int
        `value` as a Python int.
    """
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (numbers.Integral, float, np.floating)):
        raise ValueError(f"{name} must be an integer, got {value!r}")
    if isinstance(value, (float, np.floating)) and not (math.isfinite(value) and float(value).is_integer()):
        raise ValueError(f"{name} must be an integer, got {value!r}")
    value = int(value)
    if value < minimum:
        raise ValueError(f"{name} must be at least {minimum}, got {value}")
    if maximum is not None and value > maximum:
        raise ValueError(f"{name} must be at most {maximum}, got {value}")
    return value


def float64_array(value, message: str) -> np.ndarray:
    """`value` as a float64 array; `ValueError(message)` (what it must be) when it is not numbers."""
    try:
        return np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(message) from None


def require_finite(x: np.ndarray, message: str) -> np.ndarray:
    """`x` unchanged when every value is finite; else `ValueError(message)`."""
    if not np.all(np.isfinite(x)):
        raise ValueError(message)
    return x


def check_choice(name, value, choices):
    """`value` when it is one of `choices` (strings), or a one-line `ValueError` naming `name`
    and the choices.

    Parameters
    ----------
    name : str
        What the value is (`"method"`, `"scope"`), as the error message names it.
    value : object
        The value given; only a `str` among `choices` is accepted.
    choices : sequence of str
        The accepted values, listed by the error message in this order.

    Returns
    -------
    str
        `value` as a plain `str`.
    """
    if not isinstance(value, str) or value not in choices:
        raise ValueError(f"unknown {name} {value!r}; choose one of {', '.join(choices)}")
    return str(value)


def _grid_counts(lo, hi, step) -> tuple[int, int, int]:
    """Nodes per axis, counted as `wsmap.workspace.grid_axes` counts them, for a dataset grid
    (at most `MAX_GRID_NODES` nodes)."""
    return ws.grid_counts(lo, hi, step, max_nodes=MAX_GRID_NODES, what="a dataset may have")


def _checked_select(sel, total: int) -> tuple[int, int] | None:
    """A spec's `select` as `None` (every node: `None` or `"all"`) or `(start, stop)` within
    the grid's `total` nodes (a list, tuple or contiguous slice)."""
    if isinstance(sel, str):
        if sel != "all":
            raise ValueError(f"select must be 'all' or [start, stop], got {sel!r}")
        return None
    if sel is None:
        return None
    if isinstance(sel, slice):
        if sel.step not in (None, 1):
            raise ValueError(f"select must be a contiguous range [start, stop), got {sel!r}")
        sel = (sel.start, sel.stop)
    if not isinstance(sel, (list, tuple)) or len(sel) != 2:
        raise ValueError(f"select must be 'all' or [start, stop], got {sel!r}")
    start, stop = (check_int(f"select {k}", v, 0) for k, v in zip(("start", "stop"), sel))
    if stop <= start:
        raise ValueError(f"empty node selection [{start}, {stop}): stop must exceed start")
    if stop > total:
        raise ValueError(f"node selection [{start}, {stop}) runs past the grid's {total} nodes")
    return (start, stop)


# --------------------------------------------------------------------------- the spec
@dataclass(frozen=True)
class DatasetSpec:
    """Everything that determines a dataset; plain data (`to_dict` / `from_dict` via YAML).

    Attributes
    ----------
    name : str
        Identifier (file names, progress bars).
    family : `"spherical_wrist"` | `"arbitrary_6dof"` | `"puma560"` | `"panda7"`
        The arms, a family of `wsmap.robots.FAMILIES` (`arm_family`): the paper's
        spherical-wrist family (d3, d4, a2, a3 ~ U(0, beta)), Table 3's arbitrary 6-DOF arms
        (every d_i, a_i, alpha_i ~ U(0, beta)), the PUMA560 (d1 = 0) in every sample (useful with
        a random orientation), or a real-arm family of
        `CHAIN_FAMILIES` (`panda7`: the Franka Panda with its six non-zero DH lengths each
        scaled by U(0.7, 1.3), `wsmap.robots.sample_family`). A chain family's features are
        its scale factors and its labels the numerical map search with its own settings
        (`wsmap.kinematics.ik.search.MAP_SETTINGS`), so it needs `method="numerical"`, a
        fixed orientation (or point), and `tol`, `ilimit`, `rlimit`, `starts` and `beta`
        left at their defaults (they set the paper's LM path and DH draws); its default R3 grid is
        `[-1.2, 1.2]` m (`CHAIN_FAMILY_GRID`).
    scope : `"R3"` (positions at a fixed orientation) | `"SO3"` (orientations at a fixed point)
    lo, hi, step : float or 3-tuple
        The grid (`wsmap.workspace.grid_axes`): metres for R3, radians for SO3. `None`
        means the paper's range, `[-2·beta, 2·beta]` (R3) or `[0, 2·pi]` (SO3). At most
        `MAX_GRID_NODES` nodes.
    select : None or (start, stop)
        The labelled nodes: all (`None`, `"all"` in YAML) or the 0-based half-open slice
        `[start, stop)` of the flat node order (block 5 is `(5292, 6615)`).
    fixed : 3-tuple or `"random"`
        The orientation (r1, r2, r3) in radians (R3) or the point in metres (SO3); `"random"`
        draws one per sample (see `wsmap.datasets.sampling`) and makes it part of the input.
    convention : `"paper"` (`R·transl(p)`, tests `R·p`) | `"standard"` (`transl(p)·R`)
    method : `"exact"` (closed form; spherical-wrist arms only) | `"numerical"` (LM)
    tol, ilimit, rlimit, starts :
        LM settings for `method="numerical"`: tolerance on the pose-error norm (at most
        `MAX_TOL`), iteration limit, consecutive-rejection limit, and the number of start
        configurations (q0 = 0 first, then random ones; a node is reachable when any converges).
        Ignored by `"exact"`.
    samples : int
        Number of arms (rows), 1 to `MAX_SAMPLES`.
    seed : int
        Root of every random stream (non-negative).
    beta : float
        Upper bound of the uniform DH draws (m, and rad for arbitrary twists); the paper's 0.5.
    stream : `"train"` | `"test"`
        Which independent stream of `seed` the samples come from (`test_spec`).
    collision : None or mapping
        Chain families only: collision-free labels (`wsmap.datasets.collision`): `model`
        (the family's named arm's capsule model, scaled with each arm) or `link_radius`, an
        optional `scene` mapping (default: the floor `z = 0`), `self_collision`,
        `acm_samples`, `acm_seed`; kept as a `LabelCollision`.
        `None` (default): the chain's map. Part of the spec's identity (`to_dict` holds it
        when set), so a file built with other settings is refused.
    """

    name: str
    family: str = "spherical_wrist"
    scope: str = "R3"
    lo: float | tuple | None = None
    hi: float | tuple | None = None
    step: float | tuple = 0.1
    select: tuple[int, int] | None = None
    fixed: tuple[float, float, float] | str = (0.0, 0.0, 0.0)
    convention: str = "standard"
    method: str = "exact"
    tol: float = 1e-10
    ilimit: int = 500
    rlimit: int = 100
    starts: int = DEFAULT_STARTS
    samples: int = 1000
    seed: int = 0
    beta: float = 0.5
    stream: str = "train"
    collision: LabelCollision | None = None

    def __post_init__(self):
        # Every field is checked and normalised in this order, so the first bad one is the one named.
        if not isinstance(self.name, str) or not self.name.strip():
            raise ValueError(f"name must be a non-empty string, got {self.name!r}")
        for k, choices in (("family", FAMILIES), ("scope", SCOPES), ("convention", CONVENTIONS),
                           ("method", METHODS), ("stream", STREAMS)):
            self._set(k, check_choice(k, getattr(self, k), choices))
        family = self._normalise_family()
        total = self._normalise_grid(family)
        self._set("select", _checked_select(self.select, total))
        self._normalise_fixed()
        self._normalise_counts()

    def _set(self, key: str, value) -> None:
        object.__setattr__(self, key, value)  # frozen dataclass: only the checks write fields

    def _normalise_family(self) -> robots.ArmFamily:
        """Check the family against `method`, `beta` and (chain families) the settings they
        cannot honour; normalise `beta` and `collision`. Returns the registry's family."""
        family = robots.arm_family(self.family)
        if self.method == "exact" and not family.exact and not family.chain:  # (chain: _check_chain_family)
            raise ValueError(
                "method 'exact' needs arms of the spherical-wrist family (closed form); "
                f"family {self.family!r} needs method 'numerical'"
            )
        beta = _real("beta", self.beta)
        if beta <= 0:
            raise ValueError(f"beta must be positive, got {self.beta!r}")
        self._set("beta", beta)
        if family.chain:
            self._check_chain_family()
        self._set("collision", label_collision(self.collision, family))
        return family

    def _normalise_grid(self, family: robots.ArmFamily) -> int:
        """Fill in the default `lo` / `hi` (`[-2·beta, 2·beta]` or the chain family's grid for
        R3, `[0, 2·pi]` for SO3), normalise `lo`, `hi`, `step`; returns the grid's node count."""
        half = (family.grid or CHAIN_FAMILY_GRID) if family.chain else 2.0 * self.beta
        if self.lo is None:
            self._set("lo", -half if self.scope == "R3" else 0.0)
        if self.hi is None:
            self._set("hi", half if self.scope == "R3" else 2.0 * math.pi)
        for k in ("lo", "hi", "step"):
            self._set(k, _real_or_triple(k, getattr(self, k)))
        try:
            nx, ny, nz = _grid_counts(self.lo, self.hi, self.step)
        except ValueError as e:
            raise ValueError(f"empty or invalid grid (lo={self.lo}, hi={self.hi}, step={self.step}): {e}") from None
        return nx * ny * nz

    def _normalise_fixed(self) -> None:
        """`fixed` as `"random"` or a tuple of 3 floats."""
        if isinstance(self.fixed, str):
            if self.fixed != "random":
                raise ValueError(f"fixed must be 3 numbers or 'random', got {self.fixed!r}")
            return
        f = self.fixed
        if not ((isinstance(f, (list, tuple)) and len(f) == 3) or (isinstance(f, np.ndarray) and f.shape == (3,))):
            raise ValueError(f"fixed must be 3 finite numbers or 'random', got {self.fixed!r}")
        self._set("fixed", tuple(_real(f"fixed[{i}]", v) for i, v in enumerate(self.fixed)))

    def _normalise_counts(self) -> None:
        """`samples`, `seed` and the LM settings as numbers within their limits."""
        self._set("samples", check_int("samples", self.samples, 1, MAX_SAMPLES))
        self._set("seed", check_int("seed", self.seed, 0))
        self._set("ilimit", check_int("ilimit", self.ilimit, 1, MAX_LM_ITERATIONS))
        self._set("rlimit", check_int("rlimit", self.rlimit, 0, MAX_LM_ITERATIONS))
        self._set("starts", check_int("starts", self.starts, 1, MAX_STARTS))
        tol = _real("tol", self.tol)
        if not 0 < tol <= MAX_TOL:
            raise ValueError(
                f"tol must be positive and at most {MAX_TOL:g} (the forward-kinematics check of every "
                f"LM success), got {self.tol!r}"
            )
        self._set("tol", tol)

    def _check_chain_family(self) -> None:
        """The settings a chain family (`CHAIN_FAMILIES`) cannot honour are refused, not ignored."""
        fam = self.family
        if self.method != "numerical":
            raise ValueError(f"family {fam!r} has no closed form: its labels are the numerical map search, "
                             "use method 'numerical'")
        if isinstance(self.fixed, str):
            raise ValueError(f"family {fam!r} needs a fixed orientation (R3) or point (SO3), not {self.fixed!r}")
        defaults = {f.name: f.default for f in dataclasses.fields(DatasetSpec)}
        changed = []
        for k in ("tol", "ilimit", "rlimit", "starts", "beta"):
            try:
                same = float(getattr(self, k)) == float(defaults[k])
            except (TypeError, ValueError):
                same = False
            if not same:
                changed.append(f"{k}={getattr(self, k)!r}")
        if changed:
            raise ValueError(
                f"family {fam!r} is labelled by the map search (wsmap.kinematics.ik.search.MAP_SETTINGS) and "
                f"drawn by its scale factors; {', '.join(changed)} would change nothing: tol, ilimit, rlimit, "
                "starts and beta set the paper's LM path and DH draws, leave them at their defaults"
            )

    @property
    def is_chain_family(self) -> bool:
        """Whether the arms are a real-arm family (`CHAIN_FAMILIES`): scale-factor features."""
        return self.family in CHAIN_FAMILIES

    @property
    def arm_family(self) -> robots.ArmFamily:
        """The spec's `wsmap.robots.ArmFamily`; a DH family's range is `[0, beta]`."""
        family = robots.arm_family(self.family)
        return family if family.chain else family.with_range(high=self.beta)

    # ---------------------------------------------------------------- derived sizes
    @cached_property
    def grid_shape(self) -> tuple[int, int, int]:
        """Nodes along each axis `(nx, ny, nz)` of the whole grid."""
        return tuple(len(a) for a in ws.grid_axes(self.lo, self.hi, self.step))

    @property
    def grid_nodes(self) -> int:
        nx, ny, nz = self.grid_shape
        return nx * ny * nz

    @property
    def n_nodes(self) -> int:
        """Labelled nodes (label columns)."""
        if self.select is None:
            return self.grid_nodes
        return self.select[1] - self.select[0]

    @property
    def n_arm_features(self) -> int:
        """Feature columns that describe the arm: 18 DH values, or a chain family's scale factors."""
        if self.is_chain_family:
            return robots.arm_family(self.family).n_params
        return N_DH

    @property
    def n_features(self) -> int:
        return self.n_arm_features + sum(self.grid_shape) + 3

    # ---------------------------------------------------------------- plain data
    def to_dict(self) -> dict:
        """Plain YAML/JSON types: floats, ints, strings, lists; `select` `"all"` or `[start, stop]`."""
        out = {}
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if isinstance(v, tuple):
                v = list(v)
            out[f.name] = v
        if out["select"] is None:
            out["select"] = "all"
        # absent when not set: the files of specs without it keep their bytes
        if self.collision is None:
            del out["collision"]
        else:
            out["collision"] = self.collision.to_dict()
        return out

    @classmethod
    def _check_keys(cls, keys) -> None:
        known = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(keys) - known, key=str)
        if unknown:
            raise ValueError(
                f"unknown dataset spec field(s) {', '.join(map(str, unknown))}; known: {', '.join(sorted(known))}"
            )

    @classmethod
    def from_dict(cls, d: dict) -> "DatasetSpec":
        """Inverse of `to_dict`; unknown keys are an error (a typo would silently use a default)."""
        if not isinstance(d, dict):
            raise ValueError(f"a dataset spec must be a mapping, got {type(d).__name__}")
        cls._check_keys(d)
        if "name" not in d:
            raise ValueError("a dataset spec needs a name")
        return cls(**d)

    def replace(self, **changes) -> "DatasetSpec":
        """A copy with `changes`; an unknown field is a `ValueError` (like `from_dict`)."""
        self._check_keys(changes)
        return dataclasses.replace(self, **changes)


def test_spec(spec: DatasetSpec, samples: int = 1000) -> DatasetSpec:
    """The independent test set of `spec`: same everything, `samples` arms from the test stream.

    The test stream is a different `SeedSequence` spawn key of the same seed, so its arms are
    independent of (and, being continuous draws, disjoint from) the training arms.
    """
    check_spec(spec)
    if spec.stream == "test":
        raise ValueError(f"spec {spec.name!r} is already a test spec")
    return spec.replace(name=f"{spec.name}_test", samples=samples, stream="test")


test_spec.__test__ = False  # not a pytest test, despite the name


def scaled(spec: DatasetSpec, samples: int) -> DatasetSpec:
    """`spec` with fewer (or more) samples: the first `samples` arms of the same streams."""
    check_spec(spec)
    return spec.replace(samples=samples)


def check_spec(spec) -> DatasetSpec:
    """`spec` itself when it is a `DatasetSpec` (every field was checked when it was built),
    else a one-line `TypeError`.

    Parameters
    ----------
    spec : DatasetSpec
        The dataset spec a function was given.

    Returns
    -------
    DatasetSpec
        `spec`, unchanged.
    """
    if not isinstance(spec, DatasetSpec):
        raise TypeError(f"spec must be a DatasetSpec, got {type(spec).__name__}")
    return spec
