"""Checked numbers of the collision inputs: URDF attributes and `<origin>` elements, and the values
of a scene file (YAML/JSON). Every problem is a one-line `CollisionError` that starts with the
`label` naming the file, then says which value is wrong.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Sequence

import numpy as np

from ..kinematics.urdf import rpy_matrix
from .errors import CollisionError

__all__ = ["MAX_COORDINATE", "urdf_numbers", "urdf_origin", "scene_vector", "scene_positive", "shown"]

#: The largest coordinate, size or radius (m) of collision geometry: a work cell is metres across, and
#: beyond a kilometre coal's convex hulls, distances and transforms lose their precision or overflow
#: (a mesh vertex at 1e300 m crashes coal's hull).
MAX_COORDINATE = 1e3


def shown(value, limit: int = 60) -> str:
    """A user's value for a message, as they would write it: numbers joined by commas (`1, -1, 1`),
    other values by their repr, cut to `limit` characters: a message never dumps a long list or a
    mapping."""
    if isinstance(value, (list, tuple, np.ndarray)):
        text = ", ".join(f"{x:g}" if isinstance(x, (int, float, np.number)) and not isinstance(x, bool) else repr(x)
                         for x in list(value)[:12]) + (", ..." if len(value) > 12 else "")
    elif isinstance(value, dict):
        text = f"a mapping ({', '.join(map(str, list(value)[:6]))}{', ...' if len(value) > 6 else ''})"
    else:
        text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def urdf_numbers(label: str, what: str, text: str | None, count: int) -> tuple[float, ...]:
    """The numbers of a URDF attribute.

    Parameters
    ----------
    label : str
        The file, for messages.
    what : str
        The attribute, for messages (`"link 'hand' <collision> <box size>"`).
    text : str or None
        The attribute's text (None: missing).
    count : int
        How many numbers it must hold.

    Returns
    -------
    tuple of float
        `count` finite numbers of magnitude at most `MAX_COORDINATE`.
    """
    try:
        v = tuple(float(x) for x in (text or "").split())
    except ValueError:
        raise CollisionError(f"{label}: {what} is not numbers: {text!r}") from None
    if len(v) != count:
        raise CollisionError(f"{label}: {what} needs {count} numbers, got {text!r}")
    if not all(math.isfinite(x) for x in v):
        raise CollisionError(f"{label}: {what} contains NaN or infinity: {text!r}")
    if any(abs(x) > MAX_COORDINATE for x in v):
        raise CollisionError(f"{label}: {what} is beyond {MAX_COORDINATE:g} (collision geometry is at most "
                             f"{MAX_COORDINATE:g} m across): {text!r}")
    return v


def urdf_origin(el: ET.Element | None, label: str, what: str) -> np.ndarray:
    """The pose of a URDF `<origin xyz="..." rpy="...">` element.

    Parameters
    ----------
    el : xml.etree.ElementTree.Element or None
        The `<origin>` element; None (no element) is the identity. A missing attribute is `0 0 0`.
    label : str
        The file, for messages.
    what : str
        The element holding it, for messages (`"joint 'j1'"`).

    Returns
    -------
    numpy.ndarray
        `(4, 4)`: rotation `rpy_matrix(rpy)` (URDF's fixed-axis roll-pitch-yaw, rad), translation
        `xyz` (m, each at most `MAX_COORDINATE` in magnitude).
    """
    T = np.eye(4)
    if el is None:
        return T
    vals = []
    for key in ("xyz", "rpy"):
        text = el.get(key, "0 0 0")
        try:
            v = np.array([float(x) for x in text.split()])
        except ValueError:
            v = np.zeros(0)
        if v.shape != (3,) or not np.all(np.isfinite(v)):
            raise CollisionError(f"{label}: {what} <origin {key}={text!r}> is not three finite numbers")
        if key == "xyz" and np.any(np.abs(v) > MAX_COORDINATE):
            raise CollisionError(f"{label}: {what} <origin xyz={text!r}> is beyond {MAX_COORDINATE:g} m (collision "
                                 f"geometry is at most {MAX_COORDINATE:g} m from its frame)")
        vals.append(v)
    T[:3, :3] = rpy_matrix(vals[1])
    T[:3, 3] = vals[0]
    return T


def scene_vector(label: str, what: str, value, count: int = 3) -> np.ndarray:
    """A scene-file value of `count` numbers.

    Parameters
    ----------
    label : str
        The file, for messages.
    what : str
        The value, for messages (`"obstacle 'table' xyz"`).
    value : object
        The value as read from YAML/JSON: a list of numbers (or one number when `count` is 1).
    count : int
        How many numbers it must hold.

    Returns
    -------
    numpy.ndarray
        `(count,)` finite float64 numbers of magnitude at most `MAX_COORDINATE` (m, rad or a
        factor).
    """
    if isinstance(value, (int, float)) and not isinstance(value, bool) and count == 1:
        value = [value]
    if not isinstance(value, Sequence) or isinstance(value, str) or len(value) != count or not all(
            isinstance(x, (int, float)) and not isinstance(x, bool) for x in value):
        raise CollisionError(f"{label}: {what} must be {count} numbers, got {shown(value)}")
    v = np.array(value, dtype=np.float64)
    if not np.all(np.isfinite(v)):
        raise CollisionError(f"{label}: {what} contains NaN or infinity: {shown(value)}")
    if np.any(np.abs(v) > MAX_COORDINATE):
        raise CollisionError(f"{label}: {what} is beyond {MAX_COORDINATE:g} (collision geometry is at most "
                             f"{MAX_COORDINATE:g} m across): {shown(value)}")
    return v


def scene_positive(label: str, what: str, value) -> float:
    """A scene-file value that is one positive finite number (a radius, m); as `scene_vector`."""
    v = scene_vector(label, what, value, 1)[0]
    if v <= 0:
        raise CollisionError(f"{label}: {what} must be positive, got {shown(value)}")
    return float(v)
