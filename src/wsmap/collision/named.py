"""Capsule models of the named arms (`wsmap.robots.arms`), for self-collision and the floor.

No URDF with collision meshes of these arms ships with a package wsmap depends on at run time
(pybullet_data and rtb-data are test-only), so each arm gets capsules in its bodies' frames
(`wsmap.collision.geometry`: body `k` moves with joint `k`; its frame is the chain's
frame after joint `k`'s motion) along the links of its DH table, with radii that enclose the
link housings of the manufacturer's dimension drawing; the source is beside each table. Every
model stands on the floor `z = 0` of its base frame (`floor=True`: the default scene).

The radii are estimates of the housings' outer size, rounded up to 5 mm; they were not measured off
the drawings' PDFs here and are to be checked against them (the link lengths are the DH tables'
and exact). They are not the vendor's own collision model, so a map made with them is a map of the
capsule arm. A closer model: `wsmap.collision.from_urdf_collision` on the vendor's
URDF with its collision meshes.
"""

from __future__ import annotations

from ..robots import load
from .geometry import CollisionError, CollisionModel, capsule_model, capsules_along_links

__all__ = ["ARM_MODELS", "ALONG_LINKS", "arm_model"]


def _panda(chain) -> CollisionModel:
    # Franka Emika Panda datasheet's dimension drawing (estimated, see the module notes): joint
    # housings about 0.13-0.14 m across at joints 1-4, narrowing towards the wrist. Body k spans
    # the DH link k (d along z, then a along x), so body 0 is a ball at the base origin.
    radii = (0.10, 0.07, 0.07, 0.065, 0.065, 0.06, 0.055, 0.045)
    return capsules_along_links(chain, radii, floor=True, source=(
        "capsules along the Panda's modified-DH links (FCI 'Robot and interface specifications'), radii "
        f"{list(radii)} m (estimates of the housings of the Panda datasheet's dimension drawing)"))


def _iiwa14(chain) -> CollisionModel:
    # KUKA "LBR iiwa 7 R800, LBR iiwa 14 R820" specification's dimension drawing (estimated, see
    # the module notes): housings about 0.15 m across at A1-A4, narrowing towards the flange.
    radii = (0.10, 0.075, 0.075, 0.07, 0.07, 0.065, 0.06, 0.045)
    return capsules_along_links(chain, radii, floor=True, source=(
        "capsules along the iiwa 14's DH links (KUKA principal dimensions 360/420/400/126 mm), radii "
        f"{list(radii)} m (estimates of the housings of the specification's dimension drawing)"))


#: UR5e: upper arm offset 0.138 m and forearm 0.007 m along the parallel axes from the DH line
#: (Universal Robots' ur_description visual parameters for the UR5e: shoulder_offset, elbow_offset);
#: base footprint 0.149 m across (UR5e User Manual, technical specifications); the radii of the
#: tubes and housings are estimates (module notes).
UR5E_CAPSULES = (
    # (body, p0, p1, radius), metres, body frames of the UR5e's standard-DH chain
    (0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.06), 0.075),            # base
    (1, (0.0, 0.0, 0.0), (0.0, 0.0, 0.1625), 0.065),          # shoulder pan housing up to joint 2
    (2, (0.0, 0.0, 0.0), (0.0, 0.0, 0.138), 0.065),           # shoulder lift housing
    (2, (0.0, 0.0, 0.138), (-0.425, 0.0, 0.138), 0.055),      # upper arm tube
    (2, (-0.425, 0.0, 0.138), (-0.425, 0.0, 0.02), 0.055),    # elbow housing
    (3, (0.0, 0.0, 0.007), (-0.3922, 0.0, 0.007), 0.045),     # forearm tube
    (4, (0.0, 0.0, 0.0), (0.0, 0.0, 0.1333), 0.045),          # wrist 1 housing
    (5, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0997), 0.045),          # wrist 2 housing
    (6, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0996), 0.04),           # wrist 3 and the flange
)


def _ur5e(chain) -> CollisionModel:
    return capsule_model(chain, UR5E_CAPSULES, floor=True,
                         names=("base", "shoulder", "upper_arm", "forearm", "wrist_1", "wrist_2", "wrist_3"),
                         source="UR5e capsules: ur_description offsets (0.138 m, 0.007 m), UR5e User Manual "
                                "footprint; radii estimated")


#: Named arm -> the builder of its capsule model from its chain.
ARM_MODELS = {"panda": _panda, "ur5e": _ur5e, "iiwa14": _iiwa14}
#: The models built along the links of the chain they are given (`capsules_along_links`):
#: on an arm with scaled lengths (a family of `wsmap.robots.families`) the capsules follow the
#: scaled links. The UR5e's capsules are fixed coordinates and do not.
ALONG_LINKS = ("panda", "iiwa14")


def arm_model(name: str, robot=None) -> CollisionModel:
    """The capsule model of the named arm `name` (`ARM_MODELS`), on `robot` (default
    `wsmap.load(name)`; its limits may differ, its kinematics must be the named arm's, or for the
    models of `ALONG_LINKS` the named arm's table with other lengths, whose links the capsules
    then follow). An arm
    without a model is a `CollisionError` listing those that have one."""
    key = str(name).lower()
    if key not in ARM_MODELS:
        raise CollisionError(f"no collision model for robot {name!r}; named arms with one: {', '.join(ARM_MODELS)} "
                             "(or give a URDF with <collision> elements, or DH link radii)")
    return ARM_MODELS[key](load(key) if robot is None else robot)
