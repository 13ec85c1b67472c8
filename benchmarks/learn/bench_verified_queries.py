"""Verified queries: the morphology network's map with its unsure nodes decided by the classical map,
against the classical map of every node. Is it the same map, and at what share of the classical work?

For each arm (the six named arms, and ``--arms`` random ``morph6``/``morph7`` arms drawn from
``--seed``), tool down on ``[-1.5, 1.5]³`` at ``--step``: the classical map of every node
(`wsmap.workspace.constant_orientation_map`, ``method="auto"``: the closed form where the arm has
one), the network alone (`predict_morph_map`), and `wsmap.learn.verified_morph_grid` at each
``--margins`` (shell 1). Per arm and margin: nodes where the verified map differs from the classical
one (missed reachable, extra reachable), the network's own errors, the share of nodes checked, and
the time of the verified map against the classical map's (one thread, median of ``--repeat``, the
two side by side, each from ``lo, hi, step``: the grid is built in both).

    NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 .venv/bin/python benchmarks/learn/bench_verified_queries.py \\
        --model models/morph.pt [--arms 20] [--step 0.1] [--json bench/verified_queries.json]

``models/morph.pt`` is the ``morphologies`` stage's model (``dvc repro -s morphologies``).
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402


def _arms(n_random, seed):
    import wsmap
    from wsmap.robots import FAMILIES
    from wsmap.robots.morph import HELD_OUT

    arms = {name: wsmap.load(name) for name in HELD_OUT}
    for n in (6, 7):
        fam = FAMILIES[f"morph{n}"]
        for i, params in enumerate(fam.draw(n_random, seed=seed)):
            arms[f"morph{n}#{i}"] = fam.arms(params)
    return arms


def _median(fn, repeat):
    import numpy as np

    return float(np.median(harness.timings(fn, repeat, warmup=1)[0].values))


def _profiled(arm, nodes, rpy):
    """`(seconds of one classical map, {pass: seconds})`: `_MapSearch`'s passes timed by
    stopwatches around them (the waves run inside the later passes too, whose times include theirs)."""
    from wsmap import workspace as ws
    from wsmap.kinematics.ik import search

    spent, saved = {}, {}
    for name in ("__init__", "first_pass", "waves", "fk_seed_pass", "retries", "border_search"):
        saved[name] = original = getattr(search._MapSearch, name)

        def timed(self, *a, _original=original, _name=name, **k):
            with harness.Stopwatch() as watch:
                out = _original(self, *a, **k)
            spent[_name] = spent.get(_name, 0.0) + watch.seconds
            return out

        setattr(search._MapSearch, name, timed)
    try:
        total, _ = harness.timed(lambda: ws.constant_orientation_map(arm, nodes, rpy))
    finally:
        for name, original in saved.items():
            setattr(search._MapSearch, name, original)
    return total, spent


def main(argv=None) -> int:
    p = harness.parser(__doc__, repeat=3, seed=12345, repeat_help="timed calls per map (default 3)",
                       seed_help="stream of the random arms (default 12345)")
    p.add_argument("--model", default=str(harness.ROOT / "models" / "morph.pt"), metavar="FILE",
                   help="a morphology model file (default models/morph.pt, the morphologies stage's)")
    p.add_argument("--arms", type=harness.positive_int, default=10, help="random arms per family (default 10)")
    p.add_argument("--step", type=float, default=0.1, help="grid step (m) on [-1.5, 1.5]^3 (default 0.1)")
    p.add_argument("--margins", type=float, nargs="+", default=[2.0, 4.0, 8.0], help="logits (default 2 4 8)")
    p.add_argument("--profile", action="store_true", help="also time the classical map's passes per numerical arm")
    args = p.parse_args(argv)
    if not Path(args.model).is_file():
        print(f"no model file {args.model}: run `dvc repro -s morphologies` first, or give --model", file=sys.stderr)
        return 2

    import numpy as np
    import torch

    from wsmap import workspace as ws
    from wsmap.learn import morph_model as mm
    from wsmap.learn import verified_morph_grid
    from wsmap.learn.training_range import ExtrapolationWarning

    torch.set_num_threads(1)
    lo, hi = -1.5, 1.5
    nodes = ws.cartesian_grid(lo, hi, args.step)
    model, _ = mm.load_morph_model(args.model)
    rows = []
    print(f"{len(nodes)} nodes, tool down; time of the verified map / the classical map's")
    print(f"{'arm':<10} {'method':<9} {'reach':>6} {'net err':>7} {'filters':>7} | " +
          " | ".join(f"m={m:g}: checked  missed extra  time" for m in args.margins))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ExtrapolationWarning)
        for name, arm in _arms(args.arms, args.seed).items():
            truth, method = ws.constant_orientation_map(arm, nodes, mm.TOOL_DOWN, return_method=True)
            # the same question from the same inputs (lo, hi, step): the grid is built in both timings
            t_classical = _median(lambda: ws.constant_orientation_map(  # noqa: B023
                arm, ws.cartesian_grid(lo, hi, args.step), mm.TOOL_DOWN), args.repeat)
            network = mm.predict_morph_map(model, arm, nodes, allow_extrapolation=True)
            row = {"arm": name, "method": method, "reachable": int(truth.sum()),
                   "network_errors": int((network != truth).sum()), "classical_s": t_classical, "margins": []}
            if args.profile and method == "numerical":
                total, spent = _profiled(arm, nodes, mm.TOOL_DOWN)
                row["profile"] = {"total_s": total, **{k: v for k, v in spent.items()}}
                print(f"  {name} classical map {1e3 * total:.0f} ms: " + ", ".join(
                    f"{k.strip('_')} {100 * v / total:.0f} %" for k, v in spent.items()), flush=True)
            cells = []
            for m in args.margins:
                def verified(m=m):
                    return verified_morph_grid(model, arm, lo, hi, args.step, margin=m, allow_extrapolation=True)

                t = _median(verified, args.repeat)
                res = verified()
                missed, extra = int((truth & ~res.values).sum()), int((res.values & ~truth).sum())
                row["possible"] = int(res.possible.sum())
                row["margins"].append({"margin": m, "checked": res.fraction_verified, "missed": missed,
                                       "extra": extra, "rounds": res.rounds, "seconds": t,
                                       "time_share": t / t_classical})
                cells.append(f"{100 * res.fraction_verified:6.1f} % {missed:7d} {extra:5d} {t / t_classical:5.2f}")
            rows.append(row)
            print(f"{name:<10} {method:<9} {int(truth.sum()):6d} {row['network_errors']:7d} {row['possible']:7d} | "
                  + " | ".join(cells), flush=True)
    for i, m in enumerate(args.margins):
        same = sum(r["margins"][i]["missed"] + r["margins"][i]["extra"] == 0 for r in rows)
        share = np.median([r["margins"][i]["time_share"] for r in rows])
        print(f"margin {m:g}: {same} of {len(rows)} arms identical to the classical map; median time share "
              f"{share:.2f}")
    harness.write_json(args, {"nodes": int(len(nodes)), "rows": rows})
    differ = [r["arm"] for r in rows if any(c["missed"] + c["extra"] for c in r["margins"])]
    if differ:
        print(f"verified maps differ from the classical map on: {', '.join(differ)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
