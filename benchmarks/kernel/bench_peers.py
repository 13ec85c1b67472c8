"""wsmap beside its peers, in one run: Robotics Toolbox's C++ ``ik_LM`` and klampt's IK solver on the
same Panda poses and maps, with the ratios (issue 30's goals printed beside them).

Sections (the arm: ``wsmap.load("panda")``, the same modified-DH chain built in each peer, its
forward kinematics checked against wsmap's to 1e-12 before anything is timed):

1. **Raw single-start IK, per core**: ``--poses`` reachable Panda poses (forward kinematics of
   uniform joint values inside the limits), one start each at the middle of the limits, tol 1e-10,
   joint limits on. wsmap: ``ikine_search(panda, T, starts=1, q0=mid)`` on one thread (best of
   ``--repeats``); Robotics Toolbox: ``ets.ik_LM(T, q0=mid, slimit=1, tol=1e-10)`` pose by pose (its C++
   solver on the arm's ETS, one start, its default 30 iterations); klampt: ``IKSolver.solve()`` from ``mid``, one start
   (tolerance 1e-10, 100 iterations). Solves per second and success rates; every wsmap success
   confirmed by forward kinematics here.
2. **The Panda tool-down map** (21³ = 9261 nodes, ``cartesian_grid(-1, 1, 0.1)``, rpy (pi, 0, 0),
   standard convention) by ``constant_orientation_map(method="numerical")`` on 2 threads and on 1;
   recall against ``ikine_search`` with 64 starts per node; the peers with their restarts (Robotics
   Toolbox ``ik_LM`` default ``slimit`` 100; klampt ``solve_global`` with 100 restarts) on a sample
   of ``--peer-sample`` nodes, extrapolated.
3. **The Panda reachability index**, 5 cm (``cartesian_grid(-0.95, 0.95, 0.05)``, 59,319 nodes) x 50
   orientations, on 2 threads and on 1; Robotics Toolbox with restarts on ``--peer-sample`` of its
   poses, extrapolated. ``--quick`` leaves the index out.

wsmap runs on both of its kernels in every section, side by side: the lane kernel
(``wsmap.kinematics.lm_lanes``, the default: several targets per SIMD instruction) and the scalar
numba kernel (``lm_compiled``, its tested reference); the maps and the index's bits are compared
between the two. The thread ratios (2 threads against 1) are measured side by side here, the load
average printed beside them: the machine is shared.

    NUMBA_NUM_THREADS=2 OMP_NUM_THREADS=1 .venv/bin/python benchmarks/kernel/bench_peers.py --json bench/peers.json
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402

PI = np.pi
GOALS = {"raw_ik_ratio_rtb": 3.0, "map_seconds_2_threads": 0.1, "index_seconds": 15.0}
#: wsmap's two kernels, side by side: the lane (SIMD) kernel, the default, and the scalar numba one
KERNELS = ("lanes", "scalar")


def best_of(fn, repeats):
    """``(best seconds of repeats calls, the answer)``, after one warm-up call (compile or load the
    kernels)."""
    return harness.best_of(fn, repeats, warmup=1)


def poses(nodes, R):
    T = np.zeros((len(nodes), 4, 4))
    T[:, :3, :3], T[:, :3, 3], T[:, 3, 3] = R, nodes, 1.0
    return T


def rtb_panda():
    """The Panda in Robotics Toolbox: the same modified-DH rows, limits and flange."""
    import roboticstoolbox as rtb
    from spatialmath import SE3

    from wsmap import robots

    spec = robots.NAMED["panda"]
    links = [rtb.RevoluteMDH(d=d, a=a, alpha=al, qlim=list(lim)) for (d, a, al, _), lim in zip(spec.rows, spec.qlim)]
    # its ETS: ik_LM on it is the C++ solver called directly (on the DHRobot, ik_LM rebuilds the ETS
    # on every call, 30x slower)
    return rtb.DHRobot(links, tool=SE3(0, 0, spec.flange[0])).ets()


def urdf_of(chain) -> str:
    """A URDF of a single chain: joint i's origin is the fixed transform F_i, the tool a fixed joint."""
    from scipy.spatial.transform import Rotation

    F = np.array(chain.fixed)
    if chain.base is not None:
        F[0] = chain.base @ F[0]
    if chain.tool is not None:
        F[chain.n] = F[chain.n] @ chain.tool
    links = [f'<link name="l{i}"/>' for i in range(chain.n + 2)]
    joints = []
    for i in range(chain.n + 1):
        xyz = " ".join(f"{v:.17g}" for v in F[i, :3, 3])
        rpy = " ".join(f"{v:.17g}" for v in Rotation.from_matrix(F[i, :3, :3]).as_euler("xyz"))
        if i < chain.n:
            ax = " ".join(f"{v:.17g}" for v in chain.axes[i])
            lo, hi = np.array(chain.limits)[i]
            joints.append(f'<joint name="j{i}" type="revolute"><parent link="l{i}"/><child link="l{i + 1}"/>'
                          f'<origin xyz="{xyz}" rpy="{rpy}"/><axis xyz="{ax}"/>'
                          f'<limit lower="{lo:.17g}" upper="{hi:.17g}" effort="1" velocity="1"/></joint>')
        else:
            joints.append(f'<joint name="tool" type="fixed"><parent link="l{i}"/><child link="l{i + 1}"/>'
                          f'<origin xyz="{xyz}" rpy="{rpy}"/></joint>')
    return f'<robot name="arm">{"".join(links)}{"".join(joints)}</robot>'


class Klampt:
    """klampt's IK on a wsmap chain (loaded from `urdf_of`); ``q`` maps to the revolute links."""

    def __init__(self, chain):
        import klampt

        self.world = klampt.WorldModel()
        with tempfile.TemporaryDirectory() as d:
            path = os.path.join(d, "arm.urdf")
            with open(path, "w") as f:
                f.write(urdf_of(chain))
            if not self.world.loadRobot(path):
                raise RuntimeError("klampt could not load the arm's URDF")
        self.robot = self.world.robot(0)
        names = [self.robot.link(i).getName() for i in range(self.robot.numLinks())]
        # klampt gives a URDF robot a floating base (six virtual links before ours): the solver may
        # move only the arm's joints, or it "reaches" every pose by moving the base
        self.dofs = [names.index(f"l{i + 1}") for i in range(chain.n)]
        self.ee = self.robot.link(self.robot.numLinks() - 1)
        self.n = chain.n
        self.mid = np.array(chain.limits).mean(axis=1)

    def config(self, q):
        c = [0.0] * self.robot.numLinks()
        for k, j in enumerate(self.dofs):
            c[j] = float(q[k])
        return c

    def fkine(self, q):
        self.robot.setConfig(self.config(q))
        R, t = self.ee.getTransform()
        T = np.eye(4)
        T[:3, :3] = np.array(R).reshape(3, 3).T  # klampt's so3 is column-major
        T[:3, 3] = t
        return T

    def objective(self, T):
        from klampt.model import ik

        return ik.objective(self.ee, R=list(np.asarray(T[:3, :3]).T.ravel()), t=list(T[:3, 3]))

    def solve_one(self, T, q0, tol=1e-10, iters=100):
        """One start from ``q0`` (the solver's Newton-Raphson with its joint limits)."""
        from klampt.model import ik

        self.robot.setConfig(self.config(q0))
        s = ik.solver(self.objective(T))
        s.setActiveDofs(self.dofs)
        s.setMaxIters(iters)
        s.setTolerance(tol)
        if not s.solve():
            return False
        # a success counts where the arm's configuration really puts the tool on the target
        c = self.robot.getConfig()
        return bool(np.abs(self.fkine([c[j] for j in self.dofs]) - T).max() <= 1e-6)

    def solve_global(self, T, tol=1e-10, restarts=100):
        """``ik.solve_global``: random restarts until one succeeds."""
        from klampt.model import ik

        self.robot.setConfig(self.config(self.mid))
        if not ik.solve_global(self.objective(T), iters=100, tol=tol, activeDofs=self.dofs, numRestarts=restarts):
            return False
        c = self.robot.getConfig()
        return bool(np.abs(self.fkine([c[j] for j in self.dofs]) - T).max() <= 1e-6)


def section_raw(args, out, panda, rtb_rob, kl):
    from wsmap.kinematics import ikine_search, lm_compiled, lm_lanes

    rng = np.random.default_rng(0)
    lim = np.array(panda.limits)
    q = rng.uniform(lim[:, 0], lim[:, 1], size=(args.poses, panda.n))
    T = np.array(panda.fkine(q))
    mid = lim.mean(axis=1)
    rows = {}
    for kernel in KERNELS:
        for threads in (1, 2):
            lm_compiled.set_threads(threads)
            with lm_lanes.use_kernel(kernel):
                t, sol = best_of(lambda: ikine_search(panda, T, starts=1, q0=mid), args.repeat)
            ok = sol.success
            assert np.allclose(np.array(panda.fkine(sol.q[ok])), T[ok], atol=1e-6), "a wsmap success FK-refuted"
            rows[f"wsmap_{kernel}_{threads}"] = {"seconds": t, "solves_per_s": len(T) / t, "success": float(ok.mean()),
                                                 "iterations_mean": float(sol.iterations.mean())}
    lm_compiled.set_threads(2)
    if rtb_rob is not None:
        n = min(len(T), args.peer_poses)
        t, ok = harness.timed(lambda: np.array(
            [rtb_rob.ik_LM(T[i], q0=mid, slimit=1, tol=1e-10, joint_limits=True)[1] for i in range(n)], dtype=bool))
        rows["rtb"] = {"poses": n, "seconds": t, "solves_per_s": n / t, "success": float(ok.mean())}
    if kl is not None:
        n = min(len(T), args.peer_poses)
        t, ok = harness.timed(lambda: np.array([kl.solve_one(T[i], mid) for i in range(n)], dtype=bool))
        rows["klampt"] = {"poses": n, "seconds": t, "solves_per_s": n / t, "success": float(ok.mean())}
    out["raw_ik"] = rows
    w = rows["wsmap_lanes_1"]
    print(f"\n### 1. Raw single-start IK, {len(T)} reachable Panda poses, start at mid-limits, tol 1e-10\n")
    print("| solver | solves/s | success | ratio (wsmap lanes, 1 thread / it) |\n|---|---:|---:|---:|")
    for key, label in (("wsmap_lanes_1", "wsmap lane kernel, 1 thread"), ("wsmap_lanes_2", "wsmap lane kernel, 2 threads"),
                       ("wsmap_scalar_1", "wsmap scalar kernel, 1 thread"),
                       ("wsmap_scalar_2", "wsmap scalar kernel, 2 threads"),
                       ("rtb", "Robotics Toolbox ik_LM (C++), 1 start"), ("klampt", "klampt IKSolver, 1 start")):
        if key in rows:
            r = rows[key]
            print(f"| {label} | {r['solves_per_s']:,.0f} | {r['success']:.3f} | "
                  f"{w['solves_per_s'] / r['solves_per_s']:.2f} |")
    if "rtb" in rows:
        ratio = w["solves_per_s"] / rows["rtb"]["solves_per_s"]
        print(f"\ngoal: >= {GOALS['raw_ik_ratio_rtb']}x Robotics Toolbox per core, success not lower: "
              f"{ratio:.2f}x, success {w['success']:.3f} against {rows['rtb']['success']:.3f}: "
              f"{'met' if ratio >= GOALS['raw_ik_ratio_rtb'] and w['success'] >= rows['rtb']['success'] else 'NOT met'}")
    for kernel in KERNELS:
        r1, r2 = rows[f"wsmap_{kernel}_1"], rows[f"wsmap_{kernel}_2"]
        print(f"{kernel} kernel, 2 threads / 1 thread: {r2['solves_per_s'] / r1['solves_per_s']:.2f}x")
    print(f"lane kernel / scalar kernel, 1 thread: "
          f"{w['solves_per_s'] / rows['wsmap_scalar_1']['solves_per_s']:.2f}x")


def section_map(args, out, panda, rtb_rob, kl):
    from wsmap.kinematics import ikine_search, lm_compiled, lm_lanes, rotx
    from wsmap.workspace import cartesian_grid, constant_orientation_map

    nodes = cartesian_grid(-1, 1, 0.1)
    T = poses(nodes, rotx(PI))
    rows = {}
    maps = {}
    for kernel in KERNELS:
        for threads in (2, 1, 2):  # 2 again: a drift of the load shows as two different 2-thread rows
            lm_compiled.set_threads(threads)
            with lm_lanes.use_kernel(kernel):
                t, m = best_of(lambda: constant_orientation_map(panda, nodes, (PI, 0, 0), method="numerical",
                                                                convention="standard"), args.repeat)
            rows.setdefault(f"wsmap_{kernel}_{threads}", []).append(t)
            maps[kernel] = m
    lm_compiled.set_threads(2)
    rows["same_map"] = bool(np.array_equal(maps["lanes"], maps["scalar"]))
    m = maps["lanes"]
    ref = ikine_search(panda, T, starts=64).success
    recall = float((m & ref).sum() / ref.sum())
    rows["recall"], rows["reachable_reference"], rows["beyond_reference"] = recall, int(ref.sum()), int((m & ~ref).sum())
    rng = np.random.default_rng(1)
    sample = rng.choice(len(nodes), min(args.peer_sample, len(nodes)), replace=False)
    if rtb_rob is not None:
        t, ok = harness.timed(lambda: np.array([rtb_rob.ik_LM(T[i], tol=1e-10, joint_limits=True)[1]
                                                for i in sample], dtype=bool))
        rows["rtb"] = {"nodes": len(sample), "seconds_extrapolated": t * len(nodes) / len(sample),
                       "recall_on_sample": float((ok & ref[sample]).sum() / max(ref[sample].sum(), 1)),
                       "beyond_reference_on_sample": int((ok & ~ref[sample]).sum())}
    if kl is not None:
        t, ok = harness.timed(lambda: np.array([kl.solve_global(T[i]) for i in sample], dtype=bool))
        rows["klampt"] = {"nodes": len(sample), "seconds_extrapolated": t * len(nodes) / len(sample),
                          "recall_on_sample": float((ok & ref[sample]).sum() / max(ref[sample].sum(), 1)),
                       "beyond_reference_on_sample": int((ok & ~ref[sample]).sum())}
    out["tooldown_map"] = rows
    t2, t1 = min(rows["wsmap_lanes_2"]), rows["wsmap_lanes_1"][0]
    print(f"\n### 2. Panda tool-down map, 9261 nodes ({int(ref.sum())} reachable by 64-start search)\n")
    print("| method | s per map | recall | ratio (peer / wsmap lanes, 2 threads) |\n|---|---:|---:|---:|")
    for kernel in KERNELS:
        r = rows[f"wsmap_{kernel}_2"]
        print(f"| wsmap {kernel} kernel, 2 threads | {min(r):.3f} (runs: {', '.join(f'{v:.3f}' for v in r)}) | "
              f"{recall:.4f} | |")
        print(f"| wsmap {kernel} kernel, 1 thread | {rows[f'wsmap_{kernel}_1'][0]:.3f} | {recall:.4f} | |")
    for key, label in (("rtb", "Robotics Toolbox ik_LM, default restarts"), ("klampt", "klampt solve_global, 100 restarts")):
        if key in rows:
            r = rows[key]
            print(f"| {label} ({r['nodes']} nodes, extrapolated) | {r['seconds_extrapolated']:.1f} | "
                  f"{r['recall_on_sample']:.4f} | {r['seconds_extrapolated'] / t2:,.0f} |"
                  + (f" ({r['beyond_reference_on_sample']} sampled nodes reached that the reference did not)"
                     if r["beyond_reference_on_sample"] else ""))
    print(f"\ngoal: <= {GOALS['map_seconds_2_threads']} s on 2 cores: {t2:.3f} s: "
          f"{'met' if t2 <= GOALS['map_seconds_2_threads'] else 'NOT met'}; 2 threads / 1 thread: {t1 / t2:.2f}x; "
          f"the same map on both kernels: {rows['same_map']}; scalar / lanes, 2 threads: "
          f"{min(rows['wsmap_scalar_2']) / t2:.2f}x")


def section_index(args, out, panda, rtb_rob):
    from wsmap import workspace as ws
    from wsmap.kinematics import lm_compiled, lm_lanes

    nodes = ws.cartesian_grid(-0.95, 0.95, 0.05)
    R = ws.orientation_samples(50, seed=0)
    ws.reachability_index(panda, ws.cartesian_grid(-1, 1, 0.5), R[:2])  # warm-up
    rows = {}
    all_bits = {}
    for kernel in KERNELS:
        for threads in (2, 1):
            lm_compiled.set_threads(threads)
            with lm_lanes.use_kernel(kernel):
                rows[f"wsmap_{kernel}_{threads}"], (idx, bits) = harness.timed(
                    lambda: ws.reachability_index(panda, nodes, R, return_bits=True))
            all_bits[kernel] = bits
    lm_compiled.set_threads(2)
    rows["bits_differing"] = int((all_bits["lanes"] != all_bits["scalar"]).sum())
    idx, bits = ws.reachability_index(panda, nodes, R, return_bits=True)
    rows["mean_index"] = float(idx.mean())
    if rtb_rob is not None:
        rng = np.random.default_rng(2)
        cand = np.flatnonzero(bits.any(axis=1))
        picks, ks = rng.choice(cand, args.peer_sample // 3), rng.integers(0, 50, args.peer_sample // 3)
        Tr = np.zeros((len(picks), 4, 4))
        Tr[:, :3, :3], Tr[:, :3, 3], Tr[:, 3, 3] = R[ks], nodes[picks], 1.0
        t, ok = harness.timed(lambda: np.array([rtb_rob.ik_LM(t, tol=1e-10, joint_limits=True)[1] for t in Tr],
                                               dtype=bool))
        rows["rtb"] = {"poses": len(Tr), "seconds_extrapolated": t / len(Tr) * len(nodes) * 50,
                       "agreement_with_index_bits": float((ok == bits[picks, ks]).mean())}
    out["index"] = rows
    t2 = rows["wsmap_lanes_2"]
    print(f"\n### 3. Panda reachability index, 5 cm ({len(nodes)} nodes) x 50 orientations\n")
    for kernel in KERNELS:
        a, b = rows[f"wsmap_{kernel}_2"], rows[f"wsmap_{kernel}_1"]
        print(f"wsmap {kernel} kernel: {a:.1f} s on 2 threads, {b:.1f} s on 1 (2 threads / 1: {b / a:.2f}x)")
    print(f"scalar / lanes, 2 threads: {rows['wsmap_scalar_2'] / t2:.2f}x; pose bits that differ between the "
          f"kernels: {rows['bits_differing']} of {all_bits['lanes'].size}")
    if "rtb" in rows:
        r = rows["rtb"]
        print(f"Robotics Toolbox ik_LM with restarts ({r['poses']} poses, extrapolated): "
              f"{r['seconds_extrapolated']:,.0f} s ({r['seconds_extrapolated'] / t2:,.0f}x), agreement with the "
              f"index's bits {r['agreement_with_index_bits']:.3f}")
    print(f"goal: <= {GOALS['index_seconds']} s: {'met' if t2 <= GOALS['index_seconds'] else 'NOT met'}")


def main(argv=None):
    ap = harness.parser(__doc__, repeat=5, quick="leave the 5 cm index out",
                        repeat_help="timed calls of each wsmap measurement, after a warm-up; best kept (default 5)")
    ap.add_argument("--poses", type=int, default=2000, help="reachable poses of the raw IK section")
    ap.add_argument("--peer-poses", type=int, default=2000, help="of those, solved by each peer")
    ap.add_argument("--peer-sample", type=int, default=150, help="map nodes solved by each peer, extrapolated")
    args = ap.parse_args(argv)
    if min(args.poses, args.peer_poses, args.peer_sample) < 1:
        ap.error("--poses, --peer-poses and --peer-sample must be positive")
    if args.json:
        from wsmap.io import check_output_path

        check_output_path(args.json, "--json")

    import numba

    from wsmap import robots
    from wsmap.kinematics import lm_compiled
    from wsmap.kinematics.ik.warmup import ensure_compiled

    ensure_compiled(notify=lambda line: print(line, file=sys.stderr))
    panda = robots.load("panda")
    rng = np.random.default_rng(5)
    lim = np.array(panda.limits)
    qc = rng.uniform(lim[:, 0], lim[:, 1], size=(5, panda.n))
    try:
        rtb_rob = rtb_panda()
        assert np.allclose(np.array([rtb_rob.eval(q) for q in qc]), panda.fkine(qc), atol=1e-12)
    except ImportError as exc:
        print(f"roboticstoolbox unavailable: {exc}", file=sys.stderr)
        rtb_rob = None
    try:
        kl = Klampt(panda)
        assert np.allclose(np.array([kl.fkine(q) for q in qc]), panda.fkine(qc), atol=1e-12)
    except ImportError as exc:
        print(f"klampt unavailable: {exc}", file=sys.stderr)
        kl = None
    from wsmap.kinematics import lm_lanes

    out = {"info": {"numba": numba.__version__, "cpus": os.cpu_count(), "threads": lm_compiled.threads(),
                    "lane_isa": lm_lanes.isa(), "lanes": lm_lanes.LANES,
                    "load_average_at_start": os.getloadavg(), "command": " ".join(sys.argv)}}
    print(f"load average at start: {out['info']['load_average_at_start']}")
    section_raw(args, out, panda, rtb_rob, kl)
    section_map(args, out, panda, rtb_rob, kl)
    if not args.quick:
        section_index(args, out, panda, rtb_rob)
    out["info"]["load_average_at_end"] = os.getloadavg()
    print(f"\nload average at end: {out['info']['load_average_at_end']}")
    harness.write_json(args, out)


if __name__ == "__main__":
    main()
