"""Obstacles from the URDF of a work cell: tables, fences, fixtures as fixed links with ``<collision>``.

A work-cell URDF is a tree of links joined by ``fixed`` joints (no arm in it: the arm comes from its
own URDF, MJCF, DH table or name); every ``<collision>`` element of every link becomes one
:class:`~wsmap.collision.scene.Obstacle` of a :class:`~wsmap.collision.scene.Scene`. The shapes are
read by the same reader as an arm's collision elements (:mod:`wsmap.collision.geometry`: box,
cylinder, sphere, capsule; meshes through trimesh, ``package://``, ``file://`` and relative paths
looked up as for an arm).

**Frames.** ``T_link`` is a link's pose in the frame of the cell's root link (the product of the
fixed joints' ``<origin>`` from the root down); a collision element's pose is
``T_link · origin``. Then

* ``mount=None`` (default): the cell's root link *is* the world frame of the arm's chain, and the
  obstacles are ``"world"`` obstacles: they stay where they are when the arm's base moves (the
  chain's ``base`` transform places the arm in the cell; :func:`wsmap.base_placement` refuses them,
  since it moves the base under them);
* ``mount="LINK"``: the arm's base is bolted to that link of the cell (its frame is the arm's base
  frame, body 0 of the chain), and the obstacles are ``"base"`` obstacles at
  ``T_mount⁻¹ · T_link · origin``: they move with the base (a map in the base frame, a base
  placement of the whole cell).

The floor is not part of a cell file: ``floor`` (False, True for ``z = 0``, or a height in metres of
the world frame) adds it, as a scene file's ``floor:`` does; a floor the arm must not go through
can also be a thin box in the cell.

Bad input is a :class:`~wsmap.collision.geometry.CollisionError` naming the file, before any work:
not a URDF, several root links, a joint that is not ``fixed`` (an arm, a conveyor), an unknown
mount link, a cell without any ``<collision>`` element, a collision mesh that is missing, empty or
not a mesh, a shape with NaN or non-positive sizes.
"""

from __future__ import annotations

import os

import numpy as np

from ..kinematics.urdf import URDFError, _parse_xml, _read, _Tree
from .geometry import CollisionError, Shape, _origin, _urdf_shapes
from .scene import Obstacle, Scene, scene_from_dict

__all__ = ["scene_from_urdf", "CELL_SUFFIXES"]

#: File name endings :func:`wsmap.collision.load_scene` reads as a work-cell URDF.
CELL_SUFFIXES = (".urdf",)


def _floor(floor, label) -> float | None:
    # the scene file's rule for ``floor:`` (true, false or a height), with its message
    return scene_from_dict({"floor": floor}, label).floor


def scene_from_urdf(source, mount: str | None = None, *, floor: bool | float = False) -> Scene:
    """The obstacles of a work-cell URDF as a :class:`Scene` (module notes: frames, bad input).

    Parameters
    ----------
    source : path or str
        The cell's URDF file (or its XML text): links joined by fixed joints, with ``<collision>``
        elements.
    mount : str, optional
        The cell's link the arm's base is attached to: the obstacles are then in the arm's
        ``"base"`` frame (they move with the base). Default: the cell's root link is the world
        frame and the obstacles are ``"world"`` obstacles.
    floor : bool or float
        ``False`` (default): no floor; ``True``: the floor ``z = 0``; a number: the floor at that
        height (m, world frame).

    Returns
    -------
    Scene
        One obstacle per ``<collision>`` element, named after its link (``LINK`` when the link has
        one collision element, else ``LINK/NAME`` with the element's ``name`` attribute or its
        position ``1, 2, ...``), in the order of the links in the file.
    """
    try:
        data, label, path = _read(source)
    except FileNotFoundError:
        raise CollisionError(f"work-cell URDF file {os.fspath(source)!r}: no such file") from None
    try:
        root = _parse_xml(data, label)
        tree = _Tree(root, label)
    except URDFError as exc:
        raise CollisionError(str(exc)) from None
    roots = [link for link in tree.links if link not in tree.parent_joint]
    if len(roots) != 1:
        raise CollisionError(f"{label} is not one tree of links: it has {len(roots)} root links"
                             f"{' (' + ', '.join(roots) + ')' if roots else ''}; a work cell hangs from one root")
    for jname, el in tree.joints.items():
        if el.get("type") != "fixed":
            raise CollisionError(f"{label}: joint {jname!r} is {el.get('type')!r}; a work cell is fixed links only "
                                 "(an arm in it is given on its own: --urdf/--robot, from_urdf_collision)")
    if mount is not None and mount not in tree.children:
        raise CollisionError(f"{label}: unknown mount link {mount!r}; the links are: {', '.join(tree.links)}")
    floor_z = _floor(floor, label)
    # every link's pose in the root frame, walking down the tree (fixed joints: origins only)
    pose = {roots[0]: np.eye(4)}
    stack = [roots[0]]
    while stack:
        parent = stack.pop()
        for jname in tree.children[parent]:
            child = tree._child(jname)
            pose[child] = pose[parent] @ _origin(tree.joints[jname].find("origin"), label, f"joint {jname!r}")
            stack.append(child)
    if mount is None:
        frame, ref = "world", np.eye(4)
    else:
        frame, ref = "base", np.linalg.inv(pose[mount])
    urdf_dir = os.path.dirname(os.path.abspath(path)) if path else None
    obstacles = []
    for link_el in root.findall("link"):
        name = link_el.get("name")
        shapes = _urdf_shapes(link_el, label, urdf_dir)  # meshes read (and checked) here
        names = [c.get("name") or str(i + 1) for i, c in enumerate(link_el.findall("collision"))]
        T = ref @ pose[name]
        for s, cname in zip(shapes, names):
            shape = Shape(s.kind, s.size, T @ s.origin, s.vertices, s.faces, s.source)
            obstacles.append(Obstacle(name if len(shapes) == 1 else f"{name}/{cname}", shape, frame))
    if not obstacles:
        raise CollisionError(f"{label} has no <collision> elements: a work cell's obstacles are its links' "
                             "<collision> geometry")
    return Scene(floor_z, tuple(obstacles))
