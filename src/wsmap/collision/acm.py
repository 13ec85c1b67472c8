"""The allowed-collision matrix: which link pairs of an arm are never checked, and why.

Built as MoveIt's setup assistant builds it (`build_acm`): a pair is disabled when its links

* `"rigid"`: ride on the same body (their relative pose never changes);
* `"adjacent"`: are parent and child in the link tree (the nearest links with geometry above
  one another; they meet at their joint);
* `"default"`: are in contact at the default configuration (`q = 0` clipped into the limits);
* `"never"`: never collide over `samples` random configurations drawn uniformly inside the
  limits (seeded by `seed`; MoveIt's default is 10000 as well). This is a sampling heuristic: a
  pair that collides only in a sliver of the joint space can be missed, as in MoveIt;
* `"srdf"`: a MoveIt SRDF's `<disable_collisions>` disables it (`srdf=`,
  `wsmap.collision.srdf`); disabled before the sampling, which then skips it;
* `"user"`: the caller disabled it (`disable=`).

Every other pair is checked. The matrix is stored with the model
(`CollisionModel.acm`) and written into map files (`ACM.describe`).
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

import numpy as np

from .errors import CollisionError
from .fields import shown
from .geometry import CollisionModel

__all__ = ["REASONS", "ACM", "build_acm", "DEFAULT_SAMPLES", "MAX_SAMPLES"]

REASONS = ("rigid", "adjacent", "default", "never", "srdf", "user")
#: Random configurations of the "never in collision" test (MoveIt's default).
DEFAULT_SAMPLES = 10000
#: The most of them: 100 times MoveIt's default, minutes of coal tests for an arm of meshes (10^11
#: would run for days).
MAX_SAMPLES = 1_000_000


@dataclass(eq=False)
class ACM:
    """Link names `names` and the disabled pairs `disabled`: `{(a, b): reason}` with
    `a < b` link indices; `samples` and `seed` of the "never" test."""

    names: tuple
    disabled: dict = field(default_factory=dict)
    samples: int = 0
    seed: int = 0

    def enabled_pairs(self) -> list[tuple[int, int]]:
        """Link index pairs `(a, b)`, `a < b`, that are checked."""
        n = len(self.names)
        return [(a, b) for a in range(n) for b in range(a + 1, n) if (a, b) not in self.disabled]

    def allowed(self, a: str, b: str) -> bool:
        """Whether links `a` and `b` may touch (the pair is disabled)."""
        i, j = sorted((self._index(a), self._index(b)))
        return (i, j) in self.disabled

    def reason(self, a: str, b: str) -> str | None:
        i, j = sorted((self._index(a), self._index(b)))
        return self.disabled.get((i, j))

    def _index(self, name) -> int:
        if name not in self.names:
            raise CollisionError(f"allowed-collision matrix: unknown link {name!r}; the links are: "
                                 f"{', '.join(self.names)}")
        return self.names.index(name)

    def describe(self) -> dict:
        """A JSON-able record: the links, each disabled pair with its reason, the sampling."""
        return {"links": list(self.names), "samples": self.samples, "seed": self.seed,
                "disabled": [[self.names[a], self.names[b], r] for (a, b), r in sorted(self.disabled.items())],
                "enabled": [[self.names[a], self.names[b]] for a, b in self.enabled_pairs()]}


def _user_pairs(model: CollisionModel, disable) -> list[tuple[int, int]]:
    out = []
    for item in disable:
        if isinstance(item, str) or not isinstance(item, Iterable) or len(tuple(item)) != 2:
            raise CollisionError(f"allowed-collision matrix: disable takes pairs of link names, got {shown(item)}")
        a, b = tuple(item)
        for x in (a, b):
            if x not in model.names:
                raise CollisionError(f"allowed-collision matrix: unknown link {x!r}; the links are: "
                                     f"{', '.join(model.names)}")
        if a == b:
            raise CollisionError(f"allowed-collision matrix: a pair of two different links, got ({a!r}, {b!r})")
        out.append(tuple(sorted((model.index(a), model.index(b)))))
    return out


def _srdf_pairs(model: CollisionModel, srdf) -> list[tuple[int, int]]:
    from .srdf import Srdf, load_srdf

    if not isinstance(srdf, Srdf):  # a file: its links checked against the model's URDF when it is one
        source = model.source
        urdf = source if isinstance(source, str) and source.lower().endswith(".urdf") and os.path.isfile(source) else None
        srdf = load_srdf(srdf, urdf=urdf)
    return [tuple(sorted((model.index(a), model.index(b)))) for a, b in srdf.disabled_pairs(model.names)]


def _structural(links) -> dict:
    """The "rigid" and "adjacent" pairs of `links` (module notes)."""
    disabled: dict = {}
    for a in range(len(links)):
        for b in range(a + 1, len(links)):
            if links[a].body == links[b].body:
                disabled[(a, b)] = "rigid"
            elif links[a].parent == links[b].name or links[b].parent == links[a].name:
                disabled[(a, b)] = "adjacent"
    return disabled


def build_acm(model: CollisionModel, *, samples: int = DEFAULT_SAMPLES, seed: int = 0, disable=(),
              default_q=None, srdf=None) -> ACM:
    """The allowed-collision matrix of `model` (module notes); `disable` more pairs of link
    names (an unknown name is a `CollisionError` listing the links, before any work);
    `default_q` `(n,)` the default configuration (default `0` clipped into the limits); `srdf` a
    MoveIt SRDF (a `wsmap.collision.srdf.Srdf`, or its file: links checked against the model's
    URDF file) whose `<disable_collisions>` pairs of the model's links are disabled too."""
    from .checks import exact_pairs

    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or not 0 <= samples <= MAX_SAMPLES:
        raise CollisionError(f"samples must be a whole number from 0 to {MAX_SAMPLES}, got {samples!r}")
    user = _user_pairs(model, disable)
    from_srdf = [] if srdf is None else _srdf_pairs(model, srdf)
    chain = model.chain
    n = len(model.links)
    disabled = _structural(model.links)
    for p in from_srdf:  # before the default and sampled tests: MoveIt's own answer, no need to test it
        disabled.setdefault(p, "srdf")
    q0 = np.zeros(chain.n) if default_q is None else np.asarray(default_q, dtype=np.float64)
    if q0.shape != (chain.n,):
        raise CollisionError(f"default_q must have shape ({chain.n},), got {q0.shape}")
    q0 = np.clip(q0, chain.limits[:, 0], chain.limits[:, 1])
    todo = [p for p in ((a, b) for a in range(n) for b in range(a + 1, n)) if p not in disabled]
    if todo:
        hit = exact_pairs(model, todo, q0[None])[0]
        for p, h in zip(todo, hit):
            if h:
                disabled[p] = "default"
    todo = [p for p in todo if p not in disabled]
    if samples and todo:
        rng = np.random.default_rng(seed)
        seen = np.zeros(len(todo), dtype=bool)
        left = samples
        while left > 0 and not seen.all():
            m = min(left, 1000)
            q = chain.random_q(m, rng)
            live = np.flatnonzero(~seen)
            seen[live] |= exact_pairs(model, [todo[i] for i in live], q).any(axis=0)
            left -= m
        for p, s in zip(todo, seen):
            if not s:
                disabled[p] = "never"
    for p in user:
        disabled.setdefault(p, "user")
    return ACM(model.names, disabled, samples=int(samples), seed=int(seed))


def acm_from_record(model: CollisionModel, record: Mapping) -> ACM:
    """An `ACM` back from `ACM.describe`'s record (a map file), checked against
    `model`'s links."""
    names = tuple(record.get("links", ()))
    if names != model.names:
        raise CollisionError(f"allowed-collision matrix names the links {', '.join(map(str, names)) or 'none'}; the "
                             f"model has {', '.join(model.names)}")
    disabled = {}
    for a, b, r in record.get("disabled", ()):
        if r not in REASONS:
            raise CollisionError(f"allowed-collision matrix: unknown reason {r!r}; reasons are {', '.join(REASONS)}")
        disabled[tuple(sorted((model.index(a), model.index(b))))] = r
    return ACM(names, disabled, samples=int(record.get("samples", 0)), seed=int(record.get("seed", 0)))
