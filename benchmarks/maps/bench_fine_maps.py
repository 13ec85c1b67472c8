"""Fine maps, the resolution the Reuleaux users call "hours": the Panda's reachability index at
2.5 cm x 200 orientations and the UR5e's at 2.5 cm, with the peers' pose-by-pose rates extrapolated.

1. **Panda reachability index**, 2.5 cm grid over the box [-0.95, 0.95]³ m around its base (77³ =
   456,533 nodes), K = 200 orientations (super-Fibonacci, seed 0), joint limits on, 2 threads:
   wall time (issue 44's goal <= 60 s on this 2-core machine), nodes with index > 0, and recall
   against a dense reference (``ikine_search`` with ``--ref-starts`` starts per pose, each pose on
   its own) on ``--sample`` random nodes that reach some orientation, all K orientations; the
   positives the reference did not find are counted (each positive of the map has a solution
   inside the limits confirmed by forward kinematics, so these are the reference's misses).
2. **UR5e reachability index**, exact (closed form, every branch), 2.5 cm over [-1.05, 1.05]³ m
   (85³ = 614,125 nodes) x the same K orientations: wall time and nodes with index > 0. Its
   numerical counterpart (``method="numerical"``) on ``--ur-layers`` z-layers of the same grid
   (from z = 0.1 m up; a slab, so every node keeps its in-plane neighbours) for the recall where
   the answer is known, and its false positives (must be 0).
3. **Peers**, pose by pose with their restarts, on random poses of the Panda index (nodes that
   reach some orientation, random orientations), extrapolated to the whole fine index: Robotics
   Toolbox's C++ ``ik_LM`` on the arm's ETS (default ``slimit`` 100, ``--rtb-sample`` poses) and
   klampt's ``solve_global`` with 100 restarts (``--klampt-sample`` poses), both as
   ``benchmarks/kernel/bench_peers.py`` calls them; each is skipped with a line when not installed.
   The extrapolation is the sample's seconds per pose times N x K: the sample's poses come from
   nodes that reach some orientation, so it counts the far nodes (which a peer would also have to
   give up on) at the cost of near ones.

``--quick``: a 10 cm grid, 20 orientations, small samples (a smoke run of a few seconds).
The documented numbers (docs/speed.md, "Fine maps"):

    NUMBA_NUM_THREADS=2 OMP_NUM_THREADS=1 .venv/bin/python benchmarks/maps/bench_fine_maps.py --json bench/fine_maps.json
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "kernel"))  # bench_peers: the peers' wrappers
import harness  # noqa: E402

timed = harness.timed
GOAL_PANDA_SECONDS = 60.0


def _poses(nodes, R):
    """Poses `(..., 4, 4)` with positions `nodes (..., 3)` and rotations `R (..., 3, 3)` (broadcast)."""
    shape = np.broadcast_shapes(nodes.shape[:-1], R.shape[:-2])
    T = np.zeros(shape + (4, 4))
    T[..., :3, :3], T[..., :3, 3], T[..., 3, 3] = R, nodes, 1.0
    return T


def panda_index(args, R, rng):
    """Section 1: the Panda's fine index, its time and its recall against the dense reference."""
    from wsmap import robots
    from wsmap import workspace as ws
    from wsmap.kinematics import ikine_search

    panda = robots.load("panda")
    nodes = ws.cartesian_grid(-0.95, 0.95, args.step)
    t_idx, (idx, bits) = timed(lambda: ws.reachability_index(panda, nodes, R, return_bits=True))
    cand = np.flatnonzero(bits.any(axis=1))
    s = rng.choice(cand, min(args.sample, cand.size), replace=False)
    t_ref, ref = timed(lambda: ikine_search(panda, _poses(nodes[s][:, None], R[None]), starts=args.ref_starts).success)
    b = bits[s]
    row = {"nodes": len(nodes), "orientations": len(R), "step_m": args.step, "seconds": t_idx,
           "goal_seconds": GOAL_PANDA_SECONDS, "mean_index": float(idx.mean()),
           "nodes_with_index_above_0": int((idx > 0).sum()), "reachable_poses": int(bits.sum()),
           "sample_nodes": int(s.size), "reference_starts": args.ref_starts, "reference_seconds": t_ref,
           "reference_positives": int(ref.sum()), "recall": float((b & ref).sum() / max(ref.sum(), 1)),
           "positives_the_reference_missed": int((b & ~ref).sum())}
    return row, (panda, nodes, bits, cand)


def ur5e_index(args, R):
    """Section 2: the UR5e's exact fine index, and the numerical index on a slab of it."""
    from wsmap import robots
    from wsmap import workspace as ws

    ur5e = robots.load("ur5e")
    nodes = ws.cartesian_grid(-1.05, 1.05, args.step)
    t_ex, (idx, bits) = timed(lambda: ws.reachability_index(ur5e, nodes, R, method="exact", return_bits=True))
    zs = np.unique(nodes[:, 2])
    layers = zs[zs >= 0.1 - 1e-9][: args.ur_layers]
    slab = np.flatnonzero(np.isin(nodes[:, 2], layers))
    t_num, (_, nb) = timed(lambda: ws.reachability_index(ur5e, nodes[slab], R, method="numerical",
                                                         return_bits=True))
    eb = bits[slab]
    return {"nodes": len(nodes), "orientations": len(R), "step_m": args.step, "exact_seconds": t_ex,
            "mean_index": float(idx.mean()), "nodes_with_index_above_0": int((idx > 0).sum()),
            "reachable_poses": int(bits.sum()),
            "numerical": {"nodes": int(slab.size), "z_layers_m": [float(z) for z in layers], "seconds": t_num,
                          "exact_seconds_per_pose_whole_index": t_ex / bits.size,
                          "exact_positives": int(eb.sum()), "recall": float((nb & eb).sum() / max(eb.sum(), 1)),
                          "false_positives": int((nb & ~eb).sum())}}


def peers(args, R, rng, panda, nodes, bits, cand):
    """Section 3: Robotics Toolbox and klampt pose by pose on random poses of the Panda index,
    extrapolated to its N x K poses; a peer that is not installed is left out with a line."""
    import bench_peers

    total = bits.size
    rows = {}
    qc = panda.random_q(5, rng)
    for key, size in (("rtb", args.rtb_sample), ("klampt", args.klampt_sample)):
        if size < 1:
            continue
        try:
            if key == "rtb":
                rob = bench_peers.rtb_panda()
                assert np.allclose(np.array([rob.eval(q) for q in qc]), panda.fkine(qc), atol=1e-12)
                solve = lambda T, rob=rob: rob.ik_LM(T, tol=1e-10, joint_limits=True)[1]  # noqa: E731
            else:
                kl = bench_peers.Klampt(panda)
                assert np.allclose(np.array([kl.fkine(q) for q in qc]), panda.fkine(qc), atol=1e-12)
                solve = kl.solve_global
        except ImportError as exc:
            print(f"{key} unavailable: {exc}", file=sys.stderr)
            continue
        picks, ks = rng.choice(cand, size), rng.integers(0, len(R), size)
        Tr = _poses(nodes[picks], R[ks])
        t, ok = timed(lambda: np.array([bool(solve(T)) for T in Tr], dtype=bool))
        rows[key] = {"poses": size, "seconds": t, "seconds_per_pose": t / size,
                     "extrapolated_seconds_whole_index": t / size * total,
                     "agreement_with_index_bits": float((ok == bits[picks, ks]).mean()),
                     "found_where_index_has_none": int((ok & ~bits[picks, ks]).sum())}
    return rows


def _print_table(out):
    """The Markdown table of the three sections."""
    p, u = out["panda_index"], out["ur5e_index"]
    un = u["numerical"]
    cm = 100 * p["step_m"]
    print(f"\nload average at start {out['info']['load_average_at_start']}, at end {out['info']['load_average_at_end']}\n")
    print("| map | nodes x orientations | seconds | nodes with index > 0 | recall (reference) |\n|---|---:|---:|---:|---|")
    met = "met" if p["seconds"] <= GOAL_PANDA_SECONDS else "NOT met"
    print(f"| Panda reachability index, {cm:g} cm, 2 threads (goal <= 60 s: {met}) | {p['nodes']:,} x "
          f"{p['orientations']} | {p['seconds']:.1f} | {p['nodes_with_index_above_0']:,} | {p['recall']:.4f} "
          f"({p['reference_starts']} starts per pose, {p['sample_nodes']} nodes x {p['orientations']}, "
          f"{p['reference_positives']:,} positives; the map found {p['positives_the_reference_missed']} the "
          f"reference missed) |")
    print(f"| UR5e reachability index, exact (closed form), {cm:g} cm | {u['nodes']:,} x {u['orientations']} | "
          f"{u['exact_seconds']:.1f} | {u['nodes_with_index_above_0']:,} | exact |")
    print(f"| UR5e index, numerical, {len(un['z_layers_m'])} z-layers of it (z {un['z_layers_m'][0]:.3f}-"
          f"{un['z_layers_m'][-1]:.3f} m) | {un['nodes']:,} x {u['orientations']} | {un['seconds']:.1f} | | "
          f"{un['recall']:.4f} of {un['exact_positives']:,} exact positives, {un['false_positives']} false "
          f"positives |")
    labels = {"rtb": "Robotics Toolbox ik_LM (C++), slimit 100", "klampt": "klampt solve_global, 100 restarts"}
    for key, r in out["peers"].items():
        print(f"| Panda index by {labels[key]}, pose by pose ({r['poses']} poses, extrapolated) | "
              f"{p['nodes']:,} x {p['orientations']} | {r['extrapolated_seconds_whole_index']:,.0f} "
              f"({r['extrapolated_seconds_whole_index'] / 3600:,.1f} h, {r['seconds_per_pose'] * 1e3:.1f} ms per "
              f"pose) | | agrees with the index on {r['agreement_with_index_bits']:.0%} of its poses, found "
              f"{r['found_where_index_has_none']} it has not |")


def main(argv=None):
    ap = harness.parser(__doc__, seed=0, quick="a 10 cm grid, 20 orientations and small samples (a smoke run)")
    ap.add_argument("--step", type=float, default=0.025, help="grid step, m (default 0.025)")
    ap.add_argument("--orientations", type=harness.positive_int, default=200, help="K (default 200)")
    ap.add_argument("--sample", type=harness.positive_int, default=150,
                    help="Panda nodes checked against the reference, all K orientations each (default 150)")
    ap.add_argument("--ref-starts", type=harness.positive_int, default=64,
                    help="starts per pose of the reference (default 64)")
    ap.add_argument("--ur-layers", type=harness.positive_int, default=3,
                    help="z-layers of the UR5e grid mapped numerically (default 3)")
    ap.add_argument("--rtb-sample", type=int, default=100, help="poses for Robotics Toolbox, 0: none (default 100)")
    ap.add_argument("--klampt-sample", type=int, default=40, help="poses for klampt, 0: none (default 40)")
    args = ap.parse_args(argv)
    if not 0.005 <= args.step <= 0.5:
        ap.error(f"--step must be in [0.005, 0.5] m, got {args.step}")
    if min(args.rtb_sample, args.klampt_sample) < 0:
        ap.error("--rtb-sample and --klampt-sample must be 0 or more")
    if args.quick:
        args.step, args.orientations, args.sample, args.ref_starts = 0.1, 20, 10, 16
        args.ur_layers, args.rtb_sample, args.klampt_sample = 2, min(args.rtb_sample, 5), min(args.klampt_sample, 2)
    if args.json:
        from wsmap.io import check_output_path

        check_output_path(args.json, "--json")

    from wsmap import robots
    from wsmap import workspace as ws
    from wsmap.kinematics import lm_compiled
    from wsmap.kinematics.ik.warmup import ensure_compiled

    ensure_compiled(notify=lambda line: print(line, file=sys.stderr))
    lm_compiled.set_threads(2)
    out = {"info": {"cpus": os.cpu_count(), "threads": lm_compiled.threads(),
                    "load_average_at_start": os.getloadavg(), "command": " ".join(sys.argv)}}
    print(f"load average at start: {out['info']['load_average_at_start']}", file=sys.stderr)
    rng = np.random.default_rng(args.seed)
    R = ws.orientation_samples(args.orientations, seed=0)
    # warm-up: compile (or load) the kernels outside the timings
    small = ws.cartesian_grid(-1, 1, 0.5)
    ws.reachability_index(robots.load("panda"), small, R[:2])
    ws.reachability_index(robots.load("ur5e"), small, R[:2], method="numerical")

    out["panda_index"], panda_state = panda_index(args, R, rng)
    print(f"Panda index: {out['panda_index']['seconds']:.1f} s", file=sys.stderr)
    out["ur5e_index"] = ur5e_index(args, R)
    print(f"UR5e index: {out['ur5e_index']['exact_seconds']:.1f} s", file=sys.stderr)
    out["peers"] = peers(args, R, rng, *panda_state)
    out["info"]["load_average_at_end"] = os.getloadavg()
    _print_table(out)
    harness.write_json(args, out)
    return out


if __name__ == "__main__":
    main()
