"""Benchmark: the learned predictor -- inference time per map, bulk inference, training throughput, accuracy.

Measured, not asserted. Parts (all on the paper's 21³ grid, 9261 nodes, PUMA560-type arms):

(a) one map of one arm (the PUMA560) with ``SubspaceMLP.predict_maps``, for the paper's model (7
    block subspaces [84 → 125, 100, 100, 125 → 1323], assembled) and the improved model (4 DH
    inputs standardised → [256, 256, 256] → 9261 logits): feature construction, the network alone
    and the whole call, median and p10/p90 over ``--repeats`` calls (goal: < 1 ms per map);
(b) ``--arms`` arms (default 10 000) in one ``predict_maps`` call;
(c) training throughput in samples·epochs per second: full-batch Rprop + MSE on the paper's block
    network (1323 outputs) and Adam in minibatches of 256 + cross-entropy on the improved network;
(d) ``--accuracy``: the improved recipe trained on ``--n-train`` arms (exact labels, spec
    ``sec62`` scaled) for ``--minutes``; F-measure on its 1000-arm test set (``test_spec``).

Timing does not depend on the weights, so (a)-(c) use freshly initialised models.

    .venv/bin/python benchmarks/learn/bench_models.py --threads 2 --json bench_models.json
    .venv/bin/python benchmarks/learn/bench_models.py --threads 2 --skip-inference --skip-training --accuracy
"""

from __future__ import annotations

import platform
import sys
from pathlib import Path

import numpy as np
import torch

from wsmap import datasets, metrics, robots
from wsmap.learn import MLPConfig, SubspaceMLP, TrainConfig, split_indices, train
from wsmap.paper.specs import PAPER_SPECS
from wsmap.timing import time_call

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402

SEC62 = PAPER_SPECS["sec62"]
FREE_DH = [2, 3, 7, 8]  # feature columns d3, d4, a2, a3: the spherical-wrist family's free parameters
PAPER_HIDDEN = [125, 100, 100, 125]
IMPROVED_HIDDEN = [256, 256, 256]


def family_features():
    """Feature rows of 2000 arms of the family: the training range an untrained timing model records."""
    return datasets.features_for(robots.sample_spherical_wrist(2000, seed=0), SEC62)


def paper_model() -> SubspaceMLP:
    """The section 6.2 model: 7 block subspaces of 1323 nodes, assembled into the 9261-node map."""
    cfg = MLPConfig(n_inputs=SEC62.n_features, n_outputs=1323, hidden=PAPER_HIDDEN, n_subspaces=7)
    return SubspaceMLP(cfg).set_map_spec(SEC62, assemble=True).set_training_range(family_features()).eval()


def improved_config() -> MLPConfig:
    return MLPConfig(n_inputs=SEC62.n_features, n_outputs=SEC62.n_nodes, hidden=IMPROVED_HIDDEN, init="torch",
                     input_columns=FREE_DH, input_scaling="standardize", output_kind="logit")


def improved_model() -> SubspaceMLP:
    return SubspaceMLP(improved_config()).set_map_spec(SEC62).set_training_range(family_features()).eval()


def improved_train_config(**changes) -> TrainConfig:
    """The improved recipe: Adam lr 1e-3, minibatches of 256, cross-entropy on logits."""
    base = dict(optimizer="adam", optimizer_kwargs={"lr": 1e-3}, batch_size=256, loss="crossentropy")
    return TrainConfig(**{**base, **changes})


def timed(fn, repeats: int, warmup: int = 5) -> np.ndarray:
    return np.asarray(time_call(fn, repeats, warmup).values)


def stats_ms(seconds: np.ndarray) -> dict:
    p10, p50, p90 = np.percentile(seconds * 1e3, [10, 50, 90])
    return {"median_ms": float(p50), "p10_ms": float(p10), "p90_ms": float(p90), "repeats": int(seconds.size)}


def labelled(spec, count: int):
    """Features and exact labels of the first ``count`` arms of ``spec``."""
    arms, _ = datasets.draw_samples(datasets.scaled(spec, count))
    return arms, datasets.features_for(arms, spec), datasets.labels_for(arms, spec)


def bench_inference(repeats: int, n_arms: int) -> list[dict]:
    rows = []
    puma = robots.puma560()
    many = robots.sample_spherical_wrist(n_arms, seed=0)
    for name, model in (("paper 7 x [125,100,100,125] assembled", paper_model()),
                        ("improved 4 -> [256,256,256] -> 9261", improved_model())):
        plan = model.map_spec
        X = model.map_features(puma)
        key = plan["subspace"]
        feats = timed(lambda: model.map_features(puma), repeats)
        net = timed(lambda: model.predict(X, key=key, assemble=plan["assemble"]), repeats)
        total = timed(lambda: model.predict_maps(puma), repeats)
        assert model.predict_maps(puma).shape == (9261,)
        bulk = timed(lambda: model.predict_maps(many), max(3, repeats // 200), warmup=1)
        rows.append({"model": name, "parameters": sum(p.numel() for p in model.parameters()),
                     "features": stats_ms(feats), "network": stats_ms(net), "predict_maps": stats_ms(total),
                     "bulk_arms": n_arms, "bulk": stats_ms(bulk),
                     "bulk_us_per_map": float(np.median(bulk) / n_arms * 1e6)})
    return rows


def bench_training(samples: int, rprop_epochs: int, adam_epochs: int) -> list[dict]:
    rows = []
    block = PAPER_SPECS["sec61"]  # block 5: the paper's 1323-output subspace
    _, X, Y = labelled(block, samples)
    cfg = MLPConfig(n_inputs=X.shape[1], n_outputs=Y.shape[1], hidden=PAPER_HIDDEN)
    sp = split_indices(len(X), seed=0)
    torch.manual_seed(0)
    model = SubspaceMLP(cfg).configure(X[sp.train])
    res = train(model, X, Y, TrainConfig(max_epochs=rprop_epochs, max_fail=10_000, min_grad=0.0), split=sp)
    rows.append(_throughput("Rprop full batch + MSE, paper net -> 1323", res, len(sp.train), None))

    _, X, Y = labelled(SEC62, samples)
    torch.manual_seed(0)
    model = SubspaceMLP(improved_config()).configure(X[sp.train])
    res = train(model, X, Y, improved_train_config(max_epochs=adam_epochs, max_fail=10_000), split=sp)
    rows.append(_throughput("Adam batch 256 + BCE, improved net -> 9261", res, len(sp.train), 256))
    return rows


def _throughput(name, res, n_train, batch) -> dict:
    h = res.history
    epochs = len(h) - 1
    seconds = h.time[-1] - h.time[0]  # from the end of epoch 0's evaluation to the last record
    return {"run": name, "train_samples": n_train, "batch": batch or "full", "epochs": epochs,
            "seconds": seconds, "seconds_per_epoch": seconds / max(epochs, 1),
            "samples_epochs_per_s": n_train * epochs / seconds if seconds > 0 else float("nan")}


def bench_accuracy(n_train: int, minutes: float, lr_decay: str | None, test_samples: int) -> dict:
    with harness.Stopwatch() as sw:
        spec = datasets.scaled(SEC62, n_train)
        _, X, Y = labelled(spec, n_train)
        test_arms, _ = datasets.draw_samples(datasets.test_spec(spec, test_samples))
        truth = datasets.labels_for(test_arms, spec)
    data_s = sw.seconds
    # A small validation split picks the best epoch; no test split (the test set is separate).
    sp = split_indices(n_train, (0.95, 0.05, 0.0), seed=0)
    torch.manual_seed(0)
    model = SubspaceMLP(improved_config()).configure(X[sp.train]).set_map_spec(spec)
    cfg = improved_train_config(max_epochs=100_000, max_fail=1000, time_limit_s=60.0 * minutes, lr_decay=lr_decay)
    train_s, res = harness.timed(lambda: train(model, X, Y, cfg, split=sp))
    pred = model.predict_maps(test_arms, batch_size=1000)
    micro = metrics.precision_recall_f(pred, truth, "micro")
    return {"n_train": n_train, "train_split": len(sp.train), "minutes": minutes, "lr_decay": lr_decay,
            "epochs": res.stop_epoch[0], "best_epoch": res.best_epoch[0], "stop_reason": res.stop_reason[0],
            "train_seconds": train_s, "data_seconds": data_s, "test_samples": test_samples,
            "precision": micro.precision, "recall": micro.recall, "f": micro.f}


def main(argv=None) -> int:
    ap = harness.parser(__doc__, repeat=1000, threads=2, repeat_help="timed calls per one-map measurement",
                        threads_help="torch.set_num_threads (default 2)")
    ap.add_argument("--arms", type=int, default=10_000, help="arms in the bulk measurement (b)")
    ap.add_argument("--train-samples", type=int, default=10_000,
                    help="arms for the throughput runs (c); the 70%% training split is timed")
    ap.add_argument("--rprop-epochs", type=int, default=10)
    ap.add_argument("--adam-epochs", type=int, default=2)
    ap.add_argument("--skip-inference", action="store_true", help="skip (a) and (b)")
    ap.add_argument("--skip-training", action="store_true", help="skip (c)")
    ap.add_argument("--accuracy", action="store_true", help="run (d): train the improved recipe, report F")
    ap.add_argument("--n-train", type=int, default=20_000, help="(d) training arms")
    ap.add_argument("--minutes", type=float, default=5.0, help="(d) training time budget")
    ap.add_argument("--lr-decay", choices=["cosine-time"], help="(d) anneal Adam's lr over the time budget")
    ap.add_argument("--test-samples", type=int, default=1000, help="(d) test arms")
    args = ap.parse_args(argv)

    torch.set_num_threads(args.threads)
    info = {"threads": torch.get_num_threads(), "torch": torch.__version__, "python": platform.python_version(),
            "machine": platform.machine(), "processor": platform.processor() or platform.machine()}
    print(f"torch {info['torch']}, {info['threads']} threads, {info['machine']}")
    out: dict = {"info": info}

    if not args.skip_inference:
        rows = bench_inference(args.repeat, args.arms)
        out["inference"] = rows
        print("\n(a) one 9261-node map of one arm (PUMA560), ms: median [p10, p90]; goal < 1 ms")
        print(f"{'model':40s} {'params':>9s} {'features':>20s} {'network':>20s} {'predict_maps':>20s}")
        for r in rows:
            cells = [f"{r[k]['median_ms']:.3f} [{r[k]['p10_ms']:.3f}, {r[k]['p90_ms']:.3f}]"
                     for k in ("features", "network", "predict_maps")]
            print(f"{r['model']:40s} {r['parameters']:9d} " + " ".join(f"{c:>20s}" for c in cells))
        print(f"\n(b) {args.arms} arms in one predict_maps call")
        for r in rows:
            b = r["bulk"]
            print(f"{r['model']:40s} {b['median_ms'] / 1e3:.3f} s [{b['p10_ms'] / 1e3:.3f}, {b['p90_ms'] / 1e3:.3f}]"
                  f" = {r['bulk_us_per_map']:.1f} us per map")

    if not args.skip_training:
        rows = bench_training(args.train_samples, args.rprop_epochs, args.adam_epochs)
        out["training"] = rows
        print("\n(c) training throughput")
        print(f"{'run':45s} {'n_train':>8s} {'batch':>6s} {'epochs':>6s} {'s/epoch':>9s} {'samples*epochs/s':>17s}")
        for r in rows:
            print(f"{r['run']:45s} {r['train_samples']:8d} {str(r['batch']):>6s} {r['epochs']:6d} "
                  f"{r['seconds_per_epoch']:9.3f} {r['samples_epochs_per_s']:17.0f}")

    if args.accuracy:
        r = bench_accuracy(args.n_train, args.minutes, args.lr_decay, args.test_samples)
        out["accuracy"] = r
        print(f"\n(d) improved recipe, {r['n_train']} arms ({r['train_split']} trained on), {r['minutes']} min budget"
              f"{', lr decay ' + r['lr_decay'] if r['lr_decay'] else ''}: {r['epochs']} epochs "
              f"(best {r['best_epoch']}, {r['stop_reason']}) in {r['train_seconds']:.0f} s")
        print(f"    test ({r['test_samples']} arms x 9261 nodes): precision {r['precision']:.4f}, "
              f"recall {r['recall']:.4f}, F {r['f']:.4f}")

    harness.write_json(args, out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
