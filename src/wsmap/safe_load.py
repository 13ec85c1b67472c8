"""YAML and JSON files read so that a hostile file cannot hurt: one line for every problem.

The reader of job files (`wsmap.jobs.config`) and scene files (`wsmap.collision.scene`); a module
of its own, below both, so that the collision layer reads scenes without importing `wsmap.jobs`.

`load_config(path, what)` returns the file's mapping, refusing before anything is built from it:
a file over `MAX_CONFIG_BYTES`; YAML aliases (an "alias bomb" of a few hundred bytes expands to
gigabytes when anything walks it: write the value out instead); duplicate keys (the second would
silently replace the first); nesting deeper than `MAX_DEPTH`; integers of more than 30 digits; any
tag beyond YAML's plain scalars, lists and mappings.

`loads_json(text)` reads JSON text a file carries inside it (a map file's grid and settings) with
the same nesting and integer bounds; `check_npz(path)` reads the array headers of a `.npz` before
numpy loads anything: a member must hold the bytes its header declares, numbers only.
"""

from __future__ import annotations

import json
from pathlib import Path

import yaml

from . import io

__all__ = ["ConfigError", "load_config", "loads_json", "check_npz", "MAX_CONFIG_BYTES", "MAX_DEPTH"]

#: The largest job file read (bytes): a study file is a page of settings.
MAX_CONFIG_BYTES = 1_000_000
#: The deepest nesting of lists and mappings a job file may have.
MAX_DEPTH = 32
_MAX_INT_DIGITS = 30


class ConfigError(ValueError):
    """A job file that cannot be used; the message names the file and what is wrong."""


class _Loader(yaml.SafeLoader):
    """YAML's safe loader without aliases, duplicate keys, deep nesting or huge integers."""

    def compose_node(self, parent, index):
        if self.check_event(yaml.AliasEvent):
            event = self.peek_event()
            raise ConfigError(f"line {event.start_mark.line + 1}: YAML aliases (*name) are not allowed in a job "
                              "file; write the value out")
        depth = getattr(self, "_depth", 0) + 1
        if depth > MAX_DEPTH:
            raise ConfigError(f"nested deeper than {MAX_DEPTH} levels")
        self._depth = depth
        try:
            return super().compose_node(parent, index)
        finally:
            self._depth = depth - 1

    def construct_mapping(self, node, deep=False):
        seen = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)
            if not isinstance(key, (str, int, float, bool)) and key is not None:
                raise ConfigError(f"line {key_node.start_mark.line + 1}: a key must be a plain value, not "
                                  f"{type(key).__name__}")
            if key in seen:
                raise ConfigError(f"line {key_node.start_mark.line + 1}: duplicate key {str(key)[:40]!r}")
            seen.add(key)
        return super().construct_mapping(node, deep=deep)


def _int(text: str) -> int:
    digits = text.lstrip("+-").replace("_", "")
    if len(digits) > _MAX_INT_DIGITS:
        raise ConfigError(f"an integer of {len(digits)} digits (at most {_MAX_INT_DIGITS})")
    return int(text)


def _yaml_int(loader, node):
    digits = loader.construct_scalar(node).lstrip("+-").replace("_", "")
    if len(digits) > _MAX_INT_DIGITS:
        raise ConfigError(f"line {node.start_mark.line + 1}: an integer of {len(digits)} digits "
                          f"(at most {_MAX_INT_DIGITS})")
    return yaml.SafeLoader.construct_yaml_int(loader, node)


_Loader.add_constructor("tag:yaml.org,2002:int", _yaml_int)


def _pairs(pairs):
    out = {}
    for k, v in pairs:
        if k in out:
            raise ConfigError(f"duplicate key {str(k)[:40]!r}")
        out[k] = v
    return out


def _depth_ok(text: str) -> None:
    """JSON nesting deeper than `MAX_DEPTH` refused before parsing (the parser recurses)."""
    depth = deepest = 0
    in_string = escaped = False
    for ch in text:
        if in_string:
            escaped = not escaped and ch == "\\"
            if ch == '"' and not escaped:
                in_string = False
            continue
        if ch == '"':
            in_string = True
        elif ch in "[{":
            depth += 1
            deepest = max(deepest, depth)
            if deepest > MAX_DEPTH:
                raise ConfigError(f"nested deeper than {MAX_DEPTH} levels")
        elif ch in "]}":
            depth -= 1


def load_config(path, what: str = "job file") -> dict:
    """The mapping of a YAML or JSON job file (`.json` is JSON, anything else YAML); every problem
    a `ConfigError` (a `ValueError`) of one line naming `what` and the file."""
    p = Path(path)
    label = f"{what} {str(path)!r}"
    if not p.is_file():
        raise ConfigError(f"{label}: no such file")
    size = p.stat().st_size
    if size > MAX_CONFIG_BYTES:
        raise ConfigError(f"{label}: {size} bytes, more than a job file holds (at most {MAX_CONFIG_BYTES})")
    try:
        text = p.read_text(encoding="utf-8-sig")
    except (UnicodeDecodeError, OSError) as e:
        raise ConfigError(f"{label}: not a readable UTF-8 text file ({type(e).__name__})") from None
    try:
        if p.suffix.lower() == ".json":
            _depth_ok(text)
            data = json.loads(text, object_pairs_hook=_pairs, parse_int=_int,
                              parse_constant=lambda c: (_ for _ in ()).throw(ConfigError(f"{c} is not a number")))
        else:
            data = yaml.load(text, Loader=_Loader)  # noqa: S506 -- _Loader is a SafeLoader
    except ConfigError as e:
        raise ConfigError(f"{label}: {e}") from None
    except (yaml.YAMLError, json.JSONDecodeError, RecursionError) as e:
        first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise ConfigError(f"{label}: not valid {'JSON' if p.suffix.lower() == '.json' else 'YAML'}: "
                          f"{first[:200]}") from None
    if not isinstance(data, dict):
        raise ConfigError(f"{label}: the file must hold a mapping of settings, got {type(data).__name__}")
    return data


def loads_json(text: str, *, constants: bool = True):
    """JSON `text` parsed with the job files' bounds: nesting at most `MAX_DEPTH` (checked before
    parsing: the parser recurses), integers of at most 30 digits; `constants` allows `NaN` and
    `Infinity` (what `json.dumps` writes for them). Every problem a one-line `ConfigError`."""
    _depth_ok(text)
    try:
        return json.loads(text, parse_int=_int, parse_constant=(float if constants else lambda c: (_ for _ in ()).throw(
            ConfigError(f"{c} is not a number"))))
    except json.JSONDecodeError as e:
        raise ConfigError(f"not valid JSON: {str(e)[:200]}") from None
    except RecursionError:  # pragma: no cover - _depth_ok stops it first
        raise ConfigError(f"nested deeper than {MAX_DEPTH} levels") from None


def check_npz(path, text=()) -> dict:
    """`{member: (shape, dtype)}` of the arrays in the `.npz` file `path`, from their headers,
    before numpy reads any data. A `ConfigError` of one line for a member whose header does not
    parse, whose dtype is not a plain number or bool (strings, records, objects; the members named
    in `text` are one string each, as `np.savez` stores a `str`), that declares more bytes than it
    holds (a 1 kB member declaring 10^12 elements), or more than half the memory available. Not a
    zip file: an empty answer, left to numpy's own error."""
    import zipfile

    out = {}
    try:
        zf = zipfile.ZipFile(path)
    except (zipfile.BadZipFile, OSError):
        return out
    with zf:
        for info in zf.infolist():
            name = info.filename[:-4] if info.filename.endswith(".npy") else info.filename
            with zf.open(info) as f:
                shape, dtype, offset = _npy_header(f, name)
            if name in text:
                if dtype.kind != "U" or shape != ():
                    raise ConfigError(f"member {name[:40]!r} must be one string, got {shape} "
                                      f"{_KINDS.get(dtype.kind, str(dtype)[:40])}")
            elif dtype.kind not in "biuf":
                raise ConfigError(f"member {name[:40]!r} holds {_KINDS.get(dtype.kind, str(dtype)[:40])}, not numbers")
            count = 1
            for n in shape:
                count *= int(n)
            declared = count * dtype.itemsize
            if declared != info.file_size - offset:
                raise ConfigError(f"member {name[:40]!r} declares {shape} {dtype} values ({declared} bytes) but holds "
                                  f"{info.file_size - offset} bytes")
            if declared > io.available_memory() // 2:
                raise ConfigError(f"member {name[:40]!r} holds {declared / 2**30:.2f} GiB, more than half the memory "
                                  "available")
            out[name] = (shape, dtype)
    return out


_KINDS = {"b": "booleans", "i": "integers", "u": "integers", "f": "floats", "S": "byte strings", "U": "strings", "O": "Python objects", "V": "compound records", "c": "complex numbers",
          "M": "dates", "m": "time spans"}


def _npy_header(f, name: str):
    """`(shape, dtype, data offset)` of the `.npy` stream `f`, or a `ConfigError`."""
    import numpy as np

    try:
        version = np.lib.format.read_magic(f)
        if version == (1, 0):
            shape, _, dtype = np.lib.format.read_array_header_1_0(f)
        else:
            shape, _, dtype = np.lib.format.read_array_header_2_0(f)
    except (ValueError, TypeError, SyntaxError, OverflowError, RecursionError, MemoryError) as e:
        raise ConfigError(f"member {name[:40]!r} has no readable .npy header ({type(e).__name__})") from None
    return tuple(shape), np.dtype(dtype), f.tell()
