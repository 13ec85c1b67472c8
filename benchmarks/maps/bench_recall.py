"""Recall of the numerical map against exact references, against the number of IK starts.

Cases (the paper's grid, ``cartesian_grid(-1, 1, 0.1)``: 9261 nodes, standard pose convention
``T = transl(p)·R`` so that the node is the tool position), each at ``R = I`` and tool down
``R = Rx(pi)``:

* PUMA560 without limits (the paper's arm): reference the closed form (wrist-centre test);
* PUMA560 with Corke's limits (``robots.puma560(joint_limits=True)``): reference the closed form
  with limits (all 8 branches, limits up to multiples of 2·pi);
* UR5e (standard DH from Universal Robots' table, limits ±2·pi): reference EAIK (analytic; a node is
  reachable iff EAIK returns a solution not flagged least-squares whose forward kinematics is
  within 1e-6 of the target; ±2·pi limits admit every angle). EAIK is a test-only dependency.

For every case the map is computed by `wsmap.kinematics.ikine_search` with the largest
count of starts, recording which start first succeeded at each node; the recall at ``k`` starts
is the fraction of exact-reachable nodes solved by starts ``0 .. k-1``. With ``--time-each``
(default) the map is also recomputed at every count, timed, and checked to equal that prefix
(early exit makes a map with ``k`` starts the first ``k`` starts of a longer run). False positives
(numerically reachable, exactly not) must be zero at every count.

Prints a Markdown table (recall, false negatives, false positives, seconds per map) and writes
JSON with ``--json PATH``.

    OMP_NUM_THREADS=1 nice .venv/bin/python benchmarks/maps/bench_recall.py --json recall.json
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

from wsmap import robots
from wsmap import workspace as ws
from wsmap.kinematics import from_dh
from wsmap.kinematics.ik.search import DEFAULT_STARTS, ikine_search

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402

COUNTS = (1, 2, 4, 8, 12, 16, 24, 32, 48, 64)
ORIENTATIONS = {"R=I": (0.0, 0.0, 0.0), "tool down": (math.pi, 0.0, 0.0)}


def ur5e():
    """UR5e, standard DH (Universal Robots' DH table), limits ±2·pi."""
    pi = math.pi
    return from_dh(d=[0.1625, 0, 0, 0.1333, 0.0997, 0.0996], a=[0, -0.425, -0.3922, 0, 0, 0],
                   alpha=[pi / 2, 0, 0, pi / 2, -pi / 2, 0], qlim=np.tile([-2 * pi, 2 * pi], (6, 1)), name="ur5e")


def eaik_reference(chain, T, atol=1e-6):
    """(reachable (N,) bool, number of nodes where EAIK gave a non-LS solution that FK rejects)."""
    from eaik.IK_DH import DhRobot

    pi = math.pi
    bot = DhRobot(np.array([pi / 2, 0, 0, pi / 2, -pi / 2, 0]), np.array([0, -0.425, -0.3922, 0, 0, 0]),
                  np.array([0.1625, 0, 0, 0.1333, 0.0997, 0.0996]))
    out = np.zeros(len(T), dtype=bool)
    rejected = 0
    for i, sol in enumerate(bot.IK_batched(list(T), num_worker_threads=1)):
        Q = np.asarray(sol.Q).reshape(-1, 6)
        ls = np.asarray(sol.is_LS, dtype=bool).reshape(-1)
        Q = Q[~ls]
        if not len(Q):
            continue
        err = np.abs(chain.fkine(Q) - T[i]).max(axis=(-2, -1))
        rejected += int(np.any(err > atol))
        out[i] = bool(np.any(err <= atol))  # ±2pi limits: every angle has an equivalent inside
    return out, rejected


def cases(which):
    nodes = ws.cartesian_grid(-1, 1, 0.1)
    for oname, rpy in ORIENTATIONS.items():
        T = ws.target_poses(nodes, rpy, "standard")
        if "puma560" in which:
            arm = robots.puma560()
            yield "PUMA560", oname, arm, T, ws.constant_orientation_map(arm, nodes, rpy, method="exact",
                                                                        convention="standard"), {}
        if "puma560_limits" in which:
            arm = robots.puma560(joint_limits=True)
            yield "PUMA560 + limits", oname, arm, T, ws.constant_orientation_map(arm, nodes, rpy, method="exact",
                                                                                 convention="standard"), {}
        if "ur5e" in which:
            arm = ur5e()
            ref, rejected = eaik_reference(arm, T)
            yield "UR5e", oname, arm, T, ref, {"eaik_non_ls_rejected_by_fk": rejected}


def main(argv=None):
    p = harness.parser(__doc__, seed=0, seed_help="seed of the random IK starts (default 0)")
    p.add_argument("--counts", type=int, nargs="+", default=list(COUNTS))
    p.add_argument("--cases", nargs="+", default=["puma560", "puma560_limits", "ur5e"],
                   choices=["puma560", "puma560_limits", "ur5e"])
    p.add_argument("--no-time-each", dest="time_each", action="store_false",
                   help="only the largest count is run and timed; the curve comes from its start indices")
    args = p.parse_args(argv)
    counts = sorted(set(args.counts))
    S = counts[-1]
    rows = []
    for robot, oname, arm, T, exact, extra in cases(args.cases):
        t_max, res = harness.timed(lambda: ikine_search(arm, T, starts=S, seed=args.seed))  # noqa: B023
        first = res.start
        n_exact = int(exact.sum())
        row = {"robot": robot, "orientation": oname, "nodes": len(T), "reachable": n_exact, **extra,
               "seconds_max": t_max, "counts": {}}
        for k in counts:
            found = (first >= 0) & (first < k)
            entry = {"recall": float(np.sum(found & exact) / max(n_exact, 1)),
                     "false_negatives": int(np.sum(exact & ~found)),
                     "false_positives": int(np.sum(found & ~exact))}
            if args.time_each:
                if k == S:
                    entry["seconds"] = t_max
                else:
                    entry["seconds"], m = harness.timed(
                        lambda: ikine_search(arm, T, starts=k, seed=args.seed).success)  # noqa: B023
                    if not np.array_equal(m, found):
                        raise AssertionError(f"{robot} {oname}: the map with {k} starts is not the prefix of {S}")
            row["counts"][str(k)] = entry
        missed = np.flatnonzero(exact & (first < 0))
        row["missed_nodes"] = [[round(float(x), 3) for x in T[i, :3, 3]] for i in missed[:20]]
        solved = first[exact & (first >= 0)]
        row["start_histogram"] = np.bincount(solved, minlength=S).tolist() if solved.size else []
        rows.append(row)
        print(f"{robot}, {oname}: {n_exact} reachable, {S} starts in {t_max:.1f} s, "
              f"missed {len(missed)}, false positives {row['counts'][str(S)]['false_positives']}", file=sys.stderr)

    head = "| arm | R | reachable | " + " | ".join(f"{k}" for k in counts) + " |"
    print(f"Recall against the exact map (false positives in every cell: "
          f"{sum(e['false_positives'] for r in rows for e in r['counts'].values())}); "
          f"seed {args.seed}; default starts {DEFAULT_STARTS}\n")
    print(head)
    print("|" + "---|" * (3 + len(counts)))
    for r in rows:
        cells = []
        for k in counts:
            e = r["counts"][str(k)]
            cells.append(f"{e['recall']:.4f}" + (f" ({e['false_negatives']})" if e["false_negatives"] else ""))
        print(f"| {r['robot']} | {r['orientation']} | {r['reachable']} | " + " | ".join(cells) + " |")
    if args.time_each:
        print("\nSeconds per map (9261 nodes, one process, OMP_NUM_THREADS=1)\n")
        print("| arm | R | " + " | ".join(f"{k}" for k in counts) + " |")
        print("|" + "---|" * (2 + len(counts)))
        for r in rows:
            print(f"| {r['robot']} | {r['orientation']} | "
                  + " | ".join(f"{r['counts'][str(k)]['seconds']:.1f}" for k in counts) + " |")
    harness.write_json(args, {"meta": {"seed": args.seed, "default_starts": DEFAULT_STARTS}, "rows": rows})


if __name__ == "__main__":
    main()
