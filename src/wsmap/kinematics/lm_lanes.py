"""The lane kernel: the LM search of `wsmap.kinematics.lm_compiled` on several targets per instruction.

`wsmap.kinematics.lm_compiled` runs one target at a time; each LM iteration is a long chain of
dependent operations (joint after joint, pivot after pivot), so most of a core's vector units and
most of its cycles sit idle (docs/speed.md, "The limit"). The lane kernel (C++,
`src/wsmap/kinematics/_lanes/lanes.hpp`, built into the extension `wsmap.kinematics._lanes`)
keeps a block of `lanes` targets in flight: every number of the iteration is an array over the
block, so the forward kinematics, pose error, Jacobian, normal equations and solve run on several
lanes per AVX-512 or AVX2 instruction (a build per instruction set, the widest the CPU has chosen
at import, `isa`). For 6- and 7-joint arms the iteration is register-blocked: unrolled code on
vector values, the pose, the Jacobian's columns and the elimination in registers, acceptance,
damping and the stopping tests as masks over the lanes (docs/speed.md, "Register blocking"). The
end of a run (the confirmation, the next start) is done lane by lane, and a lane whose target is
done takes the next one from a counter shared by every thread of the call.

Same search, same arithmetic per target as the scalar kernel; the compilers fuse multiply-adds
differently, so answers agree to rounding (`tests/kinematics/test_lm_lanes.py`: the same successes
and starts, `q` within 1e-8, on named and random arms in every mode). A target's answer does not
depend on its lane, its neighbours or the thread count.

Which kernel runs: `set_kernel` (`"lanes"`, the default where the extension is built, or
`"scalar"`, the numba kernel, the tested reference), or the environment variable `WSMAP_KERNEL`.
Arms of more than `MAX_JOINTS` joints run on the scalar kernel.
"""

from __future__ import annotations

import os
import threading
from contextlib import contextmanager

import numba
import numpy as np

from . import lm_compiled

try:
    from . import _lanes
except ImportError as exc:  # a source checkout that was never built: the scalar kernel only
    _lanes = None
    _IMPORT_ERROR = str(exc)
else:
    _IMPORT_ERROR = ""
    # the extension reads a `KernelCall` by the names of its own table: a build from older sources
    # would ignore a new field, or miss one, so it is not used
    _differ = set(getattr(_lanes, "FIELDS", ())) ^ set(lm_compiled.call_fields())
    if _differ:
        _IMPORT_ERROR = f"built from other sources: its fields and lm_compiled.KernelCall's differ by {sorted(_differ)}"
        _lanes = None

__all__ = ["KERNELS", "LANES", "MAX_JOINTS", "MIN_BLOCKS", "available", "isa", "kernel", "set_kernel", "use_kernel",
           "run_targets", "threads_for"]

#: The kernels `set_kernel` takes.
KERNELS = ("lanes", "scalar")
#: Targets in flight per thread (4, 8 or 16; `benchmarks/kernel/bench_peers.py --lanes` compares them).
LANES = 8
#: The most joints the lane kernel takes; longer chains run on the scalar kernel.
MAX_JOINTS = 16
#: Blocks of lanes per thread at least: a call of fewer targets than `MIN_BLOCKS * lanes` per
#: thread runs on fewer threads (`threads_for`).
MIN_BLOCKS = 2
_kernel = None
# the lane threads running now, over every Python thread that calls `run_targets`
_busy = 0
_busy_lock = threading.Lock()


def available() -> bool:
    """Whether the extension `wsmap.kinematics._lanes` is built and loads."""
    return _lanes is not None


def isa() -> str:
    """The instruction set of the build in use: `"avx512"`, `"avx2"` or `"base"`."""
    if _lanes is None:
        raise RuntimeError(f"the lane kernel is not built ({_IMPORT_ERROR}); reinstall wsmap")
    return _lanes.best_isa()


def set_kernel(name: str | None = None) -> str:
    """Use kernel `name` (one of `KERNELS`) from now on; None: `WSMAP_KERNEL`, else
    `"lanes"` where the extension is built, else `"scalar"`. Returns the kernel set."""
    global _kernel
    what = "kernel"
    if name is None:
        name = os.environ.get("WSMAP_KERNEL") or ("lanes" if available() else "scalar")
        what = "WSMAP_KERNEL" if os.environ.get("WSMAP_KERNEL") else what
    if name not in KERNELS:
        raise ValueError(f"{what} must be one of {', '.join(KERNELS)}, not {name!r}")
    if name == "lanes" and not available():
        raise RuntimeError(f"the lane kernel is not built ({_IMPORT_ERROR}); reinstall wsmap, or use 'scalar'")
    _kernel = name
    return name


def kernel() -> str:
    """The kernel in use (see `set_kernel`)."""
    return _kernel if _kernel is not None else set_kernel()


@contextmanager
def use_kernel(name: str):
    """Within the block, kernel `name`; the one before after it."""
    before = kernel()
    set_kernel(name)
    try:
        yield name
    finally:
        set_kernel(before)


def runs_on_lanes(n: int) -> bool:
    """Whether a search of `n`-joint arms runs on the lane kernel now."""
    return kernel() == "lanes" and 1 <= n <= MAX_JOINTS


def run_targets(call: lm_compiled.KernelCall, lanes: int = LANES, isa: str = "auto") -> None:
    """`wsmap.kinematics.lm_compiled.run_targets` on the lane kernel (the same `KernelCall`, the
    same results to rounding), on `threads_for` threads: this one and threads the extension starts
    for the call, each running a block of `lanes` targets taken one at a time from a shared counter.
    Python threads that call it at once share `lm_compiled.threads()` (each at least one thread).

    Parameters
    ----------
    call : lm_compiled.KernelCall
        The targets, arms and settings; the answers are written into `call.out`.
    lanes : int
        Targets in flight per thread: 4, 8 or 16.
    isa : str
        `"auto"` (the widest build this CPU runs) or a narrower one (tests, benchmarks).
    """
    if _lanes is None:
        raise RuntimeError(f"the lane kernel is not built ({_IMPORT_ERROR}); reinstall wsmap, or use 'scalar'")
    global _busy
    counter = np.zeros(1, dtype=np.int64)
    with _busy_lock:  # callers at once (the index's two orientations) share the thread count
        want = max(1, min(threads_for(len(call.targets.arm), lanes), numba.get_num_threads() - _busy))
        _busy += want
    try:
        if getattr(_lanes, "THREADS", False):
            # the extension runs the blocks on threads of its own: the GIL released once, no Python
            # between them (docs/speed.md, "Thread scaling")
            _lanes.run_targets(call, counter, int(lanes), isa, want)
        else:  # a build from before that (bench_lanes.py --other): one Python thread per block
            lm_compiled.on_threads(want, lambda: _lanes.run_targets(call, counter, int(lanes), isa))
    finally:
        with _busy_lock:
            _busy -= want


def threads_for(targets: int, lanes: int = LANES) -> int:
    """The threads a call of `targets` targets runs on: `lm_compiled.threads()`, but at most one
    per `MIN_BLOCKS` blocks of `lanes` targets, so that a second thread has whole blocks to work
    on (at least one thread)."""
    return max(1, min(numba.get_num_threads(), int(targets) // (MIN_BLOCKS * int(lanes))))
