"""Fast maps, side by side in one run: the compiled IK kernel, the neighbour-started numerical maps,
the UR closed form, and the peers a user would reach for today.

Every row is measured in this run (best of ``--repeats`` after an untimed warm-up; numba's compile
happens in the warm-up). Grid: ``cartesian_grid(-1, 1, 0.1)`` (21³ = 9261 nodes), poses
``T = transl(p)·R`` in the arm's base frame. Sections:

1. **Kernel rate** on the reachable PUMA560 nodes at ``R = I`` (the closed form says which), tol
   1e-10: ``ikine_search`` compiled on 2 threads and on 1, the numpy reference kernel; the paper's LM
   (``ikine_LM``) compiled and numpy; Robotics Toolbox's C++ ``ik_LM`` one node at a time (one search
   from q = 0, tol 1e-10, as the paper's LM); pytorch-kinematics' batched ``PseudoInverseIK``
   (float64, its own tolerances, 1e-6 m / 1e-5 rad, which it cannot push to 1e-10).
2. **Whole numerical maps** (unreachable nodes included) by the map's default numerical path
   (`wsmap.kinematics.map_search`): PUMA560 (paper, no limits) and UR5e, at ``R = I`` and tool
   down; recall and false positives against the closed forms; Robotics Toolbox's ``ik_LM`` with its
   default restarts (``slimit`` 100) node by node on a sample of ``--rtb-sample`` nodes, extrapolated.
3. **Exact UR5e maps**: `wsmap.kinematics.ur_reachable` against EAIK's ``IK_batched`` (1 thread),
   labels compared node for node.
4. **Scaling** (``--scaling``): map time against nodes (10³ … 10⁶, PUMA560) and against arms
   (1 … 10⁴ exact, 1 … 10³ numerical; spherical-wrist arms) for the exact and numerical paths, with
   the log-log slope; a figure with ``--plot PATH``.

Goals (issue "fast maps", 2-core machine) are printed beside the measurements.

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/maps/bench_fast_maps.py --all-arms --scaling \\
        --json bench/fast_maps.json --plot docs/fast_maps_scaling.png
"""

from __future__ import annotations

import os
import platform
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402

PI = np.pi


def best_of(fn, repeats):
    """(best seconds of `repeats` calls, the last answer), after an untimed warm-up call (compile, caches)."""
    return harness.best_of(fn, repeats, warmup=1)


def urdf_of(chain) -> str:
    """A URDF of a single chain (no tool), for pytorch-kinematics: joint i's origin is F_i."""
    from scipy.spatial.transform import Rotation

    links = [f'<link name="l{i}"/>' for i in range(chain.n + 2)]
    joints = []
    F = chain.fixed
    for i in range(chain.n + 1):
        xyz = " ".join(f"{v:.17g}" for v in F[i, :3, 3])
        rpy = " ".join(f"{v:.17g}" for v in Rotation.from_matrix(F[i, :3, :3]).as_euler("xyz"))
        if i < chain.n:
            ax = " ".join(f"{v:.17g}" for v in chain.axes[i])
            lo, hi = chain.limits[i]
            lim = f'<limit lower="{max(lo, -1e3)}" upper="{min(hi, 1e3)}" effort="1" velocity="1"/>'
            joints.append(f'<joint name="j{i}" type="revolute"><parent link="l{i}"/><child link="l{i + 1}"/>'
                          f'<origin xyz="{xyz}" rpy="{rpy}"/><axis xyz="{ax}"/>{lim}</joint>')
        else:
            joints.append(f'<joint name="flange" type="fixed"><parent link="l{i}"/><child link="l{i + 1}"/>'
                          f'<origin xyz="{xyz}" rpy="{rpy}"/></joint>')
    return f'<robot name="arm">{"".join(links)}{"".join(joints)}</robot>'


def rtb_robot(d, a, alpha, qlim=None):
    import roboticstoolbox as rtb

    links = [rtb.RevoluteDH(d=float(d[i]), a=float(a[i]), alpha=float(alpha[i]),
                            qlim=None if qlim is None else [float(qlim[i][0]), float(qlim[i][1])])
             for i in range(len(d))]
    return rtb.DHRobot(links)


def poses(nodes, R):
    T = np.zeros((len(nodes), 4, 4))
    T[:, :3, :3], T[:, :3, 3], T[:, 3, 3] = R, nodes, 1.0
    return T


def section_kernel(args, out):
    from wsmap import robots
    from wsmap.kinematics import (
        ikine_LM,
        ikine_search,
        ikine_spherical_wrist,
        lm_compiled,
    )
    from wsmap.kinematics.ik.lm_reference import (
        ikine_LM_reference,
        ikine_search_reference,
    )
    from wsmap.workspace import cartesian_grid

    puma = robots.puma560()
    T = poses(cartesian_grid(-1, 1, 0.1), np.eye(3))
    T = T[ikine_spherical_wrist(puma, T).success.any(axis=-1)]
    M = len(T)
    rows = []

    def add(method, seconds, ok, note=""):
        rows.append({"method": method, "seconds": seconds, "solves_per_s": M / seconds,
                     "solved": float(np.mean(ok)), "note": note})

    for th in (2, 1):
        lm_compiled.set_threads(th)
        t, r = best_of(lambda: ikine_search(puma, T), args.repeat)
        add(f"wsmap ikine_search, compiled, {th} thread{'s' if th > 1 else ''}", t, r.success)
    lm_compiled.set_threads(2)
    t, r = best_of(lambda: ikine_LM(puma, T), args.repeat)
    add("wsmap ikine_LM (paper's LM), compiled, 2 threads", t, r.success)
    t, r = best_of(lambda: ikine_search_reference(puma, T), max(1, args.repeat // 2))
    add("wsmap ikine_search, numpy reference", t, r.success)
    t, r = best_of(lambda: ikine_LM_reference(puma, T), max(1, args.repeat // 2))
    add("wsmap ikine_LM (paper's LM), numpy reference", t, r.success)
    try:
        rob = rtb_robot(puma.d, puma.a, puma.alpha)

        def rtb_all():
            return np.array([rob.ik_LM(T[i], q0=np.zeros(6), ilimit=500, slimit=1, tol=1e-10,
                                       joint_limits=False)[1] for i in range(M)], dtype=bool)

        t, ok = best_of(rtb_all, 1)
        add("Robotics Toolbox ik_LM (C++), one node at a time", t, ok, "one search from q = 0, tol 1e-10")
    except ImportError as exc:
        print(f"roboticstoolbox unavailable: {exc}", file=sys.stderr)
    try:
        import pytorch_kinematics as pk
        import torch

        from wsmap.kinematics import as_chain

        torch.set_num_threads(2)
        chain = pk.build_serial_chain_from_urdf(urdf_of(as_chain(puma)), "l7").to(dtype=torch.float64)
        Tt = torch.tensor(T)
        goal = pk.Transform3d(matrix=Tt, dtype=torch.float64)
        ik = pk.PseudoInverseIK(chain, max_iterations=50, num_retries=1, pos_tolerance=1e-6, rot_tolerance=1e-5,
                                retry_configs=torch.zeros(1, 6, dtype=torch.float64),
                                early_stopping_any_converged=True, enforce_joint_limits=False)
        t, sol = best_of(lambda: ik.solve(goal), max(1, args.repeat // 2))
        add("pytorch-kinematics PseudoInverseIK, batched (torch, 2 threads)", t,
            sol.converged_any.numpy(), "start q = 0, 50 iterations, tol 1e-6 m / 1e-5 rad")
    except ImportError as exc:
        print(f"pytorch-kinematics unavailable: {exc}", file=sys.stderr)
    goal = 250_000
    out["kernel"] = {"targets": M, "rows": rows, "goal_solves_per_s": goal}
    print(f"\n### 1. IK kernel rate: the {M} reachable PUMA560 nodes of the 21³ grid, R = I, tol 1e-10\n")
    print("| method | ms | solves/s | solved | note |\n|---|---:|---:|---:|---|")
    for r in rows:
        print(f"| {r['method']} | {r['seconds'] * 1e3:.2f} | {r['solves_per_s']:,.0f} | {r['solved']:.4f} | {r['note']} |")
    print(f"\ngoal: >= {goal:,} solves/s (compiled, 2 threads): measured {rows[0]['solves_per_s']:,.0f} -> "
          f"{'met' if rows[0]['solves_per_s'] >= goal else 'NOT met'}")


def section_maps(args, out):
    from wsmap import robots
    from wsmap.kinematics import ikine_spherical_wrist, lm_compiled, rotx, ur_reachable
    from wsmap.workspace import cartesian_grid, constant_orientation_map

    lm_compiled.set_threads(2)
    nodes = cartesian_grid(-1, 1, 0.1)
    rows = []
    goals = {"puma560": 0.1, "ur5e": 0.5}
    rng = np.random.default_rng(0)
    sample = rng.choice(len(nodes), args.rtb_sample, replace=False)
    for name in ("puma560", "ur5e"):
        arm = robots.load(name)
        for label, R, rpy in (("R = I", np.eye(3), (0, 0, 0)), ("tool down", rotx(PI), (PI, 0, 0))):
            T = poses(nodes, R)
            exact = (ikine_spherical_wrist(arm, T).success.any(axis=-1) if name == "puma560" else ur_reachable(arm, T))
            t, m = best_of(lambda: constant_orientation_map(arm, nodes, rpy, method="numerical",
                                                            convention="standard"), args.repeat)
            row = {"arm": name, "orientation": label, "method": "wsmap numerical map (compiled, 2 threads)",
                   "seconds": t, "reachable": int(exact.sum()), "recall": float((m & exact).sum() / exact.sum()),
                   "false_positives": int((m & ~exact).sum()), "goal_seconds": goals[name]}
            rows.append(row)
            try:
                if label != "R = I":
                    raise ImportError("rtb row only at R = I")
                if name == "puma560":
                    rob = rtb_robot(arm.d, arm.a, arm.alpha)
                    jl = False
                else:
                    d, a, alpha, _ = np.array(robots.NAMED["ur5e"].rows).T
                    rob = rtb_robot(d, a, alpha, robots.NAMED["ur5e"].qlim)
                    jl = True
                ts, ok = harness.timed(lambda: np.array([rob.ik_LM(T[i], tol=1e-10, joint_limits=jl)[1]  # noqa: B023
                                                         for i in sample], dtype=bool))
                rows.append({"arm": name, "orientation": label,
                             "method": f"Robotics Toolbox ik_LM (C++), default restarts, node by node "
                                       f"({len(sample)} nodes, extrapolated)",
                             "seconds": ts * len(nodes) / len(sample), "reachable": int(exact[sample].sum()),
                             "recall": float((ok & exact[sample]).sum() / max(exact[sample].sum(), 1)),
                             "false_positives": int((ok & ~exact[sample]).sum()), "goal_seconds": None})
            except ImportError:
                pass
    if args.all_arms:
        # arms without a closed form: against each node solved on its own with 64 starts
        from wsmap.kinematics import ikine_search

        for name in ("panda", "iiwa14", "gen3"):
            arm = robots.load(name)
            T = poses(nodes, rotx(PI))
            t, m = best_of(lambda: constant_orientation_map(arm, nodes, (PI, 0, 0), method="numerical",
                                                            convention="standard"), max(1, args.repeat // 2))
            ref = ikine_search(arm, T, starts=64).success
            rows.append({"arm": name, "orientation": "tool down", "method": "wsmap numerical map (compiled, 2 threads)",
                         "seconds": t, "reachable": int(ref.sum()), "recall": float((m & ref).sum() / ref.sum()),
                         "false_positives": 0, "goal_seconds": None,
                         "reference": "ikine_search, 64 starts per node", "beyond_reference": int((m & ~ref).sum())})
    out["maps"] = rows
    print("\n### 2. Whole 9261-node numerical maps (unreachable nodes included)\n")
    print("| arm | R | method | s per map | recall | false positives | goal |\n|---|---|---|---:|---:|---:|---|")
    for r in rows:
        g = "" if r["goal_seconds"] is None else (
            f"<= {r['goal_seconds']} s, recall >= 0.999: "
            f"{'met' if r['seconds'] <= r['goal_seconds'] and r['recall'] >= 0.999 else 'NOT met'}")
        fp = r["false_positives"] if "reference" not in r else f"{r['beyond_reference']} beyond the reference"
        print(f"| {r['arm']} | {r['orientation']} | {r['method']} | {r['seconds']:.3f} | {r['recall']:.4f} | "
              f"{fp} | {g or r.get('reference', '')} |")


def section_ur_exact(args, out):
    from eaik.IK_DH import DhRobot

    from wsmap import robots
    from wsmap.kinematics import lm_compiled, rotx, ur_reachable
    from wsmap.workspace import cartesian_grid

    lm_compiled.set_threads(1)  # one thread each, as EAIK's IK_batched(T, 1)
    chain = robots.load("ur5e")
    d, a, alpha, _ = np.array(robots.NAMED["ur5e"].rows).T
    eaik = DhRobot(alpha, a, d)
    nodes = cartesian_grid(-1, 1, 0.1)
    rows = []
    for label, R in (("R = I", np.eye(3)), ("tool down", rotx(PI))):
        T = poses(nodes, R)
        t_ours, ours = best_of(lambda: ur_reachable(chain, T), args.repeat)
        t_eaik, sols = best_of(lambda: eaik.IK_batched(T, 1), args.repeat)
        Q = np.zeros((len(T), 8, 6))
        present = np.zeros((len(T), 8), dtype=bool)
        for i, s in enumerate(sols):
            k = s.num_solutions()
            Q[i, :k], present[i, :k] = s.Q, True
        err = np.abs(chain.fkine(np.moveaxis(Q, 1, 0)) - T).max(axis=(-1, -2)).T
        theirs = (present & (err <= 1e-6)).any(axis=-1)
        lm_compiled.set_threads(2)
        t_ours2, _ = best_of(lambda: ur_reachable(chain, T), args.repeat)
        lm_compiled.set_threads(1)
        rows.append({"orientation": label, "wsmap_seconds": t_ours, "wsmap_seconds_2_threads": t_ours2,
                     "eaik_seconds": t_eaik,
                     "speedup": t_eaik / t_ours, "identical_labels": bool(np.array_equal(ours, theirs)),
                     "reachable": int(ours.sum())})
    out["ur_exact"] = rows
    print("\n### 3. Exact UR5e maps: wsmap's UR closed form against EAIK (1 thread each)\n")
    lm_compiled.set_threads(2)
    print("| R | wsmap ur_reachable ms (2 threads) | EAIK IK_batched ms | speed-up | labels identical | goal >= 10x |")
    print("|---|---:|---:|---:|---|---|")
    for r in rows:
        print(f"| {r['orientation']} | {r['wsmap_seconds'] * 1e3:.2f} ({r['wsmap_seconds_2_threads'] * 1e3:.2f}) | "
              f"{r['eaik_seconds'] * 1e3:.2f} | "
              f"{r['speedup']:.1f}x | {r['identical_labels']} | {'met' if r['speedup'] >= 10 else 'NOT met'} |")


def section_scaling(args, out):
    from wsmap import robots
    from wsmap.kinematics import lm_compiled
    from wsmap.workspace import cartesian_grid, constant_orientation_map

    lm_compiled.set_threads(2)
    puma = robots.puma560()
    res = {"nodes": [], "arms": []}
    for step in (0.2, 0.1, 0.05, 0.04, 0.03, 0.02):
        nodes = cartesian_grid(-1, 1, step)
        for method in ("exact", "numerical"):
            t, _ = best_of(lambda: constant_orientation_map(puma, nodes, (PI, 0, 0), method=method,
                                                            convention="standard"), 1 if len(nodes) > 1e5 else 3)
            res["nodes"].append({"method": method, "nodes": len(nodes), "seconds": t})
    for count in (1, 10, 100, 1000, 10000):
        arms = robots.sample_spherical_wrist(count, seed=1)
        nodes = cartesian_grid(-1, 1, 0.1)
        t, _ = best_of(lambda: constant_orientation_map(arms, nodes, (PI, 0, 0), method="exact",
                                                        convention="standard"), 1 if count >= 1000 else 3)
        res["arms"].append({"method": "exact", "arms": count, "nodes": len(nodes), "seconds": t})
        if count <= 1000:
            small = cartesian_grid(-1, 1, 0.2)
            t, _ = best_of(lambda: constant_orientation_map(arms, small, (PI, 0, 0), method="numerical",
                                                            convention="standard"), 1 if count >= 100 else 3)
            res["arms"].append({"method": "numerical", "arms": count, "nodes": len(small), "seconds": t})
    slopes = {}
    for axis in ("nodes", "arms"):
        for method in ("exact", "numerical"):
            pts = [(r[axis], r["seconds"]) for r in res[axis] if r["method"] == method]
            x, y = np.log10([p[0] for p in pts]), np.log10([p[1] for p in pts])
            # the slope over the upper half, where fixed costs no longer dominate
            k = len(x) // 2
            slopes[f"{method} vs {axis}"] = float(np.polyfit(x[k:], y[k:], 1)[0])
    res["slopes"] = slopes
    out["scaling"] = res
    print("\n### 4. Cost against nodes (PUMA560, tool down) and arms (spherical-wrist arms)\n")
    print("| axis | method | count | nodes per arm | s |\n|---|---|---:|---:|---:|")
    for axis in ("nodes", "arms"):
        for r in res[axis]:
            print(f"| {axis} | {r['method']} | {r[axis]:,} | {r.get('nodes', r[axis]):,} | {r['seconds']:.4f} |")
    print("\nlog-log slopes (upper half of each series): " + ", ".join(f"{k}: {v:.2f}" for k, v in slopes.items()))
    if args.plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, axes = plt.subplots(1, 2, figsize=(10, 4))
        for ax, axis, xl in ((axes[0], "nodes", "grid nodes (one arm)"), (axes[1], "arms", "arms")):
            for method, mk in (("exact", "o-"), ("numerical", "s-")):
                pts = [(r[axis], r["seconds"]) for r in res[axis] if r["method"] == method]
                ax.loglog(*zip(*pts), mk, label=f"{method} (slope {slopes[f'{method} vs {axis}']:.2f})")
            ax.set_xlabel(xl)
            ax.set_ylabel("seconds per map set")
            ax.grid(True, which="both", alpha=0.3)
            ax.legend()
        axes[1].set_title("numerical: 11³ grid per arm; exact: 21³", fontsize=9)
        axes[0].set_title("PUMA560, tool down", fontsize=9)
        fig.tight_layout()
        tmp = args.plot + ".tmp.png"
        fig.savefig(tmp, dpi=120)
        os.replace(tmp, args.plot)
        print(f"figure -> {args.plot}")


def main(argv=None):
    ap = harness.parser(__doc__, repeat=5, repeat_help="timed calls per row after a warm-up, best kept (default 5)")
    ap.add_argument("--rtb-sample", type=int, default=300, help="nodes for the Robotics Toolbox map rows")
    ap.add_argument("--scaling", action="store_true", help="also measure cost against nodes and arms (minutes)")
    ap.add_argument("--all-arms", action="store_true",
                    help="also the Panda, iiwa14 and Gen3 maps, recall against 64 independent starts per node")
    ap.add_argument("--sections", default="1234", help="which sections to run (digits)")
    ap.add_argument("--plot", help="scaling figure (PNG)")
    args = ap.parse_args(argv)
    if args.rtb_sample < 1:
        ap.error("--rtb-sample must be positive")
    if args.plot and not args.scaling:
        ap.error("--plot needs --scaling")
    import numba

    out = {"info": {"python": sys.version.split()[0], "numpy": np.__version__, "numba": numba.__version__,
                    "cpus": os.cpu_count(), "machine": platform.machine(),
                    "load_average_at_start": os.getloadavg(), "command": " ".join(sys.argv)}}
    print(f"python {out['info']['python']}, numpy {np.__version__}, numba {numba.__version__}, "
          f"{os.cpu_count()} CPUs, load average at start {os.getloadavg()}")
    if "1" in args.sections:
        section_kernel(args, out)
    if "2" in args.sections:
        section_maps(args, out)
    if "3" in args.sections:
        section_ur_exact(args, out)
    if args.scaling and "4" in args.sections:
        section_scaling(args, out)
    harness.write_json(args, out)
    return out


if __name__ == "__main__":
    main()
