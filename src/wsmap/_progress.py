"""Progress of long computations: what a map function's `progress=` argument means.

Every map function takes `progress`: `False`/`None` (silent, the default), `True` (a tqdm bar
on stderr, closed when the function returns) or a callable `progress(n)` called with the number of
units (nodes, or node-orientation pairs) just settled; the numbers add up to the total, so a
callable may be `tqdm.update` of a bar of the caller's own or a counter.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager

__all__ = ["progress_bar", "check_progress"]


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
    try:
        yield bar.update
    finally:
        bar.close()
