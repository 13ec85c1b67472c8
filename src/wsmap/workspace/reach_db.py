"""ROS-Industrial REACH's results database (`reach.db.xml`), read for comparison with a wsmap study.

REACH (`reach`, `reach_ros`) saves a study as a Boost.Serialization XML archive of a
`ReachDatabase`: one result set per optimisation step, each a record per target with `reached`
(0/1), the `goal` pose (a 4x4 Eigen matrix written column by column, metres, in the kinematic base
frame), the `seed_state` and `goal_state` (joint name / value pairs, rad) and the `score` (REACH's
evaluators multiplied). `read_reach_db` returns them as arrays; the last set is REACH's answer.

The demo database of `reach_ros` (`data/cells/reach_demo/reach.db.xml`) is the reference the
`reach_study` stage and `tests/workspace/test_reach_db.py` compare a wsmap study with, target by
target.

Hostile files: a file over `MAX_DB_BYTES` is refused before it is read; the XML parser is
Python's expat, which refuses entity expansion beyond its amplification limit; every number is
checked finite and every record complete, one line naming the file and the record otherwise.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["ReachDatabase", "ReachDbError", "read_reach_db", "MAX_DB_BYTES"]

#: The largest database read (bytes): REACH's demo of 262 targets x 3 steps is 2 MB.
MAX_DB_BYTES = 512 * 1024 * 1024


class ReachDbError(ValueError):
    """A REACH database that cannot be read; the message names the file and the record."""


@dataclass(frozen=True)
class ReachDatabase:
    """A REACH results database.

    Attributes
    ----------
    reached : numpy.ndarray
        `(S, M)` bool: target `m` reached in result set `s` (one set per optimisation step).
    goals : numpy.ndarray
        `(S, M, 4, 4)` float64 goal poses (m), REACH's kinematic base frame.
    scores : numpy.ndarray
        `(S, M)` float64 scores (REACH's evaluators multiplied; 0 where not reached).
    goal_states : numpy.ndarray
        `(S, M, J)` float64 joint solutions (rad), columns in the order of `joints`.
    joints : tuple of str
        The joint names, as the first record lists them (REACH sorts them by name).
    source : str
        The file read.
    """

    reached: np.ndarray
    goals: np.ndarray
    scores: np.ndarray
    goal_states: np.ndarray
    joints: tuple
    source: str

    @property
    def final(self) -> int:
        """The index of REACH's answer: the last result set."""
        return len(self.reached) - 1

    def states(self, joint_order) -> np.ndarray:
        """The final set's goal states `(M, n)` with columns in `joint_order` (names)."""
        missing = [j for j in joint_order if j not in self.joints]
        if missing:
            raise ReachDbError(f"REACH database {self.source!r} has no joint {missing[0]!r} (it has "
                               f"{', '.join(self.joints)})")
        return self.goal_states[self.final][:, [self.joints.index(j) for j in joint_order]]


def _text(el, path: str, label: str) -> str:
    node = el.find(path)
    if node is None or node.text is None:
        raise ReachDbError(f"{label}: no <{path}>")
    return node.text


def _float(text: str, label: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise ReachDbError(f"{label}: {text!r:.40} is not a number") from None
    if not math.isfinite(v):
        raise ReachDbError(f"{label}: a NaN or infinite number")
    return v


def _record(item, label: str) -> tuple:
    reached = _text(item, "reached", label).strip() not in ("0", "false")
    goal = [_float(x.text or "", label) for x in item.findall("goal/matrix/item")]
    if len(goal) != 16:
        raise ReachDbError(f"{label}: the goal matrix has {len(goal)} numbers, not 16")
    states = item.findall("goal_state/item")
    names = tuple(_text(s, "first", label) for s in states)
    values = [_float(_text(s, "second", label), label) for s in states]
    score = _float(_text(item, "score", label), label)
    return reached, np.array(goal).reshape(4, 4).T, score, names, values


def read_reach_db(path) -> ReachDatabase:
    """Read REACH's `reach.db.xml` (module notes).

    Parameters
    ----------
    path : str or Path
        The Boost.Serialization XML archive REACH writes.

    Returns
    -------
    ReachDatabase

    Raises
    ------
    ReachDbError
        A missing, oversized or malformed file: one line naming the file and the record.
    """
    p = Path(path)
    label = f"REACH database {str(path)!r}"
    if not p.is_file():
        raise ReachDbError(f"{label}: no such file")
    if p.stat().st_size > MAX_DB_BYTES:
        raise ReachDbError(f"{label}: {p.stat().st_size} bytes, more than {MAX_DB_BYTES}")
    try:
        root = ET.parse(p).getroot()
    except ET.ParseError as exc:
        raise ReachDbError(f"{label} is not XML: {exc}") from None
    sets = root.findall("db/results/item")
    if not sets:
        raise ReachDbError(f"{label}: no result sets (<db><results><item>): not a REACH database")
    rows = []
    for s, rs in enumerate(sets):
        rows.append([_record(it, f"{label}, set {s}, target {m}") for m, it in enumerate(rs.findall("item"))])
    m, joints = len(rows[0]), rows[0][0][3] if rows[0] else ()
    for s, r in enumerate(rows):
        if len(r) != m or any(rec[3] != joints for rec in r):
            raise ReachDbError(f"{label}: set {s} has other targets or joints than set 0")
    return ReachDatabase(reached=np.array([[rec[0] for rec in r] for r in rows], dtype=bool).reshape(len(rows), m),
                         goals=np.array([[rec[1] for rec in r] for r in rows]).reshape(len(rows), m, 4, 4),
                         scores=np.array([[rec[2] for rec in r] for r in rows]).reshape(len(rows), m),
                         goal_states=np.array([[rec[4] for rec in r] for r in rows]).reshape(len(rows), m, len(joints)),
                         joints=joints, source=str(path))
