"""One map model for every arm, measured: the morphology model against the nearest-training-arm
baseline on the same held-out arms, and one 3-D map against the classical map of the same arm.

Builds (or reuses, from ``--data``) the ``morph6`` and ``morph7`` experience in shards
(`wsmap.learn.morph_model.build_morph_shards`: the tool-down map, ``R = Rx(pi)``, standard
convention, on ``[-1.5, 1.5]³`` at ``--step`` m, labelled by the numerical map search), trains
`wsmap.learn.morph_model.MorphMapModel` single-threaded for ``--minutes`` with the
project's `wsmap.learn.training.train`, and prints per-arm F, precision and recall pooled over
the held-out random arms (the shard-0 test streams, never trained on) and for each named arm
(`wsmap.robots.morph.HELD_OUT`, labelled here by the same map search), for the model and for
the nearest-neighbour baseline (the map of the training arm nearest in
`wsmap.kinematics.morphology.morphology_distance`). Then times one map of ``--time-step``
(0.1 m: 31³ = 29,791 nodes) of new arms by the model and by the classical numerical map, side by
side in this run. Everything single-threaded (``torch.set_num_threads(1)``; run with
``NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1``).

    NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 nice -n 10 .venv/bin/python benchmarks/learn/bench_morphology.py \\
        --data data/morph --shards 5 --arms 100 --test-arms 50 --step 0.2 --minutes 6 --save bench/morph.pt \\
        --json bench/morph.json
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402


def _score(pred, truth):
    from wsmap.metrics import score_maps

    s = score_maps(pred, truth)
    return {k: s[k] for k in ("f", "precision", "recall", "f_mean")}


def _experience(args):
    """The morph6 and morph7 shards (built when missing) with their held-out sets: (training sets, test
    sets, seconds spent labelling, arms labelled now)."""
    from wsmap.learn import morph_model as mm

    train_sets, tests, build_s, arms_built = [], [], 0.0, 0
    for n in (6, 7):
        sets, secs = mm.build_morph_shards(args.data, n, args.shards, args.arms, step=args.step,
                                           test_samples=args.test_arms)
        train_sets += sets[:-1]
        tests.append(sets[-1])
        build_s += sum(secs)
        arms_built += sum(args.arms for s in secs if s > 0) + (args.test_arms if secs[0] > 0 else 0)
        print(f"morph{n}: {args.shards} shards x {args.arms} arms + {args.test_arms} held-out, built in "
              f"{sum(secs):.0f} s ({sum(1 for s in secs if s > 0)} new shards)", flush=True)
    if arms_built:
        print(f"labels: {arms_built / build_s:.2f} arms/s single-threaded ({build_s / arms_built:.2f} s per arm, "
              f"{train_sets[0].labels.shape[1]} nodes)", flush=True)
    return train_sets, tests, build_s, arms_built


def _speed(model, named, tests, time_step):
    """One 3-D map of a new arm, the model against the classical map (same arm, same grid), one core."""
    import numpy as np

    import wsmap
    from wsmap import workspace as ws
    from wsmap.learn import morph_model as mm

    big = ws.cartesian_grid(-1.5, 1.5, time_step)
    timed = {"held-out morph7 arm": wsmap.robots.family_arm("morph7", tests[1].features[0, :tests[1].spec.n_arm_features]),
             "iiwa14": named["iiwa14"], "ur5e": named["ur5e"]}
    print(f"\none map of {len(big)} nodes ({time_step} m), one core:")
    speed = []
    for label, arm in timed.items():
        classical, _ = harness.timed(lambda: ws.constant_orientation_map(  # noqa: B023
            arm, big, mm.TOOL_DOWN, method="numerical", convention="standard"))
        reps, _ = harness.timings(lambda: mm.predict_morph_map(model, arm, big), 5, warmup=1)  # noqa: B023
        mod = float(np.median(reps.values))
        print(f"  {label:<22} model {1e3 * mod:8.1f} ms   classical {classical:7.2f} s   x{classical / mod:7.0f}")
        speed.append({"arm": label, "model_s": mod, "classical_s": classical})
    return speed


def _named_arms(nodes):
    """The six named arms, labelled by the same map search as the datasets: (arms, labels, seconds each)."""
    import wsmap
    from wsmap import workspace as ws
    from wsmap.learn import morph_model as mm
    from wsmap.robots.morph import HELD_OUT

    named, named_labels, named_s = {}, {}, {}
    for name in HELD_OUT:
        arm = wsmap.load(name)
        named_s[name], named_labels[name] = harness.timed(lambda: ws.constant_orientation_map(
            arm, nodes, mm.TOOL_DOWN, method="numerical", convention="standard"))  # noqa: B023
        named[name] = arm
    return named, named_labels, named_s


def _options():
    """The command line: the harness's common options and this benchmark's own."""
    p = harness.parser(__doc__)
    p.add_argument("--data", default="data/morph", help="folder of the experience shards (reused when there)")
    p.add_argument("--shards", type=int, default=5, help="shards per family (morph6, morph7)")
    p.add_argument("--arms", type=int, default=100, help="arms per shard")
    p.add_argument("--test-arms", type=int, default=50, help="held-out random arms per family")
    p.add_argument("--step", type=float, default=0.2, help="label grid step (m) on [-1.5, 1.5]^3")
    p.add_argument("--time-step", type=float, default=0.1, help="grid step (m) of the timed 3-D maps")
    p.add_argument("--minutes", type=float, default=6.0, help="training time (cosine-time schedule)")
    p.add_argument("--epochs", type=int, default=200, help="epoch cap (the time limit usually stops first)")
    p.add_argument("--batch-size", type=int, default=8, help="arms per Adam step")
    p.add_argument("--lr", type=float, default=1e-3)
    p.add_argument("--save", help="write the model here")
    return p


def main(argv=None) -> int:
    p = _options()
    args = p.parse_args(argv)

    import numpy as np
    import torch

    import wsmap
    from wsmap.kinematics.morphology import describe
    from wsmap.learn import TrainConfig
    from wsmap.learn import morph_model as mm

    torch.set_num_threads(1)
    run_clock = harness.Stopwatch().start()
    train_sets, tests, build_s, arms_built = _experience(args)
    spec = train_sets[0].spec
    nodes = wsmap.datasets.spec_nodes(spec)

    named, named_labels, named_s = _named_arms(nodes)

    # training
    tc = TrainConfig(optimizer="adam", optimizer_kwargs={"lr": args.lr}, loss="crossentropy",
                     batch_size=args.batch_size, lr_decay="cosine-time", time_limit_s=60 * args.minutes,
                     max_epochs=args.epochs, max_fail=10 ** 6, fractions=(0.95, 0.05, 0.0), seed=0)
    train_s, (model, result) = harness.timed(lambda: mm.fit_morph_model(train_sets, train_config=tc))
    epochs = len(result.history.epoch) - 1
    print(f"trained on {sum(len(d) for d in train_sets)} arms x {len(nodes)} nodes: {epochs} epochs in "
          f"{train_s:.0f} s (best epoch {result.best_epoch}, stop: {result.stop_reason}); threshold "
          f"{model.threshold} (best F on the validation arms)", flush=True)
    if args.save:
        mm.save_morph_model(model, args.save)

    # held-out random arms and named arms: model and nearest-neighbour baseline
    train_X = np.concatenate([mm.morph_features(list(d.features[:, :d.spec.n_arm_features])) for d in train_sets])
    train_Y = np.concatenate([d.labels for d in train_sets])
    test_X = np.concatenate([mm.morph_features(list(d.features[:, :d.spec.n_arm_features])) for d in tests])
    test_Y = np.concatenate([d.labels for d in tests])
    with torch.no_grad():
        logits = model.logits_at(torch.as_tensor(test_X, dtype=torch.float32),
                                 torch.as_tensor(nodes, dtype=torch.float32)).numpy()
    pred = logits > np.log(model.threshold / (1 - model.threshold))
    nn_pred, nn_dist = mm.nearest_arm_maps(train_X, train_Y, test_X)
    rows = [("held-out random arms", len(test_Y), _score(pred, test_Y), _score(nn_pred, test_Y),
             float(np.median(nn_dist)), float(test_Y.mean()))]
    for name, arm in named.items():
        truth = named_labels[name][None]
        try:
            mp = mm.predict_morph_map(model, arm, nodes)[None]
            refused = None
        except ValueError as e:
            mp, refused = None, str(e)
        nb, nd = mm.nearest_arm_maps(train_X, train_Y, describe(arm).features()[None])
        rows.append((name, 1, None if mp is None else _score(mp, truth), _score(nb, truth), float(nd[0]),
                     float(truth.mean()), refused))

    print()
    print(f"{'arms':<22} {'n':>4} | {'model F':>7} {'P':>6} {'R':>6} {'F/arm':>6} | {'nearest F':>9} {'P':>6} "
          f"{'R':>6} {'F/arm':>6} | {'NN dist m':>9} {'reach.':>6}")
    out_rows = []
    for row in rows:
        label, n, ms, ns, dist, share = row[:6]
        m = "  refused" if ms is None else f"{ms['f']:7.3f} {ms['precision']:6.3f} {ms['recall']:6.3f} {ms['f_mean']:6.3f}"
        print(f"{label:<22} {n:>4} | {m:>28} | {ns['f']:9.3f} {ns['precision']:6.3f} {ns['recall']:6.3f} "
              f"{ns['f_mean']:6.3f} | {dist:9.3f} {share:6.3f}")
        if len(row) > 6 and row[6]:
            print(f"    refused: {row[6]}")
        out_rows.append({"arms": label, "n": n, "model": ms, "nearest": ns, "nn_distance_m": dist,
                         "reachable_share": share})

    speed = _speed(model, named, tests, args.time_step)
    print(f"\ntotal {run_clock.elapsed():.0f} s")
    harness.write_json(args, {"rows": out_rows, "speed": speed, "train_s": train_s, "epochs": epochs,
                              "label_s_per_arm": build_s / arms_built if arms_built else None,
                              "named_label_s": named_s, "args": vars(args)})
    return 0


if __name__ == "__main__":
    sys.exit(main())
