"""Benchmark: a network predicting the spherical-wrist family's manipulability map (issue 14, part 4).

Measured, not asserted. One run: draws ``--train`` arms (seed ``--seed``) and ``--test`` held-out
arms (seed ``--seed + 1``) of the paper's family (d3, d4, a2, a3 ~ U(0, 0.5) m), computes their
exact manipulability maps on the ``sec61`` grid (21³ nodes on [-1, 1]³ m, rpy (0, 0, 0), the
paper's convention; `wsmap.learn.manipulability_targets`), trains
`wsmap.learn.train_manipulability_model` on one thread (``--threads``) for at most
``--minutes``, and reports on the held-out arms: pooled R² (1 − SSE/SST over arms x nodes), MAE
(m³), R² and MAE on the reachable nodes, the largest error; then the time per map, side by side:

* the network: ``predict_manipulability`` on one arm (median of ``--repeats`` calls) and per arm
  in one call for all held-out arms;
* the exact closed form: `wsmap.workspace.manipulability_maps` (factorised ``|det J|``,
  vectorised over arms) on one arm and per arm over the held-out arms, and the reference
  definition `wsmap.workspace.manipulability_map` (8 IK branches and 6 x 6 Jacobians per node)
  on one arm.

    PYTHONPATH=src OMP_NUM_THREADS=1 .venv/bin/python benchmarks/learn/bench_manipulability_model.py \\
        --train 4000 --test 500 --minutes 2.5 --json bench_manipulability_model.json

Measured so (a 2-core machine shared with other jobs; the epochs done in the time limit depend on
the load): 63 epochs, held-out R² 0.9948 pooled, MAE 0.00064 m³, R² 0.9925 on reachable nodes;
0.13 ms per predicted map in bulk against 1.8 ms exact (`docs/learned-maps.md`).
With ``--epochs 60`` (the library's default config; 2026-12-02, the machine shared with a
two-thread training run): R² 0.9947, MAE 0.00064 m³, R² 0.9925 on reachable nodes, 330 s.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import torch

from wsmap import learn, robots
from wsmap import workspace as ws
from wsmap.timing import time_call

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402


def main(argv=None) -> int:
    ap = harness.parser(__doc__, repeat=20, threads=1, seed=1,
                        repeat_help="timed calls per one-map measurement (default 20)",
                        threads_help="torch.set_num_threads (default 1)",
                        seed_help="seed of the training arms (the held-out ones: seed + 1) and of training (default 1)")
    ap.add_argument("--train", type=int, default=4000, help="training arms (5 %% of them validate)")
    ap.add_argument("--test", type=int, default=500, help="held-out arms")
    budget = ap.add_mutually_exclusive_group()
    budget.add_argument("--minutes", type=float, default=2.5,
                        help="training time limit, cosine decay over it (default 2.5)")
    budget.add_argument("--epochs", type=harness.positive_int, help="an epoch budget instead, cosine decay over it, no time "
                        "limit: the library's default config (60 epochs) when the other options are left alone")
    ap.add_argument("--hidden", default="256,256,256", help="hidden layer widths, comma-separated")
    ap.add_argument("--target", choices=learn.MANIPULABILITY_TARGETS, default="linear")
    ap.add_argument("--batch-size", type=int, default=64)
    ap.add_argument("--lr", type=float, default=1e-3)
    ap.add_argument("--save", metavar="PATH", help="also save the trained model here")
    args = ap.parse_args(argv)
    torch.set_num_threads(args.threads)

    data_s, (X, Y) = harness.timed(lambda: learn.manipulability_dataset(args.train, seed=args.seed))
    Xt, Yt = learn.manipulability_dataset(args.test, seed=args.seed + 1)
    print(f"data: {args.train} training + {args.test} held-out arms x {Y.shape[1]} nodes, exact targets "
          f"in {data_s:.1f} s (training set); {100 * (Y > 0).mean():.1f} % of values > 0, max {Y.max():.4f} m^3")

    budget = (dict(max_epochs=args.epochs, time_limit_s=None, lr_decay="cosine") if args.epochs is not None
              else dict(max_epochs=100_000, time_limit_s=60.0 * args.minutes, lr_decay="cosine-time"))
    config = learn.ManipulabilityTrainConfig(hidden=tuple(int(h) for h in args.hidden.split(",")),
                                             target=args.target, lr=args.lr, batch_size=args.batch_size,
                                             seed=args.seed, **budget)
    train_s, (model, result) = harness.timed(lambda: learn.train_manipulability_model(X, Y, config))
    best, stop = result.best_epoch, result.stop_epoch
    best, stop, reason = (best[0], stop[0], result.stop_reason[0]) if isinstance(best, list) else (
        best, stop, result.stop_reason)
    print(f"training: {train_s:.1f} s, {stop} epochs ({reason}), best epoch {best}; network 4 -> "
          f"{list(config.hidden)} -> 9261, target {config.target!r}, Adam lr {config.lr} cosine over the "
          f"{'epochs' if args.epochs is not None else 'time limit'}, batch {config.batch_size}, "
          f"{torch.get_num_threads()} thread(s)")
    if args.save:
        learn.save_manipulability_model(model, args.save, train_config=config)

    pred = learn.predict_manipulability(model, Xt)
    metrics = learn.regression_metrics(pred, Yt.astype(np.float64))
    print(f"held-out ({args.test} arms x 9261 nodes): R2 {metrics['r2']:.4f} (pooled), MAE {metrics['mae']:.3g} m^3; "
          f"reachable nodes ({metrics['n_reachable']}): R2 {metrics['r2_reachable']:.4f}, "
          f"MAE {metrics['mae_reachable']:.3g} m^3; max abs error {metrics['max_abs_error']:.3g} m^3")

    g = learn.manipulability_grid()
    one_p = Xt[:1]
    one_arm = robots.spherical_wrist(a2=one_p[0, 2], a3=one_p[0, 3], d3=one_p[0, 0], d4=one_p[0, 1])
    arms = robots.spherical_wrist(a2=Xt[:, 2], a3=Xt[:, 3], d3=Xt[:, 0], d4=Xt[:, 1])
    timing = {
        "network_one_ms": time_call(lambda: learn.predict_manipulability(model, one_p), args.repeat),
        "network_bulk_ms_per_map": time_call(lambda: learn.predict_manipulability(model, Xt), 3).scaled(1 / len(Xt)),
        "exact_one_ms": time_call(lambda: ws.manipulability_maps(one_arm, g["nodes"], g["rpy"],
                                                                 convention=g["convention"]), args.repeat),
        "exact_bulk_ms_per_map": time_call(lambda: ws.manipulability_maps(arms, g["nodes"], g["rpy"],
                                                                          convention=g["convention"]), 3
                                           ).scaled(1 / len(Xt)),
        "reference_one_ms": time_call(lambda: ws.manipulability_map(one_arm, g["nodes"], g["rpy"],
                                                                    convention=g["convention"]), 3),
    }
    ms = {k: 1e3 * float(np.median(v.values)) for k, v in timing.items()}
    print("ms per map (median):            one arm   per arm in bulk")
    print(f"  network (predict)            {ms['network_one_ms']:8.3f}   {ms['network_bulk_ms_per_map']:8.3f}")
    print(f"  exact closed form (batched)  {ms['exact_one_ms']:8.3f}   {ms['exact_bulk_ms_per_map']:8.3f}")
    print(f"  reference (IK + Jacobians)   {ms['reference_one_ms']:8.3f}")

    if args.json:
        harness.write_json(args, {
            "args": vars(args),
            "grid": {"spec": g["spec"], "nodes": len(g["nodes"]), "rpy": g["rpy"], "convention": g["convention"]},
            "config": config.to_dict(), "data_s": data_s, "train_s": train_s, "epochs": stop, "best_epoch": best,
            "stop_reason": reason, "metrics": metrics, "ms_per_map": ms,
        })
        print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
