"""MJCF collision geoms (`wsmap.kinematics.mjcf` reads the chain): the geoms with a non-zero
`contype` or `conaffinity` of the chain's bodies — spheres, capsules, cylinders, boxes, meshes
(MuJoCo's compiled vertices, tested as convex hulls, as MuJoCo does). Geoms of bodies hanging off
the chain ride with their parent at `qpos0`; the world body's (a floor plane) are not the arm's.
"""

from __future__ import annotations

import os

import numpy as np

from ..kinematics.mjcf import MJCFError, _chain_parts, _load, _pose, from_mjcf
from .geometry import CollisionError, CollisionModel, Link, Shape

__all__ = ["from_mjcf", "from_mjcf_collision", "MJCFError"]


def from_mjcf_collision(path, site_or_body: str, *, floor: bool = False) -> CollisionModel:
    """`from_mjcf` and the collision geoms of its bodies as a `CollisionModel` (one
    link per MuJoCo body that has collision geoms, named as the body)."""
    import mujoco

    path = os.fspath(path)
    m = _load(path)
    chain, place = _chain_parts(m, path, site_or_body)
    G = mujoco.mjtGeom
    links, names = [], {}
    for b in range(1, m.nbody):
        shapes = []
        for g in range(int(m.body_geomadr[b]), int(m.body_geomadr[b] + m.body_geomnum[b])) if m.body_geomnum[b] else ():
            if not (m.geom_contype[g] or m.geom_conaffinity[g]):
                continue
            k, Tb = place[b]
            T = Tb @ _pose(m.geom_pos[g], m.geom_quat[g])
            t, s = int(m.geom_type[g]), m.geom_size[g]
            if t == int(G.mjGEOM_SPHERE):
                shapes.append(Shape("sphere", (s[0],), T))
            elif t == int(G.mjGEOM_CAPSULE):
                shapes.append(Shape("capsule", (s[0], 2 * s[1]), T))
            elif t == int(G.mjGEOM_CYLINDER):
                shapes.append(Shape("cylinder", (s[0], 2 * s[1]), T))
            elif t == int(G.mjGEOM_BOX):
                shapes.append(Shape("box", tuple(2 * s), T))
            elif t == int(G.mjGEOM_MESH):
                mid = int(m.geom_dataid[g])
                v0, nv = int(m.mesh_vertadr[mid]), int(m.mesh_vertnum[mid])
                f0, nf = int(m.mesh_faceadr[mid]), int(m.mesh_facenum[mid])
                shapes.append(Shape("mesh", (), T, np.array(m.mesh_vert[v0 : v0 + nv], dtype=np.float64),
                                    np.array(m.mesh_face[f0 : f0 + nf], dtype=np.int64),
                                    source=mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_MESH, mid) or f"mesh {mid}"))
            else:
                gname = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or f"geom {g}"
                raise CollisionError(f"MJCF file {path!r}: {gname!r} is a {G(t).name[7:].lower()} geom on the arm; "
                                     "collision geoms are spheres, capsules, cylinders, boxes and meshes")
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
