"""The named arms' registry: one record per arm (`NamedArm`), the `ArmTable` of a real arm's
published kinematics, and the lookup by name.

Each module of `wsmap.robots.arms` ends by registering its arm here, with an explicit `priority`
(the order `wsmap robots` lists the arms in): a real arm registers its published table with
`register`, the paper's `puma560` (a `DHRobot`, not a table) its constructor with
`register_constructor`. Beside its kinematics an arm declares, in its own module, its capsule
collision model (`ArmCapsules`: `wsmap.collision.named` builds it) and whether the
morphology families hold it out (`held_out`: `wsmap.robots.morph.HELD_OUT`).

`ARMS` holds the records, listed by `(priority, name)`; `ROBOTS` (name -> constructor),
`NAMED` (name -> table, the real arms) and `SOURCES` (name -> the document the numbers come
from) are read-only views of it in that order; `load` looks an arm up by name.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from numbers import Real
from typing import TYPE_CHECKING

import numpy as np

from .._plugins import Registry
from ..kinematics import DHRobot, SerialChain
from ..kinematics.chain import from_dh

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap._typing import Any, ArrayLike, Sequence

__all__ = ["ArmTable", "ArmCapsules", "NamedArm", "ARMS", "NAMED", "ROBOTS", "SOURCES", "register",
           "register_constructor", "load", "from_name"]

CONVENTIONS = ("standard", "modified")
LIMIT_UNITS = ("deg", "rad")


def _is_number(x) -> bool:
    return isinstance(x, Real) and not isinstance(x, bool) and np.isfinite(x)


@dataclass(frozen=True)
class ArmTable:
    """One arm's published kinematics: a DH table, its joint limits, and the document they come from.

    `rows` are per joint `(d, a, alpha, offset)` (metres, radians); in the modified (Craig)
    convention `a` and `alpha` of row `i` are `a_{i-1}`, `alpha_{i-1}` (they act before
    joint `i`), as `wsmap.kinematics.chain.from_dh` takes them. `offset` is added to the
    joint angle (the manufacturer's zero against the DH zero). `mount` is a fixed DH row
    `(d, a, alpha, theta)` of the same convention before joint 1 (Kinova's "base to frame 1"),
    `flange` one after the last joint (Franka's flange row). `limits` are per joint
    `(lo, hi)` in `limit_unit` as published, `None` for a continuous joint.

    A table that cannot describe an arm (no rows, a row that is not four finite numbers, limits
    that do not match the rows one per joint, an unknown convention or unit, no source) is a
    `ValueError` naming the table and what is wrong, when it is made.
    """

    name: str
    title: str
    convention: str  # "standard" (distal, Corke) or "modified" (Craig)
    rows: tuple
    limits: tuple
    limit_unit: str  # "deg" or "rad"
    source: str
    mount: tuple | None = None
    flange: tuple | None = None

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name or self.name != self.name.lower() or any(
                c.isspace() for c in self.name):
            raise ValueError(f"arm table name must be a non-empty lower-case word (load() looks names up in "
                             f"lower case), got {self.name!r}")
        what = f"arm table {self.name!r}"
        if self.convention not in CONVENTIONS:
            raise ValueError(f"{what}: convention must be one of {', '.join(CONVENTIONS)}, got {self.convention!r}")
        if self.limit_unit not in LIMIT_UNITS:
            raise ValueError(f"{what}: limit_unit must be one of {', '.join(LIMIT_UNITS)}, got {self.limit_unit!r}")
        if not isinstance(self.source, str) or not self.source.strip():
            raise ValueError(f"{what} has no source: name the document its numbers come from")
        if not isinstance(self.rows, tuple) or not self.rows:
            raise ValueError(f"{what}: rows must be a non-empty tuple of (d, a, alpha, offset), one per joint")
        for i, row in enumerate(self.rows, 1):
            if not isinstance(row, tuple) or len(row) != 4 or not all(_is_number(x) for x in row):
                raise ValueError(f"{what}: row {i} must be four finite numbers (d, a, alpha, offset), got {row!r}")
        for label, row in (("mount", self.mount), ("flange", self.flange)):
            if row is not None and (not isinstance(row, tuple) or len(row) != 4
                                    or not all(_is_number(x) for x in row)):
                raise ValueError(f"{what}: {label} must be None or four finite numbers (d, a, alpha, theta), "
                                 f"got {row!r}")
        if not isinstance(self.limits, tuple) or len(self.limits) != len(self.rows):
            got = len(self.limits) if isinstance(self.limits, tuple) else type(self.limits).__name__
            raise ValueError(f"{what} has {len(self.rows)} rows (joints) but {got} limits: give one (lo, hi) or "
                             "None (continuous) per joint")
        for i, lim in enumerate(self.limits, 1):
            if lim is None:
                continue
            if (not isinstance(lim, tuple) or len(lim) != 2 or not all(_is_number(x) for x in lim)
                    or not lim[0] < lim[1]):
                raise ValueError(f"{what}: limits of joint {i} must be None (continuous) or (lo, hi) with "
                                 f"lo < hi, got {lim!r}")

    @property
    def n(self) -> int:
        return len(self.rows)

    @property
    def qlim(self) -> np.ndarray:
        """`(n, 2)` limits in radians, `±inf` for continuous joints."""
        lim = np.array([(-np.inf, np.inf) if x is None else x for x in self.limits], dtype=np.float64)
        return np.deg2rad(lim) if self.limit_unit == "deg" else lim

    def row_transform(self, row: Sequence[float]) -> np.ndarray:
        """The 4x4 transform of one fixed DH row `(d, a, alpha, theta)` in this table's convention."""
        d, a, alpha, theta = (float(x) for x in row)
        ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
        Rz = np.array([[ct, -st, 0, 0], [st, ct, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])
        Rx = np.array([[1, 0, 0, 0], [0, ca, -sa, 0], [0, sa, ca, 0], [0, 0, 0, 1.0]])
        Tz, Tx = np.eye(4), np.eye(4)
        Tz[2, 3], Tx[0, 3] = d, a
        return Rz @ Tz @ Tx @ Rx if self.convention == "standard" else Rx @ Tx @ Rz @ Tz

    def chain(self, joint_limits: bool = True, *, d: ArrayLike | None = None, a: ArrayLike | None = None,
              name: str | None = None) -> SerialChain:
        """The arm as a `SerialChain` (base frame → tool flange).

        `d` and `a` (`(..., n)`, metres) replace the table's columns of those names (a batch
        of arms with the table's twists, offsets, mount, flange and limits: an arm family, see
        `wsmap.robots.family_arm`); `name` replaces the table's name.
        """
        d0, a0, alpha, offset = np.array(self.rows, dtype=np.float64).T
        d = d0 if d is None else d
        a = a0 if a is None else a
        flange = None if self.flange is None else self.row_transform(self.flange)
        arm = from_dh(d, a, alpha, offset=offset, qlim=self.qlim if joint_limits else None,
                      modified=self.convention == "modified", flange=flange, name=name or self.name,
                      source=self.source)
        if self.mount is not None:
            fixed = arm.fixed.copy()
            fixed[..., 0, :, :] = self.row_transform(self.mount) @ fixed[..., 0, :, :]
            arm = arm.replace(fixed=fixed)
        return arm


@dataclass(frozen=True)
class ArmCapsules:
    """A named arm's capsule collision model, as numbers (`wsmap.collision.named` builds the
    `CollisionModel` from them, standing on the floor `z = 0` of the arm's base frame).

    Either `radii` (metres, one per body `0..n`): a capsule along each DH link of the chain it
    is given (`wsmap.collision.capsules_along_links`), so on an arm with other lengths (a family
    of `wsmap.robots.families`) the capsules follow its links; or `capsules`: `(body, p0, p1,
    radius)` per capsule (metres, the body's frame of the arm's chain;
    `wsmap.collision.capsule_model`) with the links' `names` per body, fixed numbers that do not
    follow other lengths. `source` says where the numbers come from (the model's `source`).
    """

    source: str
    radii: tuple[float, ...] | None = None
    capsules: tuple[tuple[int, tuple[float, float, float], tuple[float, float, float], float], ...] | None = None
    names: tuple[str, ...] | None = None

    def __post_init__(self):
        if not isinstance(self.source, str) or not self.source.strip():
            raise ValueError("a capsule model needs a source: name the drawing or document its numbers come from")
        if (self.radii is None) == (self.capsules is None):
            raise ValueError("a capsule model has either radii (along the links) or capsules (fixed), not "
                             f"{'both' if self.radii is not None else 'neither'}")

    @property
    def along_links(self) -> bool:
        """Whether the capsules follow the links of the chain they are built on."""
        return self.radii is not None


@dataclass(frozen=True)
class NamedArm:
    """One named arm's record in `ARMS`.

    `build(joint_limits)` makes the arm (`None`: its default limits); `source` names the document
    its numbers come from; `table` is its `ArmTable` (`None` for the paper's `puma560`);
    `capsules` its capsule collision model (`None`: none); `held_out` whether the morphology
    families (`wsmap.robots.morph`) never draw an arm near it. `priority` is its place in the
    order the arms are listed in (lower first).
    """

    name: str
    priority: int
    build: Callable[..., DHRobot | SerialChain]
    source: str
    table: ArmTable | None = None
    capsules: ArmCapsules | None = None
    held_out: bool = False


#: Every named arm, listed by `(priority, name)`: the paper's `puma560` first, then the real arms.
ARMS: Registry[NamedArm] = Registry("named arm")


class _ArmView(Mapping):
    """A read-only mapping `name -> field` of the arms of `ARMS` (those with the field set), in its order."""

    def __init__(self, field: str) -> None:
        self._field = field

    def _value(self, name: object) -> Any:
        if not isinstance(name, str) or name not in ARMS:
            return None
        return getattr(ARMS.get(name), self._field)

    def __getitem__(self, name: str) -> Any:
        value = self._value(name)
        if value is None:
            raise KeyError(name)
        return value

    def __contains__(self, name: object) -> bool:
        return self._value(name) is not None

    def __iter__(self) -> Iterator[str]:
        return iter([arm.name for arm in ARMS if getattr(arm, self._field) is not None])

    def __len__(self) -> int:
        return sum(1 for _ in self)

    def __repr__(self) -> str:
        return f"{{{', '.join(f'{k!r}: {v!r}' for k, v in self.items())}}}"


#: The real arms' tables by name, each from its manufacturer's published kinematics.
NAMED: Mapping[str, ArmTable] = _ArmView("table")
#: Constructors of every named arm, `name -> f(joint_limits=None)`, in the order of `ARMS`.
ROBOTS: Mapping[str, Callable[..., DHRobot | SerialChain]] = _ArmView("build")
#: The document each named arm's numbers come from, `name -> str`.
SOURCES: Mapping[str, str] = _ArmView("source")


def register_constructor(name: str, constructor: Callable[..., Any], source: str, *, priority: int,
                         capsules: ArmCapsules | None = None, held_out: bool = False,
                         table: ArmTable | None = None) -> NamedArm:
    """Make `load(name)` call `constructor(joint_limits=...)` (`None`: the arm's default).

    For an arm that is not an `ArmTable` (the paper's `puma560`); a table registers with
    `register`. Nothing is registered when an argument is refused.

    Parameters
    ----------
    name : str
        The arm's name, lower case (`load` looks names up in lower case).
    constructor : callable
        `constructor(joint_limits=None | True | False)` -> the arm (`DHRobot` or `SerialChain`).
    source : str
        The document the arm's numbers come from.
    priority : int
        The arm's place in the order of `ARMS` (lower first; today's arms use 10, 20, ... 60).
    capsules : ArmCapsules, optional
        Its capsule collision model (`wsmap.collision.arm_model`); `None`: none.
    held_out : bool
        Whether the morphology families never draw an arm near it (`wsmap.robots.morph.HELD_OUT`).
    table : ArmTable, optional
        Its published table (`register` passes it).

    Returns
    -------
    NamedArm
        The record registered.

    Raises
    ------
    ValueError
        A name already registered or not lower case, a constructor that is not callable, an empty
        source, a priority that is not an int, `capsules` not an `ArmCapsules`, `held_out` not a bool.
    """
    if not isinstance(name, str) or not name or name != name.lower():
        raise ValueError(f"a named arm's name must be a non-empty lower-case string, got {name!r}")
    if name in ARMS:
        raise ValueError(f"a robot named {name!r} is already registered; known robots: {', '.join(ROBOTS)}")
    if not callable(constructor):
        raise ValueError(f"the constructor of robot {name!r} must be callable, got {type(constructor).__name__}")
    if not isinstance(source, str) or not source.strip():
        raise ValueError(f"robot {name!r} has no source: name the document its numbers come from")
    if capsules is not None and not isinstance(capsules, ArmCapsules):
        raise ValueError(f"robot {name!r}: capsules must be an ArmCapsules or None, got {type(capsules).__name__}")
    if not isinstance(held_out, bool):
        raise ValueError(f"robot {name!r}: held_out must be True or False, got {held_out!r}")
    return ARMS.register(NamedArm(name=name, priority=priority, build=constructor, source=source, table=table,
                                  capsules=capsules, held_out=held_out))


def _named(table: ArmTable) -> Callable[..., SerialChain]:
    def make(joint_limits: bool | None = None) -> SerialChain:
        return table.chain(joint_limits=True if joint_limits is None else bool(joint_limits))

    make.__name__ = table.name
    make.__doc__ = f"The {table.title} (base → tool flange). Source: {table.source}."
    return make


def register(table: ArmTable, *, priority: int, capsules: ArmCapsules | None = None,
             held_out: bool = False) -> ArmTable:
    """Register a real arm's published table: `NAMED[table.name]` and `load(table.name)`
    (a `SerialChain` with the table's joint limits by default).

    Parameters
    ----------
    table : ArmTable
        The arm's published kinematics (checked when it is made).
    priority : int
        The arm's place in the order of `ARMS` (lower first).
    capsules : ArmCapsules, optional
        Its capsule collision model; `None`: none.
    held_out : bool
        Whether the morphology families hold it out.

    Returns
    -------
    ArmTable
        `table`.

    Raises
    ------
    TypeError
        `table` is not an `ArmTable`.
    ValueError
        As `register_constructor` (a name already registered lists the known ones).
    """
    if not isinstance(table, ArmTable):
        raise TypeError(f"register() takes an ArmTable, got {type(table).__name__}")
    register_constructor(table.name, _named(table), table.source, priority=priority, capsules=capsules,
                         held_out=held_out, table=table)
    return table


def load(name: str, joint_limits: bool | None = None) -> DHRobot | SerialChain:
    """A named arm of `ROBOTS` (`wsmap robots` lists them): `puma560` (the paper's
    `DHRobot`, d1 = 0) and the real arms of `wsmap.robots.arms` (`panda`, `iiwa14`,
    `ur5e`, `ur10e`, `gen3`: `SerialChain`).

    `joint_limits` `None` is the arm's default: the manufacturer's limits for a real arm, none
    for `puma560` (as the paper). `True`/`False` attach or drop them (anything else is a
    `ValueError`: `"no"` would read as true). The robot has `.n`,
    `.qlim` (`(n, 2)` rad, `±inf` for a continuous joint, `None` when unlimited) and
    `.fkine(q)` (base → flange). An unknown name is a `ValueError` listing the known ones.
    """
    key = str(name).lower()
    if key not in ARMS:
        raise ValueError(f"unknown robot {name!r}; known robots: {', '.join(ROBOTS)}")
    if joint_limits is not None and not isinstance(joint_limits, (bool, np.bool_)):
        # a string such as "no" is truthy: it would turn the limits on
        raise ValueError(f"joint_limits must be True, False or None (the arm's default), got {joint_limits!r}")
    return ARMS.get(key).build(joint_limits=None if joint_limits is None else bool(joint_limits))


def from_name(name: str, joint_limits: bool | None = None) -> DHRobot | SerialChain:
    """Look up a named arm: `load`."""
    return load(name, joint_limits=joint_limits)
