"""Job files (YAML or JSON) read so that a hostile file cannot hurt: one line for every problem.

`load_config(path, what)` returns the file's mapping, refusing before anything is built from it:
a file over `MAX_CONFIG_BYTES`; YAML aliases (an "alias bomb" of a few hundred bytes expands to
gigabytes when anything walks it: write the value out instead); duplicate keys (the second would
silently replace the first); nesting deeper than `MAX_DEPTH`; integers of more than 30 digits; any
tag beyond YAML's plain scalars, lists and mappings. `check_keys` then names an unknown or a
missing key with the file and the section it is in.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

# the reader itself is one level down (wsmap.safe_load), so that scene files use it too
from ..safe_load import MAX_CONFIG_BYTES, MAX_DEPTH, ConfigError, load_config

__all__ = ["ConfigError", "load_config", "check_keys", "MAX_CONFIG_BYTES", "MAX_DEPTH"]

if TYPE_CHECKING:
    from collections.abc import Iterable, Mapping


def check_keys(section: Mapping, known: Iterable[str], *, label: str, required: Iterable[str] = ()) -> None:
    """A `ConfigError` naming the first unknown key of `section` (with the known ones) or the
    first missing `required` one; `label` names the file and the section."""
    if not isinstance(section, dict):
        raise ConfigError(f"{label}: must be a mapping, got {type(section).__name__}")
    known = list(known)
    for key in section:
        if key not in known:
            raise ConfigError(f"{label}: unknown key {str(key)[:40]!r} (known: {', '.join(known)})")
    for key in required:
        if key not in section:
            raise ConfigError(f"{label}: missing key {key!r}")
