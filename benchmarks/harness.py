"""The one small harness every benchmark script runs on: its common options, its timing, the
environment record and the JSON file.

A script in `benchmarks/<area>/` is its measurement and its table only. It finds this module by
putting `benchmarks/` on `sys.path` (scripts run as files, not as a package):

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    import harness

    ap = harness.parser(__doc__, repeat=5, seed=0)   # the common options a script uses, its defaults
    ap.add_argument("--nodes", type=int, default=200)  # and its own
    args = ap.parse_args(argv)
    seconds, result = harness.best_of(lambda: work(args.nodes), args.repeat)
    harness.write_json(args, {"rows": rows})           # only when --json was given

Common options (each script names the ones it uses and their defaults): `--json PATH` (always),
`--threads N`, `--seed N`, `--repeat N` (also spelled `--repeats`, the name older commands use)
and `--quick`. Timing goes through `wsmap.timing` (`time_call`, `Timing`); `Stopwatch` times a
block that is not one call (a loop with its own bookkeeping), on the same clock.
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import time
from collections.abc import Callable
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from wsmap.timing import Timing, time_call

__all__ = ["ROOT", "Stopwatch", "best_of", "environment", "parser", "positive_int", "timed", "timings",
           "write_json"]

#: the repository root (benchmarks/ is one level below it)
ROOT = Path(__file__).resolve().parents[1]

#: the clock of `wsmap.timing.time_call` (its default), so that a `Stopwatch` and `time_call` agree
CLOCK = time.perf_counter


def _description(doc: str | None) -> str:
    """The first paragraph of a script's docstring, as its `--help` line."""
    return (doc or "").strip().split("\n\n")[0]


def _epilog(doc: str | None) -> str | None:
    """The rest of a script's docstring: what it measures and the commands behind the documented numbers."""
    parts = (doc or "").strip().split("\n\n", 1)
    return parts[1] if len(parts) > 1 else None


def parser(doc: str | None, *, repeat: int | None = None, threads: int | None | bool = False,
           seed: int | None = None, quick: str | None = None, repeat_help: str | None = None,
           threads_help: str | None = None, seed_help: str | None = None) -> argparse.ArgumentParser:
    """The argument parser of one benchmark script, with the common options it uses.

    Parameters
    ----------
    doc
        The script's docstring; its first paragraph is the `--help` description and the whole
        text its epilog (the commands that made the documented numbers).
    repeat
        Default of `--repeat` (alias `--repeats`, stored as `args.repeat`): timed repetitions;
        `None` leaves the option out.
    threads
        Default of `--threads` (stored as `args.threads`); `None` is a default of its own ("the
        library's choice"), `False` leaves the option out.
    seed
        Default of `--seed`; `None` leaves the option out.
    quick
        Help text of `--quick` (what the script leaves out or makes smaller); `None` leaves it out.
    repeat_help, threads_help, seed_help
        What the option means in this script, where the generic text says too little.

    Returns
    -------
    argparse.ArgumentParser
        With `--json PATH` always; the script adds its own options and calls `parse_args`.
    """
    ap = argparse.ArgumentParser(description=_description(doc), epilog=_epilog(doc),
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--json", metavar="PATH",
                    help="also write the numbers to this JSON file, with the environment record")
    if repeat is not None:
        ap.add_argument("--repeat", "--repeats", dest="repeat", type=positive_int, default=repeat,
                        help=repeat_help or f"timed repetitions (default {repeat})")
    if threads is not False:
        ap.add_argument("--threads", type=positive_int, default=threads,
                        help=threads_help or f"threads (default {threads})")
    if seed is not None:
        ap.add_argument("--seed", type=int, default=seed, help=seed_help or f"random seed (default {seed})")
    if quick is not None:
        ap.add_argument("--quick", action="store_true", help=quick)
    return ap


def positive_int(text: str) -> int:
    """An argparse type: an integer of at least 1 (a count of repetitions, threads, epochs)."""
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text}")
    return value


def timed(fn: Callable[[], Any]) -> tuple[float, Any]:
    """One call of `fn()`, timed by `wsmap.timing.time_call`: (seconds, its result)."""
    seconds, out = best_of(fn, 1)
    return seconds, out


def best_of(fn: Callable[[], Any], repeat: int, warmup: int = 0) -> tuple[float, Any]:
    """`repeat` timed calls of `fn()` after `warmup` untimed ones: (the fastest call's seconds, the
    last call's result)."""
    t, out = timings(fn, repeat, warmup)
    return t.min, out


def timings(fn: Callable[[], Any], repeat: int, warmup: int = 0) -> tuple[Timing, Any]:
    """`repeat` timed calls of `fn()` after `warmup` untimed ones: (their `wsmap.timing.Timing`,
    the last call's result)."""
    box: list[Any] = [None]

    def call() -> None:
        box[0] = fn()

    return time_call(call, repeats=repeat, warmup=warmup, clock=CLOCK), box[0]


class Stopwatch:
    """Wall-clock and CPU seconds of a `with` block (the block is not one call to hand to
    `timed`): `seconds`, `cpu_seconds` and `timing` (a one-value `wsmap.timing.Timing`) once the
    block has left. Inside the block `elapsed()` reads the wall time so far."""

    seconds: float
    cpu_seconds: float

    def start(self) -> "Stopwatch":
        """Start (or restart) the watch; returns it, for a watch read by `elapsed()` outside a `with` block."""
        self._t0, self._c0 = CLOCK(), time.process_time()
        return self

    def __enter__(self) -> "Stopwatch":
        return self.start()

    def elapsed(self) -> float:
        """Wall seconds since the block began."""
        return CLOCK() - self._t0

    def __exit__(self, *exc: object) -> None:
        self.seconds = CLOCK() - self._t0
        self.cpu_seconds = time.process_time() - self._c0

    @property
    def timing(self) -> Timing:
        return Timing.from_values([self.seconds])


def _git_commit() -> str | None:
    """The checkout's commit, with "+dirty" when tracked files differ from it; None without git."""
    try:
        commit = subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True, text=True,
                                timeout=10, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=ROOT,
                               capture_output=True, text=True, timeout=10, check=True).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None
    return commit + ("+dirty" if dirty else "")


def _versions() -> dict[str, str]:
    """Versions of Python, wsmap and the numerical libraries this process has imported."""
    out = {"python": platform.python_version()}
    for name in ("wsmap", "numpy", "numba", "torch", "scipy", "coal", "roboticstoolbox", "klampt", "eaik"):
        mod = sys.modules.get(name)
        if mod is not None:
            out[name] = str(getattr(mod, "__version__", "?"))
    return out


def environment(args: argparse.Namespace | None = None) -> dict[str, Any]:
    """The record of where and how a benchmark ran: machine, CPUs and load, thread settings
    (the `--threads` option and the thread variables of the environment), versions, git commit,
    the command line and the UTC time."""
    threads_env = {k: os.environ[k] for k in ("OMP_NUM_THREADS", "NUMBA_NUM_THREADS", "WSMAP_THREADS",
                                              "MKL_NUM_THREADS", "WSMAP_KERNEL") if k in os.environ}
    return {
        "machine": platform.machine(),
        "processor": platform.processor() or platform.machine(),
        "platform": platform.platform(),
        "cpus": os.cpu_count(),
        "load_average": os.getloadavg() if hasattr(os, "getloadavg") else None,
        "threads": getattr(args, "threads", None),
        "thread_environment": threads_env,
        "versions": _versions(),
        "git_commit": _git_commit(),
        "command": " ".join(sys.argv),
        "utc": datetime.now(timezone.utc).isoformat(timespec="seconds"),
    }


def write_json(args: argparse.Namespace, results: Any) -> Path | None:
    """Write `results` to `args.json` (when given) as `wsmap.io.write_json` does, beside the
    `environment` record taken now (the end of the run); returns the path, or None without
    `--json`. A mapping keeps its keys at the top level; anything else goes under "results"."""
    if not getattr(args, "json", None):
        return None
    from wsmap.io import write_json as _write

    record = {"environment": environment(args)}
    if isinstance(results, dict):
        record.update(results)
    else:
        record["results"] = results
    return _write(record, args.json)
