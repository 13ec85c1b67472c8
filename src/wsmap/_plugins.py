"""One discipline for every plug-in folder: discovery by file, order by an explicit priority.

A plug-in folder (map kinds, closed forms, named arms, collision shapes, IK solvers, parts of the
paper) is a package whose every public module (a name not starting with `_`) is one plug-in and
ends by registering its record with the folder's `Registry`. The package's `__init__`
calls `discover` once; adding a plug-in is one new file in the folder and nothing else.

The order in which a registry lists and asks its records is the records' `priority` (lower
first), then their `name`: never the file names, never the order of an import line.

Example (the folder `wsmap/workspace/kinds/`)::

    # registry.py
    KINDS = Registry("map kind")
    # constant.py
    KINDS.register(MapKind(name="R3", priority=10, ...))
    # __init__.py
    discover(__name__, __path__)
"""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Iterable, Iterator
from typing import Generic, Protocol, TypeVar

__all__ = ["Plugin", "Registry", "discover"]


class Plugin(Protocol):
    """What a registry record carries: a unique `name` and its `priority` (lower is asked first)."""

    name: str
    priority: int


P = TypeVar("P", bound=Plugin)


def discover(package: str, path: Iterable[str]) -> list[str]:
    """Import every public module of the plug-in package `package` (its `__path__` is `path`),
    in name order, so that each registers its record; returns the module names imported.

    Modules whose name starts with `_` are helpers shared by several plug-ins, not plug-ins, and
    `registry` (the folder's registry itself) is imported by whoever needs it.
    """
    names = sorted(m.name for m in pkgutil.iter_modules(list(path)) if not m.name.startswith("_"))
    for name in names:
        importlib.import_module(f"{package}.{name}")
    return names


class Registry(Generic[P]):
    """The records of one plug-in folder, listed by `(priority, name)`.

    Parameters
    ----------
    what : str
        What a record is, in words, for messages (`"map kind"`, `"closed form"`).
    """

    def __init__(self, what: str) -> None:
        self.what = what
        self._records: dict[str, P] = {}

    def register(self, record: P) -> P:
        """Add `record`; returns it. A name already registered, or a priority that is not an int,
        is a `ValueError`."""
        name = getattr(record, "name", None)
        priority = getattr(record, "priority", None)
        if not isinstance(name, str) or not name:
            raise ValueError(f"a {self.what} needs a non-empty name, got {name!r}")
        if not isinstance(priority, int) or isinstance(priority, bool):
            raise ValueError(f"{self.what} {name!r}: priority must be an int, got {priority!r}")
        if name in self._records:
            raise ValueError(f"a {self.what} named {name!r} is already registered")
        self._records[name] = record
        return record

    def unregister(self, name: str) -> None:
        """Remove the record `name` (`KeyError` if none is registered under it)."""
        del self._records[name]

    def get(self, name: str) -> P:
        """The record `name`, or a `ValueError` listing the names there are."""
        try:
            return self._records[name]
        except KeyError:
            raise ValueError(f"unknown {self.what} {name!r}; known: {', '.join(self.names())}") from None

    def __contains__(self, name: object) -> bool:
        return name in self._records

    def __iter__(self) -> Iterator[P]:
        return iter(self.records())

    def __len__(self) -> int:
        return len(self._records)

    def records(self) -> tuple[P, ...]:
        """Every record, by `(priority, name)`."""
        return tuple(sorted(self._records.values(), key=lambda r: (r.priority, r.name)))

    def names(self) -> list[str]:
        """The records' names, by `(priority, name)`."""
        return [r.name for r in self.records()]
