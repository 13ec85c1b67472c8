"""The named arms' collision models judged on the vendors' meshes by PyBullet, side by side: false
collisions and time of the fitted capsules, the two-level check and the meshes, and what each costs
the README's collision-aware Panda map against the kinematic map.

* judge: ``--samples`` random configurations (default 10,000, seed 0) of each arm with a PyBullet
  description (pybullet_data's Panda and iiwa 14; Universal Robots' UR5e and UR10e xacro and
  Kinova's Gen3 xacro expanded as ROS does, ``tests/collision/vendor_urdfs.py``: the Gen3's from a
  mirror of ``ros2_kortex``, its path in ``WSMAP_KORTEX_REPO``; ``--arms`` picks some); PyBullet calls one colliding when two arm links
  that are neither adjacent nor in contact at the zero configuration are closer than 0
  (``getClosestPoints``). Each model (``meshes``: the default, ``two-level``, ``fitted``,
  ``capsules``: the estimated ones; self-collision only, no floor) is counted for false free
  (PyBullet colliding, model free: must be 0 for all but ``capsules``) and false collisions
  (PyBullet free, model colliding), as fractions of the samples, and timed (the fastest of
  ``--repeat`` calls on all the samples, one thread);
* map: the README's collision-aware map (``cartesian_grid(-1, 1, 0.1)``, tool down, floor) of each
  arm with no checker, the meshes, the two-level check, the fitted capsules and the estimated
  capsules (where the arm has them):
  nodes, seconds (the fastest of ``--repeat`` runs, one numba thread, after a warm-up), the ratio
  to the kinematic map's time, and the returned solutions PyBullet calls colliding.

    NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 .venv/bin/python benchmarks/collision/bench_vendor_judge.py --samples 10000 --repeat 3
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

    from wsmap.collision.vendor import VENDOR, PackagedURDF, vendor_urdf
    from wsmap.robots import load

    arm = load(name)
    if isinstance(VENDOR[name], PackagedURDF):
        urdf = vendor_urdf(name)
    else:  # the UR arms and the Gen3: the vendor's xacro expanded as ROS does (tests/collision/vendor_urdfs.py)
        import tempfile

        sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tests" / "collision"))
        from vendor_urdfs import KORTEX_MISSING, gen3_urdf, kortex_present, ur_urdf

        if name == "gen3":
            if not kortex_present():
                raise SystemExit(KORTEX_MISSING)
            urdf = str(gen3_urdf(Path(tempfile.mkdtemp())))
        else:
            urdf = str(ur_urdf(name, Path(tempfile.mkdtemp())))
    cid = pb.connect(pb.DIRECT)
    robot = pb.loadURDF(urdf, useFixedBase=True, flags=pb.URDF_USE_SELF_COLLISION, physicsClientId=cid)
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


GEOMETRIES = ("meshes", "two-level", "fitted", "capsules")


def main(argv=None) -> None:
    p = harness.parser(__doc__, repeat=3)
    p.add_argument("--samples", type=harness.positive_int, default=10000)
    p.add_argument("--arms", nargs="+", default=None, help="arms of wsmap.collision.vendor.VENDOR (default: all)")
    args = p.parse_args(argv)

    import numpy as np

    import wsmap.workspace as ws
    from wsmap.collision import Scene, checker_for, default_geometry
    from wsmap.collision.vendor import VENDOR
    from wsmap.kinematics import lm_compiled
    from wsmap.robots import load

    from wsmap.collision.named import ARM_MODELS

    lm_compiled.set_threads(1)
    arms = args.arms or list(VENDOR)
    if set(arms) - set(VENDOR):
        p.error(f"--arms: no vendor meshes for {', '.join(sorted(set(arms) - set(VENDOR)))}; arms: {', '.join(VENDOR)}")
    judge, maps, judges = {}, {}, {}
    for name in arms:
        colliding, default = _judge(name)
        judges[name] = colliding
        q = load(name).random_q(args.samples, np.random.default_rng(0))
        theirs = colliding(q)
        row = {"default_geometry": default_geometry(name), "pybullet_colliding": round(float(theirs.mean()), 4),
               "default_contact_pairs": default}
        for geometry in (g for g in GEOMETRIES if g != "capsules" or name in ARM_MODELS):  # UR10e: no estimate
            chk = checker_for(name, Scene(), geometry=geometry)
            s, free = harness.best_of(lambda: chk(q), args.repeat)  # noqa: B023
            row[geometry] = {"false_free": int((free & theirs).sum()),
                             "false_collision_fraction": round(float(np.mean(~free & ~theirs)), 4),
                             "seconds": round(s, 3), "us_per_configuration": round(s / len(q) * 1e6, 2)}
        judge[name] = row
        print(name, row, flush=True)
    for name in arms:
        arm = load(name)
        grid = ws.cartesian_grid(-1, 1, 0.1)
        ws.constant_orientation_map(arm, grid[:50], (np.pi, 0, 0))  # warm-up: numba's cache
        maps[name] = {}
        for label in ("kinematic", *(g for g in GEOMETRIES if g != "capsules" or name in ARM_MODELS)):
            chk = None if label == "kinematic" else checker_for(name, geometry=label)
            s, (free, q) = harness.best_of(lambda: ws.constant_orientation_map(  # noqa: B023
                arm, grid, (np.pi, 0, 0), collision=chk, return_q=True), args.repeat)  # noqa: B023
            row = {"nodes": int(free.sum()), "seconds": round(s, 3),
                   "pybullet_colliding_solutions": int(judges[name](q[free]).sum())}
            if label != "kinematic":
                row["time_over_kinematic"] = round(s / maps[name]["kinematic"]["seconds"], 2)
            maps[name][label] = row
            print(name, label, row, flush=True)
        m = maps[name]
        lost = m["meshes"]["nodes"] - m["fitted"]["nodes"]
        print(f"{name}: the fitted capsules lose {lost} of the meshes' {m['meshes']['nodes']} nodes "
              f"({lost / m['meshes']['nodes']:.1%}); collision-aware (default, {default_geometry(name)}) / kinematic "
              f"time {m[default_geometry(name)]['time_over_kinematic']:.2f}x")
    harness.write_json(args, {"judge": judge, "maps": maps})


if __name__ == "__main__":
    main()
