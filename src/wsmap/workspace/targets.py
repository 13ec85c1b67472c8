"""Target poses from files: the pose CSV of `wsmap place` (and of `wsmap.jobs.PlacementJob`).

A file holds one pose per row, in the world frame: 6 columns `x y z r1 r2 r3` (metres; radians,
`R = Rx(r1) Ry(r2) Rz(r3)`, `T = transl(x, y, z)·R`) or 16 columns (the 4x4 matrix, row by row).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..io import numeric_rows, read_text
from .maps import target_poses
from .placement import MAX_TARGETS
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from wsmap._typing import PathLike

__all__ = ["read_target_csv", "TARGET_CSV_HELP"]

#: What a target CSV holds, in words (the command line's help epilog).
TARGET_CSV_HELP = ("Targets file (CSV, world frame, one pose per row, cells separated by commas, semicolons, tabs or "
                   "spaces, a header line allowed): 6 columns x y z r1 r2 r3 (metres; radians, R = Rx(r1) Ry(r2) "
                   "Rz(r3), T = transl(x, y, z) R) or 16 columns (the 4x4 matrix, row by row).")


def read_target_csv(path: PathLike, option: str = "--targets") -> np.ndarray:
    """Target poses from a CSV file of 6 or 16 columns (see the module notes).

    Cells are separated by commas, semicolons, tabs or spaces; a UTF-8 byte-order mark (as Excel
    writes) is skipped; `#` lines and blank lines are comments. Only the first row may be a
    header, and only when none of its cells is a number: a row with a typo is an error naming its
    line and cell, never dropped.

    Parameters
    ----------
    path : path of the file
    option : how messages name the file's option (`"--targets"`)

    Returns
    -------
    (M, 4, 4) float64 poses in the world frame (metres). Every problem is a one-line `ValueError`
    naming the file (and the line and cell where there is one).
    """
    p = Path(path)
    if not p.is_file():
        raise ValueError(f"{option} {str(path)!r}: no such file")
    label = f"{option} {path}"
    text = read_text(p, f"{label}:", "give a CSV of numbers", encoding="utf-8-sig")
    rows = numeric_rows(text, label, limit=MAX_TARGETS, too_many=f"more than {MAX_TARGETS} poses (each target is one map over "
                        "every candidate base, 1 to 10 s on one core); split the file")
    if not rows:
        raise ValueError(f"{label}: no poses in the file")
    widths = {len(r) for r in rows}
    if len(widths) != 1 or widths.pop() not in (6, 16):
        raise ValueError(f"{label}: every row needs 6 values (x y z r1 r2 r3) or 16 (a 4x4 matrix); "
                         f"found rows of {sorted({len(r) for r in rows})} values")
    a = np.array(rows, dtype=np.float64)
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{label}: NaN or infinite values")
    if a.shape[1] == 6:
        return np.stack([target_poses(r[:3], r[3:], "standard") for r in a])
    return a.reshape(-1, 4, 4)
