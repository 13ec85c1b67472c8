"""Where a job's collision geometry comes from, in one record: the arm's own (its URDF or MJCF
`<collision>` elements, a named arm's model, capsules of given radii), a scene of obstacles and the
allowed-collision matrix's settings.

`CollisionSource` is the collision part of a job (`wsmap.jobs.MapJob`, `wsmap.jobs.PlacementJob`)
and of the command line's `--collision`, `--scene`, `--mount`, `--link-radius`, `--allow` and
`--acm-samples` options. `check()` says what is wrong before any file is read; `build(robot, arm)`
reads the scene and the arm's geometry and builds the `CollisionChecker` (the matrix's random
configurations are the only work it does).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

import math

import numpy as np

from .._optional import require
from .acm import MAX_SAMPLES as MAX_ACM_SAMPLES
from .geometry import MAX_LINK_RADIUS

if TYPE_CHECKING:
    from collections.abc import Sequence

    from ..kinematics.chain import Arm
    from .checks import CollisionChecker
    from .geometry import CollisionModel

__all__ = ["CollisionSource", "ArmFiles", "MAX_ACM_SAMPLES", "MAX_LINK_RADIUS", "map_picture"]


class ArmFiles(Protocol):
    """What the collision geometry needs to know of an arm's source (`wsmap.robots.sources.ArmSource`
    is one): its description files, their end and base links, whether it is DH columns, its name."""

    urdf: str | None
    mjcf: str | None
    ee: str | None
    base: str | None
    has_dh: bool
    name: str


@dataclass(frozen=True)
class CollisionSource:
    """The collision geometry of a job; `wanted` is False when none was asked for.

    Parameters
    ----------
    collision : bool
        Count a node only with a collision-free solution: self-collision from the arm's own geometry
        (a URDF's or MJCF's `<collision>` elements, a named arm's model, `link_radius` capsules) and
        the floor for a named arm.
    scene : path, optional
        Obstacles (YAML or JSON; or a work cell's URDF); implies `collision`.
    mount : str, optional
        A `scene` URDF's link the arm's base is attached to.
    link_radius : sequence of float, optional
        Capsules of these radii (m; one, or one per body 0..n; each in `(0, MAX_LINK_RADIUS]`) along
        the links; implies `collision`.
    allow : sequence of (str, str), optional
        Link pairs never checked, besides the allowed-collision matrix's.
    acm_samples : int, optional
        Random configurations of the matrix's "never in collision" test (`DEFAULT_SAMPLES` when None;
        1 to `MAX_ACM_SAMPLES`).
    seed : int
        Seed of those configurations.
    obstacles : sequence of Obstacle
        Obstacles besides the scene file's (`wsmap.collision.scene.Obstacle`; a reach study's
        workpiece, a `surface` checked on its triangles); implies `collision`.
    srdf : path, optional
        MoveIt's SRDF of a URDF arm: its `<disable_collisions>` pairs go into the allowed-collision
        matrix (`wsmap.collision.srdf`).
    floor : float or False, optional
        The floor, explicitly: a height `z` (m, world frame; a finite number of magnitude at most
        1000), or False for none. It replaces the scene file's floor. None (default): a named arm
        stands on the floor `z = 0`, a URDF, MJCF or DH arm has none unless the scene file gives one.
    """

    collision: bool = False
    scene: str | None = None
    mount: str | None = None
    link_radius: Sequence[float] | None = None
    allow: Sequence[tuple[str, str]] | None = None
    acm_samples: int | None = None
    seed: int = 0
    obstacles: tuple = ()
    srdf: str | None = None
    floor: float | bool | None = None

    def __post_init__(self) -> None:
        if self.scene is not None:
            object.__setattr__(self, "scene", str(self.scene))
        if self.link_radius is not None:
            object.__setattr__(self, "link_radius", tuple(float(r) for r in self.link_radius))
        if self.allow is not None:
            object.__setattr__(self, "allow", tuple(tuple(p) for p in self.allow))
        object.__setattr__(self, "obstacles", tuple(self.obstacles))

    @property
    def wanted(self) -> bool:
        """Whether the job counts collisions at all."""
        return bool(self.collision or self.scene is not None or self.link_radius is not None or self.obstacles)

    def check(self) -> None:
        """Raise a one-line `ValueError` for options that go with collisions when none is asked for,
        and for a missing `collision` extra (coal), before any work."""
        if not self.wanted:
            for flag, v in (("--allow", self.allow), ("--acm-samples", self.acm_samples), ("--mount", self.mount),
                            ("--floor/--no-floor", self.floor)):
                if v is not None:
                    raise ValueError(f"{flag} is used with --collision or --scene")
            return
        if self.floor is not None:
            self._floor_height()
        if self.mount is not None and self.scene is None:
            raise ValueError("--mount names a link of a work-cell URDF given with --scene CELL.urdf")
        for r in self.link_radius or ():
            if not (math.isfinite(r) and 0 < r <= MAX_LINK_RADIUS):
                raise ValueError(f"--link-radius must be a positive number of metres, at most {MAX_LINK_RADIUS:g} "
                                 f"(a capsule around a link), got {r:g}")
        n = self.acm_samples
        if n is not None and (isinstance(n, bool) or not isinstance(n, (int, np.integer))
                              or not 1 <= n <= MAX_ACM_SAMPLES):
            raise ValueError(f"--acm-samples must be a whole number from 1 to {MAX_ACM_SAMPLES} (random configurations "
                             f"of the matrix's 'never in collision' test), got {n!r}")
        require("coal", why="--collision/--scene")

    def build(self, robot: Arm, arm: ArmFiles) -> CollisionChecker | None:
        """The checker of `robot` (built from `arm`), or None when no collision is wanted: the scene,
        meshes and link names of `allow` read and checked, the allowed-collision matrix sampled."""
        self.check()
        if not self.wanted:
            return None
        from . import DEFAULT_SAMPLES, CollisionChecker, Scene, build_acm, load_scene

        scene = load_scene(self.scene, self.mount) if self.scene is not None else None
        model = self._model(robot, arm)
        if self.obstacles:  # beside the scene file's, or beside the default floor of the model
            scene = scene or (Scene(floor=0.0) if model.floor else Scene())
            scene = Scene(scene.floor, scene.obstacles + self.obstacles)
        if self.floor is not None:  # explicit: replaces the default floor and the scene file's
            scene = Scene(self._floor_height(), () if scene is None else scene.obstacles)
        samples = DEFAULT_SAMPLES if self.acm_samples is None else self.acm_samples
        model.acm = build_acm(model, samples=samples, seed=self.seed, disable=[tuple(p) for p in (self.allow or [])],
                              srdf=self.srdf)
        return CollisionChecker(model, scene)

    def _floor_height(self) -> float | None:
        """The explicit floor's height (None: no floor); a one-line `ValueError` for a bad one."""
        if self.floor is False:
            return None
        z = 0.0 if self.floor is True else self.floor
        try:
            z = float(z)
        except (TypeError, ValueError):
            raise ValueError(f"--floor must be a height in metres, got {self.floor!r}") from None
        if not (math.isfinite(z) and abs(z) <= 1000.0):
            raise ValueError(f"--floor must be a finite height of at most 1000 m in magnitude, got {z:g}")
        return z

    def _model(self, robot: Arm, arm: ArmFiles) -> CollisionModel:
        from . import arm_model, capsules_along_links, default_geometry, from_urdf_collision

        if self.link_radius is not None:
            r = self.link_radius
            bodies = getattr(robot, "n_joints", robot.n)  # a chain's coupled joints each move a body
            if len(r) not in (1, bodies + 1):
                raise ValueError(f"--link-radius takes one radius or one per body (0..{bodies}: {bodies + 1}), "
                                 f"got {len(r)}")
            return capsules_along_links(robot, r[0] if len(r) == 1 else list(r),
                                        floor=not arm.has_dh and arm.urdf is None)
        if arm.urdf is not None:
            from ..kinematics.urdf import moving_off_chain

            moving = moving_off_chain(arm.urdf, ee_link=arm.ee, base_link=arm.base)
            if moving:
                raise ValueError(f"--collision: link {moving[0]!r} hangs below the driver of a mimic joint of the "
                                 "chain, so it moves with the chain's variable, but geometry off the chain is placed "
                                 "at its joint's zero; end the chain elsewhere (--ee) or remove its <collision>")
            model = from_urdf_collision(arm.urdf, ee_link=arm.ee, base_link=arm.base)
        elif arm.mjcf is not None:
            from .mjcf import from_mjcf_collision

            model = from_mjcf_collision(arm.mjcf, arm.ee)
        elif arm.has_dh:
            raise ValueError("DH columns carry no collision geometry: give --link-radius R (capsules along the links)")
        else:
            return arm_model(arm.name, robot, geometry=default_geometry(arm.name, robot))
        model.chain = robot  # the same chain, with the limits the job chose
        return model

    def describe(self) -> dict:
        """The source's files as a JSON-ready dict (the map file's provenance)."""
        d = {"scene_file": self.scene, "mount": self.mount}
        if self.srdf is not None:
            d["srdf_file"] = self.srdf
        if self.obstacles:
            d["obstacles"] = [{"name": o.name, "frame": o.frame, **o.shape.describe()} for o in self.obstacles]
        return d


def map_picture(checker: CollisionChecker | None, settings: dict | None = None) -> tuple[str | None, list]:
    """What a collision-aware map's pictures show of its check (`wsmap.jobs.MapJob`'s PNG and HTML).

    Parameters
    ----------
    checker : CollisionChecker or None
        The map's checker (None: a kinematic map).
    settings : dict, optional
        The map file's `collision` settings (`CollisionSource.describe` among them): its
        `scene_file` names the scene.

    Returns
    -------
    line : str or None
        What the map is free of, for the title's `collision-free: ...` line: `"scene table.yaml"`
        (the scene file's name), else `"self-collision and the floor"` or `"self-collision only"`;
        obstacles given beside a file add `" + 2 obstacles"`. None for a kinematic map.
    obstacles : list
        The scene's obstacles as triangle meshes `(name, vertices (V, 3), faces (F, 3))` in the
        frame of the map's nodes (`wsmap.collision.Scene.triangles`, base-frame obstacles placed by
        the arm's base); the floor is not drawn.
    """
    if checker is None:
        return None, []
    import os

    scene_file = (settings or {}).get("scene_file")
    extra = len((settings or {}).get("obstacles") or ())
    if scene_file:
        line = f"scene {os.path.basename(str(scene_file))}"
    else:
        parts = (["self-collision"] if checker.self_collision else []) + (
            ["the floor"] if checker.scene.floor is not None else [])
        line = " and ".join(parts) + (" only" if len(parts) == 1 else "")
    if extra:
        line += f" + {extra} obstacle{'s' if extra > 1 else ''}"
    return line, checker.scene.triangles(checker.model.chain.base)
