"""Maps over orientations, side by side in one run: the reachability index of a Panda, the reach map
of a UR5e, and the row a user would write today with Robotics Toolbox.

1. **Panda reachability index**, 5 cm grid over the box [-0.95, 0.95]³ m around its base (39³ =
   59,319 nodes), K = 50 orientations (super-Fibonacci, seed 0), joint limits on: wall time
   (goal <= 60 s on this 2-core machine); recall against a dense reference (``ikine_search`` with
   ``--ref-starts`` starts per pose, each pose on its own) on ``--sample`` random nodes that reach
   some position, all 50 orientations; positives the reference did not find (each positive of the
   map has a confirmed solution inside the limits, so these are the reference's misses).
2. **UR5e reach map** (some orientation reachable) at 2.5 cm over [-1.05, 1.05]³ (85³ nodes): wall
   time (goal <= 30 s); recall against ``ikine_search(position_only=True)`` with ``--ref-starts``
   starts on a sample.
3. **Exact UR5e index** (closed form, every orientation) on the 5 cm grid, and the numerical index of
   the same arm, for the recall of the numerical path where the answer is known.
4. **Robotics Toolbox** ``ik_LM`` (C++) with its default restarts (``slimit`` 100), pose by pose, on
   ``--rtb-sample`` poses of the Panda index, extrapolated to the whole index.

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/maps/bench_reach_maps.py --json bench/reach_maps.json
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402

timed = harness.timed


def _rtb_row(panda, R, nodes, cand, bits, rng, sample_size):
    """Section 4: Robotics Toolbox's `ik_LM`, pose by pose with restarts, on `sample_size` poses of the Panda
    index, extrapolated to the whole index; None without roboticstoolbox."""
    from wsmap import robots

    try:
        import roboticstoolbox as rtb

        # the same arm in the toolbox: Franka's modified-DH rows, limits and flange (d = 0.107 m)
        from spatialmath import SE3

        rows = np.array(robots.NAMED["panda"].rows)
        links = [rtb.RevoluteMDH(d=d, a=a, alpha=al, qlim=list(lim)) for (d, a, al, _), lim in
                 zip(rows, robots.NAMED["panda"].qlim)]
        rob = rtb.DHRobot(links, tool=SE3(0, 0, robots.NAMED["panda"].flange[0]))
        q = panda.random_q(5, rng)
        assert np.allclose(np.array([rob.fkine(qi).A for qi in q]), panda.fkine(q), atol=1e-12)
        picks = rng.choice(cand, sample_size)
        ks = rng.integers(0, 50, sample_size)
        Tr = np.zeros((sample_size, 4, 4))
        Tr[:, :3, :3], Tr[:, :3, 3], Tr[:, 3, 3] = R[ks], nodes[picks], 1.0
        t_rtb, ok = timed(lambda: np.array([rob.ik_LM(t, tol=1e-10, joint_limits=True)[1] for t in Tr], dtype=bool))
        per_pose = t_rtb / sample_size
        return {"poses": sample_size, "seconds": t_rtb, "seconds_per_pose": per_pose,
                "extrapolated_seconds_whole_index": per_pose * len(nodes) * 50,
                "agreement_with_index_bits": float((ok == bits[picks, ks]).mean())}
    except ImportError as exc:
        print(f"roboticstoolbox unavailable: {exc}", file=sys.stderr)
        return None


def _print_table(out, ref_starts):
    """The Markdown table of the four sections."""
    info = out["info"]
    pi_, ur, ui = out["panda_index"], out["ur5e_reach"], out["ur5e_index"]
    print(f"load average at start {info['load_average_at_start']}\n")
    print("| map | nodes x orientations | seconds | goal | recall (reference) |\n|---|---:|---:|---|---|")
    print(f"| Panda reachability index, 5 cm, box side 1.9 m | {pi_['nodes']:,} x 50 | {pi_['seconds']:.1f} | "
          f"<= 60 s: {'met' if pi_['seconds'] <= 60 else 'NOT met'} | {pi_['recall']:.4f} ({ref_starts} starts per "
          f"pose, {pi_['sample_nodes']} nodes x 50; the map found {pi_['positives_the_reference_missed']} the "
          f"reference missed) |")
    print(f"| UR5e reach map (any orientation), 2.5 cm | {ur['nodes']:,} | {ur['seconds']:.1f} | <= 30 s: "
          f"{'met' if ur['seconds'] <= 30 else 'NOT met'} | {ur['recall']:.4f} ({ur['sample_nodes']} nodes; "
          f"{ur['positives_the_reference_missed']} found beyond the reference) |")
    print(f"| UR5e index, exact (closed form) | {ui['nodes']:,} x 50 | {ui['exact_seconds']:.2f} | | exact |")
    print(f"| UR5e index, numerical | {ui['nodes']:,} x 50 | {ui['numerical_seconds']:.1f} | | {ui['recall']:.4f} "
          f"(closed form), {ui['false_positives']} false positives |")
    if "rtb" in out:
        r = out["rtb"]
        print(f"| Panda index by Robotics Toolbox ik_LM, restarts, pose by pose ({r['poses']} poses, extrapolated) | "
              f"{pi_['nodes']:,} x 50 | {r['extrapolated_seconds_whole_index']:,.0f} | | agrees with the index on "
              f"{r['agreement_with_index_bits']:.0%} of its poses |")


def main(argv=None):
    ap = harness.parser(__doc__)
    ap.add_argument("--sample", type=int, default=150, help="nodes of the Panda index checked against the reference")
    ap.add_argument("--ref-starts", type=int, default=64)
    ap.add_argument("--rtb-sample", type=int, default=100)
    args = ap.parse_args(argv)

    import numba

    from wsmap import robots
    from wsmap import workspace as ws
    from wsmap.kinematics import ikine_search, lm_compiled

    lm_compiled.set_threads(2)
    info = {"python": sys.version.split()[0], "numba": numba.__version__, "cpus": os.cpu_count(),
            "load_average_at_start": os.getloadavg(), "command": " ".join(sys.argv)}
    out = {"info": info}
    rng = np.random.default_rng(0)
    R = ws.orientation_samples(50, seed=0)

    # warm-up: compile (or load) the kernels outside the timings
    small = ws.cartesian_grid(-1, 1, 0.5)
    ws.reachability_index(robots.load("panda"), small, R[:2])
    ws.position_map(robots.load("ur5e"), small)

    # 1. Panda index
    panda = robots.load("panda")
    nodes = ws.cartesian_grid(-0.95, 0.95, 0.05)
    t_idx, (idx, bits) = timed(lambda: ws.reachability_index(panda, nodes, R, return_bits=True))
    cand = np.flatnonzero(bits.any(axis=1))
    s = rng.choice(cand, min(args.sample, cand.size), replace=False)
    T = np.zeros((s.size, 50, 4, 4))
    T[..., :3, :3], T[..., :3, 3], T[..., 3, 3] = R[None], nodes[s][:, None], 1.0
    t_ref, ref = timed(lambda: ikine_search(panda, T, starts=args.ref_starts).success)
    b = bits[s]
    out["panda_index"] = {
        "nodes": len(nodes), "orientations": 50, "seconds": t_idx, "goal_seconds": 60,
        "mean_index": float(idx.mean()), "nodes_with_index_above_0": int((idx > 0).sum()),
        "sample_nodes": int(s.size), "reference_starts": args.ref_starts, "reference_seconds": t_ref,
        "recall": float((b & ref).sum() / max(ref.sum(), 1)), "reference_positives": int(ref.sum()),
        "positives_the_reference_missed": int((b & ~ref).sum()),
    }

    # 2. UR5e reach map at 2.5 cm
    ur5e = robots.load("ur5e")
    fine = ws.cartesian_grid(-1.05, 1.05, 0.025)
    t_pos, pm = timed(lambda: ws.position_map(ur5e, fine))
    ps = rng.choice(len(fine), 3000, replace=False)
    Tp = ws.target_poses(fine[ps], (0, 0, 0), "standard")
    refp = ikine_search(ur5e, Tp, starts=args.ref_starts, position_only=True).success
    out["ur5e_reach"] = {"nodes": len(fine), "seconds": t_pos, "goal_seconds": 30, "reachable": int(pm.sum()),
                         "sample_nodes": int(ps.size),
                         "recall": float((pm[ps] & refp).sum() / max(refp.sum(), 1)),
                         "positives_the_reference_missed": int((pm[ps] & ~refp).sum())}

    # 3. UR5e index: exact and numerical
    t_ue, (ue, ube) = timed(lambda: ws.reachability_index(ur5e, nodes, R, return_bits=True))
    t_un, (un, ubn) = timed(lambda: ws.reachability_index(ur5e, nodes, R, method="numerical", return_bits=True))
    out["ur5e_index"] = {"nodes": len(nodes), "exact_seconds": t_ue, "numerical_seconds": t_un,
                         "recall": float((ubn & ube).sum() / ube.sum()), "false_positives": int((ubn & ~ube).sum())}

    # 4. Robotics Toolbox, pose by pose with restarts, extrapolated
    rtb_row = _rtb_row(panda, R, nodes, cand, bits, rng, args.rtb_sample)
    if rtb_row is not None:
        out["rtb"] = rtb_row

    _print_table(out, args.ref_starts)
    harness.write_json(args, out)
    return out


if __name__ == "__main__":
    main()
