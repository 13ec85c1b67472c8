"""MJCF collision geoms (`wsmap.kinematics.mjcf` reads the chain): the geoms with a non-zero
`contype` or `conaffinity` of the chain's bodies, of the types that have a record in
`wsmap.collision.shapes` (spheres, capsules, cylinders, boxes, meshes: MuJoCo's compiled vertices,
tested as convex hulls, as MuJoCo does). Geoms of bodies hanging off the chain ride with their parent
at `qpos0`; the world body's (a floor plane) are not the arm's.
"""

from __future__ import annotations

import os

from ..kinematics.mjcf import MJCFError, chain_and_bodies, from_mjcf, load_model, pose_matrix
from .errors import CollisionError
from .geometry import CollisionModel, Link
from .shapes import SHAPE_KINDS, mjcf_shape_kind

__all__ = ["from_mjcf", "from_mjcf_collision", "MJCFError"]


def _body_shapes(m, path: str, b: int, place: dict) -> list:
    """The shapes of MuJoCo body `b`'s collision geoms (a non-zero `contype` or `conaffinity`), in
    the frame of the chain body it rides on (`place`, `chain_and_bodies`)."""
    import mujoco

    shapes = []
    for g in range(int(m.body_geomadr[b]), int(m.body_geomadr[b] + m.body_geomnum[b])) if m.body_geomnum[b] else ():
        if not (m.geom_contype[g] or m.geom_conaffinity[g]):
            continue
        k, Tb = place[b]
        T = Tb @ pose_matrix(m.geom_pos[g], m.geom_quat[g])
        t = int(m.geom_type[g])
        kind = mjcf_shape_kind(t)
        if kind is None:
            gname = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or f"geom {g}"
            known = ", ".join(k.name for k in SHAPE_KINDS if k.mjcf_type)
            raise CollisionError(f"MJCF file {path!r}: {gname!r} is a {mujoco.mjtGeom(t).name[7:].lower()} geom on the "
                                 f"arm; collision geoms are of the types {known}")
        shapes.append(kind.from_mjcf(m, g, T))
    return shapes


def from_mjcf_collision(path, site_or_body: str, *, floor: bool = False) -> CollisionModel:
    """`from_mjcf` and the collision geoms of its bodies as a `CollisionModel` (one
    link per MuJoCo body that has collision geoms, named as the body)."""
    import mujoco

    path = os.fspath(path)
    m = load_model(path)
    chain, place = chain_and_bodies(m, path, site_or_body)
    links, names = [], {}
    for b in range(1, m.nbody):
        shapes = _body_shapes(m, path, b, place)
        if shapes:
            name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) or f"body{b}"
            parent = int(m.body_parentid[b])
            while parent and parent not in names:
                parent = int(m.body_parentid[parent])
            links.append(Link(name, place[b][0], tuple(shapes), parent=names.get(parent), frame=place[b][1]))
            names[b] = name
    if not links:
        raise CollisionError(f"MJCF file {path!r} has no collision geoms on the arm")
    return CollisionModel(chain, tuple(links), source=path, floor=floor)
