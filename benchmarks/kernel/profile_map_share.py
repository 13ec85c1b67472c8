"""What a second thread can gain on the Panda's maps (Amdahl): the CPU seconds of one thread inside
the lane kernel's calls against those outside them (numpy bookkeeping, pre-filters, seeding: the
part a second kernel thread does not shorten), for the tool-down map (21³ nodes) and, with
``--index``, the reachability index (5 cm x 50 orientations).

On one thread the kernel runs on the calling thread, so ``time.thread_time`` around each call of
the extension counts its CPU seconds and the rest of the thread's CPU seconds is the serial part.
CPU seconds, not wall seconds: they hardly move with the load of a shared machine (other
processes take cores away, not instructions). The best of ``--repeat`` maps (the index: one).

    NUMBA_NUM_THREADS=2 OMP_NUM_THREADS=1 .venv/bin/python benchmarks/kernel/profile_map_share.py --index
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402


def main(argv=None) -> int:
    ap = harness.parser(__doc__, repeat=10, repeat_help="maps timed, best kept (default 10; the index: 1)")
    ap.add_argument("--index", action="store_true", help="also the index, 5 cm x 50 orientations")
    args = ap.parse_args(argv)
    from wsmap import robots
    from wsmap import workspace as ws
    from wsmap.kinematics import lm_compiled, lm_lanes

    if not lm_lanes.available():
        raise SystemExit("the lane kernel is not built")
    lm_compiled.set_threads(1)
    panda = robots.load("panda")
    nodes = ws.cartesian_grid(-1, 1, 0.1)
    work = {"tool-down map, 21^3": (lambda: ws.constant_orientation_map(panda, nodes, (np.pi, 0, 0), method="numerical",
                                                                         convention="standard"), args.repeat)}
    if args.index:
        inodes, R = ws.cartesian_grid(-0.95, 0.95, 0.05), ws.orientation_samples(50)
        work["index, 5 cm x 50"] = (lambda: ws.reachability_index(panda, inodes, R), 1)
    ext, inside = lm_lanes._lanes, [0.0, 0]

    class Counted:  # the extension, its calls' thread CPU seconds counted
        def __getattr__(self, name):
            return getattr(ext, name)

        def run_targets(self, *a, **k):
            c = time.thread_time()
            try:
                return ext.run_targets(*a, **k)
            finally:
                inside[0] += time.thread_time() - c
                inside[1] += 1

    rows = []
    lm_lanes._lanes = Counted()
    try:
        for name, (fn, repeat) in work.items():
            fn()  # warm-up: the kernels, the memos
            best = None
            for _ in range(repeat):
                inside[:] = [0.0, 0]
                c = time.thread_time()
                fn()
                total = time.thread_time() - c
                if best is None or total < best[0]:
                    best = (total, inside[0], inside[1])
            total, kernel, calls = best
            rows.append({"work": name, "cpu_seconds": total, "kernel_cpu_seconds": kernel, "kernel_calls": calls,
                         "outside_cpu_seconds": total - kernel, "outside_share": (total - kernel) / total})
    finally:
        lm_lanes._lanes = ext
    import os

    print(f"load average {os.getloadavg()}\n")
    print("| one thread | CPU s | in the kernel (calls) | outside | outside share |")
    print("|---|---:|---:|---:|---:|")
    for r in rows:
        print(f"| {r['work']} | {r['cpu_seconds']:.4f} | {r['kernel_cpu_seconds']:.4f} ({r['kernel_calls']}) | "
              f"{r['outside_cpu_seconds']:.4f} | {r['outside_share']:.1%} |")
    harness.write_json(args, {"rows": rows})
    return 0


if __name__ == "__main__":
    sys.exit(main())
