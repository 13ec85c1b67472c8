"""A capsule: `size = (radius, length)` (m), the points within `radius` of the segment of `length`
along its `z` axis, centred on its frame (`length` between the centres of its end spheres, as URDF's
`<capsule>` and coal; 0 is a sphere).

URDF `<capsule radius="r" length="l"/>`; MJCF `<geom type="capsule">` (MuJoCo's size is the radius
and the half-length); a scene file's `{shape: capsule, radius: r, length: l}`. The named arms'
models are capsules, tested exactly by segment distances (`swept_sphere`).
"""

from __future__ import annotations

import numpy as np

from ._radius_length import read_scene_radius_length, read_urdf_radius_length
from .registry import SHAPE_KINDS, Shape, ShapeKind, revolved


class Capsule(ShapeKind):
    """The record of capsules (module notes)."""

    def bounding_spheres(self, shape, max_spheres):
        r, L = shape.size
        if max_spheres == 1 and L > 0:  # m + 1 spheres below would be 2
            return np.zeros((1, 3)), np.array([L / 2 + r])
        m = int(np.clip(np.ceil(L / r), 1, max_spheres - 1)) if L > 0 else 0
        # spheres on the segment, spacing s: a point within r of the segment is within
        # hypot(r, s/2) of the nearest centre
        c = np.zeros((m + 1, 3))
        c[:, 2] = np.linspace(-L / 2, L / 2, m + 1)
        return c, np.full(m + 1, np.hypot(r, L / (2 * m)) if m else r)

    def coal_geometry(self, shape):
        import coal

        return coal.Capsule(shape.size[0], shape.size[1])

    def point_distance(self, size, local):
        z = np.clip(local[..., 2], -size[1] / 2, size[1] / 2)
        return np.maximum(np.linalg.norm(local - np.stack([0 * z, 0 * z, z], -1), axis=-1) - size[0], 0.0)

    def swept_sphere(self, shape):
        return shape.size[1] / 2, shape.size[0]

    def triangles(self, shape):
        r, L = shape.size
        low, high = np.linspace(-np.pi / 2, 0.0, 9), np.linspace(0.0, np.pi / 2, 9)  # the two half spheres
        z = np.concatenate([-L / 2 + r * np.sin(low), L / 2 + r * np.sin(high)])
        return revolved(r * np.cos(np.concatenate([low, high])), z)

    def from_urdf(self, el, origin, label, what, folder):
        return Shape("capsule", read_urdf_radius_length(self, el, label, what), origin)

    def from_mjcf(self, model, geom, pose):
        s = model.geom_size[geom]
        return Shape("capsule", (s[0], 2 * s[1]), pose)

    def from_scene(self, item, pose, label, name, folder):
        return Shape("capsule", read_scene_radius_length(self, item, label, name), pose)


CAPSULE = SHAPE_KINDS.register(Capsule(name="capsule", priority=40, size_fields=("radius", "length"),
                                       zero_allowed=("length",), urdf_tag="capsule", mjcf_type="mjGEOM_CAPSULE",
                                       scene_keys=("radius", "length")))
