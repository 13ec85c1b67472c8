"""A sphere: `size = (radius,)` (m), centred on its frame.

URDF `<sphere radius="r"/>`; MJCF `<geom type="sphere">`; a scene file's `{shape: sphere, radius: r}`.
A sphere is a capsule of length 0 to the checker's exact numpy layer (`swept_sphere`).
"""

from __future__ import annotations

import numpy as np

from ..fields import scene_positive, urdf_numbers
from .registry import SHAPE_KINDS, Shape, ShapeKind, revolved


class Sphere(ShapeKind):
    """The record of spheres (module notes)."""

    def bounding_spheres(self, shape, max_spheres):
        return np.zeros((1, 3)), np.array([shape.size[0]])

    def coal_geometry(self, shape):
        import coal

        return coal.Sphere(shape.size[0])

    def point_distance(self, size, local):
        return np.maximum(np.linalg.norm(local, axis=-1) - size[0], 0.0)

    def swept_sphere(self, shape):
        return 0.0, shape.size[0]

    def triangles(self, shape):
        a = np.linspace(-np.pi / 2, np.pi / 2, 17)
        return revolved(shape.size[0] * np.cos(a), shape.size[0] * np.sin(a))

    def from_urdf(self, el, origin, label, what, folder):
        return Shape("sphere", urdf_numbers(label, f"{what} <sphere radius>", el.get("radius"), 1), origin)

    def from_mjcf(self, model, geom, pose):
        return Shape("sphere", (model.geom_size[geom][0],), pose)

    def from_scene(self, item, pose, label, name, folder):
        return Shape("sphere", (scene_positive(label, f"obstacle {name!r} radius", item.get("radius")),), pose)


SPHERE = SHAPE_KINDS.register(Sphere(name="sphere", priority=30, size_fields=("radius",), urdf_tag="sphere",
                                     mjcf_type="mjGEOM_SPHERE", scene_keys=("radius",)))
