"""Where one ikine_search call on the 2648 reachable PUMA560 poses (R = I) spends its time: the
compiled kernel (``run_compiled``) against the Python around it, best of 15 calls on 2 threads, and
a cProfile of 20 calls.

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/kernel/profile_kernel_call.py
"""

from __future__ import annotations

import cProfile
import pstats
import sys
from pathlib import Path

from wsmap import robots
from wsmap import workspace as ws
from wsmap.kinematics import ikine_search, lm_compiled
from wsmap.kinematics.ik import search

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402


def main(argv=None) -> int:
    ap = harness.parser(__doc__, repeat=15, threads=2, repeat_help="timed calls, best kept (default 15)",
                        threads_help="threads of the compiled kernel (default 2)")
    ap.add_argument("--profile-calls", type=int, default=20, help="calls under cProfile (default 20)")
    args = ap.parse_args(argv)
    lm_compiled.set_threads(args.threads)
    puma = robots.puma560()
    nodes = ws.cartesian_grid(-1, 1, 0.1)
    reach = ws.constant_orientation_map(puma, nodes, (0, 0, 0), method="exact")
    T = ws.target_poses(nodes[reach], (0, 0, 0), "paper")
    best, _ = harness.best_of(lambda: ikine_search(puma, T), args.repeat, warmup=3)
    print("best ms", best * 1e3)

    orig = search.run_compiled
    kernel_seconds = []

    def run_compiled_timed(*a, **k):
        with harness.Stopwatch() as sw:
            r = orig(*a, **k)
        kernel_seconds.append(sw.seconds)
        return r

    search.run_compiled = run_compiled_timed
    try:
        calls = []
        for _ in range(args.repeat):
            kernel_seconds.clear()
            total, _ = harness.timed(lambda: ikine_search(puma, T))
            calls.append((total, sum(kernel_seconds)))
    finally:
        search.run_compiled = orig
    b = min(calls)
    print("total %.2f ms, kernel %.2f ms, python %.2f ms" % (b[0] * 1e3, b[1] * 1e3, (b[0] - b[1]) * 1e3))
    pr = cProfile.Profile()
    pr.enable()
    for _ in range(args.profile_calls):
        ikine_search(puma, T)
    pr.disable()
    pstats.Stats(pr).sort_stats("tottime").print_stats(12)
    harness.write_json(args, {"poses": len(T), "best_call_seconds": best, "total_seconds": b[0],
                              "kernel_seconds": b[1], "python_seconds": b[0] - b[1]})
    return 0


if __name__ == "__main__":
    sys.exit(main())
