"""MJCF (MuJoCo's format) as a second source of chains and collision geometry, parsed by the
``mujoco`` package (its compiled model: frames, joint anchors and axes, meshes as MuJoCo reads them).

:func:`from_mjcf` is the serial chain from the world body to a site or a body (the tool frame);
:func:`from_mjcf_collision` adds its collision geoms (those with a non-zero ``contype`` or
``conaffinity``: spheres, capsules, cylinders, boxes, meshes as convex hulls). Hinge joints are
revolute, slide joints prismatic; a joint's coordinate is measured from its ``ref`` (``qpos0``), as
MuJoCo's ``qpos``; limits from ``range`` where ``limited``. Geoms of bodies hanging off the chain
ride with their parent at ``qpos0``; geoms of the world body (a floor plane) are not the arm's.
"""

from __future__ import annotations

import os

import numpy as np

from ..kinematics.chain import PRISMATIC, REVOLUTE, SerialChain
from .geometry import CollisionError, CollisionModel, Link, Shape

__all__ = ["from_mjcf", "from_mjcf_collision"]


def _load(path):
    import mujoco

    path = os.fspath(path)
    if not os.path.isfile(path):
        raise CollisionError(f"no such MJCF file: {path!r}")
    try:
        return mujoco.MjModel.from_xml_path(path)
    except Exception as exc:  # mujoco's own message names the element
        msg = " ".join(str(exc).split())
        raise CollisionError(f"MJCF file {path!r}: mujoco cannot read it: {msg}") from None


def _pose(pos, quat) -> np.ndarray:
    w, x, y, z = quat / np.linalg.norm(quat)
    T = np.eye(4)
    T[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                 [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                 [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    T[:3, 3] = pos
    return T


def _trans(p) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = p
    return T


def _chain_parts(m, path: str, site_or_body: str):
    """The chain and, per MuJoCo body on or below the path, ``(chain body, pose in its frame)``."""
    import mujoco

    sid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, site_or_body)
    bid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, site_or_body)
    if sid < 0 and bid < 0:
        sites = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_SITE, i) for i in range(m.nsite)]
        raise CollisionError(f"MJCF file {path!r} has no site or body {site_or_body!r}; sites: "
                             f"{', '.join(s for s in sites if s) or 'none'}")
    end = int(m.site_bodyid[sid]) if sid >= 0 else bid
    tool = _pose(m.site_pos[sid], m.site_quat[sid]) if sid >= 0 else np.eye(4)
    bodies = []
    b = end
    while b != 0:
        bodies.append(b)
        b = int(m.body_parentid[b])
    bodies.reverse()
    fixed, axes, kinds, offset, qlim, T = [], [], [], [], [], np.eye(4)
    place = {0: (0, np.eye(4))}
    for b in bodies:
        T = T @ _pose(m.body_pos[b], m.body_quat[b])
        for j in range(int(m.body_jntadr[b]), int(m.body_jntadr[b] + m.body_jntnum[b])):
            jt = int(m.jnt_type[j])
            if jt not in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)):
                name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j)
                raise CollisionError(f"MJCF file {path!r}: joint {name!r} on the chain is a ball or free joint; "
                                     "a serial chain has hinge and slide joints")
            a = m.jnt_pos[j]
            fixed.append(T @ _trans(a))
            T = _trans(-a)
            axes.append(np.array(m.jnt_axis[j], dtype=np.float64))
            kinds.append(REVOLUTE if jt == int(mujoco.mjtJoint.mjJNT_HINGE) else PRISMATIC)
            offset.append(-float(m.qpos0[m.jnt_qposadr[j]]))
            lim = m.jnt_range[j] if m.jnt_limited[j] else (-np.inf, np.inf)
            qlim.append((float(lim[0]), float(lim[1])))
        place[b] = (len(kinds), T.copy())
    if not kinds:
        raise CollisionError(f"MJCF file {path!r}: no hinge or slide joint between the world and {site_or_body!r}")
    fixed.append(T @ tool)
    name = os.path.splitext(os.path.basename(path))[0]
    chain = SerialChain(np.stack(fixed), np.stack(axes), kinds, offset=np.array(offset), qlim=np.array(qlim),
                        name=name, source=path)
    # bodies off the path: with their parent, joints at qpos0 (a fixed pose)
    for b in range(1, m.nbody):
        if b in place:
            continue
        chainb = [b]
        while int(m.body_parentid[chainb[-1]]) not in place:
            chainb.append(int(m.body_parentid[chainb[-1]]))
        for c in reversed(chainb):
            k, Tp = place[int(m.body_parentid[c])]
            place[c] = (k, Tp @ _pose(m.body_pos[c], m.body_quat[c]))
    return chain, place


def from_mjcf(path, site_or_body: str) -> SerialChain:
    """The serial chain of an MJCF file from the world body to the site or body ``site_or_body``
    (its frame is the tool frame): fixed transforms from the bodies' ``pos``/``quat`` and the
    joints' anchors, axes as MuJoCo has them (body frame), ``offset = -ref``, ``qlim`` from
    ``range``. Errors (no such file, not MJCF, an unknown site, a ball joint) are a
    :class:`~wsmap.collision.geometry.CollisionError` naming the file."""
    m = _load(path)
    return _chain_parts(m, os.fspath(path), site_or_body)[0]


def from_mjcf_collision(path, site_or_body: str, *, floor: bool = False) -> CollisionModel:
    """:func:`from_mjcf` and the collision geoms of its bodies as a :class:`CollisionModel` (one
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
