"""`SearchSettings`: the numerical inverse-kinematics settings of a map, one typed record.

A map, a reach map, an index, a base placement or a dataset label computed numerically is fixed by
its arm, its targets and these settings: which numerical solver runs (`solver`) and every number
it reads. They travel as one frozen object from whoever builds the job (the command line, a
`wsmap.workspace.kinds.MapRequest`, a Python caller) to the solver
(`wsmap.kinematics.ik.solvers`), and `SearchSettings.digest` is their stable hash (what a map
file's provenance and a cache key record).

Solvers (`solver`):

* `"search"` (default): the search started at each node from its neighbours' solutions
  (`wsmap.kinematics.ik.search.map_search`), defaults `MAP_SETTINGS`;
* `"independent"`: every target alone with `wsmap.kinematics.ik.search.ikine_search`
  (`starts` default `DEFAULT_STARTS`, per start `DEFAULT_ILIMIT` iterations and
  `DEFAULT_RLIMIT` rejections);
* `"paper"`: the paper's one-start LM from `q0` (`wsmap.kinematics.ik.lm.ikine_LM`, DH arms, its
  defaults 500 iterations and 100 rejections), which the paper's pipeline runs.

A field left `None` takes its solver's default when the record is built, so two records that
run the same search are equal and hash alike. A field the solver does not read stays `None`
(setting it is a `ValueError`), except `seed` and `starts` of the paper's solver, which the maps
have always accepted and dropped (`starts` must then be 1) and `chunk` of the search, which
splits no work there.

The kernels' own settings (`wsmap.kinematics.lm_compiled.LMSettings`) that no field of the
record drives travel by name in `kernel` (`SearchSettings(kernel={"name": value})`): a new LM
setting is a field of `LMSettings` with its default and its use in the two kernels
(`lm_compiled.py`, `_lanes/lanes.hpp`), and reaches every map through `kernel` with no edit here
or in the solvers. An empty `kernel` is left out of `to_dict` and the digest, so the settings
of every map made before it hash as they did.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..lm_compiled import SETTING_TYPES, LMSettings
from .solution import MIN_TOL
from .solver import SOLVERS

__all__ = ["MAP_SETTINGS", "DEFAULT_STARTS", "DEFAULT_ILIMIT", "DEFAULT_RLIMIT", "FK_CONFIRM_TOL", "KERNEL_FIELDS",
           "SearchSettings", "as_settings", "check_kernel_settings"]

#: Starts per target of `ikine_search`, the maps' numerical path and `reachable`. Measured
#: with `benchmarks/maps/bench_recall.py` (21³ grid; PUMA560 with and without limits against the closed
#: form, UR5e against EAIK; R = I and tool down): the hardest case, PUMA560 with limits, needs 24
#: starts for recall >= 0.999 at seed 0 but 32 at seed 1 (24: 0.9986); 32 starts missed no node in
#: any case at seeds 0-4. No false positive at any count.
DEFAULT_STARTS = 32

#: Per-start iteration and consecutive-rejection limits. The paper's 500 and 100 spend most of a
#: failing start on rejections (a start that fails, fails slowly); 100 and 20 gave the same recall
#: at every count of starts in `benchmarks/maps/bench_recall.py` (so did 60 and 10) at about half the time.
DEFAULT_ILIMIT = 100
DEFAULT_RLIMIT = 20

#: Tolerance of the forward-kinematics confirmation of every success (m and rad).
FK_CONFIRM_TOL = 1e-6

#: Defaults of `map_search` for the maps, measured with `benchmarks/maps/bench_fast_maps.py`
#: (recall against the closed forms and a 64-start reference on the 21³ grid for PUMA560 with and
#: without limits, UR5e, Panda, iiwa14, Gen3): start 0 only in the first pass (a neighbour's solution
#: is a better start than a random one), two seeds per wave, four random retries next to solved
#: nodes; per start 60 iterations and 10 rejections, and the stationary-point test at 1e-4, which
#: cut the iterations spent on unreachable nodes by about half without a missed node; a neighbour's
#: solution is not rerun without the limits (the Panda index: 13 % less time, the same recall); a
#: hole in a solved region gets 16 retries (the iiwa14 from its URDF, tool down, missed 3 of 1768
#: nodes near its axis with 4). Last, every unsolved node that borders a solved one gets the search of
#: `ikine_search` (`border_starts` = `DEFAULT_STARTS` starts, its iteration settings), after the
#: solutions of its solved neighbours: recall at the edge of the reachable region by construction, not by
#: tuning (YuMi's right arm, tool down, missed 5 of 2826 border nodes without it; `docs/recall.md`).
#: Global seeding (`fk_seeds` = 1 sample per node) gives the nodes no solved node borders their own
#: starts (PUMA560s with random limit windows: 215 of 19155 nodes missed without it, none with it;
#: `benchmarks/maps/bench_recall_islands.py`, `docs/recall.md`).
MAP_SETTINGS = dict(starts=0, seeds=2, retry=4, hole_retry=16, ilimit=60, rlimit=10, gtol=1e-4, seed_free_pass=False,
                    border_starts=DEFAULT_STARTS, fk_seeds=1)

_COUNTS = {"starts": 0, "seeds": 0, "retry": 0, "hole_retry": 0, "border_starts": 0, "fk_seeds": 0, "accept_retry": 0,
           "ilimit": 0, "rlimit": 0, "chunk": 1}
_FLAGS = ("joint_limits", "seed_free_pass", "limit_bound", "position_only")

#: The `LMSettings` fields that a search sets from the record's own fields or per call (the
#: mode, the range of starts, the per-start limits, the tolerances, the free pass).
_DRIVEN = frozenset({"mode", "k_first", "k_last", "ilimit", "rlimit", "tol", "lam0", "gtol", "confirm_tol", "free_pass"})

#: The `LMSettings` fields that `SearchSettings.kernel` may set by name: every other field.
KERNEL_FIELDS = tuple(f for f in LMSettings._fields if f not in _DRIVEN)


@dataclass(frozen=True)
class SearchSettings:
    """The settings of a numerical map search (see the module notes).

    Attributes
    ----------
    solver : str
        `"search"` (default), `"independent"`, `"paper"`, or another numerical solver registered in
        `wsmap.kinematics.ik.solvers`.
    starts : int
        Random starts per node after start 0 (`"search"`: in the first pass, default 0;
        `"independent"`: starts in all, default `DEFAULT_STARTS`; `"paper"`: 1).
    seeds : int
        The search's neighbours' solutions tried per node and wave.
    retry : int
        Random starts per node for the nodes still unsolved when no wave solves any more and next to
        a solved node, after which the waves run again from what they found.
    hole_retry : int
        The random starts instead for such a node with at least half of its neighbours solved (a
        hole in a reachable region is most likely reachable).
    border_starts : int
        The starts of `ikine_search` (`q0`, then its random starts `1 .. border_starts - 1`,
        with its per-start settings `DEFAULT_ILIMIT`, `DEFAULT_RLIMIT`, no stationary-point
        test, both passes) that every node still unsolved next to a solved node gets once, after
        the solutions of its solved neighbours that the waves did not try; 0 turns the border
        search off.
    fk_seeds : int
        Global seeding (`wsmap.kinematics.ik.fk_seeds`): configurations sampled per node of the
        map and arm (`sample_count`: at least 1024, rounded up to a power of two), whose forward
        kinematics gives every node left unsolved by the first pass and its waves the
        configuration of the sampled pose nearest its own as a start, so that regions no solved
        node borders are searched too; 0 turns it off.
    accept_retry : int
        More random starts (in rounds of 4, each followed by waves) for the nodes whose solutions
        the search's `accept` predicate all refused.
    seed : int
        Seed of the random starts (>= 0, below 2**64; default 0).
    q0 : tuple of float or None
        Start 0 (rad or m per joint; None: zeros).
    tol : float
        Tolerance on the error norm per start (m and rad), at least `MIN_TOL`.
    ilimit, rlimit : int
        Per start: iteration limit and consecutive-rejection limit.
    lam : float
        Initial LM damping.
    gtol : float
        The search's stationary-point test (`wsmap.kinematics.lm_compiled`): a start fails once
        the gradient vanishes relative to `|J|·|e|` away from a solution; 0 turns it off.
    confirm_tol : float
        Forward-kinematics confirmation tolerance (m and rad), at least `tol`.
    joint_limits : bool
        Honour the arm's revolute limits (False drops them; prismatic strokes stay).
    seed_free_pass : bool
        Whether a neighbour's solution that fails inside the limits is also run without them (the
        second pass of `ikine_search`'s starts).
    limit_bound : bool
        Whether the joint-limit bound (`wsmap.kinematics.ik.reach_filter.limit_filter`) also
        rules out nodes before any start (one arm of revolute joints, a pose target): sound, so it
        changes no success and no solution, only the time and, at the nodes it rules out,
        `reason`, `q`, `residual` and `iterations`; False is the reference path. A batch of arms
        skips it (each arm would pay its build).
    position_only : bool
        Reach the position of each target at any orientation (the error and the confirmation on
        the position alone).
    chunk : int or None
        Targets per call of the `"independent"` and `"paper"` solvers (None: their default;
        the result does not depend on it).
    kernel : mapping of str to number, or tuple of (str, value) pairs
        Fields of `wsmap.kinematics.lm_compiled.LMSettings` outside those the record drives
        (`KERNEL_FIELDS`), by name, each cast to its field's type; stored as sorted pairs (so the
        record stays hashable). Read by `"search"` and `"independent"`; empty by default (every
        field at its `LMSettings` default).
    """

    solver: str = "search"
    starts: int | None = None
    seeds: int | None = None
    retry: int | None = None
    hole_retry: int | None = None
    border_starts: int | None = None
    fk_seeds: int | None = None
    accept_retry: int | None = None
    seed: int | None = None
    q0: tuple | None = None
    tol: float | None = None
    ilimit: int | None = None
    rlimit: int | None = None
    lam: float | None = None
    gtol: float | None = None
    confirm_tol: float | None = None
    joint_limits: bool | None = None
    seed_free_pass: bool | None = None
    limit_bound: bool | None = None
    position_only: bool | None = None
    chunk: int | None = None
    kernel: Mapping | tuple | None = None

    def __post_init__(self):
        solver = _numerical_solver(self.solver)
        solver.check_given({f.name: getattr(self, f.name) for f in dataclasses.fields(self)})
        defaults, dropped = solver.defaults, solver.dropped
        for f in dataclasses.fields(self):
            name, value = f.name, getattr(self, f.name)
            if name == "solver":
                continue
            if name == "kernel" and isinstance(value, (Mapping, tuple, list)) and not value:
                value = None  # no kernel setting: as not given, for every solver
            if name in dropped:
                value = None
            elif name not in defaults:
                if value is not None:
                    raise ValueError(f"solver {self.solver!r} takes no {name} (it reads "
                                     f"{', '.join(sorted(defaults))})")
            elif value is None:
                value = defaults[name]
            object.__setattr__(self, name, _checked(name, value))
        self._check_tolerances()

    def _check_tolerances(self):
        if self.tol < MIN_TOL:
            raise ValueError(f"tol must be at least {MIN_TOL:g} (float64 forward kinematics is exact to about 1e-16 "
                             f"per metre, so no pose meets a smaller one), got {self.tol!r}")
        if self.confirm_tol is not None and self.confirm_tol < self.tol:
            raise ValueError(f"confirm_tol ({self.confirm_tol}) must be at least tol ({self.tol})")

    @classmethod
    def from_dict(cls, ik: Mapping | None = None, base: Mapping | None = None) -> SearchSettings:
        """The settings of an `ik` dict (the maps' `ik=` argument, a map file's record): `base`
        (e.g. `MAP_SETTINGS`, a kind's defaults) updated with `ik`; a key that is not a field is
        a `ValueError` naming the fields."""
        merged = {**(base or {}), **(ik or {})}
        known = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(k for k in merged if k not in known)
        if unknown:
            raise ValueError(f"unknown IK setting(s) {', '.join(map(repr, unknown))}; settings: "
                             f"{', '.join(sorted(known))}")
        return cls(**merged)

    def to_dict(self) -> dict:
        """The fields the solver reads, as plain JSON values (`q0` a list)."""
        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        reads = _numerical_solver(self.solver).defaults
        out = {k: v for k, v in out.items() if v is not None or k in reads}
        if out.get("kernel") is not None:
            out["kernel"] = dict(out["kernel"])
        if not out.get("kernel"):  # left out when empty, so older settings keep their digest
            out.pop("kernel", None)
        if out.get("q0") is not None:
            out["q0"] = list(out["q0"])
        return out

    def replace(self, **changes) -> SearchSettings:
        """A copy with `changes` (field names; checked as at construction)."""
        current = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        if "solver" in changes and changes["solver"] != self.solver:
            current = {"solver": changes["solver"]}  # the other solver's defaults, not this one's values
        return SearchSettings(**{**current, **changes})

    def digest(self) -> str:
        """The settings hash: SHA-256 (hex) of the fields as canonical JSON (equal settings, equal
        digest, in any process)."""
        text = json.dumps(self.to_dict(), sort_keys=True, separators=(",", ":"), default=repr)
        return hashlib.sha256(text.encode()).hexdigest()

    @property
    def q0_array(self) -> np.ndarray | None:
        """`q0` as a float64 array `(n,)`, or None."""
        return None if self.q0 is None else np.asarray(self.q0, dtype=np.float64)


def _numerical_solver(name):
    """The registered numerical solver `name` (`wsmap.kinematics.ik.solvers`), or a `ValueError`."""
    if not isinstance(name, str) or name not in SOLVERS or not SOLVERS.get(name).numerical:
        known = [s.name for s in SOLVERS.records() if s.numerical]
        raise ValueError(f"unknown solver {name!r}; choose one of {', '.join(known)}")
    return SOLVERS.get(name)


def _checked(name, value):
    if value is None:
        return None
    if name in _COUNTS:
        return integer_setting(name, value, _COUNTS[name])
    if name in _FLAGS:
        if not isinstance(value, (bool, np.bool_)):
            raise ValueError(f"{name} must be True or False, got {value!r}")
        return bool(value)
    if name == "seed":
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not 0 <= value < 2**64:
            raise ValueError(f"seed must be a non-negative integer below 2**64, got {value!r}")
        return int(value)
    if name == "q0":
        q = np.asarray(value, dtype=np.float64)
        if q.ndim != 1 or not np.all(np.isfinite(q)):
            raise ValueError(f"q0 must be a finite joint vector (n,), got {value!r}")
        return tuple(float(v) for v in q)
    if name == "kernel":
        return check_kernel_settings(value)
    return _positive(name, value, allow_zero=name == "gtol")


def check_kernel_settings(value) -> tuple:
    """`value` (a mapping, or pairs as `SearchSettings.kernel` stores them) as sorted `(name,
    value)` pairs of `KERNEL_FIELDS`, each cast to its `LMSettings` type and checked finite.

    Raises
    ------
    ValueError
        A name outside `KERNEL_FIELDS`, a name given twice, or a value of the wrong kind.
    """
    pairs = value.items() if isinstance(value, Mapping) else value
    try:
        pairs = [(k, v) for k, v in pairs]
    except (TypeError, ValueError):
        raise ValueError(f"kernel must map LM setting names to values, got {value!r}") from None
    names = [k for k, _ in pairs]
    unknown = sorted({str(k) for k in names if k not in KERNEL_FIELDS})
    if unknown:
        allowed = ", ".join(KERNEL_FIELDS) or "none (every field of LMSettings is set by SearchSettings' own fields)"
        raise ValueError(f"unknown kernel setting(s) {', '.join(unknown)}; the kernels' own settings: {allowed}")
    if len(set(names)) != len(names):
        raise ValueError(f"kernel names a setting twice: {names}")
    out = []
    for name, v in sorted(pairs):
        kind = SETTING_TYPES[name]
        if kind is bool:
            if not isinstance(v, (bool, np.bool_)):
                raise ValueError(f"kernel setting {name} must be True or False, got {v!r}")
        elif isinstance(v, bool) or not (np.isscalar(v) and np.isreal(v) and math.isfinite(v)) or \
                (kind is int and int(v) != v):
            raise ValueError(f"kernel setting {name} must be a finite {kind.__name__}, got {v!r}")
        out.append((name, kind(v)))
    return tuple(out)


def integer_setting(name: str, v, minimum: int) -> int:
    """`v` as an int, or a `ValueError` naming `name` unless `v` is a finite integral real `>= minimum`
    (bools refused: `True` is no count)."""
    try:
        ok = not isinstance(v, bool) and np.isscalar(v) and np.isreal(v) and np.isfinite(v) and int(v) == v
    except (TypeError, ValueError, OverflowError):
        ok = False
    if not ok or v < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {v!r}")
    return int(v)


def _positive(name, v, allow_zero=False):
    if isinstance(v, bool) or not (np.isscalar(v) and np.isreal(v) and math.isfinite(v) and
                                   (v > 0 or (allow_zero and v == 0))):
        raise ValueError(f"{name} must be {'non-negative' if allow_zero else 'positive'} and finite, got {v!r}")
    return float(v)


def as_settings(ik: SearchSettings | Mapping | None, base: Mapping | None = None) -> SearchSettings:
    """`ik` as `SearchSettings`: itself when it is one, else `SearchSettings.from_dict(ik, base)`."""
    if isinstance(ik, SearchSettings):
        return ik
    if ik is not None and not isinstance(ik, Mapping):
        raise ValueError(f"IK settings must be a SearchSettings or a dict, got {type(ik).__name__}")
    return SearchSettings.from_dict(ik, base)
