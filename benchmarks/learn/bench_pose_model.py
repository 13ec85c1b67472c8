"""The pose-conditioned network (wsmap.learn.pose_model) on RAM's protocol: F1 of held-out RAM arms on
RAM's random poses and on its boundary set, beside RAM's published 0.86 / 0.78, with the compute.

Training data: `--arms` RAM arms per joint count (5, 6, 7; `sample_morphologies` seeds 0 ..
`--shards`-1), each with `--poses` of RAM's random poses and `--geodesics` x `--per-geodesic`
boundary poses, all labelled by wsmap's IK with RAM's capsule self-collision (`ik_labels`),
cached as resumable shards in `--data DIR`. Held out: `--test-arms` arms per joint count (seed
10000, an independent stream) with the same kinds of poses, labelled the same way. Training:
Adam, binary cross-entropy, 16 arms per step, cosine decay over `--epochs` (or `--time-limit`
seconds), the epoch of lowest validation loss kept (5 % of the arms), the threshold of the best
mean per-arm F1 on those. F1 is RAM's (`ram_f1`: per arm, then the mean).

Compute: labelling and training are process CPU time (core-seconds; run with one thread as
below, so wall time is about the same). RAM (issue 42): 360 H100-hours of data and 57 h of
training.

    NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 .venv/bin/python benchmarks/learn/bench_pose_model.py \\
        [--arms 150] [--poses 200] [--geodesics 20] [--per-geodesic 10] [--test-arms 20] [--epochs 60] \\
        [--data DIR] [--model-out FILE] [--json out.json]
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402

#: RAM's compute as issue 42 quotes it (hours)
RAM_COMPUTE_H = {"data_h100_hours": 360, "training_hours": 57}


def _options():
    p = harness.parser(__doc__, seed=0)
    p.add_argument("--arms", type=harness.positive_int, default=150, help="training arms per joint count")
    p.add_argument("--shards", type=harness.positive_int, default=3, help="shards per joint count (resumable units)")
    p.add_argument("--poses", type=int, default=200, help="random poses per arm")
    p.add_argument("--geodesics", type=int, default=20, help="boundary geodesics per arm")
    p.add_argument("--per-geodesic", type=int, default=10, help="poses per geodesic (at least 2)")
    p.add_argument("--test-arms", type=harness.positive_int, default=20, help="held-out arms per joint count")
    p.add_argument("--epochs", type=harness.positive_int, default=60, help="training epochs")
    p.add_argument("--time-limit", type=float, default=None, help="training seconds at most")
    p.add_argument("--data", default="scratch/pose_model", help="shard directory (reused when there)")
    p.add_argument("--model-out", default=None, help="save the trained model here")
    return p


def main(argv=None) -> int:
    p = _options()
    args = p.parse_args(argv)
    if args.per_geodesic < 2:
        p.error(f"--per-geodesic must be at least 2, got {args.per_geodesic}")
    if args.poses < 1 or args.geodesics < 1:
        p.error(f"--poses and --geodesics must be at least 1, got {args.poses} and {args.geodesics}")
    if args.arms % args.shards:
        p.error(f"--arms ({args.arms}) must be a multiple of --shards ({args.shards})")
    if args.time_limit is not None and args.time_limit <= 0:
        p.error(f"--time-limit must be positive, got {args.time_limit}")

    import numpy as np
    import torch

    from wsmap import datasets as ds
    from wsmap.learn import TrainConfig
    from wsmap.learn import pose_model as pm

    torch.set_num_threads(1)
    kw = {"random": args.poses, "geodesics": args.geodesics, "per_geodesic": args.per_geodesic}
    train_shards = pm.build_pose_shards(args.data, ds.RAM_DOFS, args.shards, args.arms // args.shards, progress=True,
                                        first_seed=args.seed, **kw)
    test_shards = pm.build_pose_shards(args.data, ds.RAM_DOFS, 1, args.test_arms, first_seed=10_000 + args.seed,
                                       progress=True, **kw)
    tc = TrainConfig(optimizer="adam", optimizer_kwargs={"lr": 1e-3}, loss="crossentropy", batch_size=16,
                     lr_decay="cosine" if args.time_limit is None else "cosine-time", max_epochs=args.epochs,
                     max_fail=1000, fractions=(0.95, 0.05, 0.0), seed=args.seed, time_limit_s=args.time_limit)
    with harness.Stopwatch() as watch:
        model, result = pm.fit_pose_model(train_shards, train_config=tc, seed=args.seed)
    train_cpu, train_wall = watch.cpu_seconds, watch.seconds
    if args.model_out:
        pm.save_pose_model(model, args.model_out, extra={"bench": "bench_pose_model", "args": vars(args)})

    R = args.poses
    rows, per = [], {"random": [], "boundary": []}
    for sh in test_shards:  # one joint count each
        d = sh.morphs.shape[1] - 1
        T = np.zeros(sh.poses.shape[:2] + (4, 4))  # the poses back from their raw numbers
        x, y = sh.poses[..., 3:6], sh.poses[..., 6:9]
        T[..., :3, 0], T[..., :3, 1], T[..., :3, 2] = x, y, np.cross(x, y)
        T[..., :3, 3], T[..., 3, 3] = sh.poses[..., :3], 1.0
        pred = pm.predict_poses(model, sh.morphs, T)
        row = {"dof": d, "arms": len(sh.morphs)}
        for name, cols in (("random", slice(0, R)), ("boundary", slice(R, None))):
            f, fa = ds.ram_f1(pred[:, cols], sh.labels[:, cols])
            per[name].append(fa)
            row[f"f1_{name}"] = round(f, 4)
            row[f"reachable_{name}"] = round(float(sh.labels[:, cols].mean()), 4)
        rows.append(row)
    f1 = {name: round(float(np.concatenate(v).mean()), 4) for name, v in per.items()}
    label_cpu = {"train": round(sum(s.cpu_seconds for s in train_shards), 1),
                 "test": round(sum(s.cpu_seconds for s in test_shards), 1)}
    out = {"args": vars(args), "f1": f1, "by_dof": rows, "ram_published": ds.RAM_PUBLISHED,
           "threshold": model.threshold, "epochs": len(result.history.epoch) - 1, "best_epoch": result.best_epoch,
           "stop": result.stop_reason, "label_cpu_s": label_cpu, "train_cpu_s": round(train_cpu, 1),
           "train_wall_s": round(train_wall, 1), "ram_compute_hours": RAM_COMPUTE_H,
           "training_poses": int(sum(s.labels.size for s in train_shards)),
           "training_reachable_share": round(float(np.mean(np.concatenate([s.labels.ravel() for s in train_shards]))), 4)}
    n_train = sum(len(s.morphs) for s in train_shards)
    print(f"\n{n_train} training arms x {R} random + {args.geodesics} x {args.per_geodesic} boundary poses "
          f"({out['training_poses']:,} labels, reachable share {out['training_reachable_share']}); "
          f"{sum(r['arms'] for r in rows)} held-out arms")
    print("set | wsmap pose model F1 | RAM published F1 | by joint count (5, 6, 7)")
    for name in ("random", "boundary"):
        print(f"{name} | {f1[name]} | {ds.RAM_PUBLISHED['f1_' + name]} | "
              f"{', '.join(str(r['f1_' + name]) for r in rows)}")
    print(f"compute | labels {label_cpu['train'] / 3600:.3f} core-h (train) + {label_cpu['test'] / 3600:.3f} (test), "
          f"training {train_cpu / 3600:.3f} core-h ({out['epochs']} epochs, best {result.best_epoch}) | "
          f"RAM: {RAM_COMPUTE_H['data_h100_hours']} H100-h data, {RAM_COMPUTE_H['training_hours']} h training")
    harness.write_json(args, out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
