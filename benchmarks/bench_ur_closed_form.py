"""Time the UR closed form (:func:`wsmap.kinematics.closed_form_ur.ikine_ur`) against EAIK on UR5e maps.

Two maps of the 9261 nodes of ``cartesian_grid(-1, 1, 0.1)`` (m), each at one orientation:
``R = I`` and tool-down ``R = Rx(pi)``; pose ``T = transl(p) · R`` in the UR5e base frame (flange,
no tool). Per map and method, the best wall time of one whole map over ``--rounds`` cycles of
``--repeats`` runs in a row (after an untimed warm-up run):

1. ``ur_reachable(robot, T)``: all 8 branches of every pose in numpy, from the robot (its structure
   check included), single thread (run with ``OMP_NUM_THREADS=1``);
2. EAIK's ``IK_batched`` with 1 worker thread (``IK`` in a Python loop if ``IK_batched`` is
   missing), the C++ solve only: building its reachable labels is not timed;
3. the same with ``--eaik-threads`` workers (its default is 4), when that is not 1.

EAIK's label of a node: one of its solutions puts the flange within 1e-6 of ``T`` (forward
kinematics of :meth:`SerialChain.fkine`, every matrix entry). The script asserts that the labels
of every method are identical node for node, prints a Markdown table (method, seconds per map,
poses/s, ratio to ``ikine_ur``) and with ``--json PATH`` writes the numbers.

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/bench_ur_closed_form.py --repeats 5 --json out.json
"""

from __future__ import annotations

import argparse
import importlib.metadata
import json
import os
import platform
import sys
import time

import numpy as np


def _best_of(fns, repeats, rounds):
    """Best wall time in s of each function, and the result of its last call.

    Each function runs ``repeats`` times in a row (after one untimed warm-up call), so each is
    timed with its own data in cache; ``rounds`` cycles over all the functions guard against a
    change of machine load between them (the best over all rounds is kept).
    """
    best, out = [np.inf] * len(fns), [None] * len(fns)
    for _ in range(rounds):
        for i, fn in enumerate(fns):
            out[i] = fn()
            for _ in range(repeats):
                t = time.perf_counter()
                out[i] = fn()
                best[i] = min(best[i], time.perf_counter() - t)
    return best, out


def _eaik_labels(chain, T, sols):
    """Reachable labels from EAIK's solutions: a solution whose FK matches T to 1e-6."""
    Q = np.zeros((len(T), 8, 6))
    present = np.zeros((len(T), 8), dtype=bool)
    not_ls = np.zeros(len(T), dtype=bool)
    for i, s in enumerate(sols):
        k = s.num_solutions()
        Q[i, :k], present[i, :k] = s.Q, True
        not_ls[i] = not np.all(s.is_LS)
    err = np.abs(chain.fkine(np.moveaxis(Q, 1, 0)) - T).max(axis=(-1, -2)).T
    return (present & (err <= 1e-6)).any(axis=-1), not_ls


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=5, help="timed runs in a row per map and method (best is kept)")
    ap.add_argument("--rounds", type=int, default=2, help="cycles over the methods, each with --repeats runs")
    ap.add_argument("--eaik-threads", type=int, default=4, help="worker threads of EAIK's second run (its default: 4)")
    ap.add_argument("--json", metavar="PATH", help="also write the numbers to this JSON file")
    args = ap.parse_args(argv)
    if args.repeats < 1 or args.rounds < 1 or args.eaik_threads < 1:
        ap.error("--repeats, --rounds and --eaik-threads must be positive")

    from eaik.IK_DH import DhRobot

    from wsmap import robots
    from wsmap.kinematics import rotx
    from wsmap.kinematics.closed_form_ur import ur_reachable
    from wsmap.workspace import cartesian_grid

    chain = robots.load("ur5e")
    d, a, alpha, _ = np.array(robots.UR5E.rows).T
    eaik = DhRobot(alpha, a, d)
    batched = hasattr(eaik, "IK_batched")
    nodes = cartesian_grid(-1.0, 1.0, 0.1)
    N = len(nodes)
    info = {
        "python": sys.version.split()[0],
        "numpy": np.__version__,
        "eaik": importlib.metadata.version("eaik"),
        "machine": platform.machine(),
        "cpus": os.cpu_count(),
        "omp_num_threads": os.environ.get("OMP_NUM_THREADS"),
        "load_average": os.getloadavg() if hasattr(os, "getloadavg") else None,
        "nodes": N,
        "repeats": args.repeats,
        "rounds": args.rounds,
        "eaik_call": "IK_batched" if batched else "IK in a Python loop",
    }

    def eaik_solve(T, threads):
        return eaik.IK_batched(T, threads) if batched else [eaik.IK(t) for t in T]

    maps = {}
    for label, R in (("R = I", np.eye(3)), ("tool-down R = Rx(pi)", rotx(np.pi))):
        T = np.zeros((N, 4, 4))
        T[:, :3, :3], T[:, :3, 3], T[:, 3, 3] = R, nodes, 1.0
        thread_counts = [1] + ([args.eaik_threads] if batched and args.eaik_threads != 1 else [])
        fns = [lambda: ur_reachable(chain, T)] + [lambda k=k: eaik_solve(T, k) for k in thread_counts]
        times, results = _best_of(fns, args.repeats, args.rounds)
        ours = results[0]
        rows = [{"method": "wsmap ikine_ur, all 8 branches (ur_reachable; numpy, 1 thread)", "seconds": times[0]}]
        for threads, t, sols in zip(thread_counts, times[1:], results[1:]):
            theirs, not_ls = _eaik_labels(chain, T, sols)
            mism = np.flatnonzero(theirs != ours)
            assert mism.size == 0, f"{label}: labels differ from EAIK's at nodes {mism[:10]}"
            rows.append({"method": f"EAIK {info['eaik_call']} ({threads} thread{'s' if threads > 1 else ''})",
                         "seconds": t, "labels_from_is_LS_agree": bool(np.array_equal(not_ls, theirs))})
        for r in rows:
            r["poses_per_second"] = N / r["seconds"]
            r["ratio_to_ikine_ur"] = r["seconds"] / rows[0]["seconds"]
        maps[label] = {"reachable": int(ours.sum()), "labels_identical": True, "rows": rows}

    print(f"UR5e, {N} nodes of cartesian_grid(-1, 1, 0.1), best of {args.repeats} in a row x {args.rounds} "
          f"rounds; python {info['python']}, numpy {info['numpy']}, eaik {info['eaik']}, {info['cpus']} CPUs, "
          f"OMP_NUM_THREADS={info['omp_num_threads']}, load average {info['load_average']}")
    for label, m in maps.items():
        print()
        print(f"{label}: {m['reachable']} reachable nodes, labels identical to EAIK's node for node")
        print()
        print("| method | seconds per map | poses/s | time ÷ ikine_ur |")
        print("|---|---:|---:|---:|")
        for r in m["rows"]:
            print(f"| {r['method']} | {r['seconds']:.5f} | {r['poses_per_second']:,.0f} "
                  f"| {r['ratio_to_ikine_ur']:.1f} |")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"info": info, "maps": maps}, f, indent=2)
    return maps


if __name__ == "__main__":
    main()
