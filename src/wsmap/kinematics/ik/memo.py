"""Small content-keyed memos of what a solver derives from an arm's numbers (its chain form, the
kernel's arrays, the reach pre-filter's wrist orbit): a map or a search calls the solver many
times with the same arm, and these derivations are a large part of a small call's fixed cost."""

from __future__ import annotations

import threading

import numpy as np

from ..chain import SerialChain, as_chain
from ..dh import DHRobot

__all__ = ["Memo", "content_key", "chain_key", "as_chain_memo"]


def content_key(*parts):
    """A hashable key of arrays (by shape, dtype and bytes) and plain values."""
    return tuple((p.shape, p.dtype.str, p.tobytes()) if isinstance(p, np.ndarray) else p for p in parts)


_MISSING = object()


class Memo:
    """A least-recently-used memo of pure functions of an arm's numbers, keyed by content (so an
    array changed in place is a new key). Callers must not change what it returns. Safe to share
    between threads (the index solves two orientations at once): two threads that miss one key
    at once both make it, and one value stays."""

    def __init__(self, size: int = 16):
        self.size = size
        self.items: dict = {}
        self._lock = threading.Lock()

    def get(self, key, make):
        """The value stored under `key`, else `make()`, stored (the oldest entry leaves when full)."""
        with self._lock:
            value = self.items.pop(key, _MISSING)
            if value is not _MISSING:
                self.items[key] = value
                return value
        value = make()  # outside the lock: a make may take a while, or use another memo
        with self._lock:
            self.items.pop(key, None)
            if len(self.items) >= self.size:
                self.items.pop(next(iter(self.items)))
            self.items[key] = value
        return value


_CHAINS = Memo()


def chain_key(chain: SerialChain):
    """`content_key` of everything that defines a chain's kinematics and limits (its coupling too)."""
    key = content_key(chain.fixed, chain.axes, chain.kinds, np.asarray(chain.offset), chain.qlim, chain.base,
                      chain.tool)
    return key if chain.coupling is None else key + chain.coupling.key()


def as_chain_memo(robot) -> SerialChain:
    """`as_chain`, memoised by content for a `DHRobot` (its
    conversion is the larger part of a small call's fixed cost); the result is shared, not to be
    changed."""
    if isinstance(robot, DHRobot):
        key = content_key("dh", np.asarray(robot.d), np.asarray(robot.a), np.asarray(robot.alpha),
                          None if robot.qlim is None else np.asarray(robot.qlim),
                          None if robot.tool is None else np.asarray(robot.tool), robot.name)
        return _CHAINS.get(key, lambda: as_chain(robot))
    return as_chain(robot)
