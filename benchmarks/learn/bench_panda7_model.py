"""The panda7 map model, measured: F on held-out arms, ms per map against the classical map,
training time, and F against the number of training arms.

Trains `wsmap.learn.family.fit_map_model` (the recipe of ``--hidden``, ``--epochs``, ...) on
the first ``--train-arms`` arms of ``--train`` (a ``panda7_tooldown`` dataset: ``wsmap data build
panda7_tooldown --samples N --out F``), scores it on every arm of ``--test`` (the independent test
stream: ``--test``), times one map against the numerical map that labelled the data, side by
side in this run (`wsmap.learn.family.speed_against_classical`), and with ``--curve`` trains
the same recipe on fewer arms. Saves the model with ``--save``. The goals of issue 14 are printed
beside the measurements: F >= 0.97, <= 1 ms per map, >= 1000x the numerical map, training <= 20 min.

    .venv/bin/python benchmarks/learn/bench_panda7_model.py --train data/full/panda7_tooldown.npz \\
        --test data/full/panda7_tooldown.test.npz --train-arms 4000 --curve 250 500 1000 2000 \\
        --save bench/panda7_map.pt --json bench/panda7_model.json
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402


def main(argv=None) -> int:
    p = harness.parser(__doc__, threads=2, threads_help="torch threads for training (default 2)")
    p.add_argument("--train", required=True, help="panda7_tooldown training dataset (.npz)")
    p.add_argument("--test", required=True, help="its independent test set (.npz)")
    p.add_argument("--train-arms", type=int, default=None, help="first N training arms (default all)")
    p.add_argument("--hidden", type=int, nargs="+", default=[256, 256])
    p.add_argument("--epochs", type=int, default=60)
    p.add_argument("--lr", type=float, default=1e-3)
    p.add_argument("--batch-size", type=int, default=64)

    p.add_argument("--curve", type=int, nargs="*", default=[], help="also train on these numbers of arms")
    p.add_argument("--speed-arms", type=int, default=3, help="held-out arms whose classical map is timed")
    p.add_argument("--save", help="write the model here (wsmap.learn.save)")
    args = p.parse_args(argv)

    import torch

    from wsmap import datasets, learn
    from wsmap.learn import family as map_family

    torch.set_num_threads(args.threads)
    train_all = datasets.load_dataset(args.train)
    test = datasets.load_dataset(args.test)
    train = train_all.head(args.train_arms)
    recipe = map_family.MapRecipe(hidden=tuple(args.hidden), epochs=args.epochs, lr=args.lr, batch_size=args.batch_size)
    print(f"{len(train)} training arms, {len(test)} held-out arms, {test.n_nodes} nodes; recipe {recipe.to_dict()}",
          flush=True)

    train_s, (model, result) = harness.timed(lambda: map_family.fit_map_model(train, recipe))
    ev = map_family.evaluate_map_model(model, test)
    print(f"trained in {train_s:.0f} s ({torch.get_num_threads()} threads), best epoch {result.best_epoch}; "
          f"held-out F {ev['f']:.4f} (P {ev['precision']:.4f}, R {ev['recall']:.4f}; per arm {ev['f_mean']:.4f} "
          f"± {ev['f_std']:.4f})", flush=True)
    if args.save:
        learn.save(model, args.save, dataset_spec=train.spec, train_config=recipe.train_config(),
                    extra={"recipe": recipe.to_dict(), "test_f": ev["f"]})
    speed = {t: map_family.speed_against_classical(model, test, arms=args.speed_arms, threads=t) for t in (1, 2)}
    for t, s in speed.items():
        print(f"{t} thread(s): model {s['model_s'] * 1e3:.3f} ms/map (min {s['model_min_s'] * 1e3:.3f}), numerical "
              f"map {s['classical_s']:.3f} s/map: {s['speedup']:.0f}x", flush=True)
    curve = map_family.learning_curve(train_all, test, args.curve, recipe) if args.curve else []
    curve.append(map_family.curve_row(len(train), ev, train_s, result.stop_epoch))
    curve.sort(key=lambda r: r["train_arms"])

    s1 = speed[1]
    table = [
        ("F on held-out arms", f"{ev['f']:.4f}", ">= 0.97", ev["f"] >= 0.97),
        ("one map, 1 thread (ms)", f"{s1['model_s'] * 1e3:.3f}", "<= 1", s1["model_s"] <= 1e-3),
        ("speed-up over the numerical map, 1 thread", f"{s1['speedup']:.0f}x", ">= 1000x", s1["speedup"] >= 1000),
        ("training (min)", f"{train_s / 60:.1f}", "<= 20", train_s <= 1200),
    ]
    print("\n| measure | measured | goal | met |\n|---|---:|---|---|")
    for name, value, goal, met in table:
        print(f"| {name} | {value} | {goal} | {'yes' if met else 'no'} |")
    print("\n| training arms | F | P | R | training s |\n|---:|---:|---:|---:|---:|")
    for r in curve:
        print(f"| {r['train_arms']} | {r['f']:.4f} | {r['precision']:.4f} | {r['recall']:.4f} | {r['seconds']:.0f} |")
    harness.write_json(args, dict(recipe=recipe.to_dict(), train_arms=len(train), test_arms=len(test),
                                  train_seconds=train_s, best_epoch=result.best_epoch, f=ev["f"],
                                  precision=ev["precision"], recall=ev["recall"], f_mean=ev["f_mean"],
                                  f_std=ev["f_std"], speed={str(k): v for k, v in speed.items()}, curve=curve))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
