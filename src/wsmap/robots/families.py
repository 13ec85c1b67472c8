"""The families of arms: random arms for the datasets, the map models and the design study.

* `ArmFamily` — what a family of arms is (free parameters drawn from `U(low, high)` and the
  arms they make); `FAMILIES` lists every family the package knows: the paper's
  `spherical_wrist`, `arbitrary_6dof` and `puma560` (`DHFamily`, batches of
  `DHRobot`) and `panda7`, the Panda with its six non-zero DH lengths
  each scaled by `U(0.7, 1.3)` (`ScaledFamily`, batches of
  `SerialChain`); `family_arm`, `sample_family`,
  `family_params`, and the paper's samplers `sample_spherical_wrist`,
  `sample_arbitrary_6dof` (drawn with a seed or a `numpy.random.Generator`);
* `spherical_wrist` — an arm (or a batch) of the paper's spherical-wrist family from its DH
  lengths.

The named arms a family starts from (the PUMA560, the Panda's table) are the modules of
`wsmap.robots.arms`.
"""

from __future__ import annotations

import dataclasses
import warnings
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ..kinematics import SPHERICAL_WRIST_ALPHA, DHRobot, SerialChain
from .arms.panda import PANDA
from .arms.puma560 import puma560
from .registry import ArmTable
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap._typing import ArrayLike
    from wsmap.kinematics.chain import Arm

__all__ = [
    "spherical_wrist",
    "ArmFamily",
    "DHFamily",
    "ScaledFamily",
    "FamilyRangeWarning",
    "SPHERICAL_WRIST",
    "ARBITRARY_6DOF",
    "PUMA560",
    "PANDA7",
    "FAMILIES",
    "arm_family",
    "family_arm",
    "sample_family",
    "family_params",
    "sample_spherical_wrist",
    "sample_arbitrary_6dof",
]


def spherical_wrist(a2: float, a3: float, d3: float, d4: float, d1: float = 0.0, qlim: ArrayLike | None = None,
                    name: str | None = None) -> DHRobot:
    """A 6-DOF arm of the paper's spherical-wrist family (metres).

    The DH table (standard DH) is `d = [d1, 0, d3, d4, 0, 0]`, `a = [0, a2, a3, 0, 0, 0]`,
    `alpha = [pi/2, 0, -pi/2, pi/2, -pi/2, 0]`. Arguments may be arrays of one shape: a batch.
    """
    a2, a3, d3, d4, d1 = np.broadcast_arrays(*(np.asarray(x, dtype=np.float64) for x in (a2, a3, d3, d4, d1)))
    z = np.zeros_like(a2)
    d = np.stack([d1, z, d3, d4, z, z], axis=-1)
    a = np.stack([z, a2, a3, z, z, z], axis=-1)
    alpha = np.broadcast_to(SPHERICAL_WRIST_ALPHA, d.shape)
    return DHRobot(d, a, alpha, qlim=qlim, name=name)


# ------------------------------------------------------------------------------------------ arm families
def as_generator(seed: int | np.random.Generator | None) -> np.random.Generator:
    """`seed` itself when it is a `numpy.random.Generator` (the draw goes on from it), else
    `numpy.random.default_rng(seed)`: the generator every family draws from."""
    return seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)


def check_count(count: int) -> int:
    """`count` (a number of arms to draw) as an int; not a positive integer is a `ValueError`."""
    if int(count) != count or count < 1:
        raise ValueError(f"count must be a positive integer, got {count!r}")
    return int(count)


class FamilyRangeWarning(UserWarning):
    """An arm of a family was built, with `allow_extrapolation=True`, from parameters outside the
    family's range: no dataset of the family has such an arm."""


@dataclass(frozen=True)
class ArmFamily:
    """A family of arms: `n` free parameters, each drawn from `U(low, high)`, and the arms they make.

    This is the one definition of a family in the package; every family is listed in
    `FAMILIES`, and the datasets (`wsmap.datasets.DatasetSpec.family`), the map models
    and the design study (`wsmap.design`) take their families from there. Two kinds:

    * `DHFamily` -- 6-joint standard-DH arms (`DHRobot`) whose
      parameters are entries of the DH table (metres, radians): the paper's families
      `SPHERICAL_WRIST`, `ARBITRARY_6DOF` and `PUMA560` (one arm, no parameter);
    * `ScaledFamily` -- a named arm's published table with some of its lengths scaled
      (`SerialChain`); the parameters are dimensionless factors
      (`PANDA7`).

    A parameter is named after the table entry it sets: `"d3"` is the `d` of the joint-3 row,
    `"a4"` the `a` of the joint-4 row, `"alpha2"` the twist of the joint-2 row (1-based).

    Attributes
    ----------
    name
        the family's name (the key of `FAMILIES`).
    title
        one line for people.
    params
        the names of the parameters, in their order (the columns of `params` arrays).
    low, high
        the range of every parameter (the draws are `U(low, high)`).
    exact
        every arm of the family has a closed-form inverse kinematics (`method="exact"`
        maps and labels).
    """

    name: str
    title: str
    params: tuple[str, ...]
    low: float
    high: float
    exact: bool

    #: whether the parameters are scale factors of a named arm's lengths (`ScaledFamily`)
    scaled: ClassVar[bool] = False
    #: whether the arms are `SerialChain` batches whose dataset features
    #: are the parameters themselves, labelled by the map search (`wsmap.datasets.CHAIN_FAMILIES`)
    chain: ClassVar[bool] = False
    #: what a dataset's feature names put before each parameter's name
    feature_prefix: ClassVar[str] = ""
    #: the half-width (m) of a chain family's default R3 grid; `None`: the datasets' default
    grid: ClassVar[float | None] = None
    #: how an error message names the parameter values
    _values: ClassVar[str] = "parameters"
    _value: ClassVar[str] = ""

    @property
    def n_params(self) -> int:
        return len(self.params)

    def entries(self) -> list[tuple[str, int]]:
        """Where each parameter sits in the arm's table: `(column, row)`, column `"d"`, `"a"` or
        `"alpha"`, row 0-based."""
        out = []
        for p in self.params:
            column = p.rstrip("0123456789")
            out.append((column, int(p[len(column):]) - 1))
        return out

    def with_range(self, low: float | None = None, high: float | None = None) -> ArmFamily:
        """The same family with another range of its parameters (e.g. the paper's `beta`:
        `SPHERICAL_WRIST.with_range(high=beta)`)."""
        low = self.low if low is None else low
        high = self.high if high is None else high
        for what, v in (("low", low), ("high", high)):
            if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)) or not np.isfinite(v):
                raise ValueError(f"{what} of family {self.name!r} must be a finite number, got {v!r}")
        if not low < high:
            raise ValueError(f"the range of family {self.name!r} must have low < high, got [{low}, {high}]")
        return dataclasses.replace(self, low=float(low), high=float(high))

    def _check_value(self, s: np.ndarray) -> None:
        """Refuse values no arm of the family can have (any range); NaN and infinities always."""
        bad = ~np.isfinite(s)
        if bad.any():
            idx = tuple(int(i) for i in np.argwhere(bad)[0])
            raise ValueError(f"{self._value}{self.params[idx[-1]]} is {float(s[idx])!r}: {self._values} must be "
                             "finite")

    def check_params(self, params: ArrayLike, allow_extrapolation: bool = False, stacklevel: int = 2) -> np.ndarray:
        """`params` as a float64 array `(..., n_params)`, checked: numbers of that shape, valid
        values, and inside `[low, high]` -- outside it a `ValueError`, or with
        `allow_extrapolation` a `FamilyRangeWarning` (`stacklevel` as
        `warnings.warn` counts it here)."""
        if not isinstance(allow_extrapolation, (bool, np.bool_)):
            raise ValueError(f"allow_extrapolation must be True or False, got {allow_extrapolation!r}")
        names = ", ".join(self.params)
        what = self._values + (" of family " + repr(self.name))
        try:
            s = np.array(params, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError(f"{what} must be numbers of shape (..., {self.n_params}) ({names}), got "
                             f"{type(params).__name__}") from None
        if s.ndim == 0 or s.shape[-1] != self.n_params:
            raise ValueError(f"{what} must have shape (..., {self.n_params}): one "
                             f"{'factor' if self.scaled else 'value'} per parameter ({names}) in that order, got "
                             f"shape {s.shape}")
        self._check_value(s)
        out = (s < self.low) | (s > self.high)
        if out.any():
            idx = tuple(int(i) for i in np.argwhere(out)[0])
            where = "" if len(idx) == 1 else f" (arm {idx[0] if len(idx) == 2 else idx[:-1]})"
            what = (f"{self._value}{self.params[idx[-1]]}{where} is {float(s[idx])!r}, outside the range "
                    f"[{self.low}, {self.high}] of family {self.name!r}")
            if not allow_extrapolation:
                raise ValueError(f"{what}; pass allow_extrapolation=True to build the arm anyway")
            more = int(out.sum()) - 1
            word = "scale(s)" if self.scaled else "parameter(s)"
            warnings.warn(f"{what}{f' (and {more} more {word} out of range)' if more else ''}; built anyway "
                          "(allow_extrapolation=True): the family's datasets and models have no such arm",
                          FamilyRangeWarning, stacklevel=stacklevel)
        return s

    def draw(self, count: int, seed: int | None = None) -> np.ndarray:
        """The parameters `(count, n_params)` of `count` random arms: one uniform `U(low, high)`
        array from `seed` (an int, `None` or a `numpy.random.Generator`), so the first `k`
        arms of a seed are the arms of `count = k`."""
        count = check_count(count)
        return as_generator(seed).uniform(self.low, self.high, size=(count, self.n_params))

    def sample(self, count: int, seed: int | None = None) -> tuple[DHRobot | SerialChain, np.ndarray]:
        """`count` random arms: `(arms, params)`, batch `(count,)`, `params` from `draw`."""
        params = self.draw(count, seed)
        return self.arms(params), params

    def arms(self, params: ArrayLike, *, allow_extrapolation: bool = False, stacklevel: int = 2) -> Arm:
        """The arms of `params` `(..., n_params)`: a batch of shape `(...)`."""
        raise NotImplementedError

    def params_of(self, arms: Arm) -> np.ndarray:
        """The parameters `(..., n_params)` of arms of the family (read back from them); arms that
        are not of the family are a `ValueError` (`TypeError` for another kind of robot)."""
        raise NotImplementedError


@dataclass(frozen=True)
class DHFamily(ArmFamily):
    """6-joint standard-DH arms whose free parameters are entries of one DH table.

    `d`, `a`, `alpha` (6 each; metres, radians) are the table's fixed entries; an entry named
    by a parameter is set from it. The arms have no joint limits and no tool, as in the paper.
    """

    d: tuple = (0.0,) * 6
    a: tuple = (0.0,) * 6
    alpha: tuple = (0.0,) * 6

    def arms(self, params: ArrayLike, *, allow_extrapolation: bool = False, stacklevel: int = 2) -> DHRobot:
        p = self.check_params(params, allow_extrapolation, stacklevel + 1)
        shape = p.shape[:-1]
        table = {k: np.broadcast_to(np.asarray(getattr(self, k), dtype=np.float64), shape + (6,)).copy()
                 for k in ("d", "a", "alpha")}
        for k, (column, row) in enumerate(self.entries()):
            table[column][..., row] = p[..., k]
        return DHRobot(table["d"], table["a"], table["alpha"], name=self.name)

    def params_of(self, arms: DHRobot, atol: float = 1e-9) -> np.ndarray:
        if not isinstance(arms, DHRobot):
            raise TypeError(f"arms of family {self.name!r} must be a DHRobot, got {type(arms).__name__}")
        free = {(column, row) for column, row in self.entries()}
        same = arms.n == 6 and arms.tool is None and arms.qlim is None
        for column in ("d", "a", "alpha") if same else ():
            fixed = [row for row in range(6) if (column, row) not in free]
            got = getattr(arms, column)[..., fixed]
            same = same and np.allclose(got, np.asarray(getattr(self, column))[fixed], rtol=0, atol=atol)
        if not same:
            raise ValueError(f"these arms are not of family {self.name!r} ({self.title}; only "
                             f"{', '.join(self.params) or 'nothing'} may differ, no joint limits, no tool)")
        return np.stack([getattr(arms, column)[..., row] for column, row in self.entries()], axis=-1)


@dataclass(frozen=True)
class ScaledFamily(ArmFamily):
    """A named arm's published table (`table`) with some of its lengths scaled.

    `params` name the scaled lengths after the table's rows as the manufacturer numbers them (in
    the modified convention `"a4"` is Craig's `a_3`, acting before joint 4). Arm `b` of a
    batch has length `k` equal to `scales[b, k] * nominal[k]`, every scale in `[low, high]`;
    every other number of the table (twists, offsets, flange row, mount, joint limits) is the
    named arm's.
    """

    table: ArmTable | None = None

    scaled: ClassVar[bool] = True
    chain: ClassVar[bool] = True
    feature_prefix: ClassVar[str] = "scale_"
    _values: ClassVar[str] = "scales"
    _value: ClassVar[str] = "scale of "

    def _columns(self) -> list[tuple[int, int]]:
        """`(column, row)` of each parameter: column 0 is `d`, 1 is `a`; rows 0-based."""
        return [("da".index(column), row) for column, row in self.entries()]

    @property
    def nominal(self) -> np.ndarray:
        """The named arm's value of each parameter `(n_params,)` (metres)."""
        rows = np.array(self.table.rows, dtype=np.float64)
        return np.array([rows[r, c] for c, r in self._columns()])

    def _check_value(self, s: np.ndarray) -> None:
        bad = ~np.isfinite(s) | (s <= 0)
        if bad.any():
            idx = tuple(int(i) for i in np.argwhere(bad)[0])
            raise ValueError(f"scale of {self.params[idx[-1]]} is {float(s[idx])!r}: scales must be positive "
                             "and finite")

    def arms(self, params: ArrayLike, *, allow_extrapolation: bool = False, joint_limits: bool = True,
             stacklevel: int = 2) -> SerialChain:
        """The arms of `params` (scales) `(..., n_params)`: a `SerialChain` of batch
        shape `(...)` (see `family_arm`)."""
        s = self.check_params(params, allow_extrapolation, stacklevel + 1)
        rows = np.array(self.table.rows, dtype=np.float64)
        cols = np.broadcast_to(rows[:, :2].T, s.shape[:-1] + (2, self.table.n)).copy()  # (..., 2, n): d, a
        for k, (c, r) in enumerate(self._columns()):
            cols[..., c, r] = s[..., k] * rows[r, c]
        return self.table.chain(joint_limits, d=cols[..., 0, :], a=cols[..., 1, :], name=self.name)

    def params_of(self, arms: SerialChain, atol: float = 1e-12) -> np.ndarray:
        """The scales `(..., n_params)` of arms built by `arms` (read from their fixed
        transforms); an arm that is not of the family (other lengths, twists, joints, limits) is a
        `ValueError`."""
        if not isinstance(arms, SerialChain):
            raise TypeError(f"arms of family {self.name!r} must be a SerialChain, got {type(arms).__name__}")
        if arms.n != self.table.n:
            raise ValueError(f"arms of family {self.name!r} have {self.table.n} joints, got {arms.n}")
        # from_dh puts d_i and a_{i+1} (modified) or a_i (standard) in the translation of F_{i+1}
        # (modified: F_0 holds a_1) as exact sums with zeros: (a, 0, d) read back without rounding
        F = arms.fixed
        modified = self.table.convention == "modified"
        scales = []
        nominal = self.nominal
        for k, (c, r) in enumerate(self._columns()):
            if c == 0:
                v = F[..., r + 1, 2, 3]
            else:
                v = F[..., r, 0, 3] if modified else F[..., r + 1, 0, 3]
            scales.append(v / nominal[k])
        s = np.stack(scales, axis=-1)
        rebuilt = None
        if np.all(np.isfinite(s)) and np.all(s > 0):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", FamilyRangeWarning)
                rebuilt = self.arms(s, allow_extrapolation=True)
        same = (rebuilt is not None and rebuilt.kinds == arms.kinds
                and np.allclose(rebuilt.fixed, F, rtol=0, atol=atol) and np.allclose(rebuilt.axes, arms.axes)
                and np.allclose(rebuilt.offset, arms.offset) and (arms.qlim is None) == (rebuilt.qlim is None)
                and (arms.qlim is None or np.allclose(rebuilt.qlim, arms.qlim)))
        if not same:
            raise ValueError(f"these arms are not of family {self.name!r} (only {', '.join(self.params)} may differ "
                             f"from the {self.table.title}'s table)")
        return s


#: The paper's spherical-wrist family: d = [0, 0, d3, d4, 0, 0], a = [0, a2, a3, 0, 0, 0], alpha =
#: [pi/2, 0, -pi/2, pi/2, -pi/2, 0] with d3, d4, a2, a3 ~ U(0, 0.5) m (the paper's beta), drawn in
#: that order; the PUMA560 (d1 = 0) is one of its arms.
SPHERICAL_WRIST = DHFamily(name="spherical_wrist", title="spherical-wrist arms, d3, d4, a2, a3 ~ U(0, 0.5) m",
                           params=("d3", "d4", "a2", "a3"), low=0.0, high=0.5, exact=True,
                           alpha=tuple(float(x) for x in SPHERICAL_WRIST_ALPHA))
#: Table 3's arbitrary 6-DOF arms: every d_i, a_i, alpha_i ~ U(0, 0.5) (m, rad), drawn as one
#: `(count, 18)` array (rows d, a, alpha).
ARBITRARY_6DOF = DHFamily(name="arbitrary_6dof", title="arbitrary 6-DOF arms, every d, a, alpha ~ U(0, 0.5) m, rad",
                          params=tuple(f"{k}{i}" for k in ("d", "a", "alpha") for i in range(1, 7)),
                          low=0.0, high=0.5, exact=False)
_PUMA = puma560()
#: The PUMA560 (`puma560`, d1 = 0) as a family of one arm: no parameter.
PUMA560 = DHFamily(name="puma560", title="the PUMA560 (d1 = 0) in every sample", params=(), low=0.0, high=0.5,
                   exact=True, d=tuple(_PUMA.d.tolist()), a=tuple(_PUMA.a.tolist()), alpha=tuple(_PUMA.alpha.tolist()))
#: The Franka Emika Panda with the six non-zero lengths of its modified-DH table (d1 = 0.333,
#: d3 = 0.316, d5 = 0.384, a4 = 0.0825, a5 = -0.0825, a7 = 0.088 m) each scaled by an independent
#: factor in [0.7, 1.3]; flange row (d = 0.107 m) and joint limits as the Panda's.
PANDA7 = ScaledFamily(name="panda7", title="Franka Emika Panda, six lengths scaled by U(0.7, 1.3)",
                      params=("d1", "d3", "d5", "a4", "a5", "a7"), low=0.7, high=1.3, exact=False, table=PANDA)

#: Every family of arms, by name: where the package looks a family up (`arm_family`).
FAMILIES: dict[str, ArmFamily] = {f.name: f for f in (SPHERICAL_WRIST, ARBITRARY_6DOF, PUMA560, PANDA7)}


def arm_family(name: str) -> ArmFamily:
    """The `ArmFamily` `name` of `FAMILIES`; an unknown name is a `ValueError`
    listing the known ones."""
    if not isinstance(name, str) or name not in FAMILIES:
        raise ValueError(f"unknown arm family {name!r}; known families: {', '.join(FAMILIES)}")
    return FAMILIES[name]


def family_arm(name: str, params: ArrayLike, *, allow_extrapolation: bool = False) -> DHRobot | SerialChain:
    """A batch of arms of the family `name` from their parameters.

    Parameters
    ----------
    name : str
        A family of `FAMILIES`, e.g. `"panda7"`: the Franka Panda's modified-DH chain
        (base: the mounting flange, `panda_link0`; end: the tool flange) whose lengths d1, d3,
        d5, a4, a5, a7 (0.333, 0.316, 0.384, 0.0825, -0.0825, 0.088 m) are multiplied by
        `params`, or `"spherical_wrist"` (`params` are d3, d4, a2, a3 in metres).
    params : array_like, shape (..., n_params)
        In the family's order (`ArmFamily.params`), each in `[low, high]` (`panda7`:
        dimensionless factors in `[0.7, 1.3]`).
    allow_extrapolation : bool
        Build arms with parameters outside the range (still valid values), with a
        `FamilyRangeWarning`, instead of refusing them.

    Returns
    -------
    DHRobot or SerialChain
        A batch of shape `params.shape[:-1]` (`()` for one arm): a `SerialChain` with the
        Panda's joint limits (rad) and flange for `panda7`, a `DHRobot` for the DH families;
        `fkine` gives flange poses in the base frame (metres).

    Raises
    ------
    ValueError
        An unknown family, a shape other than `(..., n_params)`, a value that is not valid (not
        finite; a scale that is not positive), or a value out of range (without
        `allow_extrapolation`), naming the family, the parameter and the value.
    """
    return arm_family(name).arms(params, allow_extrapolation=allow_extrapolation, stacklevel=3)


def sample_family(name: str, count: int, seed: int | None = None) -> tuple[DHRobot | SerialChain, np.ndarray]:
    """`count` random arms of the family `name`: `(arms, params)`.

    `params` `(count, n_params)` are independent `U(low, high)` draws (one uniform array from
    `seed`: an int, `None`, or a `numpy.random.Generator`), in the order of
    `family_arm`; `arms` is `family_arm(name, params)`, batch shape `(count,)`.
    """
    return arm_family(name).sample(count, seed)


def family_params(name: str, arms: Arm) -> np.ndarray:
    """The parameters `(..., n_params)` of arms of the family `name` (built by `family_arm`),
    read back from the arms; arms of another kind are a `ValueError`."""
    return arm_family(name).params_of(arms)


def _check_beta(beta) -> float:
    if isinstance(beta, bool) or not isinstance(beta, (int, float, np.integer, np.floating)) or not (
            beta > 0 and np.isfinite(beta)):
        raise ValueError(f"beta must be positive and finite, got {beta!r}")
    return float(beta)


def sample_spherical_wrist(count: int, seed: int | None = None, beta: float = 0.5) -> DHRobot:
    """`count` arms of `SPHERICAL_WRIST` with d3, d4, a2, a3 ~ U(0, beta), independent.

    The draw order per arm is (d3, d4, a2, a3): one `(count, 4)` uniform array.
    """
    return SPHERICAL_WRIST.with_range(high=_check_beta(beta)).sample(count, seed)[0]


def sample_arbitrary_6dof(count: int, seed: int | None = None, beta: float = 0.5) -> DHRobot:
    """`count` arms of `ARBITRARY_6DOF` (Table 3): every d_i, a_i, alpha_i ~ U(0, beta) (m, rad).

    The draw is one `(count, 18)` uniform array: d_1..d_6, a_1..a_6, alpha_1..alpha_6.
    """
    return ARBITRARY_6DOF.with_range(high=_check_beta(beta)).sample(count, seed)[0]
