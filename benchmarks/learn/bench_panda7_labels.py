"""Recall of the ``panda7_tooldown`` labels (the numerical map search) against a denser reference.

The labels of `wsmap.paper.specs.PANDA7_TOOLDOWN` are
``constant_orientation_map(arms, nodes, (pi, 0, 0), method="numerical", convention="standard")``:
the map search started from neighbouring nodes' solutions (``MAP_SETTINGS``). Its ``True`` is
never wrong (every success is confirmed by forward kinematics inside the joint limits), so the
question is recall: how many reachable nodes does it miss?

Per arm (the first ``--arms`` arms of the dataset's training stream, and the Panda itself, scales 1):

* the map's labels on the whole 25³ grid (``TP`` = its reachable nodes);
* the *candidates*: the nodes the map calls unreachable that the search's sound reach filter
  does not exclude (the only nodes a miss can hide in); ``--sample`` of them, drawn uniformly
  (seeded), go to the reference, ``ikine_search(arm, T, starts=--starts)`` (64 independent starts
  per node: start 0 at q = 0, then random ones inside the limits, each with the joint limits inside
  LM and the unconstrained second pass);
* ``--check`` of the map's reachable nodes go to the reference too (how strong the reference is).

Estimated misses ``FN = found / sampled x candidates``; recall ``TP / (TP + FN)`` (an upper
bound of the true recall: the reference can miss nodes too); with no miss found, a 95 % lower
bound from the rule of three (``FN <= 3 / sampled x candidates``), else from the Clopper-Pearson
upper bound of the miss rate; ``--sample 0`` sends every candidate (a count, no estimate).

Measured (2-core machine shared with another job, OMP_NUM_THREADS=1, one numba thread):

* ``--arms 4 --sample 1000``: 0 misses in 5 x 1000 sampled candidates (arms 0-3 of the training
  stream and the Panda; 1268, 2227, 1310, 2749 and 1883 reachable nodes; 3911-7268 candidates each);
  per-arm 95 % lower bounds 0.987-0.992; the reference confirmed 500/500 of the map's reachable
  nodes; ~7 s of reference per arm;
* ``--arms 1 --sample 0`` (every candidate, ~35 s per arm): arm 0, 1 miss in 5383 candidates
  (recall 1268/1269 = 0.9992); the Panda, 0 in 5569 (recall 1.0, as on the 21³ grid); pooled
  3151/3152 = 0.9997.

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/learn/bench_panda7_labels.py --arms 4 --sample 1000 --json bench/panda7_labels.json
    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/learn/bench_panda7_labels.py --arms 0 --sample 0   # the Panda, every candidate
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402


def main(argv=None) -> None:
    p = harness.parser(__doc__, seed=0, seed_help="seed of the node samples and of the reference starts (default 0)")
    p.add_argument("--arms", type=int, default=4, help="arms of the training stream (plus the Panda itself)")
    p.add_argument("--sample", type=int, default=300,
                   help="candidate nodes per arm sent to the reference (0: every candidate, an exact count)")
    p.add_argument("--check", type=int, default=100, help="map-reachable nodes per arm sent to the reference")
    p.add_argument("--starts", type=int, default=64, help="reference starts per node")
    args = p.parse_args(argv)

    from scipy.stats import beta

    from wsmap import datasets, robots
    from wsmap import workspace as ws
    from wsmap.kinematics import as_chain, ikine_search, lm_compiled
    from wsmap.kinematics.ik.reach_filter import reach_filter
    from wsmap.paper.specs import PANDA7_TOOLDOWN as spec

    lm_compiled.set_threads(1)
    rng = np.random.default_rng(args.seed)
    nodes = datasets.spec_nodes(spec)
    T = ws.target_poses(nodes, spec.fixed, spec.convention)
    drawn = datasets.draw_scales(datasets.scaled(spec, args.arms)) if args.arms > 0 else np.zeros((0, 6))
    scales = np.vstack([drawn, np.ones((1, 6))])
    rows, totals = [], dict(tp=0, fn_est=0.0, fn_hi=0.0, sampled=0, found=0, checked=0, confirmed=0)
    for i, s in enumerate(scales):
        arm = robots.family_arm("panda7", s)
        t_map, L = harness.timed(lambda: ws.constant_orientation_map(  # noqa: B023
            arm, nodes, spec.fixed, method="numerical", convention=spec.convention))
        possible = reach_filter(as_chain(arm), T, 1e-6)
        cand = np.flatnonzero(~L & possible)
        pick = cand if args.sample <= 0 else rng.choice(cand, size=min(args.sample, cand.size), replace=False)
        yes = np.flatnonzero(L)
        check = rng.choice(yes, size=min(args.check, yes.size), replace=False)
        t_ref, ref = harness.timed(lambda: ikine_search(  # noqa: B023
            arm, T[np.concatenate([pick, check])], starts=args.starts, seed=args.seed + 1).success)
        found, confirmed = int(ref[: pick.size].sum()), int(ref[pick.size :].sum())
        tp = int(L.sum())
        rate = found / max(pick.size, 1)
        # 95 % upper bound of the miss rate among the candidates (rule of three when none was found)
        hi = 3.0 / pick.size if found == 0 else float(beta.ppf(0.95, found + 1, pick.size - found))
        if pick.size == cand.size:  # every candidate went to the reference: a count, not an estimate
            hi = rate
        fn_est, fn_hi = rate * cand.size, hi * cand.size
        row = dict(arm=i, panda=bool(np.all(s == 1)), scales=[round(float(x), 4) for x in s], reachable=tp,
                   candidates=int(cand.size), sampled=int(pick.size), missed_in_sample=found,
                   recall=tp / (tp + fn_est), recall_95_lower=tp / (tp + fn_hi),
                   reference_found_of_map_true=f"{confirmed}/{check.size}", map_s=round(t_map, 2),
                   reference_s=round(t_ref, 2))
        rows.append(row)
        for k, v in (("tp", tp), ("fn_est", fn_est), ("fn_hi", fn_hi), ("sampled", pick.size), ("found", found),
                     ("checked", check.size), ("confirmed", confirmed)):
            totals[k] += v
        print(f"arm {i}{' (Panda)' if row['panda'] else ''}: scales {row['scales']}  reachable {tp}  candidates "
              f"{cand.size}  reference found {found}/{pick.size} of the sampled candidates and {confirmed}/"
              f"{check.size} of the map's reachable nodes  recall {row['recall']:.4f} (95 % >= "
              f"{row['recall_95_lower']:.4f})  map {t_map:.1f} s, reference {t_ref:.1f} s", flush=True)
    pooled = totals["tp"] / (totals["tp"] + totals["fn_est"])
    pooled_lo = totals["tp"] / (totals["tp"] + totals["fn_hi"])
    print(f"pooled: {totals['found']} misses in {totals['sampled']} sampled candidates; recall {pooled:.4f} "
          f"(lower bound {pooled_lo:.4f} from the sum of the per-arm 95 % bounds: conservative); the reference "
          f"found {totals['confirmed']}/{totals['checked']} of the map's reachable nodes")
    if args.json:
        import os

        os.makedirs(os.path.dirname(os.path.abspath(args.json)), exist_ok=True)
    harness.write_json(args, dict(args=vars(args), rows=rows, pooled_recall=pooled, pooled_recall_95_lower=pooled_lo))


if __name__ == "__main__":
    main()
