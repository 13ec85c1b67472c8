"""Progress of long computations: what a map function's `progress=` argument means.

Every map function takes `progress`: `False`/`None` (silent, the default), `True` (a tqdm bar
on stderr, closed when the function returns) or a callable `progress(n)` called with the number of
units (nodes, or node-orientation pairs) just settled; the numbers add up to the total, so a
callable may be `tqdm.update` of a bar of the caller's own or a counter.

A wait the bar cannot show (a kernel compiled on its first call, tens of seconds at 0 %) is
announced with `notice(line)` from wherever it happens: one line on stderr while a bar of
`progress=True` is open in this context, nothing otherwise (`progress` False, None or a callable
of the caller's own), so that quiet stays quiet.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar

__all__ = ["progress_bar", "check_progress", "notice"]

# where notice() writes: set while a progress_bar(True) is open (a context variable, so that a
# bar in one thread does not make another thread's quiet work speak)
_NOTICES: ContextVar[Callable[[str], None] | None] = ContextVar("wsmap_progress_notices", default=None)


def notice(line: str) -> None:
    """Say `line` (one line, no newline) on stderr above the open progress bar, where a map
    function was called with `progress=True`; silent otherwise (see the module notes)."""
    write = _NOTICES.get()
    if write is not None:
        write(line)


def check_progress(progress) -> None:
    """`ValueError` unless `progress` is a bool, `None` or a callable."""
    if not (progress is None or isinstance(progress, bool) or callable(progress)):
        raise ValueError(f"progress must be True, False, None or a callable progress(n), got {type(progress).__name__}")


@contextmanager
def progress_bar(progress, total: int, *, unit: str = "node", desc: str | None = None
                 ) -> Iterator[Callable[[int], None] | None]:
    """The update callable of `progress` (see the module docstring) for `total` units, or `None`.

    `True` opens a tqdm bar on stderr for the `with` block (`leave=False`: it disappears when
    done, so a command's summary line stays the last thing printed); a callable is passed through.
    """
    check_progress(progress)
    if not progress:
        yield None
        return
    if progress is not True:
        yield progress
        return
    from tqdm.auto import tqdm

    bar = tqdm(total=int(total), unit=unit, desc=desc, file=sys.stderr, leave=False, dynamic_ncols=True,
               unit_scale=True, smoothing=0.1)
    # tqdm.write clears the bar, prints the line and redraws the bar below it
    token = _NOTICES.set(lambda line: tqdm.write(f"wsmap: {line}", file=sys.stderr))
    try:
        yield bar.update
    finally:
        _NOTICES.reset(token)
        bar.close()
