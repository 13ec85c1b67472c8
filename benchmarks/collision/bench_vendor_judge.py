"""The named arms' collision models judged on the vendors' meshes by PyBullet, and what the fitted
capsules cost the README's Panda map against the exact meshes.

* judge: ``--samples`` random configurations (default 10,000, seed 0) of each arm with a PyBullet
  description (pybullet_data's Panda and iiwa 14); PyBullet calls one colliding when two arm links
  that are neither adjacent nor in contact at the zero configuration are closer than 0
  (``getClosestPoints``); each model (``fitted``, ``meshes``, ``capsules``: the estimated ones,
  self-collision only, no floor) is counted for false free (PyBullet colliding, model free: must be
  0 for ``fitted``) and false collisions (PyBullet free, model colliding), as fractions;
* map: the README's collision-aware Panda map (``cartesian_grid(-1, 1, 0.1)``, tool down, floor) with
  no checker, the fitted checker (the default) and the meshes' checker: nodes, seconds (one numba
  thread, after a warm-up), and the returned solutions PyBullet calls colliding.

    NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 PYTHONPATH=src .venv/bin/python benchmarks/collision/bench_vendor_judge.py --samples 10000
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402


def _judge(name):
    """A function `q (C, n) -> bool (C,)`: PyBullet's self-collision of the vendor URDF (module notes)."""
    import numpy as np
    import pybullet as pb

    from wsmap.collision.vendor import VENDOR, vendor_urdf
    from wsmap.robots import load

    arm = load(name)
    cid = pb.connect(pb.DIRECT)
    robot = pb.loadURDF(vendor_urdf(name), useFixedBase=True, flags=pb.URDF_USE_SELF_COLLISION, physicsClientId=cid)
    nj = pb.getNumJoints(robot, physicsClientId=cid)
    index = {pb.getJointInfo(robot, j, physicsClientId=cid)[12].decode(): j for j in range(nj)}
    index[pb.getBodyInfo(robot, physicsClientId=cid)[0].decode()] = -1
    links = [index[lk] for lk in VENDOR[name].links]
    joints = [j for j in range(nj) if pb.getJointInfo(robot, j, physicsClientId=cid)[2] == pb.JOINT_REVOLUTE][:arm.n]

    def hits(q, pairs):
        for j, x in zip(joints, q):
            pb.resetJointState(robot, j, float(x), physicsClientId=cid)
        return [(a, b) for a, b in pairs if any(p[8] < 0 for p in pb.getClosestPoints(
            robot, robot, 0.0, links[a], links[b], physicsClientId=cid))]

    near = [(a, b) for a in range(len(links)) for b in range(a + 2, len(links))]
    default = set(hits(np.clip(np.zeros(arm.n), arm.limits[:, 0], arm.limits[:, 1]), near))
    pairs = [p for p in near if p not in default]
    return lambda q: np.array([bool(hits(c, pairs)) for c in q]), sorted(default)


def main(argv=None) -> None:
    p = harness.parser(__doc__)
    p.add_argument("--samples", type=harness.positive_int, default=10000)
    args = p.parse_args(argv)

    import numpy as np

    import wsmap.workspace as ws
    from wsmap.collision import Scene, checker_for
    from wsmap.collision.vendor import VENDOR
    from wsmap.kinematics import lm_compiled
    from wsmap.robots import load

    lm_compiled.set_threads(1)
    judge = {}
    for name in VENDOR:
        colliding, default = _judge(name)
        q = load(name).random_q(args.samples, np.random.default_rng(0))
        theirs = colliding(q)
        row = {"pybullet_colliding": round(float(theirs.mean()), 4), "default_contact_pairs": default}
        for geometry in ("fitted", "meshes", "capsules"):
            free = checker_for(name, Scene(), geometry=geometry)(q)
            row[geometry] = {"false_free": int((free & theirs).sum()),
                             "false_collision_fraction": round(float(np.mean(~free & ~theirs)), 4)}
        judge[name] = row
        print(name, row, flush=True)
    panda = load("panda")
    grid = ws.cartesian_grid(-1, 1, 0.1)
    ws.constant_orientation_map(panda, grid[:50], (np.pi, 0, 0))  # warm-up: numba's cache
    colliding, _ = _judge("panda")
    maps = {}
    for label, chk in (("kinematic", None), ("fitted", checker_for("panda")),
                       ("meshes", checker_for("panda", geometry="meshes"))):
        s, (free, q) = harness.timed(lambda: ws.constant_orientation_map(  # noqa: B023
            panda, grid, (np.pi, 0, 0), collision=chk, return_q=True))  # noqa: B023
        maps[label] = {"nodes": int(free.sum()), "seconds": round(s, 2),
                       "pybullet_colliding_solutions": int(colliding(q[free]).sum())}
        print(label, maps[label], flush=True)
    lost = maps["meshes"]["nodes"] - maps["fitted"]["nodes"]
    print(f"fitted loses {lost} of the meshes' {maps['meshes']['nodes']} nodes "
          f"({lost / maps['meshes']['nodes']:.1%}); collision-aware / kinematic time "
          f"{maps['fitted']['seconds'] / maps['kinematic']['seconds']:.2f}x")
    harness.write_json(args, {"judge": judge, "maps": maps})


if __name__ == "__main__":
    main()
