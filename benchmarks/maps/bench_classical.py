"""Time the classical (binary-map) algorithm on PUMA560 and the paper's 21³ grid.

Methods timed, all on the 9261 nodes of ``cartesian_grid(-1, 1, 0.1)`` at rpy = 0 under the
paper's pose convention:

1. the exact map (closed-form wrist-centre test), best of ``--repeats``;
2. the batched numerical map (Levenberg–Marquardt of the paper's Appendix, tol 1e-10, q0 = 0),
   best of ``--repeats``;
3. the paper's way: ``ikine_LM`` on one target at a time in a Python loop, for a random sample of
   ``--nodes-sample`` nodes, extrapolated to 9261;
4. Robotics Toolbox for Python's C++ ``ik_LM`` on the same sample, if ``roboticstoolbox`` imports
   (it is optional and not part of the locked environment).

Prints a Markdown table: seconds and nodes/s (for all 9261 nodes, extrapolated where sampled),
the speed-up over the paper's reported classical time (`wsmap.paper.published.RUNTIME_SECONDS`, MATLAB, one node
at a time), and the agreement of each numerical result with the exact map.

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/maps/bench_classical.py --repeats 5 --json out.json
"""

from __future__ import annotations

import os
import platform
import sys
from pathlib import Path

import numpy as np

from wsmap.paper.published import RUNTIME_SECONDS

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402

PAPER_SECONDS_9261 = RUNTIME_SECONDS[9261][0]  # the paper's classical run time for the 9261-node map


def _best_of(fn, repeats):
    """(best wall time in s, CPU time of that run in s, result of the last call)."""
    best, best_cpu, out = np.inf, np.inf, None
    for _ in range(repeats):
        with harness.Stopwatch() as sw:
            out = fn()
        if sw.seconds < best:
            best, best_cpu = sw.seconds, sw.cpu_seconds
    return best, best_cpu, out


def _agreement(pred, exact):
    pred, exact = np.asarray(pred, bool), np.asarray(exact, bool)
    return {
        "rate": float(np.mean(pred == exact)),
        "false_negatives": int(np.sum(exact & ~pred)),
        "false_positives": int(np.sum(~exact & pred)),
    }


def _rtb_puma(puma):
    """Robotics Toolbox's DHRobot with the paper's PUMA560 table (d1 = 0), or None."""
    import roboticstoolbox as rtb  # noqa: F401 - optional

    links = [
        rtb.RevoluteDH(d=float(d), a=float(a), alpha=float(al))
        for d, a, al in zip(puma.d, puma.a, puma.alpha)
    ]
    return rtb.DHRobot(links, name="puma560-paper")


def _one_at_a_time(puma, T, sample, exact, N):
    """Methods 3 and 4: `ikine_LM` and Robotics Toolbox's `ik_LM` node by node on `sample`, extrapolated to
    the `N` nodes; their rows."""
    from wsmap.kinematics import ikine_LM

    rows = []
    # 3. one node at a time, as the paper did
    ok = np.zeros(len(sample), dtype=bool)
    with harness.Stopwatch() as sw:
        for k, i in enumerate(sample):
            ok[k] = ikine_LM(puma, T[i], tol=1e-10).success
    t, c = sw.seconds, sw.cpu_seconds
    rows.append({"method": "ikine_LM one node at a time (paper's way)", "nodes": int(len(sample)),
                 "seconds": t * N / len(sample), "cpu_seconds": c * N / len(sample), "extrapolated": True,
                 "agreement": _agreement(ok, exact[sample])})

    # 4. Robotics Toolbox's C++ ik_LM, when installed
    try:
        rtb_robot = _rtb_puma(puma)
    except Exception as exc:  # ImportError, or an API that differs
        print(f"roboticstoolbox not available ({type(exc).__name__}: {exc}); skipping its ik_LM", file=sys.stderr)
        rtb_robot = None
    if rtb_robot is not None:
        # Robotics Toolbox's C++ solver (Chan's damping by default), one search from q0 = 0 so
        # that it matches the paper's setting; its own stopping rules differ from the Appendix
        ok = np.zeros(len(sample), dtype=bool)
        with harness.Stopwatch() as sw:
            try:
                for k, i in enumerate(sample):
                    sol = rtb_robot.ik_LM(T[i], q0=np.zeros(6), ilimit=500, slimit=1, tol=1e-10, joint_limits=False)
                    # 1.x returns an IKSolution (attribute .success); older releases a tuple
                    ok[k] = bool(sol.success if hasattr(sol, "success") else sol[1])
            except Exception as exc:  # an ik_LM signature other than roboticstoolbox 1.x's
                print(f"roboticstoolbox ik_LM failed ({type(exc).__name__}: {exc}); skipping it", file=sys.stderr)
                rtb_robot = None
        t, c = sw.seconds, sw.cpu_seconds
    if rtb_robot is not None:
        rows.append({"method": "roboticstoolbox ik_LM (C++, one node at a time)", "nodes": int(len(sample)),
                     "seconds": t * N / len(sample), "cpu_seconds": c * N / len(sample), "extrapolated": True,
                     "agreement": _agreement(ok, exact[sample])})
    return rows


def _print_table(rows, info, N, repeat):
    """The Markdown table of `rows` and the exact map's time."""
    print(f"PUMA560, 21^3 grid ({N} nodes), rpy = 0, paper convention; python {info['python']}, numpy "
          f"{info['numpy']}, {info['cpus']} CPUs, load average {info['load_average']}, "
          f"kernel threads {info['kernel_threads']}")
    print()
    print(f"| method | nodes timed | seconds for 9261 | CPU seconds | nodes/s | speed-up vs paper ({PAPER_SECONDS_9261} s) "
          "| agreement with exact | false neg. | false pos. |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        a = r["agreement"]
        star = " (extrapolated)" if r.get("extrapolated") else ""
        print(f"| {r['method']} | {r['nodes']} | {r['seconds']:.4g}{star} | {r['cpu_seconds']:.4g} | "
              f"{r['nodes_per_second']:,.0f} | {r['speedup_vs_paper']:,.0f}x | {a['rate']:.4f} | "
              f"{a['false_negatives']} | {a['false_positives']} |")
    print()
    print(f"exact map: {rows[0]['seconds'] * 1e3:.2f} ms (best of {repeat})")


def main(argv=None):
    ap = harness.parser(__doc__, repeat=5, seed=0, threads=None,
                        repeat_help="repeats of the whole-map timings (best is kept)",
                        seed_help="seed of the node sample", threads_help=(
                            "threads of the compiled kernel (wsmap.kinematics.lm_compiled.set_threads; default: "
                            "WSMAP_THREADS or every core)"))
    ap.add_argument("--nodes-sample", type=int, default=200, help="nodes solved one at a time (methods 3, 4)")
    ap.add_argument("--reference", action="store_true",
                    help="also time the numpy reference of the LM iteration (wsmap.kinematics.ik.lm_reference)")
    args = ap.parse_args(argv)
    if args.nodes_sample < 1:
        ap.error("--nodes-sample must be positive")
    from wsmap import robots
    from wsmap import workspace as ws
    from wsmap.kinematics import lm_compiled
    from wsmap.kinematics.ik.lm_reference import ikine_LM_reference

    kernel_threads = lm_compiled.set_threads(args.threads)

    puma = robots.puma560()
    nodes = ws.cartesian_grid(-1.0, 1.0, 0.1)
    N = len(nodes)
    T = ws.target_poses(nodes, np.zeros(3), "paper")
    rng = np.random.default_rng(args.seed)
    sample = np.sort(rng.choice(N, size=min(args.nodes_sample, N), replace=False))

    info = {
        "python": sys.version.split()[0],
        "numpy": np.__version__,
        "machine": platform.machine(),
        "cpus": os.cpu_count(),
        "load_average": os.getloadavg() if hasattr(os, "getloadavg") else None,
        "kernel_threads": kernel_threads,
        "nodes": N,
        "sample": int(len(sample)),
    }
    rows = []

    # 1. exact
    t, c, exact = _best_of(lambda: ws.constant_orientation_map(puma, nodes, method="exact"), args.repeat)
    rows.append({"method": "exact map (closed form, batched)", "nodes": N, "seconds": t, "cpu_seconds": c,
                 "agreement": _agreement(exact, exact)})

    # 2. batched numerical
    ik = {"tol": 1e-10, "solver": "paper"}  # the paper's one-start LM
    t, c, num = _best_of(
        lambda: ws.constant_orientation_map(puma, nodes, method="numerical", ik=ik), max(1, args.repeat)
    )
    rows.append({"method": "numerical map (batched LM, tol 1e-10)", "nodes": N, "seconds": t, "cpu_seconds": c,
                 "agreement": _agreement(num, exact)})

    # 2b. the numpy reference of the same iteration, for comparison
    if args.reference:
        t, c, ref = _best_of(lambda: ikine_LM_reference(puma, T, tol=1e-10).success, max(1, min(args.repeat, 2)))
        rows.append({"method": "numerical map, numpy reference LM", "nodes": N, "seconds": t,
                     "cpu_seconds": c, "agreement": _agreement(ref, exact),
                     "same_success_as_new": bool(np.array_equal(ref, num))})

    rows += _one_at_a_time(puma, T, sample, exact, N)

    for r in rows:
        r["nodes_per_second"] = N / r["seconds"]
        r["speedup_vs_paper"] = PAPER_SECONDS_9261 / r["seconds"]

    _print_table(rows, info, N, args.repeat)
    harness.write_json(args, {"info": info, "paper_seconds_9261": PAPER_SECONDS_9261, "rows": rows})
    return rows


if __name__ == "__main__":
    main()
