"""Writing files: atomic writes, output-path checks, the one writer of tables and of JSON (and the
key check of a JSON record read back, `check_record`).

Every file the project writes goes through `atomic_path` (one file) or `atomic_paths`
(several outputs of one run): a reader never sees half a file, an interrupted or failed run leaves
the files that were there before, and the outputs of one run appear together or not at all.
"""

from __future__ import annotations

import errno
import json
import math
import os
import re
import tempfile
from collections.abc import Iterable, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

__all__ = [
    "available_memory",
    "OutputPathError",
    "check_output_path",
    "check_outputs",
    "atomic_path",
    "atomic_paths",
    "jsonable",
    "write_json",
    "check_record",
    "format_cell",
    "plus_minus",
    "markdown_table",
    "write_table",
    "read_text",
    "numeric_rows",
]


class OutputPathError(ValueError):
    """An output path that cannot be written: empty, a directory, or in a folder one cannot write."""


def check_output_path(path, what: str = "output") -> Path:
    """`path` as a `Path` after checking, leaving nothing behind, that a file can be put there.

    Refused (`OutputPathError`, naming `what` and the path): an empty path, an existing
    directory, a path whose nearest existing folder is not a folder or is not writable — tested by
    creating and removing a temporary file there, since `os.access` says yes to root on a
    read-only folder. Missing folders are fine: `atomic_path` creates them when the run has
    succeeded. Several outputs of one run: `check_outputs`.
    """
    if path is None or str(path).strip() == "":
        raise OutputPathError(f"{what} path is empty")
    p = Path(path)
    if p.is_dir() or str(path).endswith(os.sep) or p.name in ("", ".", ".."):
        raise OutputPathError(f"{what} path {str(path)!r} is a directory; give a file name")
    parent = p.parent
    while not parent.exists():
        if parent == parent.parent:
            break
        parent = parent.parent
    if not parent.is_dir():
        raise OutputPathError(f"{what} path {str(path)!r}: {str(parent)!r} is not a directory")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise OutputPathError(f"{what} path {str(path)!r}: no permission to write in {str(parent)!r}")
    _probe_writable(parent, what, path)
    return p


def _probe_writable(folder: Path, what: str, path) -> None:
    """Create (and remove) a temporary file in `folder`: the one test of writability that root,
    read-only mounts, quotas and ACLs cannot fool (`os.access` says yes to root everywhere)."""
    try:
        fd, probe = tempfile.mkstemp(prefix=".wsmap-probe-", dir=folder)
    except OSError as e:
        raise OutputPathError(f"{what} path {str(path)!r}: no permission to write in {str(folder)!r} "
                              f"({e.strerror or e})") from None
    os.close(fd)
    os.unlink(probe)


def _same_file(a: Path, b: Path) -> bool:
    """Whether `a` and `b` are one file: the same real path (symbolic links resolved), or two
    existing names of one inode (hard links)."""
    if os.path.realpath(a) == os.path.realpath(b):
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:  # one of them does not exist (yet)
        return False


def check_outputs(outputs: Mapping[str, Any], inputs: Mapping[str, Any] | None = None) -> dict[str, Path]:
    """The outputs of one run checked together before any work: `{option: Path}` for every
    `outputs` entry that is not `None` (`option` names it in messages, e.g. `"--out"`).

    Each is checked by `check_output_path` (writable, by really creating a file in its folder);
    no two may be the same file (compared after resolving symbolic links, and by inode for hard
    links), and none may be one of the run's `inputs` (`{option: path}`, `None` skipped), which
    the run would otherwise replace. Each problem is an `OutputPathError` naming the options.
    """
    out = {what: check_output_path(p, what) for what, p in outputs.items() if p is not None}
    names = list(out)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            if _same_file(out[a], out[b]):
                raise OutputPathError(f"{a} {str(out[a])!r} and {b} {str(out[b])!r} are the same file; give each "
                                      "output its own")
    for what, p in (inputs or {}).items():
        if p is None:
            continue
        for a, q in out.items():
            if _same_file(q, Path(p)):
                raise OutputPathError(f"{a} {str(q)!r} is the input {what} {str(p)!r}: writing it would replace "
                                      "the input; give another output path")
    return out


def _mode_for_new_files() -> int:
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


def _temp_beside(path: Path, suffix: str | None) -> Path:
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix or path.suffix or ".tmp", dir=path.parent)
    except OSError as e:
        # name the user's path, not the temporary file's
        raise OSError(e.errno, f"cannot write {str(path)!r}: {e.strerror}") from None
    os.close(fd)
    return Path(tmp)


#: The errors of a full disk or quota, which name no file when a write (not an open) hits them.
_FULL = {errno.ENOSPC, getattr(errno, "EDQUOT", errno.ENOSPC), errno.EFBIG}


@contextmanager
def atomic_paths(paths: Sequence, suffixes: Sequence[str | None] | None = None):
    """Yield temporary paths beside each of `paths`; on success each replaces its target.

    The renames happen only after the `with` block finished without an exception, so a failed
    run leaves every target as it was (and removes the temporary files). Each temporary file keeps
    its target's suffix (or the one in `suffixes`) because some writers (`np.savez`,
    `matplotlib`) choose the format from it. The results get the mode any new file gets
    (`0666 & ~umask`; `mkstemp` would leave `0600`).
    """
    paths = [Path(p) for p in paths]
    suffixes = list(suffixes) if suffixes is not None else [None] * len(paths)
    if len(set(map(os.path.realpath, paths))) != len(paths):
        raise OutputPathError(f"two outputs of one run share a path: {[str(p) for p in paths]}")
    tmps: list[Path] = []
    try:
        for p, s in zip(paths, suffixes):
            tmps.append(_temp_beside(p, s))
        try:
            yield list(tmps)
        except OSError as e:
            if e.errno in _FULL and (e.filename is None or str(e.filename) in map(str, tmps)):
                # a full disk's error names no file (or the temporary one): name the outputs
                raise OSError(e.errno, f"{e.strerror or e} (writing {', '.join(map(str, paths))})") from e
            raise
        mode = _mode_for_new_files()
        for t in tmps:
            os.chmod(t, mode)
        _replace_all(tmps, paths)
    finally:
        for t in tmps:
            if t.exists():
                t.unlink()


def _replace_all(tmps: list[Path], paths: list[Path]) -> None:
    """Rename every `tmps[i]` over `paths[i]`; if one rename fails, undo the ones before it.

    Each existing target is first hard-linked (copied where links are not possible) to a backup
    beside it, so that a failure half way restores the files that were there.
    """
    backups: list[Path | None] = []
    done = 0
    try:
        for p in paths:
            if p.exists() and not p.is_dir():
                b = _temp_beside(p, ".bak")
                b.unlink()
                try:
                    os.link(p, b)
                except OSError:
                    import shutil

                    shutil.copy2(p, b)
                backups.append(b)
            else:
                backups.append(None)
        for t, p in zip(tmps, paths):
            try:
                os.replace(t, p)
            except OSError as e:
                raise OSError(e.errno, f"cannot write {str(p)!r}: {e.strerror}") from None
            done += 1
    except BaseException:
        for p, b in list(zip(paths, backups))[:done]:
            if b is not None:
                os.replace(b, p)
            elif p.exists():
                p.unlink()
        raise
    finally:
        for b in backups:
            if b is not None and b.exists():
                b.unlink()


@contextmanager
def atomic_path(path, suffix: str | None = None):
    """Yield a temporary path beside `path`; on success it replaces `path` in one rename.

    On an exception the temporary file is removed and `path` is left as it was.
    """
    with atomic_paths([path], [suffix]) as (tmp,):
        yield tmp


# ----------------------------------------------------------------------------------------- JSON
def jsonable(value):
    """`value` as plain JSON data: numpy arrays and scalars to Python, NaN and ±inf to `None`
    (strict JSON has no NaN), mapping keys to strings."""
    if isinstance(value, Mapping):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, (float, np.floating)):
        v = float(value)
        return v if math.isfinite(v) else None
    return value


def check_record(d, known, what: str, name: str) -> None:
    """Hold a record read back (a dict from JSON) to its keys: `ValueError` "`what` must be a
    dict" when `d` is not one, "unknown `name` keys [...]; known: [...]" when it has a key not
    in `known` (missing keys are the reader's to check)."""
    if not isinstance(d, dict):
        raise ValueError(f"{what} must be a dict; got {type(d).__name__}")
    unknown = sorted(set(d) - set(known))
    if unknown:
        raise ValueError(f"unknown {name} keys {unknown}; known: {sorted(known)}")


def write_json(obj, path) -> Path:
    """Write `obj` as indented JSON (through `jsonable`) atomically; returns `path`."""
    path = Path(path)
    text = json.dumps(jsonable(obj), indent=2, allow_nan=False) + "\n"
    with atomic_path(path) as tmp:
        tmp.write_text(text)
    return path


# --------------------------------------------------------------------------------------- tables
def format_cell(v, digits: int = 4, missing: str = "") -> str:
    """One Markdown cell: integers as integers, floats to `digits` decimals (3 significant digits
    when very large or small), NaN as "NaN", `None`/pandas' missing values as `missing`."""
    if v is None or type(v).__name__ in ("NAType", "NaTType"):
        return missing
    if isinstance(v, (bool, np.bool_)):
        return str(bool(v))
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        v = float(v)
        if math.isnan(v):
            return "NaN"
        a = abs(v)
        return f"{v:.3g}" if a != 0 and (a >= 1e5 or a < 1e-3) else f"{v:.{digits}f}"
    return str(v).replace("|", "\\|")


def plus_minus(mean, std, digits: int = 4) -> str:
    """`"0.9298 ± 0.1258"`; `"NaN"` for an undefined mean, the mean alone for an undefined std."""
    if mean is None or (isinstance(mean, float) and math.isnan(mean)):
        return "NaN"
    if std is None or (isinstance(std, float) and math.isnan(std)):
        return f"{mean:.{digits}f}"
    return f"{mean:.{digits}f} ± {std:.{digits}f}"


def _rows_and_columns(table, columns):
    if hasattr(table, "to_dict") and hasattr(table, "columns"):  # a pandas DataFrame
        cols = [str(c) for c in table.columns] if columns is None else list(columns)
        return [dict(zip(map(str, table.columns), row)) for row in table.itertuples(index=False)], cols
    rows = list(table)
    cols = list(columns) if columns is not None else (list(rows[0]) if rows else [])
    return rows, cols


def markdown_table(table, columns: Sequence[str] | None = None, *, digits: int = 4, missing: str = "",
                   whole: Iterable[str] = ()) -> str:
    """A GitHub-Markdown table of a DataFrame (index left out) or of a list of dicts.

    Cells through `format_cell`; float columns named in `whole` are shown as integers
    when every value is whole (e.g. epochs averaged over sessions that all ran as many).
    """
    rows, cols = _rows_and_columns(table, columns)
    if not cols:
        return "(no rows)\n"
    whole = set(whole)
    as_int = {c for c in cols if c in whole and all(
        isinstance(r.get(c), (int, float, np.integer, np.floating)) and
        (math.isnan(float(r[c])) or float(r[c]) == round(float(r[c]))) for r in rows)}

    def cell(r, c):
        v = r.get(c)
        if c in as_int and not (isinstance(v, float) and math.isnan(v)):
            return str(int(round(float(v))))
        return format_cell(v, digits, missing)

    lines = ["| " + " | ".join(cols) + " |", "|" + "|".join("---" for _ in cols) + "|"]
    lines += ["| " + " | ".join(cell(r, c) for c in cols) + " |" for r in rows]
    return "\n".join(lines) + "\n"


def write_table(df, stem, *, digits: int = 4, whole: Iterable[str] = ()) -> tuple[Path, Path]:
    """Write a DataFrame as `STEM.csv` (full precision) and `STEM.md` (`markdown_table`),
    both or neither; returns both paths."""
    stem = Path(stem)
    csv, md = stem.with_name(stem.name + ".csv"), stem.with_name(stem.name + ".md")
    text = markdown_table(df, digits=digits, whole=whole)
    with atomic_paths([csv, md]) as (tcsv, tmd):
        df.to_csv(tcsv, index=False)
        tmd.write_text(text)
    return csv, md


def read_json(path) -> Any:
    """JSON from `path` (`FileNotFoundError` if missing)."""
    with open(path) as f:
        return json.load(f)


def read_text(path, subject: str, hint: str, *, encoding: str = "utf-8") -> str:
    """The text of the file at `path` (`encoding`; `"utf-8-sig"` also drops a byte-order mark
    as Excel writes it). A file that is not text is a `ValueError` naming it:
    `"<subject> not a text file (byte N is not UTF-8); <hint>"`, or `"(it holds NUL bytes)"`
    where it decodes but holds NUL bytes (a binary file that happens to be valid UTF-8).
    `subject` starts the message in the caller's style: `"--targets t.csv:"`, `"params.yaml is"`."""
    raw = Path(path).read_bytes()
    try:
        text = raw.decode(encoding)
    except UnicodeDecodeError as e:
        raise ValueError(f"{subject} not a text file (byte {e.start} is not UTF-8); {hint}") from None
    if "\x00" in text:
        raise ValueError(f"{subject} not a text file (it holds NUL bytes); {hint}")
    return text


def numeric_rows(text: str, label: str, *, limit: int | None = None, too_many: str = "") -> list[list[float]]:
    """The rows of numbers of a CSV-like text (cells split on commas, semicolons, tabs or spaces;
    blank lines and `#` lines are comments).

    Only the first row may be a header, and only when none of its cells is a number; any other
    cell that is not a number is a `ValueError` naming its line and cell
    (`"<label>: line 3, cell 2 is not a number: 'O.3'"`): a row with a typo is never dropped.
    With `limit`, more than `limit` rows is the `ValueError` `"<label>: <too_many>"`, raised as
    soon as the row past the limit is read. Rows may differ in length (the caller checks widths).
    """
    rows, header_allowed = [], True
    for k, line in enumerate(text.splitlines(), 1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        cells = [c for c in re.split(r"[,;\t ]+", line) if c]
        values, bad = [], []
        for c in cells:
            try:
                values.append(float(c))
            except ValueError:
                bad.append(c)
        if bad and header_allowed and len(bad) == len(cells):
            header_allowed = False  # a header line: no number in it
            continue
        header_allowed = False
        if bad:
            raise ValueError(f"{label}: line {k}, cell {cells.index(bad[0]) + 1} is not a number: {bad[0]!r}")
        rows.append(values)
        if limit is not None and len(rows) > limit:
            raise ValueError(f"{label}: {too_many}")
    return rows


def available_memory() -> int:
    """Bytes of memory available to this process (Linux `MemAvailable`; physical size elsewhere):
    what the memory checks before any work compare with (`wsmap.workspace.grids.check_fits`,
    `wsmap.safe_load.check_npz`)."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
