"""Collision models of the named arms (`wsmap.robots.arms`), for self-collision and the floor.

`arm_model(name, geometry=...)` gives one of four geometries (`GEOMETRIES`); `default_geometry`
says which one `wsmap.collision.checker_for(name)` and the command line's `--collision` use (the
vendor record's `default`, `wsmap.collision.vendor.VENDOR`):

* `"meshes"` — the vendor's collision meshes themselves, as convex hulls checked by coal behind
  their enclosing spheres (`wsmap.collision.vendor.mesh_model`), each hull grown by
  `vendor.MESH_MARGIN` (1 mm, Bullet's margin): exact for those grown hulls. The Panda's and the
  iiwa 14's come from pybullet_data (where it is installed: their default there); the UR5e's and
  the UR10e's are committed with wsmap (the convex hulls of Universal Robots' own collision meshes,
  `wsmap/collision/data/ur_description/`: their default everywhere), and so are the Gen3's
  (Kinova's, each hull grown by its link's frame mismatch with wsmap's DH table, 0-0.8 mm:
  `wsmap/collision/data/kortex_description/`; its default everywhere);
* `"two-level"` — the same meshes with the fitted capsules as their coarse model
  (`wsmap.collision.vendor.two_level_model`): the capsules first, the meshes decide where the
  capsules collide, so the answer is the meshes', configuration for configuration (tested). Not
  a default: it does not pay on any named arm (`benchmarks/collision/bench_vendor_judge.py`,
  docs/collision.md): the Panda's and the iiwa's one hull per link coal tests about as fast as the
  capsules, and the UR arms' capsules call most of what a closed-form map asks about colliding;
* `"fitted"` — capsules (and cylinders for flat parts) fitted around the vendor's own collision
  meshes, every mesh vertex inside (`wsmap.collision.vendor.fitted_model`, `vendor.FITTED`): a body
  at least as large as the real arm, never free where the meshes collide, sometimes colliding
  where they are free. The Panda's and the iiwa's default without pybullet_data (the capsules are
  committed numbers: they need nothing);
* `"capsules"` — the estimated capsules below (the Panda, the iiwa 14 and the UR5e; the default on
  an arm of a family with other lengths): not fitted to any vendor geometry, so not guaranteed to
  contain the real arm. The PUMA 560 has no collision model.

The estimated capsules:

Each named arm declares its capsules in its own module (an `ArmCapsules` registered with it,
`wsmap.robots.registry`); this module builds them into a `CollisionModel` on the arm's chain
and lists them (`ARM_MODELS`, in the order of the named arms). A new arm's model is its
module's `capsules=`, nothing here.

For the arms without a vendor description on this machine (or on an arm of a family with other
lengths), each arm gets capsules in its bodies' frames
(`wsmap.collision.geometry`: body `k` moves with joint `k`; its frame is the chain's
frame after joint `k`'s motion) along the links of its DH table, with radii that enclose the
link housings of the manufacturer's dimension drawing; the source is beside each table. Every
model stands on the floor `z = 0` of its base frame (`floor=True`: the default scene).

The radii are estimates of the housings' outer size, rounded up to 5 mm; they were not measured off
the drawings' PDFs here and are to be checked against them (the link lengths are the DH tables'
and exact). They are not the vendor's own collision model, so a map made with them is a map of the
capsule arm. A closer model: `wsmap.collision.from_urdf_collision` on the vendor's
URDF with its collision meshes, or the fitted capsules where they exist.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from typing import TYPE_CHECKING

from ..robots import ARMS, load
from ..robots.registry import ArmCapsules
from .geometry import CollisionError, CollisionModel, capsule_model, capsules_along_links
from .vendor import FITTED, VENDOR, fitted_model, mesh_model, same_kinematics, two_level_model, vendor_installed

if TYPE_CHECKING:  # names of the annotations only
    from wsmap.kinematics.chain import Arm

__all__ = ["ARM_MODELS", "ALONG_LINKS", "GEOMETRIES", "arm_model", "capsules_model", "default_geometry"]

#: The geometries of a named arm's model (module notes).
GEOMETRIES = ("meshes", "two-level", "fitted", "capsules")


def capsules_model(capsules: ArmCapsules, chain: Arm) -> CollisionModel:
    """The `CollisionModel` of a named arm's `capsules` on `chain` (one arm), standing on the floor.

    Parameters
    ----------
    capsules : ArmCapsules
        The arm's declared capsules: radii along the links (`capsules_along_links`, which follow
        the links of `chain`) or fixed capsules in the bodies' frames (`capsule_model`).
    chain : SerialChain or DHRobot
        The arm they ride on (metres, its base frame).

    Returns
    -------
    CollisionModel
        With `floor=True` and the capsules' `source`.
    """
    if capsules.along_links:
        return capsules_along_links(chain, capsules.radii, floor=True, source=capsules.source)
    return capsule_model(chain, capsules.capsules, floor=True, names=capsules.names, source=capsules.source)


#: Named arm -> the builder of its capsule model from its chain, in the order of the named arms.
ARM_MODELS: dict[str, Callable[..., CollisionModel]] = {
    arm.name: partial(capsules_model, arm.capsules) for arm in ARMS if arm.capsules is not None}
#: The models built along the links of the chain they are given (`capsules_along_links`):
#: on an arm with scaled lengths (a family of `wsmap.robots.families`) the capsules follow the
#: scaled links. The UR5e's capsules are fixed coordinates and do not.
ALONG_LINKS: tuple[str, ...] = tuple(arm.name for arm in ARMS if arm.capsules is not None and arm.capsules.along_links)


def default_geometry(name: str, robot: Arm | None = None) -> str:
    """The geometry `arm_model` gives the named arm `name` on `robot` by default, where capsules were
    fitted to its vendor meshes and `robot` (if given) has its kinematics: the vendor record's
    `default` (`"meshes"` for all four) when the meshes can be read here, else `"fitted"`; `"capsules"` for every other arm (an arm of a
    family with other lengths gets the capsules along its links)."""
    key = str(name).lower()
    if key in FITTED and key in VENDOR and (robot is None or same_kinematics(robot, load(key))):
        return VENDOR[key].default if vendor_installed(key) else "fitted"
    return "capsules"


def arm_model(name: str, robot: Arm | None = None, geometry: str | None = None) -> CollisionModel:
    """The collision model of the named arm `name` on `robot` (default `wsmap.load(name)`; its
    limits may differ, its kinematics must be the named arm's, or for the capsule models of
    `ALONG_LINKS` the named arm's table with other lengths, whose links the capsules then follow).

    `geometry` is one of `GEOMETRIES` (module notes), default `"capsules"` (the model this
    function has always given; `wsmap.collision.checker_for` and the command line take
    `default_geometry`, the fitted capsules where they are the default). An unknown geometry, or
    an arm without that model, is a `CollisionError` listing what there is."""
    key = str(name).lower()
    geometry = "capsules" if geometry is None else geometry
    if geometry not in GEOMETRIES:
        raise CollisionError(f"unknown collision geometry {geometry!r}; geometries are {', '.join(GEOMETRIES)}")
    if geometry in ("fitted", "two-level"):
        if key not in FITTED:
            raise CollisionError(f"no fitted collision capsules for robot {name!r}; named arms with them: "
                                 f"{', '.join(FITTED)}")
        return fitted_model(key, robot) if geometry == "fitted" else two_level_model(key, robot)
    if geometry == "meshes":
        return mesh_model(key, robot)
    if key not in ARM_MODELS:
        raise CollisionError(f"no collision model for robot {name!r}; named arms with one: {', '.join(ARM_MODELS)} "
                             "(or give a URDF with <collision> elements, or DH link radii)")
    return ARM_MODELS[key](load(key) if robot is None else robot)
