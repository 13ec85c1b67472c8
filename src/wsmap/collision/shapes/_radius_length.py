"""What the cylinder and the capsule read alike: a radius and a length (m), from a URDF element and
from a scene file. A helper of the plug-ins, not one (its name starts with `_`)."""

from __future__ import annotations

from ..errors import CollisionError
from ..fields import scene_positive, scene_vector, urdf_numbers
from .registry import ShapeKind

__all__ = ["read_urdf_radius_length", "read_scene_radius_length"]


def read_urdf_radius_length(kind: ShapeKind, el, label: str, what: str) -> tuple[float, float]:
    """`(radius, length)` of a URDF `<cylinder>` or `<capsule>` element `el` (m)."""
    r = urdf_numbers(label, f"{what} <{kind.urdf_tag} radius>", el.get("radius"), 1)[0]
    L = urdf_numbers(label, f"{what} <{kind.urdf_tag} length>", el.get("length"), 1)[0]
    return r, L


def read_scene_radius_length(kind: ShapeKind, item, label: str, name: str) -> tuple[float, float]:
    """`(radius, length)` of a scene-file cylinder or capsule `item` (m): the radius positive, the
    length positive, or non-negative where the kind allows 0 (`zero_allowed`)."""
    r = scene_positive(label, f"obstacle {name!r} radius", item.get("radius"))
    length = scene_vector(label, f"obstacle {name!r} length", item.get("length"), 1)[0]
    zero = "length" in kind.zero_allowed
    if length < 0 if zero else length <= 0:
        raise CollisionError(f"{label}: obstacle {name!r}: length must be {'>= 0' if zero else 'positive'}, "
                             f"got {item.get('length')!r}")
    return r, float(length)
