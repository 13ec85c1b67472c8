"""The error of the collision layer: geometry, an allowed-collision matrix or a scene that cannot be
used. It is its own module so that every part of `wsmap.collision` (the shape records of
`wsmap.collision.shapes` included) raises the same class without importing the others."""

from __future__ import annotations

__all__ = ["CollisionError"]


class CollisionError(ValueError):
    """Collision geometry, an allowed-collision matrix or a scene that cannot be used; the message
    names the file (or the object) and what is wrong."""
