"""Time the UR closed form (`wsmap.kinematics.ik.closed_forms.ur`) against EAIK on UR5e maps.

Two maps of the 9261 nodes of ``cartesian_grid(-1, 1, 0.1)`` (m), each at one orientation:
``R = I`` and tool-down ``R = Rx(pi)``; pose ``T = transl(p) · R`` in the UR5e base frame (flange,
no tool). Per map and method, the best wall time of one whole map over ``--rounds`` cycles of
``--repeats`` runs in a row (after an untimed warm-up run; numba's compile, or the load of its
cache, happens before any of it):

1. ``ur_reachable(robot, T)`` (compiled) from the robot (its structure check included), on 1 thread
   and on ``--threads`` threads (``lm_compiled.set_threads``; default 2); and the whole exact map,
   ``constant_orientation_map(robot, nodes, rpy, method="exact")`` on 1 thread (the poses built,
   the closed form chosen, the arm checked: what a user's map call costs), printed again beside
   EAIK's 1-thread time per map;
2. ``ikine_ur(robot, T)``, compiled, 1 thread: all 8 branches with their joint angles (more than a
   map needs: about 20 ``atan2`` per pose);
3. EAIK's ``IK_batched`` with 1 worker thread (``IK`` in a Python loop if ``IK_batched`` is
   missing), the C++ solve only: building its reachable labels is not timed;
4. the same with ``--eaik-threads`` workers (its default is 4), when that is not 1.

EAIK's label of a node: one of its solutions puts the flange within 1e-6 of ``T`` (forward
kinematics of `SerialChain.fkine`, every matrix entry). The script asserts that the labels
of every method are identical node for node, prints a Markdown table per map (method, seconds per
map, poses/s, speed-up over EAIK on 1 thread) and the cost of the structure check
(``ur_parameters``, ``is_ur_type``) beside the compiled map from precomputed ``URParameters``; with
``--json PATH`` it writes the numbers. Goal: the compiled map on 1 thread at least 10x faster than
EAIK on 1 thread (aim: 30x).

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/kernel/bench_ur_closed_form.py --repeats 5 --json out.json
"""

from __future__ import annotations

import importlib.metadata
import os
import platform
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402


#: The row of the whole exact map call (poses built, closed form chosen, arm checked, the map).
EXACT_MAP = "wsmap constant_orientation_map(method='exact'), the whole map (1 thread)"


def _best_of(methods, repeats, rounds):
    """Best wall time in s of each method, and the result of its last call.

    ``methods``: ``(prepare, fn)`` pairs; ``prepare()`` (e.g. setting the thread count) runs before
    the method's turn and is not timed. Each function runs ``repeats`` times in a row (after one
    untimed warm-up call), so each is timed with its own data in cache; ``rounds`` cycles over all
    the functions guard against a change of machine load between them (the best is kept).
    """
    best, out = [np.inf] * len(methods), [None] * len(methods)
    for _ in range(rounds):
        for i, (prepare, fn) in enumerate(methods):
            prepare()
            t, out[i] = harness.best_of(fn, repeats, warmup=1)
            best[i] = min(best[i], t)
    return best, out


def _best_time(fn, number, repeats):
    """Best mean time in s of ``number`` calls in a row, over ``repeats`` tries (after a warm-up)."""
    fn()

    def calls():
        for _ in range(number):
            fn()

    return harness.best_of(calls, repeats)[0] / number


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


def _checked_rows(methods, times, results, ours, chain, T, label):
    """The labels of the first method and one row per method; asserts that every method's labels are
    the same node for node (EAIK's from its solutions, `_eaik_labels`)."""
    N = len(T)
    labels = results[0]
    rows = []
    for i, ((name, _, _), t, res) in enumerate(zip(methods, times, results)):
        row = {"method": name, "seconds": t}
        if i < ours:
            mism = np.flatnonzero(res != labels)
        else:
            theirs, not_ls = _eaik_labels(chain, T, res)
            mism = np.flatnonzero(theirs != labels)
            row["labels_from_is_LS_agree"] = bool(np.array_equal(not_ls, theirs))
        assert mism.size == 0, f"{label}: labels of {name} differ at nodes {mism[:10]}"
        rows.append(row)
    eaik1 = times[ours]
    for r in rows:
        r["poses_per_second"] = N / r["seconds"]
        r["speedup_over_eaik_1_thread"] = eaik1 / r["seconds"]
    return labels, rows


def _structure_check(chain, nodes):
    """Seconds of the structure check (`ur_parameters`, `is_ur_type`) and of the compiled map with and
    without it (from precomputed `URParameters`), on 1 thread."""
    from wsmap.kinematics import lm_compiled
    from wsmap.kinematics.ik.closed_forms.ur import (
        is_ur_type,
        ur_parameters,
        ur_reachable,
    )

    N = len(nodes)
    lm_compiled.set_threads(1)
    prm = ur_parameters(chain)
    T = np.zeros((N, 4, 4))
    T[:, :3, :3], T[:, :3, 3], T[:, 3, 3] = np.eye(3), nodes, 1.0
    number = 2000
    structure = {
        "ur_parameters_seconds": _best_time(lambda: ur_parameters(chain), number, 5),
        "is_ur_type_seconds": _best_time(lambda: is_ur_type(chain), number, 5),
        "ur_reachable_one_pose_seconds": _best_time(lambda: ur_reachable(chain, T[:1]), number, 5),
        "ur_reachable_from_parameters_seconds": _best_time(lambda: ur_reachable(prm, T), 20, 5),
        "ur_reachable_from_robot_seconds": _best_time(lambda: ur_reachable(chain, T), 20, 5),
    }
    return structure


def _print_report(info, maps, structure, repeat, rounds):
    """The run's conditions, a Markdown table per map, the structure check and the goal."""
    N, first_call = info["nodes"], info["first_call_seconds"]
    print(f"UR5e, {N} nodes of cartesian_grid(-1, 1, 0.1), best of {repeat} in a row x {rounds} "
          f"rounds; python {info['python']}, numpy {info['numpy']}, numba {info['numba']}, eaik {info['eaik']}, "
          f"{info['cpus']} CPUs, OMP_NUM_THREADS={info['omp_num_threads']}, load average {info['load_average']}; "
          f"first compiled call {first_call:.2f} s (compile or cache load)")
    for label, m in maps.items():
        print()
        print(f"{label}: {m['reachable']} reachable nodes, labels identical node for node (all methods)")
        print()
        print("| method | seconds per map | poses/s | speed-up over EAIK (1 thread) |")
        print("|---|---:|---:|---:|")
        for r in m["rows"]:
            print(f"| {r['method']} | {r['seconds']:.5f} | {r['poses_per_second']:,.0f} "
                  f"| {r['speedup_over_eaik_1_thread']:.1f}x |")
    print()
    for label, m in maps.items():  # the exact map beside EAIK, the numbers of issue 44
        rows = {r["method"]: r for r in m["rows"]}
        eaik = next(r for name, r in rows.items() if name.startswith("EAIK") and name.endswith("(1 thread)"))
        ours = rows[EXACT_MAP]
        print(f"exact map, UR5e {label}, {N} nodes: wsmap {ours['seconds'] * 1e3:.2f} ms, EAIK (1 thread) "
              f"{eaik['seconds'] * 1e3:.2f} ms ({ours['speedup_over_eaik_1_thread']:.1f}x)")
    print()
    s = structure
    print(f"structure check: ur_parameters {s['ur_parameters_seconds'] * 1e6:.1f} us, is_ur_type "
          f"{s['is_ur_type_seconds'] * 1e6:.1f} us; ur_reachable of one pose (all fixed costs) "
          f"{s['ur_reachable_one_pose_seconds'] * 1e6:.1f} us; the R = I map from the robot "
          f"{s['ur_reachable_from_robot_seconds'] * 1e3:.3f} ms, from URParameters "
          f"{s['ur_reachable_from_parameters_seconds'] * 1e3:.3f} ms (1 thread)")
    worst = min(m["rows"][0]["speedup_over_eaik_1_thread"] for m in maps.values())
    print(f"goal: compiled (1 thread) >= 10x EAIK (1 thread): {'met' if worst >= 10 else 'NOT met'} "
          f"(worst map {worst:.1f}x; aim 30x: {'met' if worst >= 30 else 'not met'})")


def _info(N, args, many, first_call, batched):
    """The run's conditions: versions, CPUs, thread settings, load, sizes and the first compiled call."""
    import numba

    return {
        "python": sys.version.split()[0],
        "numpy": np.__version__,
        "numba": numba.__version__,
        "eaik": importlib.metadata.version("eaik"),
        "machine": platform.machine(),
        "cpus": os.cpu_count(),
        "numba_threads": numba.config.NUMBA_NUM_THREADS,
        "omp_num_threads": os.environ.get("OMP_NUM_THREADS"),
        "load_average": os.getloadavg() if hasattr(os, "getloadavg") else None,
        "nodes": N,
        "repeats": args.repeat,
        "rounds": args.rounds,
        "compiled_threads": many,
        "first_call_seconds": first_call,
        "eaik_call": "IK_batched" if batched else "IK in a Python loop",
    }


def _options():
    """The command line: the harness's common options and this benchmark's own."""
    ap = harness.parser(__doc__, repeat=5, threads=2,
                        repeat_help="timed runs in a row per map and method (best is kept)",
                        threads_help="threads of the compiled kernel's second run (default 2)")
    ap.add_argument("--rounds", type=int, default=2, help="cycles over the methods, each with --repeats runs")
    ap.add_argument("--eaik-threads", type=int, default=4, help="worker threads of EAIK's second run (its default: 4)")
    return ap


def main(argv=None):
    ap = _options()
    args = ap.parse_args(argv)
    if args.rounds < 1 or args.eaik_threads < 1:
        ap.error("--rounds and --eaik-threads must be positive")

    from eaik.IK_DH import DhRobot

    from wsmap import robots
    from wsmap.kinematics import lm_compiled, rotx
    from wsmap.kinematics.ik.closed_forms.ur import ikine_ur, ur_reachable
    from wsmap.workspace import cartesian_grid, constant_orientation_map

    chain = robots.load("ur5e")
    d, a, alpha, _ = np.array(robots.NAMED["ur5e"].rows).T
    eaik = DhRobot(alpha, a, d)
    batched = hasattr(eaik, "IK_batched")
    nodes = cartesian_grid(-1.0, 1.0, 0.1)
    N = len(nodes)
    threads_before = lm_compiled.threads()
    many = lm_compiled.set_threads(args.threads)  # clamped to the cores numba sees
    with harness.Stopwatch() as sw:
        ur_reachable(chain, np.eye(4))
        ikine_ur(chain, np.eye(4))
    first_call = sw.seconds  # numba: compile, or load from its cache
    info = _info(N, args, many, first_call, batched)

    def eaik_solve(T, threads):
        return eaik.IK_batched(T, threads) if batched else [eaik.IK(t) for t in T]

    def threads(n):
        return lambda: lm_compiled.set_threads(n)

    def nothing():
        return None

    plural = lambda n: f"{n} thread{'s' if n > 1 else ''}"  # noqa: E731
    maps = {}
    for label, rpy in (("R = I", (0.0, 0.0, 0.0)), ("tool-down R = Rx(pi)", (np.pi, 0.0, 0.0))):
        T = np.zeros((N, 4, 4))
        T[:, :3, :3], T[:, :3, 3], T[:, 3, 3] = rotx(rpy[0]), nodes, 1.0
        methods = [("wsmap ur_reachable, compiled (1 thread)", threads(1), lambda: ur_reachable(chain, T)),
                   (EXACT_MAP, threads(1),
                    lambda rpy=rpy: constant_orientation_map(chain, nodes, rpy, method="exact"))]
        if many > 1:
            methods.append((f"wsmap ur_reachable, compiled ({plural(many)})", threads(many),
                            lambda: ur_reachable(chain, T)))
        methods += [
            ("wsmap ikine_ur, compiled, all 8 branches with angles (1 thread)", threads(1),
             lambda: ikine_ur(chain, T).success.any(axis=-1)),
        ]
        ours = len(methods)
        eaik_threads = [1] + ([args.eaik_threads] if batched and args.eaik_threads != 1 else [])
        methods += [(f"EAIK {info['eaik_call']} ({plural(k)})", nothing, lambda k=k: eaik_solve(T, k))
                    for k in eaik_threads]
        times, results = _best_of([(p, f) for _, p, f in methods], args.repeat, args.rounds)
        labels, rows = _checked_rows(methods, times, results, ours, chain, T, label)
        maps[label] = {"reachable": int(labels.sum()), "labels_identical": True, "rows": rows}

    structure = _structure_check(chain, nodes)
    lm_compiled.set_threads(threads_before)

    _print_report(info, maps, structure, args.repeat, args.rounds)
    harness.write_json(args, {"info": info, "maps": maps, "structure_check": structure})
    return maps


if __name__ == "__main__":
    main()
