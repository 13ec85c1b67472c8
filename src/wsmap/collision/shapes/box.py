"""A box: `size = (x, y, z)`, its full edge lengths (m), centred on its frame.

URDF `<box size="x y z"/>`; MJCF `<geom type="box">` (MuJoCo's size holds half-lengths); a scene
file's `{shape: box, size: [x, y, z]}`.
"""

from __future__ import annotations

import numpy as np

from ..errors import CollisionError
from ..fields import scene_vector, urdf_numbers
from .registry import SHAPE_KINDS, Shape, ShapeKind


class Box(ShapeKind):
    """The record of boxes (module notes)."""

    def bounding_spheres(self, shape, max_spheres):
        # cut along the longest edge into pieces about as long as the box is wide
        dims = np.array(shape.size)
        a = int(np.argmax(dims))
        rest = np.delete(dims, a)
        m = int(np.clip(np.ceil(dims[a] / max(rest.max(), 1e-9)), 1, max_spheres))
        piece = dims.copy()
        piece[a] = dims[a] / m
        c = np.zeros((m, 3))
        c[:, a] = -dims[a] / 2 + piece[a] * (np.arange(m) + 0.5)
        return c, np.full(m, 0.5 * np.linalg.norm(piece))

    def coal_geometry(self, shape):
        import coal

        return coal.Box(*shape.size)

    def point_distance(self, size, local):
        return np.linalg.norm(np.maximum(np.abs(local) - np.array(size) / 2, 0.0), axis=-1)

    def triangles(self, shape):
        corners = (np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)]) - 0.5) * np.array(shape.size)
        faces = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                          [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
        return corners, faces

    def from_urdf(self, el, origin, label, what, folder):
        return Shape("box", urdf_numbers(label, f"{what} <box size>", el.get("size"), 3), origin)

    def from_mjcf(self, model, geom, pose):
        return Shape("box", tuple(2 * model.geom_size[geom]), pose)

    def from_scene(self, item, pose, label, name, folder):
        where = f"{label}: obstacle {name!r}"
        if "size" not in item:
            raise CollisionError(f"{where}: a box needs size: [x, y, z]")
        size = scene_vector(label, f"obstacle {name!r} size", item["size"])
        if np.any(size <= 0):
            raise CollisionError(f"{where}: box size must be positive, got {item['size']!r}")
        return Shape("box", tuple(size), pose)


BOX = SHAPE_KINDS.register(Box(name="box", priority=10, size_fields=("x", "y", "z"), urdf_tag="box",
                               mjcf_type="mjGEOM_BOX", scene_keys=("size",)))
