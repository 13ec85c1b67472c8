"""Recall of the numerical map against the closed form, with and without global seeding (issue 41).

The numerical map (`wsmap.kinematics.ik.search.map_search` with `MAP_SETTINGS`, what
``constant_orientation_map(..., method="numerical")`` runs) spreads from solved nodes; global
seeding (``fk_seeds``, `wsmap.kinematics.ik.fk_seeds`) also starts every node the first pass
left from the configurations of the sampled poses nearest its own, so that islands no solved node
borders are searched. Per arm and orientation (``R = I`` and tool down ``R = Rx(pi)``, standard
convention, a cube grid ``[-half, half]³`` of ``--nodes`` per axis):

* **arms**: the closed-form named arms (PUMA560 with and without Corke's limits, UR5e, UR10e) and
  ``--random`` arms of PUMA560's DH geometry with random joint-limit windows (centre uniform in
  ``[-pi, pi)``, width uniform in ``[1, 2·pi]`` rad, from ``--seed``): limit windows that cut the
  reachable set into islands and often exclude ``q = 0``;
* **reference**: the closed form (``method="exact"``); recall = numerical ∩ exact / exact; a
  numerical node the closed form does not have is a false positive;
* **time**: each map with ``fk_seeds=0`` and with the default, alternating, best of
  ``--repeat`` (after one warm call, so the per-arm joint-limit bound and the samples are built);
  LM iterations summed over the nodes (deterministic, unlike the time).

Prints a Markdown table per arm (recall and misses without and with seeding, seconds, iterations)
and the totals; ``--json PATH`` writes it all.

    NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 .venv/bin/python benchmarks/maps/bench_recall_islands.py --nodes 13 --random 30
    # the named arms on the paper's density (21³ on [-1, 1]³)
    NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 .venv/bin/python benchmarks/maps/bench_recall_islands.py --nodes 21 --half 1.0 --random 0
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

from wsmap import load, robots
from wsmap import workspace as ws
from wsmap.kinematics import from_dh, map_search
from wsmap.kinematics.ik.search import MAP_SETTINGS
from wsmap.robots.arms.puma560 import ALPHA, A, D

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402

ORIENTATIONS = {"R=I": (0.0, 0.0, 0.0), "tool down": (math.pi, 0.0, 0.0)}


def arms(random_count: int, seed: int):
    """(name, arm) pairs: the named closed-form arms, then the random limited PUMA arms."""
    yield "PUMA560", robots.puma560()
    yield "PUMA560 + limits", robots.puma560(joint_limits=True)
    yield "UR5e", load("ur5e")
    yield "UR10e", load("ur10e")
    rng = np.random.default_rng(seed)
    for i in range(random_count):
        centre, width = rng.uniform(-math.pi, math.pi, 6), rng.uniform(1.0, 2 * math.pi, 6)
        yield f"PUMA random limits {i}", from_dh(d=D, a=A, alpha=ALPHA, qlim=np.stack([centre - width / 2,
                                                                                      centre + width / 2], -1))


def run_case(arm, nodes, nb, rpy, repeat):
    T = ws.target_poses(nodes, rpy, "standard")
    exact = ws.constant_orientation_map(arm, nodes, rpy, method="exact", convention="standard")
    off_settings = {**MAP_SETTINGS, "fk_seeds": 0}
    map_search(arm, T, nb, **MAP_SETTINGS)  # warm: the limit bound and the samples, built once per arm
    t_off, t_on = [], []
    for _ in range(repeat):
        t, off = harness.timed(lambda: map_search(arm, T, nb, **off_settings))  # noqa: B023
        t_off.append(t)
        t, on = harness.timed(lambda: map_search(arm, T, nb, **MAP_SETTINGS))  # noqa: B023
        t_on.append(t)
    n = int(exact.sum())
    return dict(reachable=n, missed_off=int((exact & ~off.success).sum()), missed_on=int((exact & ~on.success).sum()),
                false_positives=int((~exact & (off.success | on.success)).sum()),
                recall_off=float((exact & off.success).sum() / max(n, 1)),
                recall_on=float((exact & on.success).sum() / max(n, 1)),
                seconds_off=min(t_off), seconds_on=min(t_on),
                iterations_off=int(off.iterations.sum()), iterations_on=int(on.iterations.sum()),
                seeded_nodes=int((on.start == -3).sum()))


def main(argv=None):
    p = harness.parser(__doc__, repeat=3, seed=0, seed_help="seed of the random limit windows (default 0)",
                       repeat_help="timed maps without and with seeding, alternating; best kept (default 3)")
    p.add_argument("--nodes", type=harness.positive_int, default=13, help="nodes per axis (default 13)")
    p.add_argument("--half", type=float, default=0.9, help="half-width of the grid cube, m (default 0.9)")
    p.add_argument("--random", type=int, default=30, help="random limited PUMA arms (default 30)")
    args = p.parse_args(argv)
    nodes = ws.cartesian_grid(-args.half, args.half, 2 * args.half / (args.nodes - 1))
    nb = ws.node_neighbours(nodes)
    rows = []
    for name, arm in arms(args.random, args.seed):
        for oname, rpy in ORIENTATIONS.items():
            r = {"arm": name, "orientation": oname, **run_case(arm, nodes, nb, rpy, args.repeat)}
            rows.append(r)
            print(f"{name}, {oname}: {r['reachable']} reachable, missed {r['missed_off']} -> {r['missed_on']}, "
                  f"{r['seconds_off']:.3f} -> {r['seconds_on']:.3f} s", file=sys.stderr, flush=True)
    print(f"\nNumerical map vs closed form, {len(nodes)} nodes ({args.nodes}³ on ±{args.half} m), fk_seeds 0 vs "
          f"{MAP_SETTINGS['fk_seeds']}, best of {args.repeat}\n")
    print("| arm | R | reachable | missed, no seeding | missed, seeding | s, no seeding | s, seeding | "
          "LM iterations, no seeding | seeding |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        if r["reachable"] or r["false_positives"]:
            print(f"| {r['arm']} | {r['orientation']} | {r['reachable']} | {r['missed_off']} | {r['missed_on']} | "
                  f"{r['seconds_off']:.3f} | {r['seconds_on']:.3f} | {r['iterations_off']} | {r['iterations_on']} |")
    tot = {k: sum(r[k] for r in rows) for k in ("reachable", "missed_off", "missed_on", "false_positives",
                                                "seconds_off", "seconds_on", "iterations_off", "iterations_on")}
    print(f"\nTotal: {tot['reachable']} reachable nodes; missed {tot['missed_off']} without seeding, "
          f"{tot['missed_on']} with it; false positives {tot['false_positives']}; time {tot['seconds_off']:.2f} s -> "
          f"{tot['seconds_on']:.2f} s ({tot['seconds_on'] / tot['seconds_off']:.2f}x); LM iterations "
          f"{tot['iterations_off']} -> {tot['iterations_on']} ({tot['iterations_on'] / tot['iterations_off']:.3f}x)")
    harness.write_json(args, {"meta": {"nodes_per_axis": args.nodes, "half": args.half, "random": args.random,
                                       "map_settings": MAP_SETTINGS}, "rows": rows, "totals": tot})


if __name__ == "__main__":
    main()
