"""Collision-aware labels: the `collision` field of a `DatasetSpec`.

A chain family's labels (`panda7`: the numerical map search, `wsmap.datasets.labels`) can
count a node only when the search finds a joint solution that is inside the limits, confirmed by
forward kinematics **and collision-free** (`wsmap.collision`): `collision=` is passed to the
map functions, one `CollisionChecker` per arm. The settings
(`LabelCollision`) are plain data in the spec (`to_dict` / `from_dict`, YAML), so they
are part of the spec's identity: a dataset file records them in its header and a file built with
other settings (or without any) is refused by `wsmap.datasets.load_dataset`.

**Geometry of arm b.** Either

* `model`: the family's named arm's capsule model (`wsmap.collision.arm_model`; for
  `panda7` `"panda"`) built on arm b's own chain: the capsules run along arm b's links (the
  model is `capsules_along_links` of the chain it is given), so their
  lengths follow the scaled d and a; the radii are the named arm's (the housings: the family
  scales lengths, not the motors); or
* `link_radius`: capsules of these radii (m; one, or one per body `0..n`) along arm b's links.

**Which pairs count**: the allowed-collision matrix of arm b (`wsmap.collision.build_acm`,
`acm_samples` random configurations seeded by `acm_seed`): the scaled links collide in other
configurations than the Panda's, so each arm gets its own (about 0.2 s for 10000 samples).
`self_collision=False` checks the scene alone.

**Scene**: `scene` is a scene mapping in the base frame of the arm, as a scene file holds it
(`wsmap.collision.scene`: `floor`, `frame`, `obstacles` of primitives; meshes are refused:
the spec's text would not say what is in the mesh file). `None` (default): the floor `z = 0`
under the arm, which stands on it (the named arms' default scene).

Everything is seeded (the matrix's samples, the map search's seed 0), so the same spec gives the
same labels, on one core or many.
"""

from __future__ import annotations

import json
import math
import numbers
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from ..collision import DEFAULT_SAMPLES, CollisionChecker
from ..kinematics import SerialChain
from ..robots import ArmFamily

__all__ = ["LabelCollision", "label_collision"]

_KEYS = ("model", "link_radius", "scene", "self_collision", "acm_samples", "acm_seed")


@dataclass(frozen=True)
class LabelCollision:
    """The collision settings of a dataset's labels (module notes); made by `label_collision`,
    which checks them.

    Attributes
    ----------
    model : str or None
        The family's named arm whose capsule model each arm gets (`"panda"` for `panda7`).
    link_radius : float, tuple of floats, or None
        Radii (m) of capsules along each arm's links: one, or one per body `0..n`. Exactly one of
        `model` and `link_radius` is set.
    scene : str or None
        The scene mapping as canonical JSON (sorted keys; `scene_dict` gives the mapping);
        `None`: the floor `z = 0`.
    self_collision : bool
        Check the arm's link pairs (True) or the scene alone.
    acm_samples, acm_seed : int
        The allowed-collision matrix's "never in collision" sampling (`wsmap.collision.build_acm`).
    """

    model: str | None = None
    link_radius: float | tuple | None = None
    scene: str | None = None
    self_collision: bool = True
    acm_samples: int = DEFAULT_SAMPLES
    acm_seed: int = 0

    def scene_dict(self) -> dict | None:
        """The scene mapping (a scene file's content), or None (the floor `z = 0`)."""
        return None if self.scene is None else json.loads(self.scene)

    def to_dict(self) -> dict:
        """Plain YAML/JSON types, every key (the spec's identity compares them all)."""
        r = self.link_radius
        return {"model": self.model, "link_radius": list(r) if isinstance(r, tuple) else r,
                "scene": self.scene_dict(), "self_collision": self.self_collision,
                "acm_samples": self.acm_samples, "acm_seed": self.acm_seed}

    def checker(self, arm: SerialChain) -> CollisionChecker:
        """The `CollisionChecker` of one arm (a `SerialChain` of the
        spec's family, batch `()`): its capsules, its allowed-collision matrix, the scene."""
        from .. import collision as col

        if self.model is not None:
            model = col.arm_model(self.model, arm)
        else:
            model = col.capsules_along_links(arm, self.link_radius, floor=True,
                                             source=f"capsules along the links, radii {self.link_radius} m")
        scene = None if self.scene is None else col.scene_from_dict(self.scene_dict(), "dataset spec collision scene")
        if self.self_collision:
            model.acm = col.build_acm(model, samples=self.acm_samples, seed=self.acm_seed)
        return col.CollisionChecker(model, scene, self_collision=self.self_collision)


def _err(what: str) -> ValueError:
    return ValueError(f"collision: {what}")


def _count(key, value, minimum=0) -> int:
    if isinstance(value, bool) or not isinstance(value, (numbers.Integral, float)) or (
            isinstance(value, float) and not (math.isfinite(value) and value.is_integer())) or value < minimum:
        raise _err(f"{key} must be a whole number of at least {minimum}, got {value!r}")
    return int(value)


def _radius(value, bodies: int):
    def one(x, where):
        if isinstance(x, bool) or not isinstance(x, numbers.Real) or not math.isfinite(float(x)) or float(x) <= 0:
            raise _err(f"link_radius{where} must be a positive number of metres, got {x!r}")
        return float(x)

    if isinstance(value, Sequence) and not isinstance(value, str):
        if len(value) not in (1, bodies):
            raise _err(f"link_radius takes one radius or one per body (0..{bodies - 1}: {bodies}), got {len(value)}")
        radii = tuple(one(x, f"[{i}]") for i, x in enumerate(value))
        return radii[0] if len(radii) == 1 else radii
    return one(value, "")


def _scene(value) -> str:
    from ..collision import CollisionError, scene_from_dict

    if not isinstance(value, Mapping):
        raise _err(f"scene must be a mapping (floor, frame, obstacles), got {type(value).__name__}")
    obstacles = value.get("obstacles")
    for ob in obstacles if isinstance(obstacles, Sequence) and not isinstance(obstacles, str) else ():
        if isinstance(ob, Mapping) and ob.get("shape") == "mesh":
            raise _err("scene obstacles of a dataset spec are primitives (box, cylinder, capsule, sphere): a mesh "
                       "file is not part of the spec's text, so its identity would not cover it")
    try:
        scene_from_dict(value, "collision scene")
    except CollisionError as exc:
        raise _err("scene: " + str(exc).removeprefix("collision scene").lstrip(": ")) from None
    try:
        return json.dumps(value, sort_keys=True, separators=(",", ":"), allow_nan=False)
    except (TypeError, ValueError) as exc:
        raise _err(f"scene must hold plain numbers, strings and lists ({exc})") from None


def label_collision(value: Mapping | LabelCollision | None, family: ArmFamily) -> LabelCollision | None:
    """`value` (None, a mapping of `LabelCollision`'s keys, or a LabelCollision) checked
    for the spec's `family` (a `wsmap.robots.ArmFamily`): a chain family only, `model`
    its named arm's, every key known, numbers valid; a `ValueError` naming the key otherwise."""
    if value is None:
        return None
    if isinstance(value, LabelCollision):
        value = value.to_dict()
    if not isinstance(value, Mapping):
        raise _err(f"must be a mapping ({', '.join(_KEYS)}) or null, got {type(value).__name__}")
    unknown = sorted(set(value) - set(_KEYS), key=str)
    if unknown:
        raise _err(f"unknown key(s) {', '.join(map(str, unknown))}; known: {', '.join(_KEYS)}")
    if not family.chain:
        raise ValueError(f"collision labels are for the chain families (the map search with the arms' joint limits); "
                         f"family {family.name!r} is labelled by the paper's solvers, which know no collision")
    from ..collision.named import ALONG_LINKS, ARM_MODELS

    model, radius = value.get("model"), value.get("link_radius")
    if (model is None) == (radius is None):
        raise _err(f"give model (the family's named arm, {family.table.name!r}) or link_radius, not "
                   f"{'both' if model is not None else 'neither'}")
    if model is not None:
        if model != family.table.name:
            have = f"; {family.table.name!r} has one" if family.table.name in ARM_MODELS else ""
            raise _err(f"model {model!r} is not family {family.name!r}'s arm, {family.table.name!r}{have} "
                       "(or give link_radius)")
        if model not in ARM_MODELS:
            raise _err(f"no capsule model for {model!r} (named arms with one: {', '.join(ARM_MODELS)}); give link_radius")
        if model not in ALONG_LINKS:
            raise _err(f"the capsule model of {model!r} has fixed coordinates, not capsules along the links: it does "
                       "not follow the family's scaled arms; give link_radius")
    else:
        radius = _radius(radius, family.table.n + 1)
    self_collision = value.get("self_collision", True)
    if not isinstance(self_collision, bool):
        raise _err(f"self_collision must be true or false, got {self_collision!r}")
    scene = value.get("scene")
    return LabelCollision(model=model, link_radius=radius, scene=None if scene is None else _scene(scene),
                          self_collision=self_collision,
                          acm_samples=_count("acm_samples", value.get("acm_samples", DEFAULT_SAMPLES)),
                          acm_seed=_count("acm_seed", value.get("acm_seed", 0)))
