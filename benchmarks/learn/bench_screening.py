"""Catalogue screening: `wsmap.learn.screen_arms`'s top-10 arms for a set of tool-down targets
against the exhaustive classical ranking of every arm. Recall and time, side by side.

The catalogue is ``--arms`` random ``morph6`` and as many ``morph7`` arms (drawn from ``--seed``)
and the six named arms; the targets are tool-down positions on a grid of a work area in front of the
base (``--area``: x 0.3-0.7 m, y -0.3-0.3 m, z 0-0.3 m at 0.1 m by default). The exhaustive ranking
maps every arm classically at the targets (`wsmap.workspace.constant_orientation_map`,
``method="auto"``); screening maps arms best-first by an upper bound on their coverage (the reach
filter's, sound; with a finite ``--margins`` value also the network's) until no unmapped arm can
enter the top ``--top``. Both rank by coverage, ties by the arm's total link length (the smaller arm
first). Top-10 recall: the share of the exhaustive top 10 that screening returns. One thread.

    NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 .venv/bin/python benchmarks/learn/bench_screening.py \\
        --model models/morph.pt [--arms 500] [--margins inf 6 4 2] [--json bench/screening.json]

Mapping all 1,006 arms takes about six minutes on one core. ``--exhaustive-from FILE`` takes the
exhaustive coverages from an earlier ``--json`` of the same catalogue and targets instead, and the
exhaustive time is then measured on ``--time-sample`` arms drawn at random in this run and scaled to
the catalogue (stated as such in the output and the JSON).
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402


def _catalogue(n_random, seed):
    import wsmap
    from wsmap.robots import FAMILIES
    from wsmap.robots.morph import HELD_OUT

    names, arms = [], []
    for n in (6, 7):
        fam = FAMILIES[f"morph{n}"]
        for i, params in enumerate(fam.draw(n_random, seed=seed)):
            names.append(f"morph{n}#{i}")
            arms.append(fam.arms(params))
    for name in HELD_OUT:
        names.append(name)
        arms.append(wsmap.load(name))
    return names, arms


def _exhaustive(args, names, arms, targets):
    """`(seconds, coverage (B,), how the seconds were measured)`, or None for a file of another catalogue."""
    import json

    import numpy as np

    from wsmap import workspace as ws
    from wsmap.learn import morph_model as mm

    def coverage_of(idx):
        return np.array([ws.constant_orientation_map(arms[i], targets, mm.TOOL_DOWN).mean() for i in idx])

    if not args.exhaustive_from:
        seconds, coverage = harness.timed(lambda: coverage_of(range(len(arms))))
        return seconds, coverage, "every arm mapped in this run"
    earlier = json.loads(Path(args.exhaustive_from).read_text())
    if earlier.get("names") != names or earlier.get("targets") != int(len(targets)):
        return None
    coverage = np.array(earlier["coverage"])
    sample = np.random.default_rng(0).choice(len(arms), min(args.time_sample, len(arms)), replace=False)
    seconds, part = harness.timed(lambda: coverage_of(sample))
    if not np.array_equal(part, coverage[sample]):
        print(f"warning: {int((part != coverage[sample]).sum())} of the sampled arms' coverages differ from "
              f"{args.exhaustive_from}", file=sys.stderr)
    return (seconds * len(arms) / len(sample), coverage,
            f"{len(sample)} random arms mapped in this run in {seconds:.1f} s, scaled to {len(arms)}")


def main(argv=None) -> int:
    p = harness.parser(__doc__, seed=2024, seed_help="stream of the random arms (default 2024)")
    p.add_argument("--model", default=str(harness.ROOT / "models" / "morph.pt"), metavar="FILE",
                   help="a morphology model file (default models/morph.pt, the morphologies stage's)")
    p.add_argument("--arms", type=harness.positive_int, default=500, help="random arms per family (default 500)")
    p.add_argument("--margins", type=float, nargs="+", default=[float("inf"), 6.0, 4.0, 2.0],
                   help="screen_arms' margin in logits; inf: the sound bound alone (default inf 6 4 2)")
    p.add_argument("--top", type=harness.positive_int, default=10, help="the ranking's length (default 10)")
    p.add_argument("--exhaustive-from", metavar="JSON", help="reuse the exhaustive coverages of an earlier --json "
                   "of the same arms and targets instead of mapping every arm again")
    p.add_argument("--time-sample", type=harness.positive_int, default=100,
                   help="with --exhaustive-from: arms mapped to time the exhaustive ranking (default 100)")
    p.add_argument("--area", type=float, nargs=7, default=[0.3, -0.3, 0.0, 0.7, 0.3, 0.3, 0.1],
                   metavar=("X0", "Y0", "Z0", "X1", "Y1", "Z1", "STEP"), help="the targets' grid (m)")
    args = p.parse_args(argv)
    if not Path(args.model).is_file():
        print(f"no model file {args.model}: run `dvc repro -s morphologies` first, or give --model", file=sys.stderr)
        return 2
    if args.exhaustive_from and not Path(args.exhaustive_from).is_file():
        print(f"no file {args.exhaustive_from} (--exhaustive-from)", file=sys.stderr)
        return 2
    if any(not m >= 0 for m in args.margins):
        print(f"--margins must be non-negative numbers of logits (inf allowed), got {args.margins}", file=sys.stderr)
        return 2

    import numpy as np
    import torch

    from wsmap import workspace as ws
    from wsmap.kinematics import as_chain
    from wsmap.learn import morph_model as mm
    from wsmap.learn import screen_arms
    from wsmap.learn.training_range import ExtrapolationWarning

    torch.set_num_threads(1)
    model, _ = mm.load_morph_model(args.model)
    names, arms = _catalogue(args.arms, args.seed)
    cost = np.array([np.linalg.norm(as_chain(a).fixed[..., :3, 3], axis=-1).sum() for a in arms])
    a = args.area
    targets = ws.cartesian_grid(a[:3], a[3:6], a[6])
    print(f"{len(arms)} arms, {len(targets)} tool-down targets", flush=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ExtrapolationWarning)
        ex = _exhaustive(args, names, arms, targets)
        if ex is None:
            print(f"{args.exhaustive_from} holds other arms or targets", file=sys.stderr)
            return 2
        exhaustive_s, coverage, how = ex
        truth = np.lexsort((np.arange(len(arms)), cost, -coverage))[:args.top]
        print(f"exhaustive: {exhaustive_s:.1f} s ({how}); {int((coverage == coverage.max()).sum())} arms cover "
              f"{coverage.max():.2f}; its top {args.top}: " + ", ".join(f"{names[i]} {coverage[i]:.2f}" for i in truth),
              flush=True)
        rows = []
        for m in args.margins:
            seconds, res = harness.timed(lambda m=m: screen_arms(model, arms, targets, top=args.top, margin=m,
                                                                 cost=cost, allow_extrapolation=True))
            recall = len(set(res.ranking) & set(truth)) / args.top
            same = bool(np.array_equal(res.ranking, truth))
            sound = bool((coverage <= res.bound + 1e-12).all())
            rows.append({"margin": m, "seconds": seconds, "recall": recall, "same_ranking": same,
                         "mapped": int(len(res.mapped)), "complete": res.complete, "bound_sound": sound,
                         "speedup": exhaustive_s / seconds, "ranking": [names[i] for i in res.ranking]})
            print(f"screening, margin {m:g}: {seconds:.2f} s ({exhaustive_s / seconds:.1f}x faster), "
                  f"{len(res.mapped)} arms mapped, top-{args.top} recall {recall:.2f}"
                  f"{' (the exhaustive ranking)' if same else ''}; bound >= coverage on every arm: {sound}", flush=True)
    harness.write_json(args, {"arms": len(arms), "names": names, "coverage": coverage.tolist(),
                              "targets": int(len(targets)), "exhaustive_s": exhaustive_s, "exhaustive_timing": how,
                              "exhaustive_top": [names[i] for i in truth],
                              "exhaustive_coverage": [float(coverage[i]) for i in truth], "rows": rows})
    return 0


if __name__ == "__main__":
    sys.exit(main())
