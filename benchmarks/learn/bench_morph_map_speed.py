"""One 3-D map of a morphology model, coarse to fine against dense: the same map, and how fast.

For each model file and each ``--margin``, maps random ``morph6``/``morph7`` arms (``--arms`` of
each, drawn from ``--seed``) and the six named arms on ``[-1.5, 1.5]³`` at ``--step`` (0.1 m:
29,791 nodes) with `wsmap.learn.morph_model.predict_morph_grid` (coarse to fine) and with
`wsmap.learn.morph_model.predict_morph_map` (the network at every node), and counts the
nodes where the two maps differ (positives the coarse pass skipped, and any other difference) and
the share of nodes the network was evaluated at. Then times both, one thread, median of
``--repeats``, side by side on the named arms and a random ``morph7`` arm, with the classical
numerical map of the same arm once for scale.

    NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 .venv/bin/python benchmarks/learn/bench_morph_map_speed.py \\
        --models models/morph.pt [--margins 2 4 6 8] [--arms 100] [--json bench/morph_map_speed.json]
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402


def main(argv=None) -> int:
    p = harness.parser(__doc__, repeat=20, seed=12345, repeat_help="timed calls per map (default 20)",
                       seed_help="stream of the random arms (default 12345)")
    p.add_argument("--models", nargs="+", required=True, metavar="FILE", help="morphology model files")
    p.add_argument("--arms", type=int, default=100, help="random arms per family")
    p.add_argument("--step", type=float, default=0.1, help="grid step (m) on [-1.5, 1.5]^3")
    p.add_argument("--coarse", type=int, default=3, help="every coarse-th node first")
    p.add_argument("--margins", type=float, nargs="+", default=[2.0, 4.0, 6.0, 8.0], help="logits")
    args = p.parse_args(argv)

    import numpy as np
    import torch

    import wsmap
    from wsmap import workspace as ws
    from wsmap.learn import morph_model as mm
    from wsmap.learn.training_range import ExtrapolationWarning
    from wsmap.robots import FAMILIES
    from wsmap.robots.morph import HELD_OUT

    torch.set_num_threads(1)
    lo, hi = -1.5, 1.5
    nodes = ws.cartesian_grid(lo, hi, args.step)
    arms = {}
    for n in (6, 7):
        fam = FAMILIES[f"morph{n}"]
        for i, params in enumerate(fam.draw(args.arms, seed=args.seed)):
            arms[f"morph{n}#{i}"] = fam.arms(params)
    arms.update({name: wsmap.load(name) for name in HELD_OUT})
    out = {"args": vars(args), "nodes": int(len(nodes)), "models": {}}
    for path in args.models:
        model, _ = mm.load_morph_model(path)
        res = {"agreement": [], "speed": []}
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ExtrapolationWarning)
            dense = {k: mm.predict_morph_map(model, a, nodes, allow_extrapolation=True) for k, a in arms.items()}
            for margin in args.margins:
                missed = extra = differ = positives = 0
                for k, a in arms.items():
                    g = mm.predict_morph_grid(model, a, lo, hi, args.step, coarse=args.coarse, margin=margin,
                                              allow_extrapolation=True)
                    d = dense[k]
                    missed += int(np.sum(d & ~g))
                    extra += int(np.sum(g & ~d))
                    differ += int(np.any(g != d))
                    positives += int(d.sum())
                row = {"margin": margin, "arms": len(arms), "positives": positives, "missed": missed,
                       "extra": extra, "arms_differing": differ}
                res["agreement"].append(row)
                print(f"{path} margin {margin:g}: {len(arms)} arms, {positives} positive nodes dense; coarse to "
                      f"fine missed {missed}, added {extra}; {differ} arms differ", flush=True)
            margin = mm.MARGIN if mm.MARGIN in args.margins else args.margins[-1]
            timed = [k for k in arms if k in ("iiwa14", "ur5e", "panda", "ur10e")] + ["morph7#0"]
            for k in timed:
                a = arms[k]

                def median(f):
                    return float(np.median(harness.timings(f, args.repeat, warmup=1)[0].values))

                t_dense = median(lambda: mm.predict_morph_map(model, a, nodes, allow_extrapolation=True))
                t_grid = median(lambda: mm.predict_morph_grid(model, a, lo, hi, args.step, coarse=args.coarse,
                                                              margin=margin, allow_extrapolation=True))
                ws.constant_orientation_map(a, ws.cartesian_grid(lo, hi, 0.5), mm.TOOL_DOWN, convention="standard")
                classical, _ = harness.timed(
                    lambda: ws.constant_orientation_map(a, nodes, mm.TOOL_DOWN, convention="standard"))  # noqa: B023
                row = {"arm": k, "margin": margin, "dense_ms": 1e3 * t_dense, "grid_ms": 1e3 * t_grid,
                       "classical_s": classical, "grid_vs_classical": classical / t_grid,
                       "reachable_share": float(dense[k].mean())}
                res["speed"].append(row)
                print(f"  {k:<10} dense {1e3 * t_dense:6.1f} ms   coarse to fine {1e3 * t_grid:6.1f} ms "
                      f"(x{t_dense / t_grid:4.1f})   classical {classical:6.3f} s (x{classical / t_grid:5.0f}); "
                      f"{100 * dense[k].mean():.1f} % reachable", flush=True)
        out["models"][path] = res
    harness.write_json(args, out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
