"""How many unreachable map nodes are certified unreachable, per arm, and what the certificate costs.

Per arm (every named arm of ``wsmap.robots``, and the real-arm URDFs of ``bench_recall_arms.py``)
and orientation (tool frame ``R = I`` and tool down ``R = Rx(pi)``, pose convention ``standard``):
the map (``constant_orientation_map``: the closed form where the arm has one, else the default
numerical search), then each node's status (``wsmap.node_status``: reached, certified unreachable,
not found; `wsmap.kinematics.ik.certificate`). Columns: nodes not reached, the share of them
certified, the time of the map, of the status, and of the map with the border search skipping the
nodes the branch and bound certifies (``search.BORDER_CERTIFY_BUDGET = --skip-budget``; the same
answers, checked). Named arms on the paper's grid (21³, -1..1 m); URDF arms on
``bench_recall_arms.grid`` (``--nodes`` per axis around the first joint).

    # quick (the named arms and 5 URDF arms, 11³ nodes for the URDF arms; about 2 minutes)
    NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 .venv/bin/python benchmarks/maps/bench_certificates.py --quick
    # full (every arm, 15³ nodes for the URDF arms)
    NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 .venv/bin/python benchmarks/maps/bench_certificates.py
    # the branch and bound's tests before and after (certificate.BOX_TESTS 15, the tests of before the
    # tilt forms, the shoulder-first split and the near joint, beside the default; --before-tests 0:
    # none of the tests), one run, with the Panda and the iiwa14 on narrow limits of joints 0 and n-1
    NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 .venv/bin/python benchmarks/maps/bench_certificates.py --quick \
        --named-only --compare --narrow --skip-budget 0 --repeat 3
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

import wsmap
from wsmap import robots
from wsmap import workspace as ws
from wsmap.kinematics.ik import certificate, search

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
sys.path.insert(0, str(Path(__file__).resolve().parent))  # benchmarks/maps/: the URDF arms' list
import bench_recall_arms as bra  # noqa: E402
import harness  # noqa: E402

ORIENTATIONS = {"R=I": (0.0, 0.0, 0.0), "tool down": (math.pi, 0.0, 0.0)}
NAMED = ["puma560", "panda", "iiwa14", "ur5e", "ur10e", "gen3"]


def _urdf_arms(names, nodes_per_axis):
    """(name, chain, nodes) of the URDF arms of bench_recall_arms (None where its data packages are
    missing: the reason instead)."""
    try:
        from wsmap.kinematics.urdf import from_urdf

        out = []
        for name, source, base_link, ee_link in bra.ARMS:
            if names is not None and name not in names:
                continue
            chain = from_urdf(bra.urdf_text(source), ee_link=ee_link, base_link=base_link, name=name)
            out.append((name, chain, bra.grid(chain, nodes_per_axis)[0]))
        return out, None
    except ImportError as e:  # pybullet_data, rtbdata or xacro not installed
        return [], f"URDF arms skipped: {e}"


def _narrow_ends(arm):
    """The arm with joint 0 limited to ±1 rad and its last joint to ±0.5 rad (where the limits of
    the two end joints, which the invariants do not see, decide most)."""
    lim = np.array(arm.qlim, dtype=np.float64)
    lim[0], lim[-1] = [-1.0, 1.0], [-0.5, 0.5]
    return arm.replace(qlim=lim)


def _status_before(arm, T, reached, method, budget, tests):
    """The status with the branch and bound's tests of before (`certificate.BOX_TESTS = tests`),
    and its time."""
    old = certificate.BOX_TESTS
    certificate.BOX_TESTS = tests
    try:
        return harness.timed(lambda: wsmap.node_status(arm, T, reached, method, budget=budget))
    finally:
        certificate.BOX_TESTS = old


def measure(name, arm, nodes, skip_budget, repeat, budget, compare=False, before_tests=15):
    rows = []
    for oname, rpy in ORIENTATIONS.items():
        T = ws.target_poses(nodes, rpy, "standard")
        t_map, (reached, method) = harness.best_of(
            lambda: ws.constant_orientation_map(arm, nodes, rpy, return_method=True), repeat)  # noqa: B023
        t_status, status = harness.timed(lambda: wsmap.node_status(arm, T, reached, method, budget=budget))  # noqa: B023
        t_skip = None
        if method == "numerical" and skip_budget:
            search.BORDER_CERTIFY_BUDGET = skip_budget
            try:
                t_skip, skipped = harness.best_of(lambda: ws.constant_orientation_map(arm, nodes, rpy), repeat)  # noqa: B023
            finally:
                search.BORDER_CERTIFY_BUDGET = 0
            if not np.array_equal(skipped, reached):
                raise AssertionError(f"{name}, {oname}: the skip changed the map")
        unreachable = int((~reached).sum())
        cert = int((status == wsmap.CERTIFIED).sum())
        rows.append(dict(arm=name, orientation=oname, method=method, joints=arm.n, nodes=len(nodes),
                         unreachable=unreachable, certified=cert, not_found=unreachable - cert,
                         fraction=cert / max(unreachable, 1), seconds_map=t_map, seconds_status=t_status,
                         seconds_map_skip=t_skip))
        r = rows[-1]
        if compare:
            t_before, before = _status_before(arm, T, reached, method, budget, before_tests)
            # the split order changed (the shoulder first), so a node certified before may not be now
            r["lost"] = int(((before == wsmap.CERTIFIED) & (status != wsmap.CERTIFIED)).sum())
            r["certified_before"] = int((before == wsmap.CERTIFIED).sum())
            r["fraction_before"] = r["certified_before"] / max(unreachable, 1)
            r["seconds_status_before"] = t_before
        print(f"{name}, {oname}: {unreachable} not reached, {r['fraction']:.2%} certified, map {t_map:.3f} s, "
              f"status {t_status:.2f} s" + (f"; before {r['fraction_before']:.2%}, {r['seconds_status_before']:.2f} s, "
                                            f"{r['lost']} certified before only" if compare else ""),
              file=sys.stderr, flush=True)
    return rows


def table(rows) -> str:
    compare = any("certified_before" in r for r in rows)
    head = ("| arm | R | method | nodes | not reached | certified | not found | share | map s | status s | "
            "map s, skip |" + (" share before | status s before |" if compare else ""))
    lines = [head, "|---" * (head.count(" | ") + 1) + "|"]
    for r in rows:
        skip = "" if r["seconds_map_skip"] is None else f"{r['seconds_map_skip']:.3f}"
        before = (f" {r['fraction_before']:.2%} | {r['seconds_status_before']:.2f} |" if "certified_before" in r
                  else (" | |" if compare else ""))
        lines.append(f"| {r['arm']} | {r['orientation']} | {r['method']} | {r['nodes']} | {r['unreachable']} | "
                     f"{r['certified']} | {r['not_found']} | {r['fraction']:.2%} | {r['seconds_map']:.3f} | "
                     f"{r['seconds_status']:.2f} | {skip} |" + before)
    return "\n".join(lines)


def main(argv=None):
    p = harness.parser(__doc__, repeat=1, quick="the named arms and 5 URDF arms (bench_recall_arms.QUICK), 11 nodes "
                                                "per axis for them")
    p.add_argument("--nodes", type=int, help="URDF arms: nodes per axis (default 15, 11 with --quick)")
    p.add_argument("--budget", type=int, default=certificate.CELL_BUDGET,
                   help=f"boxes per node of the branch and bound (default {certificate.CELL_BUDGET})")
    p.add_argument("--skip-budget", type=int, default=1000,
                   help="boxes per border node for the map with the skip (0: no such map; default 1000)")
    p.add_argument("--named-only", action="store_true", help="only the named arms")
    p.add_argument("--urdf-only", action="store_true", help="only the URDF arms")
    p.add_argument("--narrow", action="store_true",
                   help="also the Panda and the iiwa14 with joint 0 limited to +-1 rad and the last joint to +-0.5 rad")
    p.add_argument("--compare", action="store_true",
                   help="also the status with the branch and bound's tests of before (certificate.BOX_TESTS = "
                        "--before-tests)")
    p.add_argument("--before-tests", type=int, default=15,
                   help="certificate.BOX_TESTS of the --compare column (default 15: before the tilt forms, the "
                        "shoulder-first split and the near joint; 0: none of the box tests)")
    args = p.parse_args(argv)

    nodes_per_axis = args.nodes or (11 if args.quick else 15)
    grid = ws.cartesian_grid(-1, 1, 0.1)
    ws.constant_orientation_map(robots.load("panda"), grid[:100], (math.pi, 0, 0))  # compile before timing
    certificate.joint_certificate(robots.load("panda"), ws.target_poses(grid[:2], (math.pi, 0, 0)), budget=10)
    rows = []
    for name in [] if args.urdf_only else NAMED:
        rows += measure(name, robots.load(name), grid, args.skip_budget, args.repeat, args.budget, args.compare, args.before_tests)
    if args.narrow:
        for name in ("panda", "iiwa14"):
            rows += measure(f"{name}, narrow ends", _narrow_ends(robots.load(name)), grid, args.skip_budget, args.repeat,
                            args.budget, args.compare, args.before_tests)
    note = None
    if not args.named_only:
        arms, note = _urdf_arms(set(bra.QUICK) if args.quick else None, nodes_per_axis)
        for name, chain, nodes in arms:
            rows += measure(name, chain, nodes, args.skip_budget, args.repeat, args.budget, args.compare, args.before_tests)
    print(table(rows))
    if note:
        print(note)
    harness.write_json(args, {"rows": rows, "budget": args.budget, "skip_budget": args.skip_budget,
                              "box_tests": certificate.BOX_TESTS, "before_tests": args.before_tests})


if __name__ == "__main__":
    main()
