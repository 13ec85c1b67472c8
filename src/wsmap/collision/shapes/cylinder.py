"""A cylinder: `size = (radius, length)` (m), centred on its frame, its axis `z`.

URDF `<cylinder radius="r" length="l"/>`; MJCF `<geom type="cylinder">` (MuJoCo's size is the radius
and the half-length); a scene file's `{shape: cylinder, radius: r, length: l}`.
"""

from __future__ import annotations

import numpy as np

from ._radius_length import read_scene_radius_length, read_urdf_radius_length
from .registry import SHAPE_KINDS, Shape, ShapeKind, revolved


class Cylinder(ShapeKind):
    """The record of cylinders (module notes)."""

    def bounding_spheres(self, shape, max_spheres):
        r, L = shape.size
        m = int(np.clip(np.ceil(L / (2 * r)), 1, max_spheres))
        c = np.zeros((m, 3))
        c[:, 2] = -L / 2 + L / m * (np.arange(m) + 0.5)
        return c, np.full(m, np.hypot(r, L / (2 * m)))

    def coal_geometry(self, shape):
        import coal

        return coal.Cylinder(shape.size[0], shape.size[1])

    def point_distance(self, size, local):
        rr = np.maximum(np.hypot(local[..., 0], local[..., 1]) - size[0], 0.0)
        return np.hypot(rr, np.maximum(np.abs(local[..., 2]) - size[1] / 2, 0.0))

    def triangles(self, shape):
        r, L = shape.size
        return revolved([0.0, r, r, 0.0], [-L / 2, -L / 2, L / 2, L / 2])

    def from_urdf(self, el, origin, label, what, folder):
        return Shape("cylinder", read_urdf_radius_length(self, el, label, what), origin)

    def from_mjcf(self, model, geom, pose):
        s = model.geom_size[geom]
        return Shape("cylinder", (s[0], 2 * s[1]), pose)

    def from_scene(self, item, pose, label, name, folder):
        return Shape("cylinder", read_scene_radius_length(self, item, label, name), pose)


CYLINDER = SHAPE_KINDS.register(Cylinder(name="cylinder", priority=20, size_fields=("radius", "length"),
                                         urdf_tag="cylinder", mjcf_type="mjGEOM_CYLINDER",
                                         scene_keys=("radius", "length")))
