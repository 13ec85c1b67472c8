"""Catalogue screening: the network's top-10 arms for a set of tool-down targets, verified
classically, against the exhaustive classical ranking of every arm. Recall and time, side by side.

The catalogue is ``--arms`` random ``morph6`` and as many ``morph7`` arms (drawn from ``--seed``)
and the six named arms; the targets are tool-down positions on a grid of a work area in front of the
base (``--area``: x 0.3-0.7 m, y -0.3-0.3 m, z 0-0.3 m at 0.1 m by default). The exhaustive ranking
maps every arm classically at the targets (`wsmap.workspace.constant_orientation_map`,
``method="auto"``); `wsmap.learn.screen_arms` maps only its ``--candidates`` best predicted. Both
rank by coverage, ties by the arm's total link length (the smaller arm first). Top-10 recall: the
share of the exhaustive top 10 that screening returns. One thread.

    NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 .venv/bin/python benchmarks/learn/bench_screening.py \\
        --model models/morph.pt [--arms 500] [--candidates 50] [--json bench/screening.json]
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402


def main(argv=None) -> int:
    p = harness.parser(__doc__, seed=2024, seed_help="stream of the random arms (default 2024)")
    p.add_argument("--model", default=str(harness.ROOT / "models" / "morph.pt"), metavar="FILE",
                   help="a morphology model file (default models/morph.pt, the morphologies stage's)")
    p.add_argument("--arms", type=harness.positive_int, default=500, help="random arms per family (default 500)")
    p.add_argument("--candidates", type=harness.positive_int, nargs="+", default=[20, 50, 100],
                   help="arms mapped classically by screening (default 20 50 100)")
    p.add_argument("--top", type=harness.positive_int, default=10, help="the ranking's length (default 10)")
    p.add_argument("--slack", type=float, nargs="+", default=[0.0, 0.1, 0.2],
                   help="screen_arms' slack: arms this near the top predicted coverage first, by cost (default 0 0.1 0.2)")
    p.add_argument("--exhaustive-from", metavar="JSON", help="reuse the exhaustive coverages of an earlier --json "
                   "of the same arms and targets instead of mapping every arm again")
    p.add_argument("--area", type=float, nargs=7, default=[0.3, -0.3, 0.0, 0.7, 0.3, 0.3, 0.1],
                   metavar=("X0", "Y0", "Z0", "X1", "Y1", "Z1", "STEP"), help="the targets' grid (m)")
    args = p.parse_args(argv)
    if not Path(args.model).is_file():
        print(f"no model file {args.model}: run `dvc repro -s morphologies` first, or give --model", file=sys.stderr)
        return 2

    import numpy as np
    import torch

    import wsmap
    from wsmap import workspace as ws
    from wsmap.kinematics import as_chain
    from wsmap.learn import morph_model as mm
    from wsmap.learn import screen_arms
    from wsmap.learn.training_range import ExtrapolationWarning
    from wsmap.robots import FAMILIES
    from wsmap.robots.morph import HELD_OUT

    torch.set_num_threads(1)
    model, _ = mm.load_morph_model(args.model)
    names, arms = [], []
    for n in (6, 7):
        fam = FAMILIES[f"morph{n}"]
        for i, params in enumerate(fam.draw(args.arms, seed=args.seed)):
            names.append(f"morph{n}#{i}")
            arms.append(fam.arms(params))
    for name in HELD_OUT:
        names.append(name)
        arms.append(wsmap.load(name))
    cost = np.array([np.linalg.norm(as_chain(a).fixed[..., :3, 3], axis=-1).sum() for a in arms])
    a = args.area
    targets = ws.cartesian_grid(a[:3], a[3:6], a[6])
    print(f"{len(arms)} arms, {len(targets)} tool-down targets", flush=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ExtrapolationWarning)
        if args.exhaustive_from:
            import json

            earlier = json.loads(Path(args.exhaustive_from).read_text())
            if earlier.get("names") != names or earlier.get("targets") != int(len(targets)):
                print(f"{args.exhaustive_from} holds other arms or targets", file=sys.stderr)
                return 2
            exhaustive_s, coverage = earlier["exhaustive_s"], np.array(earlier["coverage"])
        else:
            exhaustive_s, coverage = harness.timed(lambda: np.array(
                [ws.constant_orientation_map(arm, targets, mm.TOOL_DOWN).mean() for arm in arms]))
        truth = np.lexsort((np.arange(len(arms)), cost, -coverage))[:args.top]
        print(f"exhaustive: {exhaustive_s:.1f} s; its top {args.top}: "
              + ", ".join(f"{names[i]} {coverage[i]:.2f}" for i in truth), flush=True)
        rows = []
        for slack in args.slack:
            for c in args.candidates:
                seconds, res = harness.timed(lambda c=c, slack=slack: screen_arms(
                    model, arms, targets, top=args.top, candidates=c, cost=cost, slack=slack, allow_extrapolation=True))
                recall = len(set(res.ranking) & set(truth)) / args.top
                rows.append({"slack": slack, "candidates": c, "seconds": seconds, "recall": recall,
                             "speedup": exhaustive_s / seconds, "ranking": [names[i] for i in res.ranking]})
                print(f"screening, slack {slack:g}, {c} candidates: {seconds:.2f} s ({exhaustive_s / seconds:.0f}x "
                      f"faster), top-{args.top} recall {recall:.2f}", flush=True)
    harness.write_json(args, {"arms": len(arms), "names": names, "coverage": coverage.tolist(),
                              "targets": int(len(targets)), "exhaustive_s": exhaustive_s,
                              "exhaustive_top": [names[i] for i in truth],
                              "exhaustive_coverage": [float(coverage[i]) for i in truth], "rows": rows})
    return 0


if __name__ == "__main__":
    sys.exit(main())
