"""Reach-study speed and coverage (issue 43): many targets, many bases, a catalogue, a REACH-like peer.

Sections (each prints a Markdown table; ``--json PATH`` writes them all):

* **targets** — ``--targets`` tool poses sampled on REACH's demo part (``data/cells/reach_demo/part.ply``,
  placed 0.15 m lower and 0.1 m nearer than in the demo), the tool free about its axis (``--turns``
  variants), one UR5e base, self-collision on and the part an obstacle on its triangles: the time of
  ``evaluate_targets`` (best of ``--repeat``, after a warm call) and the coverage;
* **bases** — the same cell's demo cloud (262 targets, ``--turns``), a base region of about
  ``--bases`` candidates (positions x 4 headings): the time of ``rank_bases`` (exact top 3) and how many
  candidates it verified;
* **catalogue** — the six named arms on that cell, each at its best base of a 64-candidate region;
* **baseline** — a REACH-like peer on the demo cloud at the UR5e's best base of the bases section:
  per target and turn, Robotics Toolbox's C++ ``ik_LM`` (``--restarts`` random restarts, joint limits),
  a solution counted when wsmap's checker calls it collision-free (the same geometry); every target the
  peer reaches must be reached by wsmap.

    NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 .venv/bin/python benchmarks/study/bench_study.py
    NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 .venv/bin/python benchmarks/study/bench_study.py --quick
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from wsmap import load, robots
from wsmap.collision import Obstacle, Scene, Shape, arm_model, checker_for
from wsmap.collision.named import ARM_MODELS
from wsmap.collision.shapes.mesh import read_mesh
from wsmap.workspace.study import REACHED, BaseRegion, evaluate_targets, rank_bases, tool_variants
from wsmap.workspace.workpiece import targets_from_mesh, targets_from_points

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402

CELL = harness.ROOT / "data" / "cells" / "reach_demo"
#: The demo part moved 0.1 m towards the arm and 0.15 m down: within a UR5e's reach from the origin.
PART_POSE = np.array([[1, 0, 0, -0.1], [0, 1, 0, 0], [0, 0, 1, -0.15], [0, 0, 0, 1.0]])
TCP = np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0.1], [0, 0, 0, 1.0]])


def part_checker(name: str):
    """The default checker of the named arm `name` (`checker_for`) with the floor and the demo part,
    a surface obstacle at `PART_POSE`."""
    v, f = read_mesh(str(CELL / "part.ply"), "part")
    part = Obstacle("part", Shape("surface", (), PART_POSE, v, f, source="part.ply"), frame="world")
    floor = 0.0 if arm_model(name).floor else None
    return checker_for(name, Scene(floor=floor, obstacles=(part,)), samples=2000)


def section_targets(args):
    robot, chk = load("ur5e"), part_checker("ur5e")
    spacing = 0.0125
    ts = targets_from_mesh(CELL / "part.ply", spacing, pose=PART_POSE, max_targets=200_000)
    while len(ts) < args.targets:
        spacing *= 0.9
        ts = targets_from_mesh(CELL / "part.ply", spacing, pose=PART_POSE, max_targets=200_000)
    T = ts.poses[:args.targets]
    V = tool_variants(args.turns)
    run = lambda: evaluate_targets(robot, T, variants=V, tcp=TCP, collision=chk)  # noqa: E731
    run()
    seconds, res = harness.best_of(run, args.repeat)
    row = {"arm": "ur5e", "targets": len(T), "variants": len(V), "seconds": seconds,
           "coverage": res.coverage, "certified": int((res.status == 1).sum())}
    print(f"| targets | variants | seconds | coverage | certified |\n|---|---|---|---|---|\n"
          f"| {row['targets']} | {row['variants']} | {seconds:.2f} | {res.coverage:.3f} | {row['certified']} |")
    return row


def _cloud():
    return targets_from_points(CELL / "part.pcd", pose=PART_POSE).poses


def section_bases(args):
    robot, chk = load("ur5e"), part_checker("ur5e")
    per_side = max(2, int(round(np.sqrt(args.bases / 4))))
    step = 1.0 / (per_side - 1)
    region = BaseRegion(x=(-0.8, 0.2), y=(-0.5, 0.5), step=step, yaws=4)
    sw = harness.Stopwatch().start()
    rank = rank_bases(robot, _cloud(), region, top=3, variants=tool_variants(args.turns), tcp=TCP, collision=chk)
    seconds = sw.elapsed()
    best = rank.bases[0]
    row = {"candidates": len(rank.candidates), "verified": rank.verified, "seconds": seconds,
           "best_coverage": rank.best.coverage, "best_xy": best[:2, 3].round(3).tolist()}
    print(f"| candidates | verified | seconds | best coverage | best base (x, y) m |\n|---|---|---|---|---|\n"
          f"| {row['candidates']} | {rank.verified} | {seconds:.1f} | {rank.best.coverage:.3f} | {row['best_xy']} |")
    return row, rank


def section_catalogue(args):
    rows = []
    region = BaseRegion(x=(-0.6, 0.2), y=(-0.3, 0.3), step=0.2, yaws=4)
    whole = harness.Stopwatch().start()
    for name in robots.ROBOTS:
        chk = part_checker(name) if name in ARM_MODELS else None  # the others have no collision model
        sw = harness.Stopwatch().start()
        rank = rank_bases(load(name), _cloud(), region, top=1, variants=tool_variants(args.turns), tcp=TCP,
                          collision=chk)
        rows.append({"arm": name, "collision": chk is not None, "coverage": rank.best.coverage,
                     "seconds": sw.elapsed()})
    total = whole.elapsed()
    print("| arm | collision | coverage | seconds |\n|---|---|---|---|")
    for r in rows:
        print(f"| {r['arm']} | {r['collision']} | {r['coverage']:.3f} | {r['seconds']:.1f} |")
    print(f"all six: {total:.1f} s")
    return {"rows": rows, "seconds": total}


def section_baseline(args, base):
    import roboticstoolbox as rtb

    robot, chk = load("ur5e"), part_checker("ur5e")
    from wsmap.robots.arms.ur5e import UR5E  # the published table wsmap's UR5e is built from

    lim = np.asarray(robot.qlim)
    peer = rtb.DHRobot([rtb.RevoluteDH(d=d, a=a, alpha=al, offset=off, qlim=lim[i])
                        for i, (d, a, al, off) in enumerate(UR5E.rows)])
    q_test = np.random.default_rng(0).uniform(lim[:, 0], lim[:, 1], (5, 6))
    np.testing.assert_allclose(np.array([peer.fkine(q).A for q in q_test]), robot.fkine(q_test), atol=1e-9)
    T = _cloud()
    V = tool_variants(args.turns)
    E = np.linalg.inv(base) @ T[:, None] @ V[None] @ np.linalg.inv(TCP)
    rng = np.random.default_rng(args.seed)
    sw = harness.Stopwatch().start()
    peer_ok = np.zeros(len(T), dtype=bool)
    for m in range(len(T)):
        for k in range(len(V)):
            for _ in range(args.restarts):
                q0 = rng.uniform(lim[:, 0], lim[:, 1])
                q, ok, *_ = peer.ik_LM(E[m, k], q0=q0, ilimit=30, slimit=1, tol=1e-8)
                if ok and chk.at_bases(q[None], base)[0]:
                    peer_ok[m] = True
                    break
            if peer_ok[m]:
                break
    peer_seconds = sw.elapsed()
    sw = harness.Stopwatch().start()
    ours = evaluate_targets(robot, T, base=base, variants=V, tcp=TCP, collision=chk).status == REACHED
    our_seconds = sw.elapsed()
    row = {"targets": len(T), "peer_reached": int(peer_ok.sum()), "wsmap_reached": int(ours.sum()),
           "peer_only": int((peer_ok & ~ours).sum()), "peer_seconds": peer_seconds, "wsmap_seconds": our_seconds}
    print(f"| targets | peer reached | wsmap reached | peer only | peer s | wsmap s |\n|---|---|---|---|---|---|\n"
          f"| {len(T)} | {row['peer_reached']} | {row['wsmap_reached']} | {row['peer_only']} | "
          f"{peer_seconds:.1f} | {our_seconds:.2f} |")
    return row


def main(argv=None):
    ap = harness.parser(__doc__, repeat=3, seed=0, quick="1000 targets, 100 bases, 3 restarts")
    ap.add_argument("--targets", type=harness.positive_int, default=10_000)
    ap.add_argument("--turns", type=harness.positive_int, default=8)
    ap.add_argument("--bases", type=harness.positive_int, default=1000)
    ap.add_argument("--restarts", type=harness.positive_int, default=10)
    args = ap.parse_args(argv)
    if args.quick:
        args.targets, args.bases, args.restarts, args.repeat = 1000, 100, 3, 1
    print("## targets")
    targets = section_targets(args)
    print("\n## bases")
    bases, rank = section_bases(args)
    print("\n## catalogue")
    catalogue = section_catalogue(args)
    print("\n## baseline")
    baseline = section_baseline(args, rank.bases[0])
    harness.write_json(args, {"targets": targets, "bases": bases, "catalogue": catalogue, "baseline": baseline})


if __name__ == "__main__":
    main()
