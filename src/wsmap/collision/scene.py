"""Obstacles around an arm: a floor plane, boxes, cylinders, spheres, capsules and meshes, from
Python, a YAML/JSON scene file, or the URDF of a work cell.

A `Scene` is in the world frame of the arm's chain (the chain's `base` transform places the
arm in it; the identity when it has none): the floor is the half-space `z <= floor` (metres), and
each `Obstacle` has a shape (`wsmap.collision.geometry.Shape`, its `origin` the
obstacle's pose) in the `"world"` frame or the arm's `"base"` frame (moved with the base).

Only moving bodies are checked against a scene: body 0 (the base and links fixed to it) stands where
the user put it, on the floor or on a table, and touching what it stands on is not a collision.

A scene file (`load_scene`) is YAML or JSON::

    frame: base            # default frame of the obstacles: base (default) or world
    floor: true            # true (z = 0), false, or a height in metres
    obstacles:
      - {name: table, shape: box, size: [1.0, 0.8, 0.04], xyz: [0.6, 0, -0.02]}
      - {shape: cylinder, radius: 0.05, length: 0.6, xyz: [0.4, 0.4, 0.3], rpy: [0, 0, 0]}
      - {shape: sphere, radius: 0.1, xyz: [0.5, -0.3, 0.5], frame: world}
      - {shape: mesh, file: bowl.stl, scale: 1.0, xyz: [0.5, 0, 0.1]}

`xyz` (m) and `rpy` (rad, URDF's fixed-axis roll-pitch-yaw) place an obstacle; the other keys are
its shape kind's (`ShapeKind.scene_keys`, `wsmap.collision.shapes`); a mesh file is read relative to
the scene file. Anything else (an unknown shape or key, a NaN or negative size, a number beyond
`MAX_COORDINATE` (1 km), more than `MAX_OBSTACLES` obstacles, a file that is not YAML/JSON) is a
`CollisionError` naming the file and the problem, before any work. The file is read by the job
files' hardened reader (`wsmap.safe_load.load_config`): YAML aliases (an alias bomb), duplicate
keys, nesting deeper than 32 levels and files over 1 MB are refused before anything is built.

A file ending in `.urdf` is read as the URDF of a work cell (`scene_from_urdf`, below).

**Work cells.** A work-cell URDF (`scene_from_urdf`) is a tree of links joined by `fixed` joints
(no arm in it: the arm comes from its own URDF, MJCF, DH table or name); every `<collision>` element
of every link becomes one `Obstacle` of a `Scene`. The shapes are read by the same reader as an
arm's collision elements (`wsmap.collision.geometry.urdf_link_shapes`, the shape records of
`wsmap.collision.shapes`: box, cylinder, sphere, capsule; meshes through trimesh, `package://`,
`file://` and relative paths looked up as for an arm).

**Frames.** `T_link` is a link's pose in the frame of the cell's root link (the product of the
fixed joints' `<origin>` from the root down); a collision element's pose is
`T_link · origin`. Then

* `mount=None` (default): the cell's root link *is* the world frame of the arm's chain, and the
  obstacles are `"world"` obstacles: they stay where they are when the arm's base moves (the
  chain's `base` transform places the arm in the cell; `wsmap.base_placement` checks each
  candidate base's solutions against them where they stand);
* `mount="LINK"`: the arm's base is bolted to that link of the cell (its frame is the arm's base
  frame, body 0 of the chain), and the obstacles are `"base"` obstacles at
  `T_mount⁻¹ · T_link · origin`: they move with the base (a map in the base frame, a base
  placement of the whole cell).

The floor is not part of a cell file: `floor` (False, True for `z = 0`, or a height in metres of
the world frame) adds it, as a scene file's `floor:` does; a floor the arm must not go through
can also be a thin box in the cell.

Bad input is a `CollisionError` naming the file, before any work:
not a URDF, several root links, a joint that is not `fixed` (an arm, a conveyor), an unknown
mount link, a cell without any `<collision>` element, a collision mesh that is missing, empty or
not a mesh, a shape with NaN or non-positive sizes.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ..kinematics.urdf import URDFError, URDFTree, parse_xml, read_source, rpy_matrix
from ..safe_load import ConfigError, load_config
from .errors import CollisionError
from .fields import MAX_COORDINATE, scene_vector, shown, urdf_origin
from .geometry import urdf_link_shapes
from .shapes import SHAPE_KINDS, Shape
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap._typing import PathLike

__all__ = ["FRAMES", "CELL_SUFFIXES", "MAX_OBSTACLES", "Obstacle", "Scene", "load_scene", "scene_from_dict",
           "scene_from_urdf"]

FRAMES = ("base", "world")
#: The most obstacles a scene may hold: every moving link is tested against each for every
#: configuration, so a scene of 10^4 obstacles already costs 10^4 sphere tests per link and pose.
MAX_OBSTACLES = 10_000
_COMMON = ("name", "shape", "xyz", "rpy", "frame")


@dataclass(frozen=True, eq=False)
class Obstacle:
    """One obstacle: `shape` (its `origin` the pose in `frame`), `frame` `"base"` or
    `"world"`, `name` for messages and map files."""

    name: str
    shape: Shape
    frame: str = "base"

    def __post_init__(self):
        if self.frame not in FRAMES:
            raise CollisionError(f"obstacle {self.name!r}: frame must be one of {', '.join(FRAMES)}, "
                                 f"got {self.frame!r}")

    def pose(self, base: np.ndarray | None) -> np.ndarray:
        """The obstacle's world pose (4, 4), `base` the arm's base transform (or None)."""
        if self.frame == "base" and base is not None:
            return base @ self.shape.origin
        return self.shape.origin


@dataclass(frozen=True, eq=False)
class Scene:
    """The floor height `floor` (m, world `z`; `None`: no floor) and `obstacles`."""

    floor: float | None = None
    obstacles: tuple = ()

    def __post_init__(self):
        if self.floor is not None and (isinstance(self.floor, bool) or not math.isfinite(float(self.floor))
                                       or abs(float(self.floor)) > MAX_COORDINATE):
            raise CollisionError(f"the floor height must be a finite number of metres (at most {MAX_COORDINATE:g} "
                                 f"in magnitude) or None, got {self.floor!r}")
        object.__setattr__(self, "obstacles", tuple(self.obstacles))
        if len(self.obstacles) > MAX_OBSTACLES:
            raise CollisionError(f"a scene holds at most {MAX_OBSTACLES} obstacles, got {len(self.obstacles)}")
        for ob in self.obstacles:
            if not isinstance(ob, Obstacle):
                raise CollisionError(f"scene obstacles must be Obstacle records, got {type(ob).__name__}")

    @property
    def empty(self) -> bool:
        return self.floor is None and not self.obstacles

    def triangles(self, base: np.ndarray | None = None) -> list[tuple[str, np.ndarray, np.ndarray]]:
        """The obstacles as triangle meshes for drawing (a map's slices and 3-D view): one
        `(name, vertices (V, 3), faces (F, 3))` per obstacle whose kind can be drawn
        (`ShapeKind.triangles`), the vertices in the world frame (m), base-frame obstacles placed
        by `base` (the arm's base transform `(4, 4)`, or None). The floor is not among them."""
        out = []
        for ob in self.obstacles:
            tri = ob.shape.record.triangles(ob.shape)
            if tri is not None:
                P = ob.pose(base)
                out.append((ob.name, np.asarray(tri[0], dtype=np.float64) @ P[:3, :3].T + P[:3, 3],
                            np.asarray(tri[1], dtype=np.int64)))
        return out

    def describe(self) -> dict:
        """A JSON-able record (map files)."""
        return {"floor": self.floor, "obstacles": [{"name": o.name, "frame": o.frame, **o.shape.describe()}
                                                   for o in self.obstacles]}


def _obstacle(item, i: int, label: str, frame: str, folder: str | None) -> Obstacle:
    where = f"{label}: obstacle {i + 1}"
    if not isinstance(item, Mapping):
        raise CollisionError(f"{where} must be a mapping with a 'shape', got {type(item).__name__}")
    name = item.get("shape")
    if not isinstance(name, str) or name not in SHAPE_KINDS:
        raise CollisionError(f"{where} has unknown shape {shown(name)}; shapes are {', '.join(SHAPE_KINDS.names())}")
    kind = SHAPE_KINDS.get(name)
    unknown = sorted(set(item) - set(_COMMON) - set(kind.scene_keys))
    if unknown:
        raise CollisionError(f"{where} ({name}) has unknown keys {', '.join(map(str, unknown))}; a {name} takes "
                             f"{', '.join(_COMMON + kind.scene_keys)}")
    name = str(item.get("name", f"{name}{i + 1}"))[:80]
    T = np.eye(4)
    T[:3, 3] = scene_vector(label, f"obstacle {name!r} xyz", item.get("xyz", [0, 0, 0]))
    T[:3, :3] = rpy_matrix(scene_vector(label, f"obstacle {name!r} rpy", item.get("rpy", [0, 0, 0])))
    return Obstacle(name, kind.from_scene(item, T, label, name, folder), item.get("frame", frame))


def scene_from_dict(d, label: str = "scene", folder: str | None = None) -> Scene:
    """A `Scene` from the mapping of a scene file (module notes); `label` names it in
    messages, `folder` is where relative mesh files are."""
    if not isinstance(d, Mapping):
        raise CollisionError(f"{label} must be a mapping (frame, floor, obstacles), got {type(d).__name__}")
    unknown = sorted(set(d) - {"frame", "floor", "obstacles"})
    if unknown:
        raise CollisionError(f"{label} has unknown keys {', '.join(map(str, unknown))}; a scene has frame, floor, "
                             "obstacles")
    frame = d.get("frame", "base")
    if frame not in FRAMES:
        raise CollisionError(f"{label}: frame must be one of {', '.join(FRAMES)}, got {shown(frame)}")
    floor = d.get("floor", False)
    if floor is True:
        floor = 0.0
    elif floor is False or floor is None:
        floor = None
    elif isinstance(floor, (int, float)) and math.isfinite(floor) and abs(floor) <= MAX_COORDINATE:
        floor = float(floor)
    else:
        raise CollisionError(f"{label}: floor must be true, false or a finite height in metres (at most "
                             f"{MAX_COORDINATE:g} in magnitude), got {shown(floor)}")
    obstacles = d.get("obstacles", []) or []
    if not isinstance(obstacles, Sequence) or isinstance(obstacles, str):
        raise CollisionError(f"{label}: obstacles must be a list, got {type(obstacles).__name__}")
    if len(obstacles) > MAX_OBSTACLES:
        raise CollisionError(f"{label} has {len(obstacles)} obstacles, more than a scene may hold ({MAX_OBSTACLES})")
    for item in obstacles:
        if isinstance(item, Mapping) and item.get("frame", frame) not in FRAMES:
            raise CollisionError(f"{label}: obstacle frame must be one of {', '.join(FRAMES)}, "
                                 f"got {shown(item.get('frame'))}")
    return Scene(floor, tuple(_obstacle(item, i, label, frame, folder) for i, item in enumerate(obstacles)))


def load_scene(path: PathLike, mount: str | None = None) -> Scene:
    """Read a scene file: YAML or JSON (module notes), or, by its suffix `.urdf`, the URDF of a
    work cell (`scene_from_urdf`; `mount` is the cell's link the arm's
    base is attached to, which puts the obstacles in the base frame). Every problem is a one-line
    `CollisionError` naming the file."""
    path = os.fspath(path)
    if path.lower().endswith(CELL_SUFFIXES):
        return scene_from_urdf(path, mount)
    label = f"scene file {path!r}"
    if mount is not None:
        raise CollisionError(f"{label}: a mount link ({mount!r}) is for a work-cell URDF (.urdf); a YAML/JSON scene "
                             "gives each obstacle's frame (base or world)")
    if not os.path.isfile(path):
        raise CollisionError(f"{label}: no such file")
    if os.path.getsize(path) == 0:
        raise CollisionError(f"{label} is empty")
    # the job files' hardened reader: no YAML aliases (an alias bomb), duplicate keys, nesting beyond
    # MAX_DEPTH, huge integers or files over MAX_CONFIG_BYTES; JSON text is YAML, so a scene.yaml
    # may hold either
    try:
        d = load_config(path, "scene file")
    except ConfigError as exc:
        msg = str(exc)
        for fmt in ("YAML", "JSON"):  # the scene's own wording for a syntax error
            msg = msg.replace(f": not valid {fmt}: ", " is not YAML or JSON: ")
        raise CollisionError(msg) from None
    return scene_from_dict(d, label, os.path.dirname(os.path.abspath(path)))


# ------------------------------------------------------------------------------------ work cells
#: File name endings `wsmap.collision.load_scene` reads as a work-cell URDF.
CELL_SUFFIXES = (".urdf",)


def scene_from_urdf(source: PathLike, mount: str | None = None, *, floor: bool | float = False) -> Scene:
    """The obstacles of a work-cell URDF as a `Scene` (module notes, "Work cells": frames, bad input).

    Parameters
    ----------
    source : path or str
        The cell's URDF file (or its XML text): links joined by fixed joints, with `<collision>`
        elements.
    mount : str, optional
        The cell's link the arm's base is attached to: the obstacles are then in the arm's
        `"base"` frame (they move with the base). Default: the cell's root link is the world
        frame and the obstacles are `"world"` obstacles.
    floor : bool or float
        `False` (default): no floor; `True`: the floor `z = 0`; a number: the floor at that
        height (m, world frame).

    Returns
    -------
    Scene
        One obstacle per `<collision>` element, named after its link (`LINK` when the link has
        one collision element, else `LINK/NAME` with the element's `name` attribute or its
        position `1, 2, ...`), in the order of the links in the file.
    """
    try:
        data, label, path = read_source(source)
    except FileNotFoundError:
        raise CollisionError(f"work-cell URDF file {os.fspath(source)!r}: no such file") from None
    try:
        root = parse_xml(data, label)
        tree = URDFTree(root, label)
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
    floor_z = scene_from_dict({"floor": floor}, label).floor  # the scene files' rule
    count = sum(len(el.findall("collision")) for el in root.findall("link"))
    if count > MAX_OBSTACLES:  # before any mesh is read
        raise CollisionError(f"{label} has {count} <collision> elements, more than a scene may hold ({MAX_OBSTACLES})")
    # every link's pose in the root frame, walking down the tree (fixed joints: origins only)
    pose = {roots[0]: np.eye(4)}
    stack = [roots[0]]
    while stack:
        parent = stack.pop()
        for jname in tree.children[parent]:
            child = tree.child(jname)
            pose[child] = pose[parent] @ urdf_origin(tree.joints[jname].find("origin"), label, f"joint {jname!r}")
            stack.append(child)
    if mount is None:
        frame, ref = "world", np.eye(4)
    else:
        frame, ref = "base", np.linalg.inv(pose[mount])
    urdf_dir = os.path.dirname(os.path.abspath(path)) if path else None
    obstacles = []
    for link_el in root.findall("link"):
        name = link_el.get("name")
        shapes = urdf_link_shapes(link_el, label, urdf_dir)  # meshes read (and checked) here
        names = [c.get("name") or str(i + 1) for i, c in enumerate(link_el.findall("collision"))]
        T = ref @ pose[name]
        for s, cname in zip(shapes, names):
            obstacles.append(Obstacle(name if len(shapes) == 1 else f"{name}/{cname}", s.placed(T), frame))
    if not obstacles:
        raise CollisionError(f"{label} has no <collision> elements: a work cell's obstacles are its links' "
                             "<collision> geometry")
    return Scene(floor_z, tuple(obstacles))
