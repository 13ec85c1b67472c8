"""The first call of the compiled IK kernels: compiled now, with a one-line notice, rather than during
the first map in silence (`ensure_compiled`, called by `wsmap map` before it maps)."""

from __future__ import annotations

import time

import numpy as np

from ... import robots
from .. import lm_compiled, lm_coupled, lm_lanes
from ..chain import as_chain
from .reach_filter import reach_filter
from .search import ikine_search

__all__ = ["ensure_compiled", "needs_compile"]


def _scalar(joints) -> tuple:
    """Of the joint counts `joints` (an int or a sequence), those whose search runs on the scalar
    (numba) kernel now: none where the lane kernel runs them (`lm_lanes.runs_on_lanes`)."""
    joints = (joints,) if isinstance(joints, (int, np.integer)) else tuple(joints)
    return tuple(int(n) for n in joints if not lm_lanes.runs_on_lanes(int(n)))


def needs_compile(joints=(6, 7), coupled: bool = False) -> bool:
    """Whether the first numerical map of this process on arms of the joint counts `joints` will
    compile numba code: the scalar kernel's builds where it runs them
    (`wsmap.kinematics.lm_compiled.needs_compile`), else the search's helpers alone; with
    `coupled`, the arm's joints are coupled (`SerialChain.coupling`) and its search runs on
    `wsmap.kinematics.lm_coupled` (`lm_coupled.needs_compile`) besides the helpers."""
    if coupled:
        return lm_compiled.needs_compile(()) or lm_coupled.needs_compile()
    return lm_compiled.needs_compile(_scalar(joints))


def _ensure_coupled(notify) -> float:
    """`ensure_compiled` for an arm with coupled joints: the kernel of `wsmap.kinematics.lm_coupled`
    (one build for every joint count), announced, compiled by a one-pose search of the PUMA560 coupled
    by the identity."""
    if not needs_compile(coupled=True):
        return 0.0
    if notify is not None and lm_coupled.needs_compile():
        notify(f"compiling the IK kernel of coupled joints once, about {lm_compiled.estimate()} s; "
               f"cached in {lm_compiled.cache_dir()}")
    t0 = time.perf_counter()
    puma = as_chain(robots.load("puma560"))
    ikine_search(puma.couple(np.arange(puma.n)), np.asarray(puma.fkine(np.linspace(-0.5, 0.5, puma.n)))[None], starts=2,
                 seed=0)
    reach_filter(puma, np.asarray(puma.fkine(np.zeros(puma.n)))[None], 1e-6)  # the search's other helpers
    return time.perf_counter() - t0


def ensure_compiled(notify=None, joints=(6, 7), coupled: bool = False) -> float:
    """Compile the IK kernels for arms of the joint counts `joints` (an int or a sequence: 6 takes
    the six-joint build, any other count the generic one; none where the lane kernel,
    `wsmap.kinematics.lm_lanes`, runs them: then only the search's numba helpers, silently) now if the first map would
    (`wsmap.kinematics.lm_compiled.needs_compile`: numba's cache index says), and say so first:
    `notify` (a callable taking one line; None: silent) gets "compiling the IK kernels once, about
    N s; cached in DIR", N the last cold compile measured here per build (or
    `COLD_COMPILE_SECONDS`). The compile is a one-pose search of
    the PUMA560 (six joints) and of the Panda (seven: the generic build) as the counts need (every
    kernel, the types every caller passes), and the PUMA560's wrist-orbit pre-filter. Returns the
    seconds it took (0.0 where everything was cached: loading is left to the first call).
    `coupled`: for an arm with coupled joints, whose search runs on `wsmap.kinematics.lm_coupled`
    (the notice names that kernel; `joints` is not read)."""
    if coupled:
        return _ensure_coupled(notify)
    if not needs_compile(joints):
        return 0.0
    builds = lm_compiled.builds_for(_scalar(joints))
    # the numba batches take tens of seconds; the lane kernel is compiled at install, and the
    # search's numba helpers alone about a second: no notice for those
    if notify is not None and builds:
        notify(f"compiling the IK kernels once, about {lm_compiled.estimate() * len(builds)} s; "
               f"cached in {lm_compiled.cache_dir()}")
    t0 = time.perf_counter()
    puma = robots.load("puma560")
    T = np.asarray(puma.fkine(np.linspace(-0.5, 0.5, puma.n)))[None]
    if lm_compiled.builds_for(_scalar(6)) <= builds:
        ikine_search(puma, T, starts=2, seed=0)
    else:
        reach_filter(as_chain(puma), T, 1e-6)  # the wrist-orbit test alone
    if lm_compiled.builds_for(_scalar(7)) <= builds:
        panda = robots.load("panda")
        ikine_search(panda, np.asarray(panda.fkine(np.linspace(-0.5, 0.5, panda.n)))[None], starts=2, seed=0)
    seconds = time.perf_counter() - t0
    if builds:
        lm_compiled.record_compile_seconds(seconds / len(builds))
    return seconds
