"""Collision-free maps, side by side in one run: the tool-down map (``T = transl(p)·Rx(pi)``) on the
21³ grid (``cartesian_grid(-1, 1, 0.1)``) of the Panda, the iiwa 14 and the UR5e (their capsule
models, `wsmap.collision.named`) and of pybullet_data's Panda URDF (collision meshes, hand), with
self-collision and the floor, against the chain's map.

Per arm:

* the allowed-collision matrix (10000 random configurations, seed 0) and its build time;
* the chain's map and the collision-free map (``collision=``), each timed after a warm-up (numba
  compiled, caches filled), and their ratio (goal <= 3);
* every node marked reachable has its returned solution checked by coal alone
  (`CollisionChecker.exact`, no spheres): collisions found (goal 0), FK error, limits;
* recall against a reference that solves each node with ``--starts`` (default 64) independent
  random starts (one-start ``ikine_search`` runs from uniform configurations inside the limits,
  seeded) and keeps any collision-free solution (goal >= 0.995); for the UR5e also against its
  closed form, every branch checked (the map it computes by default);
* the exact check's cost per configuration (coal on every enabled pair and the floor) and the
  fraction of the configurations the checker decided without coal (the spheres; capsule pairs
  in numpy).

    NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 .venv/bin/python benchmarks/collision/bench_collision.py

``--index``: instead, the Panda's reachability index at 5 cm x 50 orientations (the real_arms
grid: the cube of half-width 1.2 m, 49³ nodes; super-Fibonacci orientations, seed 0) with
self-collision, the floor and a table (a solid box in the base frame, params.yaml's
``real_arms.collision.table``), against the same index of the chain alone, side by side (goal
<= 3 minutes on this machine), each once (``--index-step``, ``--index-orientations`` to change it;
``--index-border-starts 0``: both without the map search's border search):

    NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 .venv/bin/python benchmarks/collision/bench_collision.py --index
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from wsmap import load
from wsmap.collision import CollisionChecker, arm_model, build_acm
from wsmap.kinematics import ikine_search
from wsmap.workspace import cartesian_grid, constant_orientation_map, target_poses

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402

DOWN = (np.pi, 0.0, 0.0)


def reference(robot, chk, T, starts, seed):
    """Collision-free reachability by ``starts`` independent random starts per node: (N,) bool."""
    rng = np.random.default_rng(seed)
    free = np.zeros(len(T), dtype=bool)
    for k in range(starts):
        todo = np.flatnonzero(~free)
        if not todo.size:
            break
        q0 = robot.random_q(todo.size, rng)
        res = ikine_search(robot, T[todo], starts=1, q0=q0, seed=seed + k)
        hit = np.flatnonzero(res.success)
        if hit.size:
            free[todo[hit[chk(res.q[hit])]]] = True
    return free


def timed(f, repeats=2):
    """(best seconds of `repeats` calls of `f()`, the last answer)."""
    return harness.best_of(f, repeats)


#: params.yaml's real_arms.collision.table: size (m) and centre (m) in the base frame; top at 0.3 m
TABLE = {"size": [0.8, 1.2, 0.3], "xyz": [0.75, 0.0, 0.15]}


def bench_index(step, k, half_width=1.2, ik=None):
    """The Panda's index with and without collisions, timed once each (after a small warm-up);
    ``ik``: search settings for both (e.g. ``{"border_starts": 0}``)."""
    from wsmap.collision import CollisionChecker, scene_from_dict
    from wsmap.workspace import orientation_samples, reachability_index

    robot = load("panda")
    nodes = cartesian_grid(-half_width, half_width, step)
    R = orientation_samples(k, seed=0)
    model = arm_model("panda")
    t_acm, model.acm = timed(lambda: build_acm(model), 1)
    table = scene_from_dict({"frame": "base", "floor": True,
                             "obstacles": [{"name": "table", "shape": "box", **TABLE}]})
    chk = CollisionChecker(model, table)
    warm = cartesian_grid(-0.6, 0.6, 0.3)
    reachability_index(robot, warm, R[:4])  # numba compiled, caches filled
    reachability_index(robot, warm, R[:4], collision=chk)
    print(f"Panda reachability index, {len(nodes)} nodes ({step} m) x {k} orientations; self-collision, the floor "
          f"and a table {TABLE} (base frame); matrix {t_acm:.2f} s; {len(chk.pairs)} enabled link pairs")
    print(f"  search settings: {ik or 'the defaults (MAP_SETTINGS)'}")
    t0, i0 = timed(lambda: reachability_index(robot, nodes, R, ik=ik), 1)
    print(f"  chain alone      {t0:7.1f} s   reached {int((i0 > 0).sum())} nodes, sum of the index {i0.sum():.0f}",
          flush=True)
    chk.stats.__init__()
    t1, (i1, bits, q) = timed(lambda: reachability_index(robot, nodes, R, collision=chk, return_bits=True,
                                                        return_q=True, ik=ik), 1)
    st = chk.stats
    print(f"  collision-free   {t1:7.1f} s   reached {int((i1 > 0).sum())} nodes, sum of the index {i1.sum():.0f}; "
          f"ratio {t1 / t0:.2f}; goal <= 180 s: {'met' if t1 <= 180 else 'missed'}")
    print(f"  volume lost: {(1 - (i1 > 0).sum() / max((i0 > 0).sum(), 1)):.1%} of the reached nodes, "
          f"{(1 - i1.sum() / max(i0.sum(), 1)):.1%} of the index-weighted volume")
    print(f"  checker: {st.configurations} configurations, {st.fast_fraction:.1%} decided without coal, "
          f"{st.exact_tests} coal tests, {st.seconds:.1f} s in the checker ({st.exact_seconds:.1f} s exact)")
    # every returned solution of a sample of the positive poses: free by coal alone
    rng = np.random.default_rng(0)
    pos = np.argwhere(bits)
    sample = pos[rng.choice(len(pos), min(2000, len(pos)), replace=False)]
    qs = q[sample[:, 0], sample[:, 1]]
    colliding = int((~chk.exact(qs)).sum())
    print(f"  {len(sample)} returned solutions sampled: colliding by coal alone {colliding} "
          f"(goal 0); inside the limits {bool(robot.within_limits(qs).all())}")
    return {"nodes": len(nodes), "step": step, "orientations": k, "search_settings": ik, "acm_seconds": t_acm,
            "chain_seconds": t0, "collision_free_seconds": t1, "chain_nodes_reached": int((i0 > 0).sum()),
            "free_nodes_reached": int((i1 > 0).sum()), "sampled_solutions": len(sample),
            "sampled_colliding": colliding, "checker": vars(st)}


def main(argv=None):
    ap = harness.parser(__doc__)
    ap.add_argument("--arms", nargs="+", default=["panda", "iiwa14", "ur5e", "panda-urdf"],
                    help="named arms (capsule models) and 'panda-urdf': pybullet_data's Panda URDF with its "
                         "collision meshes and hand (the tool at panda_hand)")
    ap.add_argument("--starts", type=int, default=64)
    ap.add_argument("--step", type=float, default=0.1)
    ap.add_argument("--index", action="store_true",
                    help="the Panda's reachability index with self-collision and a table against the chain's, instead")
    ap.add_argument("--index-step", type=float, default=0.05)
    ap.add_argument("--index-orientations", type=int, default=50)
    ap.add_argument("--index-border-starts", type=int, default=None,
                    help="the map search's border_starts for both indexes (default: MAP_SETTINGS', 32)")
    args = ap.parse_args(argv)
    if args.index:
        ik = None if args.index_border_starts is None else {"border_starts": args.index_border_starts}
        harness.write_json(args, {"index": bench_index(args.index_step, args.index_orientations, ik=ik)})
        return
    results = {}
    nodes = cartesian_grid(-1, 1, args.step)
    T = target_poses(nodes, DOWN, "standard")
    print(f"tool-down map, {len(nodes)} nodes, self-collision + floor; reference {args.starts} starts per node")
    for name in args.arms:
        if name == "panda-urdf":
            import os

            import pybullet_data

            from wsmap.collision import from_urdf_collision

            model = from_urdf_collision(os.path.join(pybullet_data.getDataPath(), "franka_panda", "panda.urdf"),
                                        ee_link="panda_hand", floor=True)
            robot = model.chain
        else:
            robot = load(name)
            model = arm_model(name)
        t_acm, model.acm = timed(lambda: build_acm(model), 1)
        chk = CollisionChecker(model)
        constant_orientation_map(robot, nodes, DOWN, convention="standard")  # warm-up: numba, caches
        constant_orientation_map(robot, nodes, DOWN, convention="standard", collision=chk)
        t0, m0 = timed(lambda: constant_orientation_map(robot, nodes, DOWN, convention="standard"))
        chk.stats.__init__()
        t1, (m1, q) = timed(lambda: constant_orientation_map(robot, nodes, DOWN, convention="standard",
                                                             collision=chk, return_q=True), 1)
        st = type(chk.stats)(**vars(chk.stats))  # this map's checks only
        fast = st.fast_fraction
        te, exact_free = harness.timed(lambda: chk.exact(q[m1]))  # noqa: B023 - called at once
        per_config = te / max(int(m1.sum()), 1)
        fk = np.abs(robot.fkine(q[m1]) - T[m1]).max() if m1.any() else 0.0
        t_ref, ref = timed(lambda: reference(robot, chk, T, args.starts, 1), 1)
        both = ref & m1
        recall = both.sum() / max(ref.sum(), 1)
        print(f"\n{name}: {len(chk.pairs)} enabled link pairs of {len(model.links) * (len(model.links) - 1) // 2} "
              f"(matrix {t_acm:.2f} s)")
        print(f"  chain map        {int(m0.sum()):5d} nodes  {t0:7.3f} s")
        print(f"  collision-free   {int(m1.sum()):5d} nodes  {t1:7.3f} s   ratio {t1 / t0:.2f} (goal <= 3)")
        print(f"  returned solutions colliding (coal alone): {int((~exact_free).sum())} (goal 0); "
              f"FK error {fk:.1e}; within limits {bool(robot.within_limits(q[m1]).all())}")
        print(f"  reference ({args.starts} starts, {t_ref:.1f} s): {int(ref.sum())} nodes; recall {recall:.4f} "
              f"(goal >= 0.995); map nodes the reference missed {int((m1 & ~ref).sum())}")
        print(f"  checker: {st.configurations} configurations, {fast:.1%} decided without coal (spheres, capsules), "
              f"{st.exact_tests} coal tests, {st.seconds:.2f} s in the checker ({st.exact_seconds:.2f} s exact)")
        print(f"  exact check (coal, every pair and the floor): {per_config * 1e3:.3f} ms per configuration")
        results[name] = {"enabled_pairs": len(chk.pairs), "acm_seconds": t_acm, "chain_nodes": int(m0.sum()),
                         "chain_seconds": t0, "free_nodes": int(m1.sum()), "free_seconds": t1,
                         "colliding_solutions": int((~exact_free).sum()), "fk_error": float(fk),
                         "reference_nodes": int(ref.sum()), "reference_seconds": t_ref, "recall": float(recall),
                         "checker": vars(st), "exact_seconds_per_configuration": per_config}
        if name == "ur5e":
            # the chain's closed-form map stops at the first valid branch without its angles; the
            # collision-free one needs every branch's angles: the numerical maps side by side as well
            tn0, _ = timed(lambda: constant_orientation_map(robot, nodes, DOWN, convention="standard",
                                                            method="numerical"), 1)
            tn1, num = timed(lambda: constant_orientation_map(robot, nodes, DOWN, convention="standard",
                                                              method="numerical", collision=chk), 1)
            print(f"  numerical: chain map {tn0:.3f} s, collision-free {tn1:.3f} s, ratio {tn1 / tn0:.2f}")
            print(f"  numerical collision-free map against the closed form (all 8 branches): recall "
                  f"{(num & m1).sum() / max(m1.sum(), 1):.4f}, false positives {int((num & ~m1).sum())}")
            results[name].update(numerical_chain_seconds=tn0, numerical_free_seconds=tn1)
    harness.write_json(args, {"step": args.step, "starts": args.starts, "arms": results})


if __name__ == "__main__":
    main()
